"""The default grid of ``evaluate``: wall time with ``--jobs N``, and bit-identical tables.

Runs ``python -m refsynth evaluate`` (the default grid, or ``--grid quick``)
``--runs`` times in fresh processes, each with ``--jobs N --json``, and
prints each run's wall time and whether the rows, with the timing column
left out, are identical across the runs (they must be: every case is a pure
function of its seeds).

Run::

    python benchmarks/bench_evaluate.py                 # 2 runs of the default grid, --jobs 2
    python benchmarks/bench_evaluate.py --grid quick    # seconds
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--runs", type=int, default=2)
    parser.add_argument("--grid", choices=["default", "quick"], default="default")
    args = parser.parse_args(argv)
    rows, walls = [], []
    with tempfile.TemporaryDirectory() as folder:
        for run in range(args.runs):
            out = Path(folder) / f"run{run}.json"
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "refsynth", "evaluate",
                            "--grid", args.grid, "--jobs", str(args.jobs), "--json", str(out),
                            "--quiet"], check=True, stdout=subprocess.DEVNULL)
            walls.append(time.perf_counter() - start)
            rows.append([{k: v for k, v in r.items() if k != "seconds"}
                         for r in json.loads(out.read_text())])
            print(f"run {run + 1}: {len(rows[-1])} rows, {walls[-1]:.0f} s "
                  f"({walls[-1] / 60:.1f} min) with --jobs {args.jobs}")
    same = all(r == rows[0] for r in rows[1:])
    print(f"rows identical across {args.runs} runs (timing left out): {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
