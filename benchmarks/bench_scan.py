"""Acquisition with the simulated rig: wall time, faults, SIGKILL and resume (issue 4).

Runs the real command line (``python -m refsynth.cli.scan scan --simulate ...``,
the same as ``python -m refsynth scan``) in fresh processes and prints, as
Markdown tables:

1. the wall time of a 500-slice scan at 40 % sampling, no artificial delay,
   for each strategy (target: ≤ 30 s), and of a complete scan;
2. the same stripes scan with faults injected (5 % of replies corrupted, 2 %
   dropped, one disconnect): it completes, and every saved slice (and
   ``scan.npz``) is byte-identical to the fault-free scan with the same seed;
3. a scan killed with SIGKILL mid-way, then ``--resume``: it completes, no
   slice is acquired twice (the files saved before the kill are untouched and
   the resumed session acquires exactly the rest) and none is lost (the plan
   is complete and byte-identical to the uninterrupted scan).

Run::

    python benchmarks/bench_scan.py            # about 30 s on 2 cores
    python benchmarks/bench_scan.py --seed 3
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SUMMARY = re.compile(r"(\d+)/(\d+) slices .*?; (\d+) acquired now, (\d+) already on disk\), "
                     r"(\d+) pictures; retries (\d+), faults recovered (\d+) \((\d+) reconnects\); "
                     r"([\d.]+) s")


def scan(out: Path, *options: str, env=None) -> tuple[dict, float]:
    """Run one scan; returns its parsed summary and the process's wall time."""
    command = [sys.executable, "-m", "refsynth.cli.scan", "scan", "--simulate", "--out", str(out),
               "--quiet", *options]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=600)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"scan failed ({' '.join(options)}): {done.stderr.strip()}")
    match = SUMMARY.search(done.stdout)
    keys = ("total", "planned", "acquired", "already", "pictures", "retries", "faults",
            "reconnects", "seconds")
    values = dict(zip(keys, (float(v) if k == "seconds" else int(v)
                             for k, v in zip(keys, match.groups()))))
    return values, wall


def files(folder: Path) -> dict[str, bytes]:
    out = {f"slices/{p.name}": p.read_bytes() for p in sorted((folder / "slices").iterdir())}
    out["scan.npz"] = (folder / "scan.npz").read_bytes()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    seed = ["--seed", str(args.seed)]
    work = Path(tempfile.mkdtemp(prefix="refsynth-bench-scan-"))
    env = dict(os.environ, TMPDIR=str(work))  # a killed simulator's links stay in here
    try:
        print(f"## 1. Simulated scans, no artificial delay (seed {args.seed})\n")
        print("| strategy | slices (of 500) | pictures | scan (s) | process wall (s) | target |")
        print("| --- | --- | --- | --- | --- | --- |")
        cases = [("stripes", "0.4"), ("every", "0.4"), ("distance", "0.4"), ("all", "1")]
        for strategy, fraction in cases:
            summary, wall = scan(work / strategy, "--strategy", strategy, "--fraction", fraction,
                                 *seed, env=env)
            target = "≤ 30 s: " + ("met" if wall <= 30 else "MISSED") if fraction == "0.4" else ""
            label = f"{strategy}, --fraction {fraction}" if strategy != "all" else "all"
            print(f"| {label} | {summary['planned']} ({summary['planned'] / 5:.1f} %) | "
                  f"{summary['pictures']} | "
                  f"{summary['seconds']:.1f} | {wall:.1f} | {target} |")

        print("\n## 2. Faults: 5 % of replies corrupted, 2 % dropped, one disconnect\n")
        faults = "corrupt=0.05,drop=0.02,disconnect=1"
        summary, wall = scan(work / "faults", "--strategy", "stripes", "--fraction", "0.4",
                             "--faults", faults, *seed, env=env)
        clean, noisy = files(work / "stripes"), files(work / "faults")
        identical = clean == noisy
        print("| slices | retries | faults recovered | reconnects | wall (s) | "
              "byte-identical to the fault-free scan |")
        print("| --- | --- | --- | --- | --- | --- |")
        print(f"| {summary['total']}/{summary['planned']} | {summary['retries']} | "
              f"{summary['faults']} | {summary['reconnects']} | {wall:.1f} | "
              f"{'yes' if identical else 'NO'} ({len(clean) - 1} slice files + scan.npz) |")

        print("\n## 3. SIGKILL mid-scan, then --resume\n")
        out = work / "killed"
        command = [sys.executable, "-m", "refsynth.cli.scan", "scan", "--simulate", "--out",
                   str(out), "--quiet", "--strategy", "stripes", "--fraction", "0.4", *seed]
        slices = out / "slices"
        with subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) as process:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and process.poll() is None and (
                not slices.is_dir() or len(list(slices.glob("*.slice"))) < 100
            ):
                time.sleep(0.002)
            process.send_signal(signal.SIGKILL)
            process.wait(timeout=30)
        killed = process.returncode == -signal.SIGKILL
        before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in slices.glob("*.slice")}
        summary, wall = scan(out, "--resume", env=env)
        after = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in slices.glob("*.slice")}
        untouched = all(after.get(name) == stamp for name, stamp in before.items())
        exact = summary["acquired"] == summary["planned"] - len(before) and summary["already"] \
            == len(before)
        complete = files(out) == clean
        print("| killed by SIGKILL | saved before | acquired on resume | planned | "
              "none twice | none lost (identical to uninterrupted) |")
        print("| --- | --- | --- | --- | --- | --- |")
        print(f"| {'yes' if killed else 'NO (finished first)'} | {len(before)} | "
              f"{summary['acquired']} | {summary['planned']} | "
              f"{'yes' if untouched and exact else 'NO'} | {'yes' if complete else 'NO'} |")
        if not (identical and killed and untouched and exact and complete):
            raise SystemExit("a check failed")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
