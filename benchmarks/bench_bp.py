"""BP range synthesis: time, memory, accuracy against NP and the baselines (§3.2.3).

Prints, as Markdown tables:

0. BP against the colorization fill (issue #15): the Motorcycle at 112×94,
   225×188, 450×375 and 900×750, x-stripes 78 % unknown, each size in a fresh
   process: BP's time, its iteration count and the peak resident memory of the
   process after BP (scene loaded, BP run; nothing else yet), then
   :func:`refsynth.evaluation.baselines.colorization_fill` on the same input in
   the same process (the faster of two runs) and the ratio, of wall-clock and of
   CPU time (the latter steadier on a shared machine). Targets: ≤ 6× at
   450×375, ≤ 5× at 900×750, peak ≤ 1 GB at 900×750. ``--big`` adds BP on a
   2048×2048 Motorcycle (about 4 minutes; within 4 GB, its estimate printed);
1. speed: BP on the 128×128 synthetic room at 61 % (grid 5/25) and on the
   Motorcycle at 450×375, 78 % unknown (x-stripes), with peak memory; time
   against ``k`` and against the number of unknown pixels (the paper's
   ``O(n k² T)``);
2. accuracy on the synthetic room (128×128, the paper's grid stripes
   rw/xw = 24/80, 10/20, 5/25, 3/28) and on the Motorcycle (450×375, x-stripes
   63/78/85 %): BP (refsynth's defaults: since 0.9 on NP's fill, so over the
   same seeds as NP), BP as Fig. 6 prints it (the observations' measured
   range, the fixed disc), BP without the edge-constraint rule, NP (3 seeds),
   and the
   nearest, linear and harmonic fills, each measured in the same run; for BP
   also the *candidate ceiling* (the MAR if every pixel picked its best
   candidate) and the MAR of the 50 % most confident synthesized pixels
   against the other 50 %.

3. ``--proposals``: BP's proposals (issue #10 item 4, a departure,
   :mod:`refsynth.synthesis.belief.proposals`) on the Motorcycle's x-stripes
   63/78/85 % at a stripe phase (1: the choosing split of
   ``audit_departures.py``; 0: its report split), over seeds: each variant's
   MAR (mean ± sd), its candidate ceiling, the MAR of its first-ranked labels
   (each node's largest Φ, Eq. 2's best match) and the share of nodes whose MAP
   value is that label's, its seconds, beside NP and the classical fills (the
   same calls as ``audit_departures.py``, so the same numbers); ``--room`` does
   the same on the room's grids 10/20 and 5/25.

Every case runs in a fresh process, so that its peak resident memory
(``ru_maxrss``) is its own. Needs scikit-image for the Motorcycle pair.

Run::

    python benchmarks/bench_bp.py            # about 15 minutes on 2 cores
    python benchmarks/bench_bp.py --quick    # sections 0 and 1 only
    python benchmarks/bench_bp.py --ratios   # section 0 only (about 3 minutes)
    python benchmarks/bench_bp.py --proposals --phase 1 --sizes 450x375   # section 3
    python benchmarks/bench_bp.py --proposals --room                      # section 3, room
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import resource
import sys
import time

import numpy as np
from audit_departures import VARIANTS  # this script's folder: one variant table

from refsynth.synthesis.options import draws_at_random


def _rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1024.0 if sys.platform != "darwin" else rss / 1024.0**2


def _scene(name, size):
    from refsynth.scenes import motorcycle, synthetic_room

    return synthetic_room((size, size), seed=0) if name == "room" else motorcycle(size)


def _sampling(shape, spec, phase=0):
    from refsynth.acquisition.sampling import stripes, x_stripes_for_fraction

    if spec.startswith("g"):
        rw, xw = (int(v) for v in spec[1:].split("_"))
        return stripes(shape, rw, xw, axes="xy")
    return x_stripes_for_fraction(shape, int(spec[1:]) / 100.0, phase=phase)


METHODS = {
    "BP": {"method": "bp"},
    "BP, Fig. 6": {"method": "bp", "observation": "measured", "training_radius": "fixed",
                   "range_copy": "value"},
    "BP, no edge rule": {"method": "bp", "use_edges": False},
    "NP": {"method": "np"},
}


def _case(args):
    scene_name, size, spec, method, seed, extra = args
    import refsynth
    from refsynth.acquisition.sampling import unknown_fraction
    from refsynth.evaluation.baselines import BASELINES
    from refsynth.evaluation.metrics import evaluate
    from refsynth.synthesis.readings import split_options

    scene = _scene(scene_name, size)
    known = _sampling(scene.range.shape, spec) & scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    before = _rss_mb()
    start = time.perf_counter()
    row = {}
    if method in BASELINES:
        estimate = BASELINES[method](scene.intensity, partial)
    else:
        keywords, readings = split_options({**METHODS[method], **extra})
        result = refsynth.synthesize(scene.intensity, partial, seed=seed, **keywords,
                                     readings=readings)
        estimate = result.range
        if result.method == "bp":
            rows, cols = result.order[:, 0], result.order[:, 1]
            truth = scene.range[rows, cols]
            ok = np.isfinite(truth)
            err = np.abs(result.candidate_values[ok] - truth[ok, None])
            conf = result.confidence[rows, cols][ok]
            chosen = np.abs(estimate[rows, cols][ok] - truth[ok])
            top = conf >= np.median(conf)
            row.update(ceiling=float(err.min(axis=1).mean()), iterations=result.iterations,
                       mar_confident=float(chosen[top].mean()),
                       mar_rest=float(chosen[~top].mean()) if (~top).any() else float("nan"))
    seconds = time.perf_counter() - start
    row.update(scene=scene.name, sampling=spec, unknown=100 * unknown_fraction(known),
               n_unknown=int((~known).sum()), method=method, seed=seed, seconds=seconds,
               rss_before=before, rss_peak=_rss_mb(), k=extra.get("candidates", 8),
               **evaluate(estimate, scene.range, known))
    return row


#: Section 3's variants: keyword arguments of refsynth.synthesize, by the names of
#: audit_departures.py's table (one table for both scripts): NP and every BP variant there
#: (Fig. 6's BP, BP's departures for issue #10 — NP's proposals, the completed observations,
#: Eq. 6 with the centres, the gap-sized training disc, the labels' copy — and the
#: parameters' readings: λ, σ_i, σ_s, μ, k).
PROPOSAL_VARIANTS = {name: kw for name, kw in VARIANTS.items()
                     if name == "np" or kw["method"] == "bp"}
#: Section 3's variants that make no random choice: one seed is enough.
DETERMINISTIC = {name for name, kw in PROPOSAL_VARIANTS.items() if not draws_at_random(kw)}
CLASSICAL = ("nearest", "colorization", "joint-bilateral")


def _proposal_case(args):
    """One fill of section 3: MAR, candidate ceiling (BP) and seconds."""
    import refsynth
    from refsynth.evaluation.baselines import BASELINES
    from refsynth.evaluation.metrics import evaluate
    from refsynth.synthesis.readings import split_options

    name, scene_name, size, spec, phase, seed = args
    scene = _scene(scene_name, size)
    known = _sampling(scene.range.shape, spec, phase) & scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    start = time.perf_counter()
    ceiling = top = kept = float("nan")
    if name in CLASSICAL:
        estimate = BASELINES[name](scene.intensity, partial)
    else:
        keywords, readings = split_options(PROPOSAL_VARIANTS[name])
        result = refsynth.synthesize(scene.intensity, partial, seed=seed, **keywords,
                                     readings=readings)
        estimate = result.range
        if result.method == "bp":  # the candidate ceiling: each node's best candidate
            rows, cols = result.order[:, 0], result.order[:, 1]
            truth = scene.range[rows, cols]
            ok = np.isfinite(truth)
            values = result.candidate_values[ok]
            ceiling = float(np.abs(values - truth[ok, None]).min(axis=1).mean())
            # the first-ranked label (Eq. 2's best, the largest Φ): its error, and the share
            # of nodes whose MAP value is its value
            top = float(np.abs(values[:, 0] - truth[ok]).mean())
            kept = float(np.mean(estimate[rows, cols][ok] == values[:, 0]))
    seconds = time.perf_counter() - start
    return dict(name=name, case=f"{scene.name} {spec}", seed=seed, ceiling=ceiling, top=top,
                kept=kept, mar=float(evaluate(estimate, scene.range, known)["mar"]),
                seconds=seconds)


def _proposal_table(pool, args):
    if args.room:
        cases = [("room", 128, spec) for spec in ("g10_20", "g5_25")]
    else:
        cases = [("motorcycle", tuple(int(v) for v in size.split("x")), f"x{f}")
                 for size in args.sizes.split(",") for f in (63, 78, 85)]
    names = [v for v in args.variants.split(",") if v]
    jobs = [(b, *case, args.phase, 0) for case in cases for b in CLASSICAL]
    # plain BP makes no random choice: one seed
    jobs += [(v, *case, args.phase, seed) for case in cases for v in names
             for seed in range(1 if v in DETERMINISTIC else args.seeds)]
    rows = []
    for row in pool.imap(_proposal_case, jobs):
        rows.append(row)
        print(f"  {row['case']} {row['name']} seed {row['seed']}: MAR {row['mar']:.3f} "
              f"ceiling {row['ceiling']:.3f} ({row['seconds']:.1f} s)", file=sys.stderr,
              flush=True)
    where = "the room's grids" if args.room else f"stripe phase {args.phase}"
    print(f"\n## 3. BP's proposals ({where})\n")
    print("| case | variant | MAR mean ± sd | / best classical | candidate ceiling "
          "| first-ranked label's MAR | MAP = first-ranked | s |")
    print("|---|---|---|---|---|---|---|---|")
    for case in dict.fromkeys(r["case"] for r in rows):
        here = [r for r in rows if r["case"] == case]
        best = min(r["mar"] for r in here if r["name"] in CLASSICAL)
        for name in dict.fromkeys(r["name"] for r in here):
            mine = [r for r in here if r["name"] == name]
            mar = np.array([r["mar"] for r in mine])
            sd = f" ± {mar.std(ddof=1):.3f}" if mar.size > 1 else ""
            print(f"| {case} | {name} | {mar.mean():.3f}{sd} | {mar.mean() / best:.2f} | "
                  f"{_fmt(float(np.mean([r['ceiling'] for r in mine])))} | "
                  f"{_fmt(float(np.mean([r['top'] for r in mine])))} | "
                  f"{_percent(float(np.mean([r['kept'] for r in mine])))} | "
                  f"{np.mean([r['seconds'] for r in mine]):.1f} |", flush=True)


def _ratio_case(size):
    """BP, then the colorization fill twice, on the Motorcycle at ``size``, x-stripes 78 %."""
    import refsynth
    from refsynth.evaluation.baselines import colorization_fill

    scene = _scene("motorcycle", size)
    known = _sampling(scene.range.shape, "x78") & scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    before = _rss_mb()
    start, cpu = time.perf_counter(), time.process_time()
    result = refsynth.synthesize(scene.intensity, partial, method="bp")
    bp_seconds, bp_cpu = time.perf_counter() - start, time.process_time() - cpu
    peak = _rss_mb()
    times, cpus = [], []
    for _ in range(2):
        start, cpu = time.perf_counter(), time.process_time()
        colorization_fill(scene.intensity, partial)
        times.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu)
    return dict(size=size, n_unknown=int((~known).sum()), bp=bp_seconds, bp_cpu=bp_cpu,
                colorization=min(times), colorization_cpu=min(cpus),
                iterations=result.iterations, rss_before=before, rss_peak=peak)


def _big_case(size):
    """BP on a large Motorcycle: its memory estimate, time and peak memory."""
    import refsynth
    from refsynth.synthesis.belief.memory import bp_memory_estimate

    scene = _scene("motorcycle", size)
    known = _sampling(scene.range.shape, "x78") & scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    unknown = ~known
    pairs = int(np.count_nonzero(unknown[:, :-1] & unknown[:, 1:])
                + np.count_nonzero(unknown[:-1, :] & unknown[1:, :]))
    estimate = bp_memory_estimate(partial.shape, int(unknown.sum()), n_pairs=pairs)
    before = _rss_mb()
    start = time.perf_counter()
    result = refsynth.synthesize(scene.intensity, partial, method="bp")
    seconds = time.perf_counter() - start
    return (f"\nBP on {size[0]}×{size[1]} ({int(unknown.sum())} unknown pixels): "
            f"{seconds:.0f} s, {result.iterations} iterations; estimate "
            f"{estimate / 2**20:.0f} MB; RSS {before:.0f} → {_rss_mb():.0f} MB")


def _ratio_table(pool):
    print("| size | unknown pixels | BP s | colorization s | BP / colorization "
          "| (CPU time) | iterations | µs per unknown pixel | RSS before → after BP MB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in pool.imap(_ratio_case, [(112, 94), (225, 188), (450, 375), (900, 750)]):
        print(f"| {r['size'][0]}×{r['size'][1]} | {r['n_unknown']} | {r['bp']:.2f} | "
              f"{r['colorization']:.2f} | {r['bp'] / r['colorization']:.1f}× | "
              f"{r['bp_cpu'] / r['colorization_cpu']:.1f}× | {r['iterations']} | "
              f"{1e6 * r['bp'] / r['n_unknown']:.1f} | "
              f"{r['rss_before']:.0f} → {r['rss_peak']:.0f} |", flush=True)


def _run(cases, pool):
    rows = []
    for row in pool.imap(_case, cases):
        rows.append(row)
        print(f"  {row['scene']} {row['sampling']} {row['method']} seed {row['seed']}: "
              f"{row['seconds']:.2f} s, MAR {row['mar']:.4f}", file=sys.stderr)
    return rows


def _fmt(value, spec=".3f"):
    return "–" if value is None or (isinstance(value, float) and np.isnan(value)) else \
        format(value, spec)


def _percent(value):
    """A share as a percentage, or "–" where there is none (a classical fill, NP)."""
    return "–" if np.isnan(value) else f"{100 * value:.1f} %"


def _accuracy_table(rows):
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["scene"], r["sampling"], r["method"]), []).append(r)
    print("| scene | sampling | unknown | method | MAR | RMSE | bad>1 | candidate ceiling "
          "| MAR 50 % most confident / rest | iterations | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for (scene, sampling, method), members in groups.items():
        mar = np.array([m["mar"] for m in members])
        spread = f" ± {mar.std(ddof=1):.3f}" if len(mar) > 1 else ""
        first = members[0]
        split = (f"{first['mar_confident']:.3f} / {first['mar_rest']:.3f}"
                 if "mar_confident" in first else "–")
        print(f"| {scene} | {sampling} | {first['unknown']:.1f} % | {method}"
              f"{' (' + str(len(mar)) + ' seeds)' if len(mar) > 1 else ''} | "
              f"{mar.mean():.3f}{spread} | {np.mean([m['rmse'] for m in members]):.3f} | "
              f"{np.mean([m['bad1'] for m in members]):.3f} | {_fmt(first.get('ceiling'))} | "
              f"{split} | {first.get('iterations', '–')} | "
              f"{np.mean([m['seconds'] for m in members]):.2f} |")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="sections 0 and 1 only")
    parser.add_argument("--ratios", action="store_true",
                        help="section 0 only: BP against the colorization fill")
    parser.add_argument("--big", action="store_true",
                        help="with section 0, BP on a 2048×2048 Motorcycle too")
    parser.add_argument("--seeds", type=int, default=3,
                        help="seeds of NP and of BP on NP's fill (default 3)")
    parser.add_argument("--proposals", action="store_true",
                        help="section 3 only: BP's proposals against BP, NP and the classical")
    parser.add_argument("--phase", type=int, default=1,
                        help="section 3: the stripe phase (1: choosing split; 0: report)")
    parser.add_argument("--sizes", default="450x375", help="section 3: sizes, e.g. 450x375")
    parser.add_argument("--room", action="store_true",
                        help="section 3 on the room's grids 10/20 and 5/25 instead")
    parser.add_argument("--variants", default="np,bp,bp-proposals-np",
                        help=f"section 3's variants, from {','.join(PROPOSAL_VARIANTS)}")
    args = parser.parse_args(argv)
    ctx = mp.get_context("spawn")
    with ctx.Pool(1, maxtasksperchild=1) as pool:
        if args.proposals:
            _proposal_table(pool, args)
            return 0
        print("## 0. BP against the colorization fill (Motorcycle, x-stripes 78 %)\n")
        _ratio_table(pool)
        if args.big:
            print(pool.apply(_big_case, ((2048, 2048),)))
        if args.ratios:
            return 0
        print("\n## 1. Speed and memory\n")
        cases = [("room", 128, "g5_25", "BP", 0, {}),
                 ("motorcycle", (450, 375), "x78", "BP", 0, {})]
        rows = _run(cases, pool)
        print("| scene | sampling | unknown | k | iterations | wall s | RSS before → peak MB |")
        print("|---|---|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['scene']} | {r['sampling']} | {r['unknown']:.1f} % | {r['k']} | "
                  f"{r['iterations']} | {r['seconds']:.2f} | "
                  f"{r['rss_before']:.0f} → {r['rss_peak']:.0f} |")
        print("\nTime against k (Motorcycle 225×188, x-stripes 78 %, 20 iterations, "
              "no early stop):\n")
        fixed = {"iterations": 20, "tolerance": 0.0}
        cases = [("motorcycle", (225, 188), "x78", "BP", 0, {"candidates": k, **fixed})
                 for k in (4, 8, 16)]
        cases += [("motorcycle", size, "x78", "BP", 0, fixed)
                  for size in ((112, 94), (450, 375))]
        rows = _run(cases, pool)
        print("| size | unknown pixels n | k | wall s | µs per n·k² |")
        print("|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['scene']} | {r['n_unknown']} | {r['k']} | {r['seconds']:.2f} | "
                  f"{1e6 * r['seconds'] / (r['n_unknown'] * r['k'] ** 2):.3f} |")
        if args.quick:
            return 0

        print("\n## 2. Accuracy\n")
        cases = []
        for scene, size, samplings in (
            ("room", 128, ("g24_80", "g10_20", "g5_25", "g3_28")),
            ("motorcycle", (450, 375), ("x63", "x78", "x85")),
        ):
            for spec in samplings:
                # BP draws through NP's fill (its default observations since 0.9): seeds
                cases += [(scene, size, spec, name, s, {}) for s in range(args.seeds)
                          for name in ("BP", "BP, no edge rule")]
                cases += [(scene, size, spec, "BP, Fig. 6", 0, {})]
                cases += [(scene, size, spec, "NP", s, {}) for s in range(args.seeds)]
                cases += [(scene, size, spec, b, 0, {})
                          for b in ("nearest", "linear", "harmonic")]
        _accuracy_table(_run(cases, pool))
    return 0


if __name__ == "__main__":
    sys.exit(main())
