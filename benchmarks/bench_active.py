"""Active scanning (§5) against the fixed strategies: MAR against the fraction of columns scanned.

Every scene goes through Table 4's protocol (§3.3) as ``bench_scenes.py`` loads
it (the largest centred crop of the target's aspect, an exact area resize; the
Motorcycle with ``--motorcycle``). A strategy chooses which whole columns are
measured (the rig's vertical slices, §4), at each fraction of the columns:

``even``
    columns evenly spread over the width (``round(linspace(0, W − 1, k))``);
``x-stripes``
    Table 4's vertical stripes, 3 columns wide (``x_stripes_for_fraction``);
``distance``
    Fig. 2's distance-driven columns (``distance_driven`` on the truth's column
    medians, their inverse for a disparity: the rig's coarse pass);
``active``
    ``even`` at the first fraction (20 %), then one call of
    :func:`refsynth.acquisition.next_slices` (``--active-method``, default BP)
    per ``--step`` (5 %) of the columns, each on what is measured so far.

``--active-error`` chooses what the greedy rule of ``next_slices`` knows. Three
values take a piece of its knowledge away (ablations: what that piece buys);
three put the truth's version of a piece in its place (probes of what a better
version would buy, not strategies a rig can run: they read the truth):

``uncertainty``
    ``next_slices`` itself: the fill, its uncertainty map, the bend of the
    measured columns, and the pixels a measurement can reach (their rows
    returned a range in the measured columns bounding their gap; on one side
    only, the intensity decides).
``no-uncertainty``
    the same with an uncertainty map of 0 (each gain is the line's distance
    from the fill alone): what the uncertainty map buys.
``all-pixels``
    the same counting every unmeasured pixel in place of the returning ones:
    what knowing where the rangefinder returned buys.
``no-bend``
    the same without the bend of the measured columns (the scale of the line's
    error is the uncertainty alone): what the bend term buys.
``fill-error``
    the same with the fill's true absolute error in place of its uncertainty
    map: what a perfect uncertainty map would buy.
``truth-counts``
    the same with the pixels that have truth counted (what the MAR scores) in
    place of the returning pixels: what knowing where the rangefinder returns
    would buy.
``truth``
    the truth in place of the fill, no uncertainty, and the pixels with truth
    counted, so each gain is the true error the measurement removes from the
    lines across the gaps: how far the rule can go.

A pixel without truth takes the nearest pixel's truth in the probes.

Each fill (NP, BP, the classical fills of :mod:`refsynth.evaluation.baselines`)
is scored with MAR (Eq. 13) over the unknown pixels that have ground truth. The
target: active BP at 40 % ≤ 0.8× the best of BP and the classical fills on
``even`` and on ``distance`` at 40 % (the printed ratio, per scene, with its
geometric mean and largest value). With ``even`` runs above 40 % it also prints
a yardstick: BP on those evenly spread columns over the same denominator, what
measuring more columns buys without choosing them.

Run::

    python benchmarks/bench_active.py ../shared/data --motorcycle --size 225x188 \\
        --figure docs/images/active_scanning.png --json active.json
    python benchmarks/bench_active.py --motorcycle --size 225x188 --methods bp,linear \\
        --fractions 20,40
    python benchmarks/bench_active.py --size 225x188 --from-json a.json,b.json \\
        --figure docs/images/active_scanning.png     # the tables of saved runs
    python benchmarks/bench_active.py --from-json a.json,even.json \\
        --fractions 40,60,80     # the yardstick: even.json has BP on even at 60, 80 %
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
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench_scenes
import bench_scenes  # noqa: E402  (puts the checkout on the path if refsynth is not installed)

from refsynth._files import write_atomic  # noqa: E402
from refsynth.acquisition import next_slices, x_stripes_for_fraction  # noqa: E402
from refsynth.acquisition.active import (  # noqa: E402
    _greedy,
    measured_columns,
    returning_pixels,
)
from refsynth.evaluation.baselines import BASELINES  # noqa: E402
from refsynth.evaluation.cases import known_mask, parse_size  # noqa: E402
from refsynth.evaluation.metrics import evaluate  # noqa: E402
from refsynth.synthesis.api import synthesize  # noqa: E402

STRATEGIES = ("even", "x-stripes", "distance", "active")
CLASSICAL = bench_scenes.CLASSICAL
DEFAULT_METHODS = ("np", "bp", *CLASSICAL)
DEFAULT_FRACTIONS = (20, 30, 40, 50, 60)
#: What next_slices's greedy rule knows (``--active-error``): next_slices itself, three
#: ablations, three probes; each with the chooser the run's header names.
ACTIVE_ERRORS = {
    "uncertainty": "next_slices",
    "no-uncertainty": "greedy choice with an uncertainty of 0 (an ablation)",
    "all-pixels": "greedy choice counting every unmeasured pixel (an ablation)",
    "no-bend": "greedy choice without the bend term (an ablation)",
    "fill-error": "greedy choice with the fill's true error in place of its uncertainty "
                  "(a probe)",
    "truth-counts": "greedy choice counting the pixels with truth (a probe)",
    "truth": "greedy choice with the truth in place of the fill (a probe)",
}


def even_columns(width: int, fraction: float) -> np.ndarray:
    """``round(fraction · width)`` columns evenly spread, ascending."""
    count = max(1, int(round(fraction * width)))
    return np.unique(np.round(np.linspace(0, width - 1, count)).astype(np.int64))


def column_mask(shape: tuple[int, int], columns) -> np.ndarray:
    mask = np.zeros(shape, dtype=bool)
    mask[:, np.asarray(columns, dtype=np.int64)] = True
    return mask


def fixed_mask(scene, strategy: str, fraction: float) -> np.ndarray:
    """The known mask of a fixed strategy at a fraction of the columns (pixels with truth)."""
    shape = scene.range.shape
    if strategy == "even":
        mask = column_mask(shape, even_columns(shape[1], fraction))
    elif strategy == "x-stripes":
        mask = x_stripes_for_fraction(shape, 1.0 - fraction)
    else:
        return known_mask(scene, f"distance{int(round(100 * (1.0 - fraction)))}")
    return mask & scene.has_truth


def nearest_truth(scene) -> np.ndarray:
    """The truth, each pixel without truth taking the nearest pixel's."""
    nearest = ndimage.distance_transform_edt(~scene.has_truth, return_distances=False,
                                             return_indices=True)
    return scene.range[nearest[0], nearest[1]]


def truth_slices(scene, partial: np.ndarray, n: int) -> np.ndarray:
    """next_slices's greedy choice with the truth in place of the fill (the ``truth`` probe):
    the estimate is the truth, the uncertainty 0 and the pixels that count those with truth
    (what the MAR scores), so each gain is the true error the measurement removes from the
    lines. A line ending on a pixel without truth takes the nearest pixel's truth."""
    estimate = nearest_truth(scene)
    return _greedy(estimate, np.zeros_like(estimate), measured_columns(partial), n,
                   scene.has_truth)


def probe_slices(scene, partial: np.ndarray, n: int, error: str, method: str,
                 seed: int) -> np.ndarray:
    """next_slices's choice with one piece of its knowledge taken away or replaced by the
    truth's (``--active-error``): ``no-uncertainty``, an uncertainty map of 0;
    ``all-pixels``, every unmeasured pixel counted; ``no-bend``, no bend term (the bend all
    NaN); ``fill-error``, the fill's true absolute error in place of its uncertainty map;
    ``truth-counts``, the pixels with truth in place of the returning ones; ``truth``,
    :func:`truth_slices`."""
    if error == "truth":
        return truth_slices(scene, partial, n)
    result = synthesize(scene.intensity, partial, method=method, seed=seed)
    measured = measured_columns(partial)
    uncertainty, counts = result.uncertainty, returning_pixels(partial, scene.intensity)
    bend = None
    if error == "no-bend":
        bend = np.full(partial.shape, np.nan)
    elif error == "no-uncertainty":
        uncertainty = np.zeros_like(uncertainty)
    elif error == "fill-error":
        uncertainty = np.where(np.isfinite(partial), 0.0,
                               np.abs(result.range - nearest_truth(scene)))
    elif error == "all-pixels":
        counts = np.broadcast_to(~measured[None, :], counts.shape)
    elif error == "truth-counts":
        counts = scene.has_truth & ~measured[None, :]
    return _greedy(result.range, uncertainty, measured, n, counts, bend)


def active_masks(scene, fractions: Sequence[int], step: int, method: str, seed: int,
                 progress=None, start: int | None = None, error: str = "uncertainty"
                 ) -> tuple[dict[int, np.ndarray], list[float]]:
    """``{percent: mask}`` of the active strategy (from ``even`` at ``start`` %, default the
    first fraction), and the seconds of each next_slices call (another ``error``: an ablation or
    a probe, :func:`probe_slices`)."""
    width = scene.range.shape[1]
    start = min(fractions) if start is None else start
    columns = set(even_columns(width, start / 100).tolist())
    masks, seconds, percent = {}, [], start
    while True:
        mask = column_mask(scene.range.shape, sorted(columns)) & scene.has_truth
        if percent in fractions:
            masks[percent] = mask
        if percent >= max(fractions):
            return masks, seconds
        percent += step
        wanted = int(round(percent / 100 * width)) - len(columns)
        partial = np.where(mask, scene.range, np.nan)
        began = time.perf_counter()
        if error != "uncertainty":
            picks = probe_slices(scene, partial, max(wanted, 1), error, method, seed)
        else:
            picks = next_slices(scene.intensity, partial, max(wanted, 1), method=method,
                                seed=seed)
        seconds.append(time.perf_counter() - began)
        columns.update(picks.tolist())
        if progress:
            progress(f"  {scene.name}: active {percent} % ({seconds[-1]:.1f} s)")


def fill(scene, known: np.ndarray, method: str, seed: int) -> np.ndarray:
    partial = np.where(known, scene.range, np.nan)
    if method in BASELINES:
        return BASELINES[method](scene.intensity, partial)
    return synthesize(scene.intensity, partial, method=method, seed=seed).range


def run_scene(name: str, scene, fractions, methods, strategies, step, active_method, seed,
              progress=None, start: int | None = None, error: str = "uncertainty"
              ) -> tuple[list[dict], list[float]]:
    rows, calls = [], []
    for strategy in strategies:
        if strategy == "active":
            masks, calls = active_masks(scene, fractions, step, active_method, seed, progress,
                                        start, error)
        else:
            masks = {f: fixed_mask(scene, strategy, f / 100) for f in fractions}
        for percent, known in masks.items():
            scanned = 100.0 * float(np.mean(np.isfinite(
                np.where(known, scene.range, np.nan)).any(axis=0)))
            for method in methods:
                began = time.perf_counter()
                estimate = fill(scene, known, method, seed)
                rows.append(dict(scene=name, units=scene.units, strategy=strategy,
                                 fraction=percent, columns_percent=scanned, method=method,
                                 mar=evaluate(estimate, scene.range, known)["mar"],
                                 seconds=time.perf_counter() - began))
            if progress:
                progress(f"  {name}: {strategy} {percent} % done")
    return rows, calls


def _key(row) -> tuple:
    return row["scene"], row["strategy"], row["fraction"], row["method"]


def _mar(rows, scene, strategy, fraction, method) -> float:
    for row in rows:
        if _key(row) == (scene, strategy, fraction, method):
            return row["mar"]
    return math.nan


def target_ratios(rows, scenes, methods, at: int = 40, *, strategy: str = "active",
                  fraction: int | None = None) -> dict[str, float]:
    """Per scene: BP's MAR on ``strategy``'s columns at ``fraction`` % (default ``at``) over
    the best of BP and the classical fills on even and distance at ``at`` % (NaN where a
    run is missing). The target is the default; ``strategy="even"`` at a larger
    ``fraction`` is the yardstick: what more evenly spread columns buy."""
    rivals = [m for m in ("bp", *CLASSICAL) if m in methods]
    ratios = {}
    for scene in scenes:
        fixed = [_mar(rows, scene, s, at, m) for s in ("even", "distance") for m in rivals]
        best = min((mar for mar in fixed if not math.isnan(mar)), default=math.nan)
        active = _mar(rows, scene, strategy, at if fraction is None else fraction, "bp")
        if math.isnan(best) or math.isnan(active):
            ratios[scene] = math.nan
        else:
            ratios[scene] = active / best if best > 0 else (math.inf if active > 0 else math.nan)
    return ratios


def geometric_mean(ratios) -> float:
    """The geometric mean of the finite ratios (NaN if none is)."""
    finite = [r for r in ratios if np.isfinite(r)]
    return math.exp(np.mean(np.log(finite))) if finite else math.nan


def yardstick(rows, scenes, methods, fractions) -> str:
    """The yardstick's table: BP on evenly spread columns at each of ``fractions`` (above
    40 %) over the target's denominator, per scene and as a geometric mean."""
    table = {f: target_ratios(rows, scenes, methods, strategy="even", fraction=f)
             for f in fractions}
    lines = ["\nyardstick: BP on evenly spread columns at more than 40 % / the same best "
             "at 40 %:", f"  {'columns scanned, %':>24s}  "
             + " ".join(f"{f:>6d}" for f in fractions)]
    for scene in scenes:
        lines.append(f"  {scene:>24s}  " + " ".join(f"{table[f][scene]:6.3f}"
                                                    for f in fractions))
    means = [geometric_mean(table[f].values()) for f in fractions]
    lines.append(f"  {'geometric mean':>24s}  " + " ".join(f"{m:6.3f}" for m in means))
    return "\n".join(lines)


def format_tables(rows, scenes, methods, strategies, fractions) -> str:
    lines = []
    for scene in scenes:
        units = next(r["units"] for r in rows if r["scene"] == scene)
        lines.append(f"\n{scene} (MAR in {units}; columns scanned, %: "
                     + " ".join(f"{f:>8d}" for f in fractions) + ")")
        for method in methods:
            for strategy in strategies:
                values = " ".join(f"{_mar(rows, scene, strategy, f, method):8.4f}"
                                  for f in fractions)
                lines.append(f"  {method:>15s} {strategy:>9s}  {values}")
    return "\n".join(lines)


def figure(rows, scenes, methods, strategies, fractions):
    """One panel per scene: MAR against the columns scanned, per strategy (colour): BP
    solid, NP dotted, the best classical fill dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = min(len(scenes), 3)
    rows_n = math.ceil(len(scenes) / columns)
    fig, axes = plt.subplots(rows_n, columns, figsize=(4.2 * columns, 3.2 * rows_n),
                             squeeze=False)
    colours = dict(zip(STRATEGIES, ("tab:blue", "tab:orange", "tab:green", "tab:red")))
    classical = [m for m in methods if m in CLASSICAL]
    for ax, scene in zip(axes.ravel(), scenes):
        for strategy in strategies:
            for label, style, chosen in (("BP", "-", ["bp"]), ("NP", ":", ["np"]),
                                         ("best classical", "--", classical)):
                chosen = [m for m in chosen if m in methods]
                if not chosen:
                    continue
                values = [min(_mar(rows, scene, strategy, f, m) for m in chosen)
                          for f in fractions]
                ax.plot(fractions, values, style, color=colours[strategy], marker=".",
                        label=f"{strategy}, {label}")
        units = next(r["units"] for r in rows if r["scene"] == scene)
        ax.set_title(scene, fontsize=9)
        ax.set_xlabel("columns scanned (%)")
        ax.set_ylabel(f"MAR ({units})")
        ax.set_yscale("log")
    for ax in axes.ravel()[len(scenes):]:
        ax.axis("off")
    handles, labels = axes.ravel()[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=7)
    fig.tight_layout(rect=(0, 0.04 * (1 + len(labels) // 4), 1, 1))
    return fig


def main(argv: Sequence[str] | None = None, out=None) -> int:
    out = out or sys.stdout
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    bench_scenes.add_scene_arguments(parser)
    parser.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    parser.add_argument("--strategies", default=",".join(STRATEGIES))
    parser.add_argument("--fractions", default=",".join(map(str, DEFAULT_FRACTIONS)),
                        help="percent of the columns (default 20,30,40,50,60)")
    parser.add_argument("--step", type=int, default=5,
                        help="active: percent of the columns added per next_slices call")
    parser.add_argument("--active-start", type=int, default=None, metavar="PERCENT",
                        help="active: the evenly spread columns it starts from (default: the "
                        "first of --fractions)")
    parser.add_argument("--active-method", default="bp", choices=("np", "bp"))
    parser.add_argument("--active-error", default="uncertainty", choices=tuple(ACTIVE_ERRORS),
                        help="active: choose with next_slices (default); without a piece of "
                        "its knowledge (ablations): an uncertainty of 0 (no-uncertainty), "
                        "every unmeasured pixel counted (all-pixels), no bend term "
                        "(no-bend); or, as a probe of what "
                        "a piece is worth, with the truth's in its place: the fill's error "
                        "for its uncertainty (fill-error), the pixels with truth for the "
                        "returning ones (truth-counts), or all (truth)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="write the runs here")
    parser.add_argument("--figure", default=None, metavar="PATH", help="write the curves here")
    parser.add_argument("--from-json", default=None, metavar="FILE,...",
                        help="print (and plot) the runs saved by --json instead of running; "
                        "a later file's run replaces an earlier's of the same scene, "
                        "strategy, fraction and method")
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    try:
        size = parse_size(args.size)
        methods = bench_scenes.split_list(args.methods)
        bad = [m for m in methods if m not in {"np", "bp", *BASELINES}]
        if bad or not methods:
            raise ValueError(f"--methods: unknown {bad}")
        strategies = bench_scenes.split_list(args.strategies)
        if not strategies or set(strategies) - set(STRATEGIES):
            raise ValueError(f"--strategies: choose from {', '.join(STRATEGIES)}")
        fractions = sorted({int(f) for f in bench_scenes.split_list(args.fractions)})
        if not fractions or fractions[0] < 1 or fractions[-1] > 95:
            raise ValueError("--fractions must be percentages in 1-95")
        start = fractions[0] if args.active_start is None else args.active_start
        if args.step < 1 or not 1 <= start <= fractions[0] or any(
                (f - start) % args.step for f in fractions):
            raise ValueError("--step must be >= 1 and divide the fractions' distances from "
                             "--active-start (at most the first fraction)")
        if args.from_json:
            specs = []
        else:
            specs = bench_scenes.specs_from_arguments(args)
    except ValueError as error:
        print(f"bench_active.py: {error}", file=sys.stderr)
        return 2
    progress = None if args.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    rows, calls, scenes = [], {}, [name for name, _ in specs]
    active_method, active_error = args.active_method, args.active_error
    for path in bench_scenes.split_list(args.from_json or ""):
        saved = json.loads(Path(path).read_text())
        if any(r["strategy"] == "active" for r in saved["rows"]):   # as its active runs chose
            active_method = saved.get("active_method", active_method)
            active_error = saved.get("active_error", active_error)
        later = {_key(r) for r in saved["rows"]}   # a later file's run replaces an earlier's
        rows = [r for r in rows if _key(r) not in later] + saved["rows"]
        calls.update(saved["next_slices_seconds"])
        scenes += [s for s in dict.fromkeys(r["scene"] for r in saved["rows"]) if s not in scenes]
    if args.from_json:
        wanted = bench_scenes.split_list(args.scenes) if args.scenes else scenes
        scenes = [s for s in scenes if s in wanted]
        rows = [r for r in rows if r["scene"] in scenes and r["method"] in methods
                and r["strategy"] in strategies and r["fraction"] in fractions]
    for name, spec in specs:
        scene = bench_scenes.load(spec, size)
        found, seconds = run_scene(name, scene, fractions, methods, strategies, args.step,
                                   active_method, args.seed, progress, start, active_error)
        rows += found
        calls[name] = seconds
        if args.json:
            write_atomic(args.json, json.dumps(dict(command=" ".join(sys.argv), rows=rows,
                                                    next_slices_seconds=calls,
                                                    active_method=active_method,
                                                    active_error=active_error),
                                               indent=1).encode())
    chooser = ACTIVE_ERRORS[active_error]
    print(f"bench_active: size {size}, seed {args.seed}, {len(scenes)} scenes, active: "
          f"{active_method.upper()}'s {chooser}, +{args.step} % per call; MAR (Eq. 13)",
          file=out)
    print(format_tables(rows, scenes, methods, strategies, fractions), file=out)
    if "active" in strategies and 40 in fractions and "bp" in methods:
        ratios = target_ratios(rows, scenes, methods)
        print("\nactive BP at 40 % / best of BP and the classical fills on even and distance "
              "at 40 % (target <= 0.8):", file=out)
        for scene, ratio in ratios.items():
            shown = "n/a (no even or distance run)" if math.isnan(ratio) else f"{ratio:.3f}"
            print(f"  {scene:>24s}  {shown}", file=out)
        mean = geometric_mean(ratios.values())
        if not math.isnan(mean):
            print(f"  {'geometric mean':>24s}  {mean:.3f}"
                  f"   largest {np.nanmax(list(ratios.values())):.3f}", file=out)
    larger = [f for f in fractions if f > 40]
    if "even" in strategies and 40 in fractions and "bp" in methods and larger:
        print(yardstick(rows, scenes, methods, larger), file=out)
    every = [s for seconds in calls.values() for s in seconds]
    if every and active_error == "uncertainty":  # only next_slices's own calls
        fills = [r["seconds"] for r in rows if r["method"] == active_method]
        cost = (f" = {np.mean(every) / np.mean(fills):.2f} of the mean "
                f"{active_method.upper()} fill of the run ({np.mean(fills):.1f} s)"
                if fills else "")
        print(f"\nnext_slices: {len(every)} calls, mean {np.mean(every):.1f} s{cost}", file=out)
    if args.figure:
        fig = figure(rows, scenes, methods, strategies, fractions)
        buffer = io.BytesIO()
        fig.savefig(buffer, format=Path(args.figure).suffix[1:] or "png", dpi=110)
        write_atomic(args.figure, buffer.getvalue())
        print(f"wrote {args.figure}", file=out)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
