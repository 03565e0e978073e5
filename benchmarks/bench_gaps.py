"""NP and BP with and without the post-passes (the gap reading, the median), against the classical
fills.

The readings ``gaps`` (:mod:`refsynth.synthesis.gap_readings`) and ``median``
(:mod:`refsynth.synthesis.median_pass`) on the scenes and protocol of ``bench_scenes.py``
(Table 4's centred 6:5 crop and area resize, MAR of Eq. 13 over the unknown pixels with truth):
per scene × sampling × seed, NP (and BP) run once with ``readings={"gaps": "copy", "median":
0}`` (every unknown pixel as the method filled it, the paper's reading) and the post-passes
are applied to that one result, so the rows differ by the post-passes only:

- ``np-copy`` / ``bp-copy``: the fill as copied (``gaps="copy"``, ``median=0``);
- ``np`` / ``bp``: :func:`~refsynth.synthesis.gap_readings.gap_gate` with its defaults and the
  Canny edges NP used, then :func:`~refsynth.synthesis.median_pass.median_pass` (3 × 3): bit
  for bit :func:`refsynth.synthesize`'s default (``gaps="gate"``, ``median=3``);
- ``np-gate``: the gate alone (``median=0``);
- ``np-clip``: the default with the gate's ``jump=0`` (every bounded gap clipped to its bounds,
  no line);
- ``np-jump<J>`` (``--jumps``): the default with the gate's ``jump=J``;
- ``np-median<K>`` (``--medians``): the gate, then a ``K × K`` median;
- ``np-fixed``, ``np-narrow`` (``--windows``): the default with the 5 × 5 neighbourhood on
  every sampling (the reading ``window="fixed"``, :mod:`refsynth.synthesis.window_reading`),
  and with the 3 × 3 one on every sampling: each its own fill where the default's window
  differs, the default's fill where it is the same;
- ``row-linear``: :func:`~refsynth.synthesis.gap_readings.row_interpolation` of the completed
  slices (:func:`~refsynth.synthesis.gap_readings.complete_slices`) alone;

beside the four classical fills (nearest, linear, colorization, joint-bilateral). The table is
``bench_scenes.py``'s: each method's ratio to the best classical fill (or ``--mar``: MAR, mean
± sd over seeds), and the aggregate (geometric mean and worst ratio, per group of scenes).

Run::

    python benchmarks/bench_gaps.py ../shared/data --motorcycle --seeds 0,1 \\
        --samplings x63,x78,distance60,g5_25 --arrays /tmp/gaps --json /tmp/gaps.json

``--arrays DIR`` keeps each NP / BP fill as
``DIR/<scene>_<sampling>_<size>_<method>-copy_<seed>.npy`` (``-fixed_``, ``-narrow_`` for
``--windows``' fills; a classical fill's without the seed) and reuses it on the next run (its
seconds are then not measured: NaN).
"""

from __future__ import annotations

import argparse
import io
import json
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

# this checkout's refsynth (not another one installed), and bench_scenes beside this file
sys.path[:0] = [str(Path(__file__).resolve().parents[1]), str(Path(__file__).resolve().parent)]

import bench_scenes as scenes  # noqa: E402

from refsynth._files import write_atomic  # noqa: E402
from refsynth.evaluation.baselines import BASELINES  # noqa: E402
from refsynth.evaluation.cases import known_mask, parse_sampling, parse_size  # noqa: E402
from refsynth.evaluation.metrics import evaluate  # noqa: E402
from refsynth.synthesis.api import (  # noqa: E402
    synthesis_edges,
    synthesize,
    validate_inputs,
)
from refsynth.synthesis.gap_readings import (  # noqa: E402
    complete_slices,
    gap_gate,
    row_interpolation,
)
from refsynth.synthesis.median_pass import check_median, median_pass  # noqa: E402
from refsynth.synthesis.window_reading import (  # noqa: E402
    DEFAULT_NEIGHBOURHOOD,
    NARROW_NEIGHBOURHOOD,
    choose_neighbourhood,
)

#: The choosing cases (the gate leaves grids alone: add g5_25 to see it).
DEFAULT_SAMPLINGS = ("x63", "x78", "distance60")


def readings(base: str, jumps: Sequence[float], medians: Sequence[int] = (),
             windows: bool = False) -> list[str]:
    """The post-pass readings' labels of one base method."""
    return [f"{base}-copy", f"{base}-gate", base, f"{base}-clip",
            *[f"{base}-jump{j:g}" for j in jumps], *[f"{base}-median{k}" for k in medians],
            *([f"{base}-fixed", f"{base}-narrow"] if windows else [])]


def _fill(scene, partial, base, seed, path, stored_only, neighbourhood=None):
    """One NP / BP fill without the post-passes (from ``path`` when stored) and its seconds."""
    if path is not None and path.is_file():
        return np.load(path), math.nan
    if stored_only:
        return None, math.nan
    start = time.perf_counter()
    estimate = synthesize(scene.intensity, partial, method=base, seed=seed,
                          neighbourhood=neighbourhood, readings={"gaps": "copy", "median": 0}).range
    seconds = time.perf_counter() - start
    if path is not None:
        write_atomic(path, _npy(estimate))
    return estimate, seconds


def _row(scene, name, size, sampling, method, seed, estimate, known, seconds) -> dict:
    scores = evaluate(estimate, scene.range, known)
    return dict(scene=name, size=size, units=scene.units, sampling=sampling, method=method,
                seed=seed, mar=scores["mar"], rmse=scores["rmse"], evaluated=scores["n"],
                unknown_percent=100.0 * float(np.mean(~known)), seconds=seconds)


def run_case(name: str, spec: str, size: str, sampling: str, bases: Sequence[str],
             seeds: Sequence[int], jumps: Sequence[float], arrays: str | None, have: set,
             progress=None, stored_only: bool = False, medians: Sequence[int] = (),
             windows: bool = False) -> list[dict]:
    """Every row of one scene × sampling (the classical fills once, the bases per seed)."""
    scene = scenes.load(spec, size)
    known = known_mask(scene, sampling)
    partial = np.where(known, scene.range, np.nan)
    image = validate_inputs(scene.intensity, partial)[0]   # NP's edges: refsynth.synthesize's
    edges = synthesis_edges(image, sigma=0.8)
    rows = []
    if (name, size, sampling, "row-linear", seeds[0]) not in have:
        for method in (*scenes.CLASSICAL, "row-linear"):
            path = (Path(arrays) / f"{name}_{sampling}_{size}_{method}.npy"
                    if arrays and method != "row-linear" else None)
            start = time.perf_counter()
            if path is not None and path.is_file():
                estimate, start = np.load(path), math.nan
            elif stored_only and method != "row-linear":
                continue
            else:
                estimate = (row_interpolation(complete_slices(partial)) if method == "row-linear"
                            else BASELINES[method](scene.intensity, partial))
                if path is not None:
                    write_atomic(path, _npy(estimate))
            rows.append(_row(scene, name, size, sampling, method, seeds[0], estimate, known,
                             time.perf_counter() - start))
    for base in bases:
        for seed in seeds:
            if (name, size, sampling, f"{base}-copy", seed) in have:
                continue
            stored = Path(arrays) / f"{name}_{sampling}_{size}_{base}" if arrays else None
            path = Path(f"{stored}-copy_{seed}.npy") if arrays else None
            estimate, seconds = _fill(scene, partial, base, seed, path, stored_only)
            if estimate is None:
                continue
            start = time.perf_counter()
            gated = gap_gate(estimate, partial, edges=edges)
            final = median_pass(gated, partial)
            post = time.perf_counter() - start
            copied = _row(scene, name, size, sampling, f"{base}-copy", seed, estimate, known,
                          seconds)
            default = _row(scene, name, size, sampling, base, seed, final, known, seconds + post)
            rows += [copied, default,
                     _row(scene, name, size, sampling, f"{base}-gate", seed, gated, known,
                          seconds + post)]
            rows.append(_row(scene, name, size, sampling, f"{base}-clip", seed,
                             median_pass(gap_gate(estimate, partial, jump=0.0, edges=edges),
                                         partial), known, seconds))
            for jump in jumps:
                rows.append(_row(scene, name, size, sampling, f"{base}-jump{jump:g}", seed,
                                 median_pass(gap_gate(estimate, partial, jump=jump, edges=edges),
                                             partial), known, seconds))
            for k in medians:
                rows.append(_row(scene, name, size, sampling, f"{base}-median{k}", seed,
                                 median_pass(gated, partial, k), known, seconds))
            for label, side in (("fixed", DEFAULT_NEIGHBOURHOOD),
                                ("narrow", NARROW_NEIGHBOURHOOD)) if windows else ():
                other, other_seconds = estimate, seconds
                if choose_neighbourhood(partial) != side:
                    other, other_seconds = _fill(
                        scene, partial, base, seed,
                        Path(f"{stored}-{label}_{seed}.npy") if arrays else None, False, side)
                rows.append(_row(scene, name, size, sampling, f"{base}-{label}", seed,
                                 median_pass(gap_gate(other, partial, edges=edges), partial),
                                 known, other_seconds))
            if progress is not None:
                progress(f"{name} {sampling} {base} seed {seed}: MAR {default['mar']:.4g} "
                         f"(copy {copied['mar']:.4g}; {seconds:.1f} s, post-passes {post:.3f} s)")
    return rows


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def format_table(summary: dict, methods: Sequence[str], mar: bool = False) -> str:
    """Per case each method's ratio to the best classical fill (or its MAR), then the aggregate."""
    header = ["scene", "sampling", "best classical", *methods]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for entry in summary["cases"]:
        values = entry["methods"]
        best = entry.get("best_classical")
        cells = [entry["scene"], entry["sampling"],
                 f"{best} {values[best]['mar']:.4g}" if best else "–"]
        for method in methods:
            value = values.get(method)
            if value is None or (not mar and value.get("ratio") is None):
                cells.append("–")
            elif mar:
                cells.append(scenes._fmt(value))
            else:
                cells.append(f"{value['ratio']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Aggregate: ratio to the best classical fill (geometric mean / worst / cases "
              "at or under 1.0)", "", "| method | group | cases | geomean | worst | ≤ 1.0 |",
              "|---|---|---|---|---|---|"]
    for method, groups in summary["aggregate"].items():
        for group, value in groups.items():
            lines.append(f"| {method} | {group} | {value['cases']} | {value['geomean']:.3f} | "
                         f"{value['worst']:.3f} | {value['wins']} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None, out=None) -> int:
    out = out or sys.stdout
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    scenes.add_scene_arguments(parser)
    parser.add_argument("--samplings", default=",".join(DEFAULT_SAMPLINGS))
    parser.add_argument("--bases", default="np,bp", help="np, bp or np,bp (default)")
    parser.add_argument("--jumps", default="", help="other jumps of the gate to print")
    parser.add_argument("--medians", default="", help="other median windows to print (odd)")
    parser.add_argument("--windows", action="store_true",
                        help="also the default with the 5 x 5, and the 3 x 3, window on every "
                        "sampling")
    parser.add_argument("--seeds", default="0", help="comma-separated seeds (default 0)")
    parser.add_argument("--arrays", default=None, help="a folder to keep / reuse NP, BP results")
    parser.add_argument("--stored-only", action="store_true",
                        help="with --arrays: skip the runs not stored there")
    parser.add_argument("--json", default=None, help="write the runs here")
    parser.add_argument("--resume", action="store_true", help="keep the runs in --json")
    parser.add_argument("--mar", action="store_true", help="MARs in the table, not ratios")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    try:
        size = parse_size(args.size)
        samplings = [parse_sampling(s) for s in scenes.split_list(args.samplings)]
        bases = scenes.split_list(args.bases)
        if not bases or set(bases) - {"np", "bp"}:
            raise ValueError(f"--bases must list np and/or bp, got {args.bases!r}")
        jumps = [float(j) for j in scenes.split_list(args.jumps)]
        if any(not j >= 0 for j in jumps):
            raise ValueError("--jumps must list numbers >= 0")
        medians = scenes.split_list(args.medians)
        if not all(k.isdigit() for k in medians):
            raise ValueError(f"--medians must list odd window sides, got {args.medians!r}")
        medians = [check_median(int(k)) for k in medians]
        seeds = [int(s) for s in scenes.split_list(args.seeds)]
        if not seeds or min(seeds) < 0:
            raise ValueError("--seeds must list non-negative integers")
        if args.resume and not args.json:
            raise ValueError("--resume needs --json")
        if args.stored_only and not args.arrays:
            raise ValueError("--stored-only needs --arrays")
        if args.arrays and not Path(args.arrays).is_dir():
            raise ValueError(f"--arrays must be an existing folder, got {args.arrays!r}")
        specs = scenes.specs_from_arguments(args)
    except ValueError as error:
        print(f"bench_gaps.py: {error}", file=sys.stderr)
        return 2
    rows = []
    if args.resume and Path(args.json).is_file():
        rows = [r for r in json.loads(Path(args.json).read_text())["runs"] if r["size"] == size]
    have = {(r["scene"], r["size"], r["sampling"], r["method"], r["seed"]) for r in rows}
    methods = [m for b in bases for m in readings(b, jumps, medians, args.windows)]
    methods += ["row-linear", *scenes.CLASSICAL]
    progress = None if args.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    for name, spec in specs:
        for sampling in samplings:
            rows += run_case(name, spec, size, sampling, bases, seeds, jumps, args.arrays, have,
                             progress, stored_only=args.stored_only, medians=medians,
                             windows=args.windows)
            if args.json:
                write_atomic(args.json, json.dumps(dict(command=" ".join(sys.argv), runs=rows),
                                                   indent=1, allow_nan=True).encode())
    chosen = [r for r in rows if r["scene"] in {n for n, _ in specs}
              and r["sampling"] in samplings and r["method"] in methods
              and r["seed"] in seeds]
    summary = scenes.summarise(chosen, methods)
    print(f"bench_gaps: size {size}, seeds {','.join(map(str, seeds))}, {len(specs)} scenes, "
          "MAR (Eq. 13) in each scene's unit" if args.mar else
          "each method's MAR (Eq. 13) over the best classical fill's", file=out)
    print(format_table(summary, methods, mar=args.mar), file=out)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
