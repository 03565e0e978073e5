"""A scan killed at any moment resumes: many SIGKILLs, each resumed, give the uninterrupted bytes.

The simulated scan runs in a subprocess (``python -m refsynth.cli.scan scan --simulate``) and is
killed with SIGKILL, again and again, at seeded moments of two kinds: a random time after its
start (anywhere: the import, the devices' start, a slice, a picture, the manifest), or the
instant a new slice file (or picture) appears on disk, which lands between a slice's write and
the manifest's update. Each kill is followed by ``--resume``; at the end every slice, every
picture and ``scan.npz`` must be byte-identical to an uninterrupted scan's, nothing set aside
and no temporary file left. The kills are seeded (44; KILL_SEED=<n> in the environment tries
another sequence).
"""

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rig_fakes import fake_scan

from refsynth.acquisition import ScanSettings

#: Scan processes started and killed (``-m "not slow"`` leaves them out).
pytestmark = pytest.mark.slow

#: The kills, bounded: about one per 3 slices of the 50 planned (and the pictures).
MAX_KILLS = 18


def _count(directory: Path, suffix: str) -> int:
    try:
        return sum(1 for entry in os.scandir(directory) if entry.name.endswith(suffix))
    except FileNotFoundError:
        return 0


def _wait_and_kill(process: subprocess.Popen, out: Path, rng: random.Random) -> bool:
    """Kill ``process`` at a seeded moment; True if it was still running when killed."""
    mode = rng.choice(["time", "slice", "slice", "picture"])
    deadline = time.monotonic() + 60
    if mode == "time":
        time.sleep(rng.uniform(0.05, 2.0))
    else:
        directory, suffix = (out / "slices", ".slice") if mode == "slice" else (out / "images",
                                                                               ".png")
        wanted = _count(directory, suffix) + (rng.randint(1, 4) if mode == "slice" else 1)
        while (process.poll() is None and time.monotonic() < deadline
               and _count(directory, suffix) < wanted):
            time.sleep(0.001)
    running = process.poll() is None
    if running:
        process.send_signal(signal.SIGKILL)
    process.wait(timeout=60)
    return running


def _unlisted_slices(out: Path) -> int:
    """Slice files on disk that manifest.json does not list (a kill between the two writes)."""
    path = out / "manifest.json"
    if not path.exists():
        return 0
    listed = json.loads(path.read_text())["slices"]  # never torn: written atomically
    return sum(1 for p in (out / "slices").glob("pan-*.slice")
               if str(int(p.stem[4:])) not in listed)


def _snapshot(folder: Path) -> dict[str, bytes]:
    found = {"scan.npz": (folder / "scan.npz").read_bytes()}
    for sub in ("slices", "images"):
        found.update({f"{sub}/{p.name}": p.read_bytes() for p in (folder / sub).iterdir()})
    return found


@pytest.mark.slow
def test_a_scan_killed_at_random_moments_resumes_with_the_uninterrupted_bytes(tmp_path):
    pytest.importorskip("pty")
    rng = random.Random(int(os.environ.get("KILL_SEED", "44")))
    out = tmp_path / "scan"
    env = dict(os.environ, TMPDIR=str(tmp_path))  # the killed simulators' links stay in here
    # no faults: no reply is ever late, so a long deadline only guards a loaded machine
    command = [sys.executable, "-m", "refsynth.cli.scan", "scan", "--simulate", "--out",
               str(out), "--strategy", "every", "--step", "10", "--quiet", "--timeout", "2"]
    kills = windows = 0
    status = None
    for run in range(MAX_KILLS):
        with subprocess.Popen([*command, *(["--resume"] if run else [])], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) as process:
            killed = _wait_and_kill(process, out, rng)
            error = process.stderr.read().decode(errors="replace")
        if not killed:  # it finished before its kill
            status = process.returncode
            break
        assert process.returncode in (-signal.SIGKILL, 0), error
        kills += process.returncode == -signal.SIGKILL
        windows += _unlisted_slices(out) > 0
    if status is None:  # resumed after the last kill, to the end
        final = subprocess.run([*command, "--resume"], env=env, capture_output=True, text=True,
                               timeout=300)
        status, error = final.returncode, final.stderr
    assert status == 0, error
    assert kills >= 5, kills

    fake_scan(tmp_path / "uninterrupted", ScanSettings("every", step=10))
    assert _snapshot(out) == _snapshot(tmp_path / "uninterrupted")
    assert not (out / "rejected").exists()
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["complete"] and len(manifest["slices"]) == 50
    print(f"{kills} kills, {windows} between a slice's write and the manifest's update")


def test_two_scan_processes_into_one_folder_the_second_is_refused(tmp_path):
    """The lock holds across processes: a resume started while the scan runs is refused in one
    line, exit 2, and the running scan completes undisturbed."""
    pytest.importorskip("pty")
    out = tmp_path / "scan"
    env = dict(os.environ, TMPDIR=str(tmp_path))
    command = [sys.executable, "-m", "refsynth.cli.scan", "scan", "--simulate", "--out",
               str(out), "--strategy", "every", "--step", "25", "--no-camera", "--quiet",
               "--timeout", "2"]
    with subprocess.Popen([*command, "--faults", "delay=0.05"], env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as first:
        deadline = time.monotonic() + 60
        while first.poll() is None and time.monotonic() < deadline and _count(
                out / "slices", ".slice") < 1:
            time.sleep(0.005)
        second = subprocess.run([*command, "--resume"], env=env, capture_output=True, text=True,
                                timeout=120)
        still_running = first.poll() is None
        output, error = first.communicate(timeout=120)
    assert still_running, "the first scan ended before the second started: too fast to test"
    assert second.returncode == 2 and second.stderr.count("\n") == 1, second.stderr
    assert second.stderr.startswith(f"refsynth scan: error: '{out}' is in use by another scan")
    assert first.returncode == 0 and "20/20 slices" in output, error
