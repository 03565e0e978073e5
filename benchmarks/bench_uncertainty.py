"""The uncertainty map against the true errors: its mean, its ranking (AUSE), its zeros.

Per scene × sampling × method (NP, BP as they fill, ``readings={"gaps": "copy", "median": 0}``,
seed 0), on
the scenes and protocol of ``bench_scenes.py`` (Table 4's centred crop and area resize; the
unknown pixels with truth are scored):

- ``MAR``: Eq. 13's mean absolute error of the synthesized range;
- ``mean/MAR``: the mean of :attr:`refsynth.SynthesisResult.uncertainty` over the same
  pixels, over the MAR (1 is a calibrated scale; the target is 0.7–1.4);
- ``AUSE``: the area between the sparsification curve of the uncertainty (the MAR of the
  pixels left after dropping the most uncertain first, against the fraction dropped) and that
  of the true errors (the oracle), as a fraction of the MAR (0 is a perfect ranking; the
  target is at most 0.3); beside it the same for a random ranking and for the result's
  ``confidence`` (least confident dropped first);
- ``zero``: the share of synthesized pixels whose uncertainty is 0 (must be 0);
- ``cost``: the map's time over the synthesis's, in the same run (``nan`` when the result
  came from ``--arrays``).

``--default`` also scores the map of :func:`refsynth.synthesize`'s default output: the fill
after :func:`~refsynth.synthesis.gap_readings.gap_gate` with the fill's edges
(``gaps="gate"``) and :func:`~refsynth.synthesis.median_pass.median_pass` (``median=3``), the
method's fill given as ``raw``. ``--fit`` re-fits the weights and scales of
:data:`refsynth.synthesis.uncertainty.CALIBRATION` on the cases run (a grid search of the
weights whose ``mean / MAR`` varies least across the cases among those of mean AUSE at most
0.15, the scale centring that ratio's range on 1) and prints them; with ``--default`` the
default output's cases count too. ``--held-out`` asks how the scale carries to a scene it was
not set on: for each scene, the scale is set again from the other scenes' cases alone (the
geometric middle of their ``mean / MAR`` range, with :data:`CALIBRATION`'s weights; the
scored cases: the default output's with ``--default``), and that scene's ``mean / MAR`` is printed
under it beside the one under :data:`CALIBRATION`'s scale.

Run::

    python benchmarks/bench_uncertainty.py ../shared/data --motorcycle --arrays /tmp/unccache \\
        --default
    python benchmarks/bench_uncertainty.py ../shared/data --motorcycle --arrays /tmp/unccache \\
        --default --fit
    python benchmarks/bench_uncertainty.py ../shared/data --motorcycle --arrays /tmp/unccache \\
        --default --held-out
    python benchmarks/bench_uncertainty.py ../shared/data --motorcycle --size 225x188 \\
        --scenes motorcycle,kv2_livingroom_raw --samplings x78,x63

``--arrays DIR`` keeps each result as ``DIR/<scene>_<sampling>_<size>_<method>.npz`` (range,
confidence, BP's candidate values, the synthesis's seconds) and reuses it.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

# this checkout's refsynth (not another one installed), and bench_scenes beside this file
sys.path[:0] = [str(Path(__file__).resolve().parents[1]), str(Path(__file__).resolve().parent)]

import bench_scenes as scenes  # noqa: E402

from refsynth.evaluation.cases import known_mask, parse_sampling, parse_size  # noqa: E402
from refsynth.synthesis.api import (  # noqa: E402
    synthesis_edges,
    synthesize,
    validate_inputs,
)
from refsynth.synthesis.gap_readings import gap_gate  # noqa: E402
from refsynth.synthesis.median_pass import median_pass  # noqa: E402
from refsynth.synthesis.uncertainty import (  # noqa: E402
    CALIBRATION,
    uncertainty_features,
    uncertainty_map,
)

TERMS = ("spread", "labels", "variation", "floor")
GRID = (0.0, 0.1, 0.25, 0.5, 1.0, 2.0, 4.0)
#: ``--fit``: the largest mean AUSE (over the MAR) a calibration may have.
AUSE_LIMIT = 0.15


def sparsification(order: np.ndarray, errors: np.ndarray) -> np.ndarray:
    """The MAR of the pixels kept after dropping ``order``'s first ``i`` pixels, ``i = 0 … n−1``."""
    kept = errors[order][::-1]  # least uncertain first
    means = np.cumsum(kept) / np.arange(1, kept.size + 1)
    return means[::-1]


def ause(score: np.ndarray, errors: np.ndarray) -> float:
    """AUSE over the MAR: ``score`` high = dropped first (ties: the raster order)."""
    curve = sparsification(np.argsort(-score, kind="stable"), errors)
    oracle = sparsification(np.argsort(-errors, kind="stable"), errors)
    return float(np.mean(curve - oracle) / errors.mean())


def load_result(name, spec, size, sampling, method, arrays):
    """The scene, its mask, and the result's arrays (cached in ``arrays``) with its seconds."""
    scene = scenes.load(spec, size)
    known = known_mask(scene, sampling)
    path = Path(arrays) / f"{name}_{sampling}_{size}_{method}.npz" if arrays else None
    if path is not None and path.is_file():
        with np.load(path) as stored:
            result = {key: stored[key] for key in stored.files}
        result["seconds"] = math.nan
        return scene, known, result
    partial = np.where(known, scene.range, np.nan)
    start = time.perf_counter()
    out = synthesize(scene.intensity, partial, method=method, seed=0,
                     readings={"gaps": "copy", "median": 0})
    seconds = time.perf_counter() - start
    result = dict(range=out.range, confidence=out.confidence, edges=out.edges, seconds=seconds)
    if out.candidate_values is not None:
        result["candidate_values"] = out.candidate_values
    if path is not None:
        Path(arrays).mkdir(parents=True, exist_ok=True)
        np.savez(path, **result)
    return scene, known, result


def score_case(scene, known, result, method, default=False) -> tuple[dict, np.ndarray, object]:
    """The figures of one case, its estimate and raw fill (``default``: synthesize's post-passes,
    the gate then the median)."""
    partial = np.where(known, scene.range, np.nan)
    estimate, raw = result["range"], None
    if default:
        edges = result.get("edges")
        if edges is None:   # a cache without them: synthesize's Canny, recomputed
            edges = synthesis_edges(validate_inputs(scene.intensity, partial)[0], sigma=0.8)
        estimate = median_pass(gap_gate(result["range"], partial, edges=edges), partial)
        raw = result["range"]
    start = time.perf_counter()
    unc = uncertainty_map(partial, estimate, method=method, raw=raw,
                          candidate_values=result.get("candidate_values"))
    seconds = time.perf_counter() - start
    scored = ~known & np.isfinite(scene.range)
    errors = np.abs(estimate - scene.range)[scored]
    mar = float(errors.mean())
    noise = np.random.default_rng(0).permutation(errors.size).astype(float)
    return dict(mar=mar, mean_ratio=float(unc[scored].mean() / mar),
                ause=ause(unc[scored], errors), random=ause(noise, errors),
                confidence=ause(-result["confidence"][scored], errors),
                zero=float(np.mean(unc[~known] <= 0.0)),
                finite=bool(np.isfinite(unc).all()),
                cost=seconds / result["seconds"], units=scene.units), estimate, raw


def fit(cases: Sequence[tuple], method: str, ause_limit: float = AUSE_LIMIT) -> dict:
    """Weights and scale of :data:`~refsynth.synthesis.uncertainty.CALIBRATION` from ``cases``.

    ``cases``: ``(scene, known, result, estimate, raw)``. A grid of the weights: of those whose
    mean AUSE over the cases is at most ``ause_limit``, the one whose ``mean / MAR`` varies
    least across the cases (the ratio of its largest to its smallest; ties: the smaller
    AUSE); the scale puts the geometric middle of that ratio's range at 1.
    """
    prepared = []
    for scene, known, result, estimate, raw in cases:
        partial = np.where(known, scene.range, np.nan)
        scored = ~known & np.isfinite(scene.range)
        terms = uncertainty_features(partial, estimate, method=method, raw=raw,
                                     candidate_values=result.get("candidate_values"))
        errors = np.abs(estimate - scene.range)[scored]
        means = {t: float(terms[t][scored].mean() / errors.mean()) for t in TERMS}
        keep = np.random.default_rng(0).permutation(errors.size)[:20000]  # the grid's cost
        prepared.append((errors[keep], {t: terms[t][scored][keep] for t in TERMS}, means))
    used = [t for t in TERMS if method == "bp" or t != "labels"]
    candidates = []
    for weights in itertools.product(GRID, repeat=len(used)):
        if not any(weights[:-1]):
            continue
        ratios = [sum(w * m[t] for w, t in zip(weights, used)) for _, _, m in prepared]
        candidates.append((max(ratios) / min(ratios), weights, ratios))
    candidates.sort(key=lambda c: c[0])
    best = None
    for spread, weights, ratios in candidates:
        if best is not None and spread > best[0] * 1.05:
            break
        score = np.mean([ause(sum(w * f[t] for w, t in zip(weights, used)), errors)
                         for errors, f, _ in prepared])
        if score <= ause_limit and (best is None or score < best[1]):
            best = (spread if best is None else best[0], score, weights, ratios)
    if best is None:
        raise ValueError(f"no weights of the grid reach a mean AUSE <= {ause_limit}")
    _, _, weights, ratios = best
    chosen = {t: 0.0 for t in TERMS}
    chosen.update(zip(used, weights))
    chosen["scale"] = float(1.0 / math.sqrt(min(ratios) * max(ratios)))
    return chosen


def held_out(cases: Sequence[tuple], method: str) -> list[tuple[str, float, float]]:
    """Per scene: ``(scene, mean / MAR under CALIBRATION, mean / MAR under the scale set on
    the other scenes' cases alone)``, the ratio averaged over the scene's cases.

    ``cases``: ``(scene name, ratio)``, the ratio ``mean(map) / MAR`` under CALIBRATION.
    Every term of the map is multiplied by the scale, so a case's ratio under another scale
    is its ratio times the new scale over CALIBRATION's.
    """
    scale = CALIBRATION[method]["scale"]
    rows = []
    for name in dict.fromkeys(n for n, _ in cases):
        own = [r for n, r in cases if n == name]
        others = [r / scale for n, r in cases if n != name]   # the ratios under scale 1
        refit = 1.0 / math.sqrt(min(others) * max(others))
        rows.append((name, float(np.mean(own)), float(np.mean(own) / scale * refit)))
    return rows


def main(argv: Sequence[str] | None = None, out=None) -> int:
    out = out or sys.stdout
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    scenes.add_scene_arguments(parser)
    parser.add_argument("--samplings", default="x78", help="comma-separated (default x78)")
    parser.add_argument("--methods", default="np,bp", help="np, bp or np,bp (default)")
    parser.add_argument("--arrays", default=None, help="a folder to keep / reuse the results")
    parser.add_argument("--default", action="store_true",
                        help="also score synthesize's default output (the gate, the median)")
    parser.add_argument("--fit", action="store_true", help="re-fit CALIBRATION and print it")
    parser.add_argument("--held-out", action="store_true",
                        help="each scene's mean/MAR under a scale set on the other scenes alone")
    args = parser.parse_args(argv)
    try:
        size = parse_size(args.size)
        samplings = [parse_sampling(s) for s in scenes.split_list(args.samplings)]
        methods = scenes.split_list(args.methods)
        if not methods or set(methods) - {"np", "bp"}:
            raise ValueError(f"--methods must be np, bp or np,bp, got {args.methods!r}")
        specs = scenes.specs_from_arguments(args)
    except ValueError as error:
        print(f"bench_uncertainty: {error}", file=sys.stderr)
        return 2
    header = ("| scene | sampling | method | MAR | mean/MAR | AUSE | random | confidence | "
              "zero | cost |")
    print(header, file=out)
    print("|" + "---|" * 10, file=out)
    collected: dict[str, list] = {m: [] for m in methods}
    ratios: dict[str, list] = {m: [] for m in methods}
    figures: dict[str, list] = {}
    for (name, spec), sampling, method in itertools.product(specs, samplings, methods):
        scene, known, result = load_result(name, spec, size, sampling, method, args.arrays)
        for default in (False, True) if args.default else (False,):
            row, estimate, raw = score_case(scene, known, result, method, default)
            collected[method].append((scene, known, result, estimate, raw))
            label = f"{method} (default)" if default else f"{method} (as filled)"
            figures.setdefault(label, []).append(row)
            if default or not args.default:
                ratios[method].append((name, row["mean_ratio"]))
            print(f"| {name} | {sampling} | {label} | {row['mar']:.4g} {row['units']} | "
                  f"{row['mean_ratio']:.2f} | {row['ause']:.3f} | {row['random']:.3f} | "
                  f"{row['confidence']:.3f} | {100 * row['zero']:.1f} % | "
                  f"{100 * row['cost']:.2f} % |", file=out, flush=True)
    print("", file=out)
    for label, rows in figures.items():
        ratio = np.array([r["mean_ratio"] for r in rows])
        print(f"{label}: AUSE mean {np.mean([r['ause'] for r in rows]):.3f}, worst "
              f"{max(r['ause'] for r in rows):.3f}; mean/MAR {ratio.min():.2f}–{ratio.max():.2f}; "
              f"zero on synthesized pixels {max(r['zero'] for r in rows):.1%}", file=out)
    if args.held_out:
        scored = "the default output" if args.default else "the fill as filled"
        print(f"\nmean/MAR, each scene under a scale set on the other scenes ({scored}):",
              file=out)
        for method in methods:
            if len({n for n, _ in ratios[method]}) < 2:
                print(f"  {method}: --held-out needs two scenes or more", file=out)
                continue
            for name, own, refit in held_out(ratios[method], method):
                print(f"  {method}  {name:>24s}  {own:.2f} (all scenes)  {refit:.2f} (held out)",
                      file=out)
    if args.fit:
        print("\nCALIBRATION = {", file=out)
        for method in methods:
            print(f"    {method!r}: {fit(collected[method], method)},  # was "
                  f"{CALIBRATION[method]}", file=out)
        print("}", file=out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
