"""Why NP loses to interpolation on Fig. 2's distance-driven columns: figure, gap table, prototypes.

Three commands, each on scenes of a folder in ``../shared/data``'s layout
(see ``benchmarks/bench_scenes.py``) and/or the Motorcycle, at Table 4's
protocol (450 × 375 by default), MAR (Eq. 13) on the unknown pixels with
ground truth:

``figure``
    One NP run per scene (default: the first NYU frame and the Motorcycle) at
    the distance sampling (60 % unknown), traced (``the trace below``):
    the absolute residual, the fill order (the step at which each pixel was
    synthesized), the column offset of the pixel each value was copied from
    (``q − p``; 0 = the same, unknown, column) and whether that source was a
    measured pixel, whether the offset copy took its shift. Also prints, per
    class of source, the share of steps and their MAR.
``gaps``
    MAR by the width of the gap a pixel lies in (the run of unknown pixels of
    its row, 1–6 columns and wider) for NP's readings: the order (priority /
    onion), Eq. 2's range term (``range_weight`` 0, 1, 4), the copy
    (``range_copy`` offset / value), the edge tier (``use_edges``,
    ``edges_last``), beside the nearest and linear fills.
``prototypes``
    Ideas for NP measured without touching the package (a hook in the traced
    loop replaces the value NP writes): ``interp-edges`` takes the linear
    fill where the row's gap looks like one surface (the jump across it
    within twice what the slopes beside it predict) and NP's value where it
    does not; ``shape`` copies the drawn source's departure from the chord
    between the pixels at the same offsets around it onto the chord between
    the target's measured gap ends (the offset copy generalised from a
    constant to a chord: the range's *shape* anchored to the range around
    the target); ``onion-shape`` the same in the onion order (narrow gaps
    filled from both sides, layer by layer).

Run (the numbers in ``docs/distance_sampling.md``)::

    python benchmarks/diagnose_distance.py figure ../shared/data --motorcycle \\
        --out docs/images/distance_diagnosis.png
    python benchmarks/diagnose_distance.py gaps ../shared/data --motorcycle \\
        --scenes motorcycle --variants np,onion,value-copy,no-edges,no-edge-tier
    python benchmarks/diagnose_distance.py gaps ../shared/data \\
        --scenes nyu_basement_raw_00000 --variants np,onion,value-copy,no-edges,no-edge-tier
    python benchmarks/diagnose_distance.py prototypes ../shared/data --motorcycle \\
        --size 225x188 --scenes motorcycle,nyu_basement_raw_00000 --samplings distance60,x78
    python benchmarks/diagnose_distance.py prototypes ../shared/data --size 225x188 \\
        --scenes mb2005_reindeer_half,kv2_livingroom_raw --samplings distance60,x78
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # bench_scenes

import bench_scenes  # noqa: E402  (puts the checkout on the path if refsynth is not installed)

from refsynth.evaluation.baselines import linear_fill, nearest_fill  # noqa: E402
from refsynth.evaluation.cases import known_mask, parse_sampling  # noqa: E402
from refsynth.numeric import (  # noqa: E402
    CONFIDENCE_BITS,
    INTENSITY_BITS,
    RANGE_BITS,
    quantise_grey,
    quantise_intensity,
    quantise_range,
)
from refsynth.synthesis.api import (
    synthesis_edges,
    synthesize,  # noqa: E402
)
from refsynth.synthesis.filltable import FillTable  # noqa: E402
from refsynth.synthesis.limits import validate_inputs  # noqa: E402
from refsynth.synthesis.neighbourhood import disc_offsets  # noqa: E402
from refsynth.synthesis.onion import onion_order  # noqa: E402
from refsynth.synthesis.priority import FillFront  # noqa: E402
from refsynth.synthesis.readings import split_options  # noqa: E402

MAX_GAP = 6
#: The fill the diagnosis reads: as filled, with the paper's 5 × 5 window.
AS_FILLED = {"gaps": "copy", "median": 0, "window": "fixed"}
#: NP's readings compared by ``gaps``: label -> synthesize() keywords. Each runs the fill as
#: filled (``gaps="copy"``, ``median=0``) with the paper's 5 × 5 window (``window="fixed"``)
#: unless it names them: ``np-gate`` adds the post-passes, ``np-default`` is the default.
GAP_VARIANTS = {
    "np": {},
    "np-gate": {"gaps": "gate", "median": 3},
    "np-default": {"gaps": "gate", "median": 3, "window": "gaps"},
    "onion": {"ordering": "onion"},
    "value-copy": {"range_copy": "value"},
    "lambda0": {"range_weight": 0.0},
    "lambda4": {"range_weight": 4.0},
    "no-edges": {"use_edges": False},
    "no-edge-tier": {"edges_last": False},
    "onion-value": {"ordering": "onion", "range_copy": "value"},
}


# ----------------------------------------------------------------------------- NP's trace
# A diagnostic copy of refsynth.synthesis.nonparametric.np_fill that records, per step, the
# target p, the drawn source q, the best match, |Γ'| and the offset copy's shift. It checks
# that its range equals refsynth.synthesize's bit for bit, so a change of the package's loop
# shows up here as an error rather than as a wrong trace.


@dataclass
class Trace:
    """One NP run's output and per-step trace (rows in fill order)."""

    range: np.ndarray          # (H, W) the dense range
    target: np.ndarray         # (N, 2) row, col of p
    source: np.ndarray         # (N, 2) row, col of the drawn q
    best: np.ndarray           # (N, 2) row, col of Eq. 4's best match
    members: np.ndarray        # (N,) |Γ'| (Eq. 5)
    shift: np.ndarray          # (N,) the offset copy's Δ in the caller's unit (0: none)
    source_known: np.ndarray   # (N,) q was measured (not synthesized)
    step: np.ndarray           # (H, W) the fill step of each synthesized pixel, -1 if measured
    edges: np.ndarray | None = None   # (H, W) the Canny edges the run used


def traced_np_fill(image, range_values, edges, rng, *, neighbourhood=5, radius=10.0,
                   epsilon=0.1, use_edges=True, use_isophotes=True, ordering="priority",
                   range_weight=1.0, missing_range="mean", confidence_update="best",
                   colour=True, edges_last=True, channels="sum", range_copy="offset",
                   override=None):
    """``np_fill`` with a trace; ``override(p_rc, candidates_rc, value, ctx)`` may replace
    the value written (a prototype's hook: returns the new value in the caller's unit or
    None to keep NP's)."""
    H, W = range_values.shape
    n = neighbourhood
    known = np.isfinite(range_values)
    rq, _, span = quantise_range(range_values)
    range_norm = np.where(known, rq * 2.0**-RANGE_BITS, np.nan)
    levels = quantise_intensity(image)
    if not colour:
        levels = quantise_grey(levels)[:, :, None]
    pad = max(int(np.ceil(radius)), n // 2 + 1)
    table = FillTable(levels * 2.0**-INTENSITY_BITS, range_norm, n, pad, range_weight,
                      missing_range, channels)
    front = FillFront(known, range_norm, edges, n, pad, rng, use_edges=use_edges,
                      use_isophotes=use_isophotes, edges_last=edges_last)
    Wp = front.shape[1]
    dr, dc = disc_offsets(radius)
    disc = dr * Wp + dc
    filled = front.filled.ravel()
    values = front.range_norm.ravel()
    original = np.pad(np.where(known, range_values, 0.0), pad).ravel()
    known_p = np.pad(known, pad).ravel()
    total = int((~known).sum())
    draws = rng.random(total)
    if ordering == "onion":
        schedule = onion_order(known, rng)
        schedule = (schedule // W + pad) * Wp + (schedule % W + pad)
    update = ordering != "onion"
    scale = 1.0 + epsilon
    grid, unit = 2.0**CONFIDENCE_BITS, 2.0**-CONFIDENCE_BITS
    at, threshold = np.zeros((), dtype=np.int64), np.zeros(())
    shifting = range_copy == "offset"
    low, high = float(np.min(range_values[known])), float(np.max(range_values[known]))
    to_grid, span_unit, full = 2.0**RANGE_BITS, span * 2.0**-RANGE_BITS, 2**RANGE_BITS
    tp, tq, tb = (np.empty(total, np.int64) for _ in range(3))
    tm = np.empty(total, np.int64)
    ts = np.zeros(total)
    for step in range(total):
        p = int(schedule[step]) if not update else front.queue.pop()
        at[()] = p
        candidates = np.add(disc, at)
        candidates = candidates.compress(filled[candidates])
        if candidates.size == 0:
            from refsynth.synthesis.nonparametric import _widened_candidates
            candidates = _widened_candidates(p, filled, Wp, radius)
        candidates, d = table.shortlist_step(p, candidates, scale)
        if candidates.size == 1:
            best = j = 0
            count = 1
        else:
            best = int(d.argmin())
            threshold[()] = scale * d[best]
            members = np.less_equal(d, threshold).nonzero()[0]
            count = members.size
            j = int(members[int(draws[step] * members.size)])
        q = int(candidates[j])
        value = values[q]
        original[p] = original[q]
        if shifting:
            shift = table.offset_shift(j)
            was = int(value * to_grid)
            now = min(max(was + shift, 0), full) if shift else was
            if now != was:
                value = now * 2.0**-RANGE_BITS
                original[p] = min(max((now - was) * span_unit + original[q], low), high)
        ts[step] = original[p] - original[q]
        if override is not None:
            new = override(p, q, original, known_p, filled, (Wp, pad), low, high)
            if new is not None:
                new = min(max(new, low), high)
                original[p] = new
                value = round((new - low) / span * to_grid) * 2.0**-RANGE_BITS
        confidence = front.confidence_of(int(candidates[best]))
        if confidence_update == "product":
            confidence = front.confidence_of(p) * confidence
        front.fill_step(p, value, round(confidence * grid) * unit, update)
        table.set_range(p, value)
        tp[step], tq[step], tb[step], tm[step] = p, q, int(candidates[best]), count
    inner = (slice(pad, pad + H), slice(pad, pad + W))
    out = np.where(known, range_values, original.reshape(front.shape)[inner])

    def rc(flat):
        rows, cols = np.divmod(flat, Wp)
        return np.stack([rows - pad, cols - pad], axis=1)

    step_map = np.full((H, W), -1, np.int64)
    target = rc(tp)
    step_map[target[:, 0], target[:, 1]] = np.arange(total)
    return Trace(range=out, target=target, source=rc(tq), best=rc(tb), members=tm, shift=ts,
                 source_known=known_p[tq], step=step_map)


def traced_synthesize(intensity, partial, *, seed=0, check=True, override=None,
                      use_edges=True, canny_sigma=0.8, **options) -> Trace:
    """NP as ``refsynth.synthesize(intensity, partial, seed=seed, **options)`` fills it, traced.

    With ``check`` (and no ``override``) the range is compared bit for bit with
    ``refsynth.synthesize``'s with :data:`AS_FILLED`'s readings (the 5 × 5 window unless
    ``neighbourhood`` is given); a difference raises ``AssertionError``.
    """
    image, range_values = validate_inputs(intensity, partial)
    edges = (synthesis_edges(image, sigma=canny_sigma) if use_edges
             else np.zeros(partial.shape, bool))
    rng = np.random.default_rng(seed)
    trace = traced_np_fill(image, range_values, edges, rng, use_edges=use_edges,
                           override=override, **options)
    trace.edges = edges
    if check and override is None:
        keywords, readings = split_options(options)
        reference = synthesize(intensity, partial, seed=seed, use_edges=use_edges,
                               canny_sigma=canny_sigma, **keywords,
                               readings={**AS_FILLED, **readings}).range
        if not np.array_equal(reference, trace.range):
            raise AssertionError("the traced NP differs from refsynth.synthesize: "
                                 "update the trace below to the package's np_fill")
    return trace


# ----------------------------------------------------------------------------- measures


def gap_widths(known: np.ndarray) -> np.ndarray:
    """Per pixel, the length of the run of unknown pixels of its row it lies in (0 if known)."""
    height, width = known.shape
    out = np.zeros(known.shape, np.int64)
    for row in range(height):
        unknown = ~known[row]
        edges = np.flatnonzero(np.diff(np.concatenate([[0], unknown.astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2]):
            out[row, start:stop] = stop - start
    return out


def mar_by_gap(estimate, truth, known, widths) -> dict:
    """MAR over the unknown pixels with truth, by gap width 1..MAX_GAP and wider, and all."""
    scored = ~known & np.isfinite(truth)
    error = np.abs(estimate - truth)
    out = {}
    for w in range(1, MAX_GAP + 2):
        chosen = scored & ((widths == w) if w <= MAX_GAP else (widths > MAX_GAP))
        out[str(w) if w <= MAX_GAP else f">{MAX_GAP}"] = (
            float(error[chosen].mean()) if chosen.any() else None, int(chosen.sum()))
    out["all"] = (float(error[scored].mean()), int(scored.sum()))
    return out


def source_classes(trace, truth) -> list[tuple[str, int, float]]:
    """Steps by the kind of source they copied: share and MAR of each class."""
    rows, cols = trace.target[:, 0], trace.target[:, 1]
    error = np.abs(trace.range[rows, cols] - truth[rows, cols])
    has = np.isfinite(error)
    dc = np.abs(trace.source[:, 1] - cols)
    classes = [
        ("measured source, shift taken", trace.source_known & (trace.shift != 0)),
        ("measured source, value copied", trace.source_known & (trace.shift == 0)),
        ("synthesized, same column (dc = 0)", ~trace.source_known & (dc == 0)),
        ("synthesized, other column, shift taken",
         ~trace.source_known & (dc > 0) & (trace.shift != 0)),
        ("synthesized, other column, value copied",
         ~trace.source_known & (dc > 0) & (trace.shift == 0)),
    ]
    if trace.edges is not None:
        on_edge = trace.edges[rows, cols]
        classes += [("(any source) target on a Canny edge: the last tier", on_edge),
                    ("(any source) target off the edges", ~on_edge)]
    return [(name, int(mask.sum()), float(error[mask & has].mean()) if (mask & has).any()
             else float("nan")) for name, mask in classes]


# ----------------------------------------------------------------------------- prototypes


def _row_brackets(known: np.ndarray, values: np.ndarray):
    """Per pixel: the measured value left and right in its row, their columns, and the
    values one measured pixel further out (NaN where there is none)."""
    height, width = known.shape
    cols = np.arange(width)
    out = {k: np.full(known.shape, np.nan) for k in ("L", "R", "cL", "cR", "LL", "RR",
                                                     "cLL", "cRR")}
    for row in range(height):
        kc = np.flatnonzero(known[row])
        if kc.size == 0:
            continue
        left = np.searchsorted(kc, cols, side="right") - 1        # last known <= c
        right = np.searchsorted(kc, cols, side="left")            # first known >= c
        for key, idx in (("L", left), ("R", right), ("LL", left - 1), ("RR", right + 1)):
            ok = (idx >= 0) & (idx < kc.size)
            column = np.where(ok, kc[np.clip(idx, 0, kc.size - 1)], -1)
            out[key][row, ok] = values[row, column[ok]]
            out["c" + key][row, ok] = column[ok]
    return out


def smooth_gaps(known: np.ndarray, values: np.ndarray, tolerance: float) -> np.ndarray:
    """True where the row's gap looks like one surface: the jump across it is within
    twice what the slopes beside it predict, plus ``tolerance``."""
    b = _row_brackets(known, values)
    width = b["cR"] - b["cL"]
    slope_left = np.abs(b["L"] - b["LL"]) / (b["cL"] - b["cLL"])
    slope_right = np.abs(b["RR"] - b["R"]) / (b["cRR"] - b["cR"])
    slope = np.fmax(slope_left, slope_right)
    slope = np.where(np.isfinite(slope), slope, 0.0)
    jump = np.abs(b["R"] - b["L"])
    return np.isfinite(jump) & (jump <= 2.0 * slope * width + tolerance)


def prototype(name: str):
    """fill(scene, known, seed) -> range for a prototype ``name`` (see the module's docstring).

    ``interp-edges``: the linear fill where :func:`smooth_gaps` finds the row's gap smooth,
    NP's value elsewhere. ``shape`` (and ``onion-shape``, in the onion order): the chord
    between the measured ends of ``p``'s row gap plus the drawn source's departure from its
    own chord, taken between the pixels at the same horizontal offsets around ``q``
    (measured or synthesized) or, where those are not filled yet, between the measured
    pixels beside ``q`` in its row (``q`` itself excluded); NP's value where the gap meets
    the image's border. A constant departure is the offset copy; a measured source in a
    known column has departure 0 only when the range is straight across it.
    ``detail`` (the source's departure from the linear fill) is the linear fill exactly:
    every measured source has departure 0, so every copy has.
    """
    def fill(scene, known, seed):
        partial = np.where(known, scene.range, np.nan)
        span = float(np.nanmax(partial) - np.nanmin(partial))
        lin = linear_fill(scene.intensity, partial)
        smooth = smooth_gaps(known, partial, 2.0**-7 * span) if name == "interp-edges" else None
        brackets = _row_brackets(known, partial) if name.endswith("shape") else None
        state = {}

        def override(p, q, original, known_p, filled, geometry, low, high):
            Wp, pad = geometry
            if not state:
                state["lin"] = np.pad(lin, pad).ravel()
                if brackets is not None:
                    state["b"] = {k: v.ravel() for k, v in brackets.items()}
            pr, pc = divmod(p, Wp)
            pr, pc = pr - pad, pc - pad
            if smooth is not None:
                return state["lin"][p] if smooth[pr, pc] else None
            b = state["b"]
            i = pr * known.shape[1] + pc
            cl, cr = b["cL"][i], b["cR"][i]
            if not (np.isfinite(cl) and np.isfinite(cr)) or cr <= cl:
                return None
            left, right = int(pc - cl), int(cr - pc)
            chord_p = b["L"][i] + (b["R"][i] - b["L"][i]) * left / (left + right)
            ql, qr = q - left, q + right                # same row, padded frame
            qrow, qc = divmod(q, Wp)
            qrow, qc = qrow - pad, qc - pad
            if qc - left >= 0 and qc + right < known.shape[1] and filled[ql] and filled[qr]:
                chord_q = original[ql] + (original[qr] - original[ql]) * left / (left + right)
                return chord_p + (original[q] - chord_q)
            # else the chord between the measured pixels beside q (a measured q excluded)
            j = qrow * known.shape[1] + qc
            ends = ("LL", "RR") if known[qrow, qc] else ("L", "R")
            lv, rv = b[ends[0]][j], b[ends[1]][j]
            lc, rc = b["c" + ends[0]][j], b["c" + ends[1]][j]
            if not (np.isfinite(lv) and np.isfinite(rv)) or rc <= lc:
                return None
            chord_q = lv + (rv - lv) * (qc - lc) / (rc - lc)
            return chord_p + (original[q] - chord_q)

        options = {"ordering": "onion"} if name.startswith("onion") else {}
        return traced_synthesize(scene.intensity, partial, seed=seed, override=override,
                                 **options).range
    return fill


PROTOTYPES = ("interp-edges", "shape", "onion-shape")


# ----------------------------------------------------------------------------- commands


def _scenes(args):
    specs = bench_scenes.scene_specs(args.folder, args.motorcycle,
                                     args.scenes.split(",") if args.scenes else None,
                                     warn=lambda m: None)
    return [(name, bench_scenes.load(spec, args.size)) for name, spec in specs]


def command_figure(args, out) -> dict:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from refsynth._files import write_atomic

    scenes = _scenes(args)
    fig, axes = plt.subplots(len(scenes), 4, figsize=(17, 3.6 * len(scenes)), squeeze=False)
    report = {}
    for row, (name, scene) in enumerate(scenes):
        known = known_mask(scene, "distance60")
        partial = np.where(known, scene.range, np.nan)
        start = time.perf_counter()
        trace = traced_synthesize(scene.intensity, partial, seed=args.seed)
        seconds = time.perf_counter() - start
        residual = np.abs(trace.range - scene.range)
        residual[known] = 0.0                                   # measured: black
        scored = ~known & np.isfinite(scene.range)
        lin = linear_fill(scene.intensity, partial)
        near = nearest_fill(scene.intensity, partial)
        mars = {m: float(np.abs(e - scene.range)[scored].mean())
                for m, e in (("np", trace.range), ("linear", lin), ("nearest", near))}
        classes = source_classes(trace, scene.range)
        report[name] = dict(mar=mars, classes=classes, seconds=seconds)
        print(f"\n{name} ({scene.units}), distance60, NP seed {args.seed}: MAR NP "
              f"{mars['np']:.4g}, linear {mars['linear']:.4g}, nearest {mars['nearest']:.4g}",
              file=out)
        print("| source of the copied value | steps | share | MAR |", file=out)
        print("|---|---|---|---|", file=out)
        total = len(trace.members)
        for label, count, value in classes:
            print(f"| {label} | {count} | {100 * count / total:.1f} % | {value:.4g} |",
                  file=out)
        step = trace.step.astype(float)
        step[step < 0] = np.nan
        dc = np.full(known.shape, np.nan)
        dc[trace.target[:, 0], trace.target[:, 1]] = trace.source[:, 1] - trace.target[:, 1]
        kind = np.full(known.shape, np.nan)
        kind[trace.target[:, 0], trace.target[:, 1]] = np.where(
            trace.source_known, np.where(trace.shift != 0, 0, 1),
            np.where(trace.shift != 0, 2, 3))
        high = float(np.nanpercentile(residual, 99))
        panels = [
            (residual, f"{name}: |NP − truth| (MAR {mars['np']:.3g}; linear "
                       f"{mars['linear']:.3g})", dict(cmap="magma", vmin=0, vmax=high)),
            (step, "fill order (step)", dict(cmap="viridis")),
            (dc, "source column − target column", dict(cmap="RdBu", vmin=-6, vmax=6)),
            (kind, "source: measured+shift / measured / synth.+shift / synth.",
             dict(cmap=matplotlib.colors.ListedColormap(
                 ["#1b9e77", "#d95f02", "#7570b3", "#e7298a"]), vmin=-0.5, vmax=3.5)),
        ]
        for ax, (image, title, kw) in zip(axes[row], panels):
            shown = ax.imshow(image, interpolation="nearest", **kw)
            ax.set_title(title, fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
            fig.colorbar(shown, ax=ax, fraction=0.035)
    fig.tight_layout()
    if args.out:
        def save(stream):
            fig.savefig(stream, format="png", dpi=args.dpi)
        write_atomic(args.out, save)
        print(f"\nwrote {args.out}", file=out)
    plt.close(fig)
    return report


def _fmt(value) -> str:
    return "–" if value is None else f"{value:.4g}"


def command_gaps(args, out) -> dict:
    report = {}
    variants = {k: v for k, v in GAP_VARIANTS.items()
                if not args.variants or k in args.variants.split(",")}
    fills = {label: (lambda image, partial, options=options: synthesize(
        image, partial, seed=args.seed, **split_options(options)[0],
        readings={**AS_FILLED, **split_options(options)[1]}).range)
        for label, options in variants.items()}
    fills.update(nearest=nearest_fill, linear=linear_fill)
    for name, scene in _scenes(args):
        known = known_mask(scene, args.sampling)
        partial = np.where(known, scene.range, np.nan)
        widths = gap_widths(known)
        results = report[name] = {}
        print(f"\n{name} ({scene.units}), {args.sampling}, seed {args.seed}: MAR by gap "
              "width (columns; pixels scored in brackets), a row per method as it ends",
              file=out, flush=True)
        for label, fill in fills.items():
            results[label] = mar_by_gap(fill(scene.intensity, partial), scene.range, known,
                                        widths)
            if len(results) == 1:
                keys = list(results[label])
                print("| method | " + " | ".join(f"{k} ({results[label][k][1]})" for k in keys)
                      + " |", file=out)
                print("|---|" + "---|" * len(keys), file=out)
            print(f"| {label} | " + " | ".join(_fmt(results[label][k][0]) for k in keys) + " |",
                  file=out, flush=True)
    return report


def command_prototypes(args, out) -> dict:
    samplings = [parse_sampling(s) for s in args.samplings.split(",")]
    report = {}
    print("| scene | sampling | np | " + " | ".join(PROTOTYPES) +
          " | linear | nearest | best proto / linear |", file=out)
    print("|---|---|" + "---|" * (len(PROTOTYPES) + 4), file=out)
    for name, scene in _scenes(args):
        for sampling in samplings:
            known = known_mask(scene, sampling)
            partial = np.where(known, scene.range, np.nan)
            scored = ~known & np.isfinite(scene.range)

            def mar(estimate, truth=scene.range, scored=scored):
                return float(np.abs(estimate - truth)[scored].mean())

            row = {"np": mar(synthesize(scene.intensity, partial, seed=args.seed,
                                        readings=AS_FILLED).range)}
            for label in PROTOTYPES:
                row[label] = mar(prototype(label)(scene, known, args.seed))
            row["linear"] = mar(linear_fill(scene.intensity, partial))
            row["nearest"] = mar(nearest_fill(scene.intensity, partial))
            report[f"{name} {sampling}"] = row
            best = min(row[label] for label in PROTOTYPES)
            print(f"| {name} | {sampling} | " + " | ".join(
                f"{row[k]:.4g}" for k in ("np", *PROTOTYPES, "linear", "nearest")) +
                f" | {best / row['linear']:.2f} |", file=out, flush=True)
    return report


def main(argv: Sequence[str] | None = None, out=None) -> int:
    out = out or sys.stdout
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=["figure", "gaps", "prototypes"])
    parser.add_argument("folder", nargs="?", default=None)
    parser.add_argument("--motorcycle", action="store_true")
    parser.add_argument("--scenes", default="nyu_basement_raw_00000,motorcycle")
    parser.add_argument("--size", default="450x375")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sampling", default="distance60", help="gaps: the sampling")
    parser.add_argument("--samplings", default="distance60,x78", help="prototypes' samplings")
    parser.add_argument("--variants", default=None, help="gaps: labels of GAP_VARIANTS")
    parser.add_argument("--out", default=None, help="figure: the PNG to write")
    parser.add_argument("--dpi", type=int, default=80)
    parser.add_argument("--json", default=None, help="write the numbers here")
    args = parser.parse_args(argv)
    try:
        args.size = bench_scenes.parse_size(args.size)
        args.sampling = parse_sampling(args.sampling)
        report = {"figure": command_figure, "gaps": command_gaps,
                  "prototypes": command_prototypes}[args.command](args, out)
    except ValueError as error:
        print(f"diagnose_distance.py: {error}", file=sys.stderr)
        return 2
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
