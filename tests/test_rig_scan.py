"""Scans: slice plans, slice files, fault-tolerant and resumable acquisition, the CLI."""

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from refsynth.acquisition import (
    PanUnit,
    Rangefinder,
    RigSimulator,
    RoomRig,
    ScanSettings,
    load_scan,
    plan_slices,
    read_slice,
    run_scan,
)
from refsynth.acquisition.geometry import SLICE_COUNT, SLICE_START, pan_angle, polar_angle
from refsynth.acquisition.scan_folder import SliceRecord, slice_bytes
from refsynth.acquisition.slice_plan import coarse_slices
from refsynth.cli.scan import add_scan_parser, main

# ----------------------------------------------------------------------------- plans


def test_plans_of_each_strategy():
    stripes = plan_slices(ScanSettings("stripes", 0.4))
    assert len(stripes) == 200 and stripes[:8].tolist() == [0, 1, 2, 3, 10, 11, 12, 13]
    assert len(plan_slices(ScanSettings("stripes", 0.3, stripe_width=3))) in range(140, 161)
    assert plan_slices(ScanSettings("every", 0.4)).tolist() == list(range(0, 500, 3))
    assert plan_slices(ScanSettings("every", 0.4, step=7)).tolist() == list(range(0, 500, 7))
    assert plan_slices(ScanSettings("all")).tolist() == list(range(500))
    assert plan_slices(ScanSettings("stripes", 1.0)).tolist() == list(range(500))


def test_distance_plan_is_denser_where_the_scene_is_far():
    settings = ScanSettings("distance", 0.4)
    profile = np.full(500, np.nan)
    coarse = coarse_slices(settings)
    profile[coarse] = np.where(coarse < 250, 2.0, 8.0)  # near on the left, far on the right
    plan = plan_slices(settings, profile)
    assert set(coarse.tolist()) <= set(plan.tolist())
    assert abs(len(plan) - 200) <= 5
    assert (plan >= 250).sum() > 2 * (plan < 250).sum()
    assert np.all(np.diff(plan) > 0)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [({"strategy": "random"}, ValueError, "`strategy`"),
     ({"fraction": 0.0}, ValueError, "`fraction`"),
     ({"fraction": 1.5}, ValueError, "`fraction`"),
     ({"step": 0}, ValueError, "`step`"),
     ({"seq": 1900, "count": 200}, ValueError, "`seq` \\+ `count`"),
     ({"average": 100}, ValueError, "`average`"),
     ({"camera": "yes"}, TypeError, "`camera`")],
)
def test_settings_validation(kwargs, error, match):
    with pytest.raises(error, match=match):
        ScanSettings(**kwargs)


def test_distance_plan_needs_a_coarse_pass():
    with pytest.raises(ValueError, match="coarse_range"):
        plan_slices(ScanSettings("distance"))


# ----------------------------------------------------------------------------- slice files


def test_slice_files_hold_only_the_data(tmp_path):
    range_mm, amplitude = RoomRig(0).measure(42, SLICE_START, SLICE_COUNT, 10)
    record = SliceRecord(42, SLICE_START, SLICE_COUNT, 10, range_mm, amplitude)
    data = slice_bytes(record)
    assert data == slice_bytes(SliceRecord(42, SLICE_START, SLICE_COUNT, 10, range_mm.copy(),
                                           amplitude.copy()))
    assert data.startswith(b"refsynth-slice 1\npan 42\nseq 379\ncount 243\naverage 10\n\n")
    path = tmp_path / "pan-0042.slice"
    path.write_bytes(data)
    back = read_slice(path)
    assert (back.pan_index, back.seq, back.count, back.average) == (42, 379, 243, 10)
    np.testing.assert_array_equal(back.range_mm, range_mm)
    np.testing.assert_array_equal(back.amplitude, amplitude)
    for position in (5, 60, len(data) // 2, len(data) - 3):
        corrupt = bytearray(data)
        corrupt[position] ^= 0x01
        path.write_bytes(bytes(corrupt))
        with pytest.raises(ValueError, match="pan-0042.slice' is not a valid slice file"):
            read_slice(path)


# ----------------------------------------------------------------------------- acquisition


@pytest.fixture
def ptys():
    pytest.importorskip("pty")
    pytest.importorskip("termios")


def simulated_scan(folder, settings=None, *, seed=0, faults=None, resume=False, progress=None):
    # without faults no reply is ever late: a long deadline keeps a loaded machine from
    # turning a slow reply into a "fault"; with faults a short one keeps the test fast
    timeout = 0.1 if faults else 2.0
    with RigSimulator(seed=seed, faults=faults, camera_dir=Path(folder) / "images",
                      reconnect_delay=0.05) as sim, \
            PanUnit(sim.pan_port, timeout=timeout, retries=10) as pan, \
            Rangefinder(sim.laser_port, timeout=timeout, retries=10) as laser:
        return run_scan(folder, pan, laser, settings, resume=resume, progress=progress,
                        source={"simulated": True, "seed": seed, "faults": str(faults)})


def folder_bytes(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes()
            for sub in ("slices", "images") for p in sorted((folder / sub).iterdir())}


EVERY_10 = ScanSettings("every", step=10)


def test_a_scan_with_faults_saves_exactly_the_fault_free_bytes(ptys, tmp_path):
    clean = simulated_scan(tmp_path / "clean", EVERY_10)
    assert clean.complete and clean.acquired == clean.planned == 50 and clean.images == 10
    assert clean.faults == 0
    faults = "corrupt=0.05,drop=0.02,error=0.02,disconnect=2,disconnect_after=30"
    noisy = simulated_scan(tmp_path / "noisy", EVERY_10, faults=faults)
    assert noisy.complete and noisy.acquired == 50 and noisy.reconnects == 2
    assert noisy.faults > 5 and noisy.retries > 0
    assert folder_bytes(tmp_path / "clean") == folder_bytes(tmp_path / "noisy")
    assert (tmp_path / "clean" / "scan.npz").read_bytes() == \
        (tmp_path / "noisy" / "scan.npz").read_bytes()
    manifest = json.loads((tmp_path / "noisy" / "manifest.json").read_text())
    assert manifest["complete"] and len(manifest["slices"]) == 50
    assert manifest["sessions"][0]["reconnects"] == 2
    assert {e["pan_index"] for e in manifest["images"].values()} == set(range(25, 500, 50))


def test_the_assembled_scan_is_spherical_samples_of_the_room(ptys, tmp_path):
    simulated_scan(tmp_path, ScanSettings("every", step=25))
    scan = load_scan(tmp_path)
    assert scan.complete and scan.r.shape == (20, SLICE_COUNT) == scan.theta.shape
    assert scan.pan_index.tolist() == list(range(0, 500, 25))
    np.testing.assert_allclose(scan.phi[:, 0], pan_angle(scan.pan_index))
    np.testing.assert_allclose(scan.theta[0], polar_angle(scan.encoder))
    np.testing.assert_array_equal(scan.theta_axis, scan.theta[0])
    np.testing.assert_array_equal(scan.phi_axis, scan.phi[:, 0])
    rig = RoomRig(0)
    truth = np.stack([rig.truth(i, SLICE_START, SLICE_COUNT) for i in scan.pan_index])
    ok = np.isfinite(scan.r)
    assert ok.mean() > 0.95 and np.median(np.abs(scan.r[ok] - truth[ok])) < 0.003
    image = scan.range_image()
    assert image.shape == (SLICE_COUNT, 500)
    assert np.isnan(image[:, 1]).all() and np.isfinite(image[:, 25]).mean() > 0.9
    assert scan.known_slices.sum() == 20
    points = scan.points()
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), scan.r[ok])
    assert [im.pan_index for im in scan.images] == list(range(25, 500, 50))
    assert all(im.path.is_file() for im in scan.images)


def test_an_interrupted_scan_resumes_without_acquiring_twice(ptys, tmp_path):
    settings = ScanSettings("stripes", 0.3)

    def stop_after_40(done, total, index):
        if done == 40:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulated_scan(tmp_path, settings, progress=stop_after_40)
    before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns)
              for p in (tmp_path / "slices").iterdir()}
    assert len(before) == 40 and not (tmp_path / "scan.npz").exists()
    partial = load_scan(tmp_path)
    assert not partial.complete and partial.r.shape == (40, SLICE_COUNT)
    summary = simulated_scan(tmp_path, resume=True)
    assert summary.complete and summary.already == 40
    assert summary.acquired == summary.planned - 40
    after = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns)
             for p in (tmp_path / "slices").iterdir()}
    assert all(after[name] == stamp for name, stamp in before.items())  # not written again
    assert len(after) == summary.planned == len(plan_slices(settings))
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert [s["session"] for s in manifest["sessions"]] == [1, 2]
    assert sum(s["acquired"] for s in manifest["sessions"]) == summary.planned
    # a second resume has nothing left to do
    again = simulated_scan(tmp_path, resume=True)
    assert again.acquired == 0 and again.already == summary.planned and again.complete


def test_distance_driven_scan_resumes_inside_its_coarse_pass(ptys, tmp_path):
    settings = ScanSettings("distance", 0.3, camera=False)

    def stop_in_the_coarse_pass(done, total, index):
        if done == 20:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        simulated_scan(tmp_path / "a", settings, progress=stop_in_the_coarse_pass)
    assert json.loads((tmp_path / "a" / "manifest.json").read_text())["plan"] is None
    resumed = simulated_scan(tmp_path / "a", resume=True)
    assert resumed.complete and resumed.already == 20
    whole = simulated_scan(tmp_path / "b", settings)
    manifest = json.loads((tmp_path / "b" / "manifest.json").read_text())
    assert set(manifest["coarse"]) <= set(manifest["plan"])
    assert whole.complete and abs(whole.planned - 150) <= 5
    assert resumed.planned == whole.planned
    assert not manifest["images"]
    assert folder_bytes(tmp_path / "a") == folder_bytes(tmp_path / "b")


def test_resume_refuses_what_would_mix_two_scans(ptys, tmp_path):
    simulated_scan(tmp_path, ScanSettings("every", step=50, camera=False))
    with pytest.raises(ValueError, match="already holds a scan"):
        simulated_scan(tmp_path, ScanSettings("every", step=50, camera=False))
    with pytest.raises(ValueError, match="other settings \\(step differ"):
        simulated_scan(tmp_path, ScanSettings("every", step=25, camera=False), resume=True)
    with pytest.raises(ValueError, match="seed differ"):
        simulated_scan(tmp_path, resume=True, seed=1)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty and holds no scan"):
        simulated_scan(other)


# ----------------------------------------------------------------------------- SIGKILL


def test_sigkill_mid_scan_then_resume(ptys, tmp_path):
    out = tmp_path / "scan"
    env = dict(os.environ, TMPDIR=str(tmp_path))  # the killed simulator's links stay in here
    command = [sys.executable, "-m", "refsynth.cli.scan", "scan", "--simulate", "--out", str(out),
               "--strategy", "every", "--step", "5", "--quiet", "--timeout", "2"]
    slices = out / "slices"
    with subprocess.Popen([*command, "--faults", "delay=0.003"], env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) as process:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and process.poll() is None and (
            not slices.is_dir() or len(list(slices.glob("*.slice"))) < 15
        ):
            time.sleep(0.005)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    assert process.returncode == -signal.SIGKILL
    before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in slices.glob("*.slice")}
    assert 15 <= len(before) < 100

    resumed = subprocess.run([*command, "--resume"], env=env, capture_output=True, text=True,
                             timeout=120)
    assert resumed.returncode == 0, resumed.stderr
    match = re.search(r"(\d+)/100 slices .* (\d+) acquired now, (\d+) already on disk",
                      resumed.stdout)
    assert match, resumed.stdout
    total, now, already = map(int, match.groups())
    assert (total, already, now) == (100, len(before), 100 - len(before))
    after = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in slices.glob("*.slice")}
    assert len(after) == 100 and all(after[name] == stamp for name, stamp in before.items())
    assert not list(slices.glob(".*"))  # no temporary file left

    clean = simulated_scan(tmp_path / "clean", ScanSettings("every", step=5))
    assert clean.complete
    assert folder_bytes(out) == folder_bytes(tmp_path / "clean")


# ----------------------------------------------------------------------------- the CLI


def test_cli_scan(ptys, tmp_path, capsys):
    out = tmp_path / "scan"
    status = main(["scan", "--simulate", "--out", str(out), "--strategy", "every", "--step", "25",
                   "--no-camera", "--quiet", "--seed", "3", "--timeout", "2"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert re.search(r"refsynth scan: 20/20 slices \(4.0 % of 500; 20 acquired now, 0 already "
                     r"on disk\), 0 pictures; retries 0, faults recovered 0 \(0 reconnects\); "
                     r"[\d.]+ s", captured.out)
    assert load_scan(out).r.shape == (20, SLICE_COUNT)
    # resume keeps the saved seed and settings; progress goes to stderr
    status = main(["scan", "--simulate", "--out", str(out), "--resume"])
    captured = capsys.readouterr()
    assert status == 0 and "0 acquired now, 20 already on disk" in captured.out
    assert json.loads((out / "manifest.json").read_text())["source"]["seed"] == 3


@pytest.mark.parametrize(
    ("arguments", "match"),
    [
        ([], "give --simulate, or both --pan-port and --laser-port"),
        (["--pan-port", "/dev/null"], "give --simulate, or both"),
        (["--simulate", "--pan-port", "x"], "--simulate takes no --pan-port"),
        (["--pan-port", "a", "--laser-port", "b", "--faults", "drop=0.1"], "are for --simulate"),
        (["--simulate", "--faults", "drop=2"], "fraction in \\[0, 1\\]"),
        (["--simulate", "--faults", "oops"], "unknown fault 'oops'"),
        (["--simulate", "--retries", "-1"], "--retries must be >= 0"),
        (["--pan-port", "/nonexistent/a", "--laser-port", "/nonexistent/b"],
         "pan unit: open /nonexistent/a: "),
    ],
)
def test_cli_errors_are_one_line(tmp_path, capsys, arguments, match):
    status = main(["scan", "--out", str(tmp_path / "x"), *arguments])
    err = capsys.readouterr().err
    assert status == 2
    assert err.startswith("refsynth scan: error: ") and err.count("\n") == 1
    assert re.search(match, err), err


def test_cli_refuses_to_overwrite_a_scan(ptys, tmp_path, capsys):
    out = tmp_path / "scan"
    arguments = ["scan", "--simulate", "--out", str(out), "--strategy", "every", "--step", "100",
                 "--no-camera", "--quiet"]
    assert main(arguments) == 0
    capsys.readouterr()
    assert main(arguments) == 2
    assert "already holds a scan: resume it (--resume)" in capsys.readouterr().err
    assert main([*arguments[:-4], "--resume", "--strategy", "stripes"]) == 2
    assert "other settings (strategy differ" in capsys.readouterr().err


def test_add_scan_parser_plugs_into_any_parser():
    parser = argparse.ArgumentParser()
    add_scan_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["scan", "--simulate", "--out", "x", "--fraction", "0.3",
                              "--strategy", "distance"])
    assert callable(args.func) and args.fraction == 0.3 and args.strategy == "distance"
    with pytest.raises(SystemExit):
        parser.parse_args(["scan", "--simulate", "--out", "x", "--fraction", "1.5"])
