"""NP (or BP) in two checkouts of refsynth, alternately, on one input (issue #15).

A speed change must keep the outputs bit for bit and should show in time, but this
machine is shared and its speed drifts by more than the change: a single run of each
version proves nothing. This script runs ``refsynth.synthesize`` from two source trees in
the order A B B A, ``--rounds`` times, each fill in a **fresh subprocess** (its own
imports, no warm caches from the other version) with ``PYTHONPATH`` set to its tree, on
the same input: the Motorcycle at ``--size`` with x-stripes at 78 % unknown, built once
here (``bench_speed._case``) and handed to every run in a file. Each run reports the CPU
seconds of the call (``time.process_time``) and a SHA-256 of the dense range, the
confidence and the fill order. It prints every run, then per tree the mean and the best,
the change of B against A, and whether every run of both trees gave the same hash.

Run::

    git worktree add /tmp/refsynth-base <commit>      # the version to compare against
    python benchmarks/compare_trees.py /tmp/refsynth-base . --size 450x375 --rounds 3
    python benchmarks/compare_trees.py /tmp/refsynth-base . --method bp-colorization

(``--method``: ``np``, ``bp`` (BP's default, NP's fill first) or ``bp-colorization``, BP
on the colorization fill's observations.)

The README's alternating runs (0.8.1–0.8.3, *Speed and memory*) are this comparison.
Needs scikit-image (the Motorcycle).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_speed import _case, _size  # noqa: E402

#: What a child runs: one fill from the tree on PYTHONPATH, its CPU seconds and its hash.
CHILD = """
import hashlib, inspect, sys, time
import numpy as np
import refsynth
case = np.load(sys.argv[1])
options = {"method": sys.argv[2], "seed": 0}
if sys.argv[2] == "bp-colorization":  # BP on the colorization fill's observations
    options = {"method": "bp", "observation": "colorization"}
    if "readings" in inspect.signature(refsynth.synthesize).parameters:  # a tree with presets
        options = {"method": "bp", "readings": {"observation": "colorization"}}
start = time.process_time()
result = refsynth.synthesize(case["image"], case["partial"], **options)
seconds = time.process_time() - start
digest = hashlib.sha256()
for field in ("range", "confidence", "order"):
    value = getattr(result, field, None)
    if value is not None:
        digest.update(np.ascontiguousarray(value).tobytes())
print(repr(seconds), digest.hexdigest(), refsynth.__file__)
"""


def _tree(text: str) -> Path:
    path = Path(text).resolve()
    if not (path / "refsynth" / "__init__.py").is_file():
        raise argparse.ArgumentTypeError(f"{text!r} holds no refsynth/__init__.py")
    return path


def run_once(tree: Path, case: Path, method: str) -> tuple[float, str]:
    """One fill from ``tree`` in a fresh subprocess: (CPU seconds, hash)."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run([sys.executable, "-c", CHILD, str(case), method], cwd=tree, env=env,
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"the fill from {tree} failed:\n{done.stderr.strip()}")
    seconds, digest, where = done.stdout.split()
    if not Path(where).resolve().is_relative_to(tree):
        raise RuntimeError(f"the fill meant for {tree} imported refsynth from {where}")
    return float(seconds), digest


def compare(a: Path, b: Path, size: tuple[int, int], rounds: int, method: str = "np",
            out=sys.stdout) -> dict:
    """A B B A, ``rounds`` times; prints the runs and the summary, returns the times."""
    image, partial, fraction = _case(size)
    times: dict[str, list[float]] = {"A": [], "B": []}
    digests: set[str] = set()
    with tempfile.TemporaryDirectory() as folder:
        case = Path(folder) / "case.npz"
        np.savez(case, image=image, partial=partial)
        print(f"{method} on the Motorcycle at {size[0]}×{size[1]}, x-stripes "
              f"{fraction:.0f} % unknown; A = {a}, B = {b}", file=out)
        for _ in range(rounds):
            for name in "ABBA":
                seconds, digest = run_once(a if name == "A" else b, case, method)
                times[name].append(seconds)
                digests.add(digest)
                print(f"{name} {seconds:.3f} s {digest[:16]}", file=out, flush=True)
    mean = {k: statistics.fmean(v) for k, v in times.items()}
    best = {k: min(v) for k, v in times.items()}
    for name in "AB":
        print(f"{name}: mean {mean[name]:.3f} s, best {best[name]:.3f} s "
              f"({len(times[name])} runs)", file=out)
    print(f"B against A: mean {100 * (mean['B'] / mean['A'] - 1):+.1f} %, best "
          f"{100 * (best['B'] / best['A'] - 1):+.1f} %", file=out)
    same = len(digests) == 1
    print("outputs: " + ("the same bits in every run" if same else
                         f"DIFFER ({len(digests)} hashes)"), file=out)
    return {"times": times, "same": same}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", type=_tree, help="the first source tree (e.g. the base version)")
    parser.add_argument("b", type=_tree, help="the second source tree (e.g. this checkout)")
    parser.add_argument("--size", type=_size, default=(450, 375), help="WIDTHxHEIGHT")
    parser.add_argument("--rounds", type=int, default=3, help="A B B A rounds (default 3)")
    parser.add_argument("--method", choices=("np", "bp", "bp-colorization"), default="np")
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:
        return int(stop.code or 0)
    if args.rounds < 1:
        print("compare_trees.py: error: --rounds must be at least 1", file=sys.stderr)
        return 2
    try:
        result = compare(args.a, args.b, args.size, args.rounds, args.method)
    except RuntimeError as error:
        print(f"compare_trees.py: error: {error}", file=sys.stderr)
        return 1
    return 0 if result["same"] else 1


if __name__ == "__main__":
    sys.exit(main())
