"""Audit refsynth's departures from the paper on real images (issue #10).

For each reading of the paper that refsynth could take — the paper's literal
text and refsynth's departure — run NP (or BP) on the Middlebury 2014
Motorcycle (scikit-image's copy) with x-stripes at 63 / 78 / 85 % unknown
(Table 4's protocol), over several seeds, and print MAR (Eq. 13, in the
pair's disparity pixels) beside the classical fills.

Two splits keep choosing apart from reporting:

- ``choose``: stripe phase 1 (the known columns shifted by one), 450×375;
  defaults are decided here;
- ``report``: stripe phase 0 (what ``python -m refsynth evaluate`` uses),
  450×375 and the pair's full 741×500; the README's figures come from here.
- ``crop``: issue #10's own protocol, never chosen on: the pair's columns
  70:670 (600×500, :data:`refsynth.scenes.MOTORCYCLE_CROP`) at 450×375 and as
  stored, stripe phase 0, MAR in the pair's own disparity pixels (sizes are
  printed as ``crop450x375``).

Usage::

    python benchmarks/audit_departures.py --split choose            # decide
    python benchmarks/audit_departures.py --split report            # report
    python benchmarks/audit_departures.py --variants np,np-product --sizes 450x375 \\
        --fractions 78 --seeds 0,1,2 --jobs 2

Each line is ``variant size fraction: mean ± sd over seeds (ratio to the best
classical fill)``; a variant wins when its mean is lower by more than the sum
of the two seed-to-seed standard deviations. Every variant audits the fill as filled,
with the paper's 5 × 5 window (``gaps="copy"``, ``median=0``, ``window="fixed"``), unless it
names them: ``np-gaps`` and ``bp-gaps`` add the default post-passes after it (the gap
reading, then the 3 × 3 median), ``np-window`` and ``bp-window`` the default's window (3 × 3
where the stripes' gaps are at most 5 columns wide).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

#: Fig. 6 as printed: the observations' measured range, the fixed training disc and the labels'
#: centre values (BP's defaults since issue #10 complete the observations, widen the disc by
#: the gap's depth and, since 0.6, shift the labels: ``range_copy="offset"``).
FIG6 = {"observation": "measured", "training_radius": "fixed", "range_copy": "value"}
#: Eq. 5's copy as printed: the drawn centre's value (NP's default since 0.5 shifts it by the
#: windows' consistent range difference, ``range_copy="offset"``).
VALUE_COPY = {"range_copy": "value"}

#: The variants: keyword arguments of refsynth.synthesize. "np" and "bp" are the
#: defaults, "bp-fig6" is Fig. 6 as printed; each other entry changes one reading — of
#: Fig. 6 for the BP entries, unless it names the observation or the training disc, and of
#: Eq. 5's value copy for the NP entries, unless it names the copy.
VARIANTS: dict[str, dict] = {
    "np": {"method": "np"},
    # the post-passes after the fill (every other variant runs as filled)
    "np-gaps": {"method": "np", "gaps": "gate", "median": 3},
    "bp-gaps": {"method": "bp", "gaps": "gate", "median": 3},
    "np-window": {"method": "np", "window": "gaps"},
    "bp-window": {"method": "bp", "window": "gaps"},
    "np-product": {"method": "np", "confidence_update": "product"},
    "np-best": {"method": "np", "confidence_update": "best"},
    "np-literal-eq2": {"method": "np", "missing_range": "ignore"},
    "np-mean-eq2": {"method": "np", "missing_range": "mean"},
    "np-lambda0.25": {"method": "np", "range_weight": 0.25},
    "np-lambda0.5": {"method": "np", "range_weight": 0.5},
    "np-lambda1": {"method": "np", "range_weight": 1.0},
    "np-lambda4": {"method": "np", "range_weight": 4.0},
    "np-lambda16": {"method": "np", "range_weight": 16.0},
    "np-lambda64": {"method": "np", "range_weight": 64.0},
    "np-grey": {"method": "np", "colour": False},
    "np-colour": {"method": "np", "colour": True},
    "np-noedges": {"method": "np", "use_edges": False},
    "np-noisophotes": {"method": "np", "use_isophotes": False},
    "np-onion": {"method": "np", "ordering": "onion"},
    "np-value-copy": {"method": "np", "range_copy": "value"},
    "np-offset-copy": {"method": "np", "range_copy": "offset"},
    # the paper's literal readings together (Eq. 11: C(best); Eq. 2: equal weights on the
    # normalised intensity and range, the range term only where both have range), and each of
    # refsynth's departures from them on its own
    "np-literal": {"method": "np", "confidence_update": "best", "range_weight": 1.0,
                   "missing_range": "ignore"},
    "np-literal+lambda16": {"method": "np", "confidence_update": "best", "range_weight": 16.0,
                            "missing_range": "ignore"},
    "np-literal+mean": {"method": "np", "confidence_update": "best", "range_weight": 1.0,
                        "missing_range": "mean"},
    "np-literal+grey": {"method": "np", "confidence_update": "best", "range_weight": 1.0,
                        "missing_range": "ignore", "colour": False},
    "np-literal+no-edge-tier": {"method": "np", "confidence_update": "best", "range_weight": 1.0,
                                "missing_range": "ignore", "edges_last": False},
    # issue #10's remaining readings, each against the defaults ("np" / "bp"): Eq. 2's colour
    # term averaged over the channels (0.2's reading; the default sums them, as Eq. 2 does);
    # the edge tier dropped (Eq. 10's 1 / (1 + E) term alone)
    "np-channel-mean": {"method": "np", "channels": "mean"},
    "np-no-edge-tier": {"method": "np", "edges_last": False},
    # is the channel sum's gain colour, or only a lighter range term? λ = 0.1 with the
    # channel mean, and λ = 1/3 on the grey level (each exactly a lighter range term)
    "np-lambda0.1": {"method": "np", "channels": "mean", "range_weight": 0.1},
    "np-grey-lambda1/3": {"method": "np", "colour": False, "range_weight": 1.0 / 3.0},
    # 0.2's defaults, for the tables' "before" rows
    "np-0.2": {"method": "np", "channels": "mean"},
    "bp-0.2": {"method": "bp", "channels": "mean", "proximity": 1.0},
    "bp": {"method": "bp"},
    "bp-lambda0.25": {"method": "bp", "range_weight": 0.25},
    "bp-lambda0.5": {"method": "bp", "range_weight": 0.5},
    "bp-lambda1": {"method": "bp", "range_weight": 1.0},
    "bp-lambda16": {"method": "bp", "range_weight": 16.0},
    "bp-deaf-edges": {"method": "bp", "edge_rule": "deaf"},
    "bp-grey": {"method": "bp", "colour": False},
    # BP's candidate ranking: μ = 0 is the paper's (the observation alone) and the default;
    # μ = 1 was 0.2's; then one step (a factor 2) each side of k = 8, σ_i = 0.1, σ_s = 0.2
    "bp-no-proximity": {"method": "bp", "proximity": 0.0},
    "bp-proximity0.5": {"method": "bp", "proximity": 0.5},
    "bp-proximity1": {"method": "bp", "proximity": 1.0},
    "bp-proximity2": {"method": "bp", "proximity": 2.0},
    "bp-k4": {"method": "bp", "candidates": 4},
    "bp-k16": {"method": "bp", "candidates": 16},
    "bp-sigma-i0.05": {"method": "bp", "sigma_i": 0.05},
    "bp-sigma-i0.2": {"method": "bp", "sigma_i": 0.2},
    "bp-sigma-s0.1": {"method": "bp", "sigma_s": 0.1},
    "bp-sigma-s0.4": {"method": "bp", "sigma_s": 0.4},
    # Eq. 2's channel mean for BP (0.2's reading)
    "bp-channel-mean": {"method": "bp", "channels": "mean"},
    # issue #10 item 4 (a departure, refsynth.synthesis.belief.proposals): NP's fill proposes a
    # label per pixel beside the k training patches; "-completed": the training patches'
    # unknown range from NP too; "x3": three NP fills propose
    "bp-proposals-np": {"method": "bp", "proposals": "np"},
    "bp-proposals-np-completed": {"method": "bp", "proposals": "np-completed"},
    "bp-proposals-np-x3": {"method": "bp", "proposals": "np", "proposal_runs": 3},
    # issue #10's BP targets (departures, refsynth.synthesis.belief.observation / centres): the
    # observations' range completed by the colorization fill for Eq. 2's ranking ("-completed":
    # the training patches' too); Eq. 6 with the centres as one more shared pixel; and both
    "bp-obs-colorization": {"method": "bp", "observation": "colorization"},
    "bp-obs-colorization-completed": {"method": "bp", "observation": "colorization-completed"},
    "bp-centres": {"method": "bp", "compatibility": "overlap-centres"},
    "bp-centres-sigma-s0.1": {"method": "bp", "compatibility": "overlap-centres",
                              "sigma_s": 0.1},
    "bp-obs-colorization-centres": {"method": "bp", "observation": "colorization",
                                    "compatibility": "overlap-centres"},
    "bp-obs-colorization-centres-sigma-s0.1": {
        "method": "bp", "observation": "colorization", "compatibility": "overlap-centres",
        "sigma_s": 0.1},
    "bp-obs-colorization-completed-centres-sigma-s0.1": {
        "method": "bp", "observation": "colorization-completed",
        "compatibility": "overlap-centres", "sigma_s": 0.1},
    # the training disc widened by the node's depth in its gap (belief.gap_radius)
    "bp-gap-radius": {"method": "bp", "training_radius": "gap"},
    "bp-obs-colorization-gap-radius": {"method": "bp", "observation": "colorization",
                                       "training_radius": "gap"},
    "bp-obs-colorization-completed-centres-sigma-s0.1-gap-radius": {
        "method": "bp", "observation": "colorization-completed",
        "compatibility": "overlap-centres", "sigma_s": 0.1, "training_radius": "gap"},
    # the same with NP's proposals (belief.proposals): random, 3 seeds
    "bp-obs-colorization-centres-sigma-s0.1-proposals-np": {
        "method": "bp", "observation": "colorization", "compatibility": "overlap-centres",
        "sigma_s": 0.1, "proposals": "np"},
    "bp-obs-colorization-completed-centres-sigma-s0.1-proposals-np-completed": {
        "method": "bp", "observation": "colorization-completed",
        "compatibility": "overlap-centres", "sigma_s": 0.1, "proposals": "np-completed"},
}
VARIANTS = {name: ({**FIG6, **kw} if kw["method"] == "bp" else {**VALUE_COPY, **kw})
            for name, kw in VARIANTS.items()}
VARIANTS["np"] = {"method": "np"}          # the defaults: the offset copy (0.5)
VARIANTS["bp"] = {"method": "bp"}          # the defaults: NP's fill completes (0.9), gap radius
#: 0.4-0.8's default observations: the entries below that measured those releases' BP name them,
#: so that their commands in the README print the same figures under 0.9's default
COLORIZATION = {"observation": "colorization"}
VARIANTS["bp-0.8"] = {"method": "bp", **COLORIZATION}   # 0.6-0.8's default BP (0.7's fill)
VARIANTS["bp-fig6"] = {"method": "bp", **FIG6}
# BP's copy, the other defaults kept: the labels' centre values (0.5's BP) or shifted (0.6)
VARIANTS["bp-value-copy"] = {"method": "bp", "range_copy": "value", **COLORIZATION}
VARIANTS["bp-offset-copy"] = {"method": "bp", "range_copy": "offset", **COLORIZATION}
# BP's observations completed by NP's fill (0.8, an option; the default since 0.9, so the same
# as "bp"): depends on the seed
VARIANTS["bp-obs-np"] = {"method": "bp", "observation": "np"}
# the labels' shift agreement (offset_tolerance, 0.8.4): 2**-k of the span; BP's default is
# 2**-7 (NP's) with the colorization fill's observations and 2**-3 with NP's fill
for _k in (0, 2, 3, 4, 5, 7):
    VARIANTS[f"bp-obs-np-tolerance{_k}"] = {"method": "bp", "observation": "np",
                                            "offset_tolerance": 2.0**-_k}
    VARIANTS[f"bp-tolerance{_k}"] = {"method": "bp", "offset_tolerance": 2.0**-_k,
                                     **COLORIZATION}
VARIANTS["bp-offset-copy-obs-colorization-completed"] = {
    "method": "bp", "range_copy": "offset", "observation": "colorization-completed"}
# BP's defaults with one parameter changed (the entries above change Fig. 6's): how much the
# messages can move the MAP away from Eq. 2's first-ranked label (bench_bp.py --proposals)
for _name, _kw in {"sigma-i0.4": {"sigma_i": 0.4}, "sigma-i1.5": {"sigma_i": 1.5},
                   "sigma-s0.05": {"sigma_s": 0.05}, "lambda0.25": {"range_weight": 0.25},
                   "lambda4": {"range_weight": 4.0}, "lambda16": {"range_weight": 16.0}}.items():
    VARIANTS[f"bp-with-{_name}"] = {"method": "bp", **_kw, **COLORIZATION}
# BP's defaults with 0.6's observations' fill (Gauss-Seidel on the image alone; 0.7 solves
# it by the cascade, refsynth.synthesis.completion): run_one switches the fill's solver
VARIANTS["bp-fill-gauss-seidel"] = {"method": "bp", "fill_solver": "gauss-seidel",
                                    **COLORIZATION}
CLASSICAL = ("nearest", "colorization", "joint-bilateral")
SPLITS = {"choose": {"phase": 1, "sizes": ("450x375",)},
          "report": {"phase": 0, "sizes": ("450x375", "741x500")},
          "crop": {"phase": 0, "sizes": ("450x375", "600x500"), "crop": True}}


def _scene(size: str, crop: bool = False):
    from refsynth.scenes import MOTORCYCLE_CROP, motorcycle

    width, height = (int(v) for v in size.split("x"))
    if crop:  # issue #10's protocol: columns 70:670, the disparity in the pair's pixels
        return motorcycle((width, height), crop=MOTORCYCLE_CROP, units="native")
    return motorcycle((width, height))


@contextlib.contextmanager
def _fill_solver(solver: str | None):
    """BP's observations filled by ``portable_colorization(..., solver=solver)`` inside."""
    if solver is None:
        yield
        return
    from refsynth.synthesis.belief import observation as bp_observation
    from refsynth.synthesis.completion import portable_colorization

    bp_observation.portable_colorization = functools.partial(portable_colorization,
                                                             solver=solver)
    try:
        yield
    finally:
        bp_observation.portable_colorization = portable_colorization


def run_one(job: tuple) -> dict:
    """One fill: (variant or baseline, size, fraction %, phase, seed[, crop]) -> its scores."""
    import refsynth
    from refsynth.acquisition import x_stripes_for_fraction
    from refsynth.evaluation import BASELINES, evaluate
    from refsynth.synthesis.readings import split_options

    name, size, fraction, phase, seed = job[:5]
    scene = _scene(size, crop=len(job) > 5 and job[5])
    known = x_stripes_for_fraction(scene.range.shape, fraction / 100.0, phase=phase)
    known &= scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    start = time.perf_counter()
    if name in CLASSICAL:
        estimate = BASELINES[name](scene.intensity, partial)
    else:
        options = {"gaps": "copy", "median": 0, "window": "fixed",   # the fill, as filled
                   **VARIANTS[name]}
        solver = options.pop("fill_solver", None)
        with _fill_solver(solver):
            keywords, readings = split_options(options)
            estimate = refsynth.synthesize(scene.intensity, partial, seed=seed, **keywords,
                                           readings=readings).range
    seconds = time.perf_counter() - start
    scores = evaluate(estimate, scene.range, known)
    return dict(name=name, size=f"crop{size}" if len(job) > 5 and job[5] else size,
                fraction=fraction, phase=phase, seed=seed,
                mar=float(scores["mar"]), seconds=seconds)


def summarise(rows: list[dict]) -> str:
    """One line per (variant, size, fraction): mean ± sd over seeds and the ratio to the best
    classical fill of the same case."""
    lines = []
    cases = sorted({(r["size"], r["fraction"]) for r in rows})
    for size, fraction in cases:
        here = [r for r in rows if (r["size"], r["fraction"]) == (size, fraction)]
        best = min(
            (np.mean([r["mar"] for r in here if r["name"] == b]) for b in CLASSICAL
             if any(r["name"] == b for r in here)),
            default=np.nan,
        )
        names = list(dict.fromkeys(r["name"] for r in here))
        for name in names:
            mars = np.array([r["mar"] for r in here if r["name"] == name])
            secs = np.mean([r["seconds"] for r in here if r["name"] == name])
            sd = mars.std(ddof=1) if mars.size > 1 else 0.0
            lines.append(
                f"{name:<16} {size:>8} x{fraction}  MAR {mars.mean():.3f} ± {sd:.3f}"
                f"  ({mars.mean() / best:.2f} × best classical {best:.3f})  {secs:6.1f} s"
                f"  n={mars.size}"
            )
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--split", choices=sorted(SPLITS), default="choose",
                        help="choose: stripe phase 1 at 450x375; report: phase 0 at 450x375 "
                             "and 741x500; crop: issue #10's crop (cols 70:670) at 450x375 and "
                             "600x500, phase 0 (default: choose)")
    parser.add_argument("--variants", default="np,np-product",
                        help=f"comma-separated, from: {','.join(VARIANTS)}")
    parser.add_argument("--sizes", default=None, help="override the split's sizes, e.g. 450x375")
    parser.add_argument("--fractions", default="63,78,85", help="unknown %% (default 63,78,85)")
    parser.add_argument("--seeds", default="0,1,2", help="seeds (default 0,1,2)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = parser.parse_args(argv)
    split = SPLITS[args.split]
    variants = [v for v in args.variants.split(",") if v]
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        parser.error(f"unknown variant(s) {unknown}; choose from {','.join(VARIANTS)}")
    sizes = args.sizes.split(",") if args.sizes else split["sizes"]
    fractions = [int(f) for f in args.fractions.split(",")]
    seeds = [int(s) for s in args.seeds.split(",")]
    crop = split.get("crop", False)
    jobs = [(b, s, f, split["phase"], 0, crop) for s in sizes for f in fractions
            for b in CLASSICAL]
    jobs += [(v, s, f, split["phase"], seed, crop) for s in sizes for f in fractions
             for v in variants for seed in seeds]
    print(f"split {args.split} (stripe phase {split['phase']}), {len(jobs)} fills",
          file=sys.stderr)
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = []
        for i, row in enumerate(pool.map(run_one, jobs), 1):
            rows.append(row)
            print(f"[{i}/{len(jobs)}] {row['name']} {row['size']} x{row['fraction']} "
                  f"seed {row['seed']}: {row['mar']:.3f} ({row['seconds']:.1f} s)",
                  file=sys.stderr)
    print(summarise(rows))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as stream:
            json.dump(rows, stream, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
