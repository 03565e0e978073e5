"""The figure builders: every PNG in ``figures/`` (``python -m refsynth figures``).

The analogues of the paper's figures on refsynth's scenes, and the demo's;
:func:`make_figures` writes them all (the command line is
:mod:`refsynth.cli.figures`):

========================================  ===============================================
file                                      what
========================================  ===============================================
``demo_result.png``,                      :func:`refsynth.plotting.demo.run_demo` (exactly
``demo_np_bp.png``,                       what ``demo --quick --out figures``
``demo_comparison.png``                   writes)
``model_view.png``,                       :func:`refsynth.plotting.story.run_pipeline_demo`:
``pipeline_np.png``,                      the main demo's figures, exactly what ``demo``
``pipeline_bp.png``                       writes (run in a temporary folder)
``fig07_ordering.png``                    Fig. 7: priority (Eqs. 10–12) against onion-peel
                                          order: fill order, result, residual
``fig11_samplings_room.png``              Figs. 11/Table 1: the grid samplings × NP × BP
                                          on the synthetic room
``fig13_edges.png``                       Fig. 13/Table 3: no edges / NP / BP on four rooms
``fig16_isophotes.png``                   Fig. 16: NP without and with isophotes
``fig17_samplings_motorcycle.png``        Fig. 17/Table 4: x-stripes × NP × BP on the
                                          Motorcycle
``mar_vs_unknown.png``                    MAR against the unknown fraction, every method
``bp_confidence.png``                     BP's confidence map against its absolute error
========================================  ===============================================

Scenes: the synthetic room 128×128 (metres) and the Middlebury 2014
Motorcycle at 225×188 (disparity in pixels of that size) for the heavier
panels (Figs. 16, 17 and the confidence map). ``quick=True`` (``--quick``)
shrinks everything (rooms 32×32, Motorcycle 64×40, two fractions and one
seed) and leaves out the main demo's three figures (its scans alone take
most of a minute), for tests.

Every colour bar names its unit (:func:`refsynth.plotting.layouts.unit_label`);
range and error scales stop at percentiles of the values shown, with an
arrow where values lie beyond; panels that show only synthesized pixels
(residuals, confidence, fill order) paint the measured ones
:data:`~refsynth.plotting.layouts.MEASURED_COLOUR`, a grey in no colour map,
labelled "measured".
Every random choice flows from fixed seeds and no figure shows a time, so the
command writes byte-identical PNGs on every run (with the same matplotlib).

References
----------
Torres-Méndez & Dudek (2008), §3.2.4 (Fig. 7), §3.3 (Figs. 11, 13, 16, 17,
Tables 1–4), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from refsynth._files import write_atomic
from refsynth.evaluation.aggregation import aggregate
from refsynth.evaluation.cases import grid_cases, known_mask
from refsynth.evaluation.runner import run_cases
from refsynth.plotting.demo import DEMO_FIGURES, ProgressFactory, run_demo
from refsynth.plotting.layouts import (
    ERROR_CMAP,
    colour_bar_extend,
    error_top,
    finish_figure,
    panel,
    panel_grid,
    range_scale,
    save_figure,
    unit_label,
)
from refsynth.plotting.story import run_pipeline_demo
from refsynth.scenes import motorcycle, synthetic_room
from refsynth.synthesis.api import synthesize

__all__ = [
    "FIGURES",
    "PIPELINE_FIGURES",
    "fill_order_image",
    "ordering_figure",
    "scenes_figure",
    "mar_curve_figure",
    "confidence_figure",
    "make_figures",
]

#: The figures of the main demo (``python -m refsynth demo``,
#: :func:`refsynth.plotting.story.run_pipeline_demo`) that :func:`make_figures` copies.
PIPELINE_FIGURES = ("model_view.png", "pipeline_np.png", "pipeline_bp.png")

#: Every file :func:`make_figures` writes, in order.
FIGURES = (
    *DEMO_FIGURES,
    *PIPELINE_FIGURES,
    "fig07_ordering.png",
    "fig11_samplings_room.png",
    "fig13_edges.png",
    "fig16_isophotes.png",
    "fig17_samplings_motorcycle.png",
    "mar_vs_unknown.png",
    "bp_confidence.png",
)

DPI = 110


@dataclass(frozen=True)
class _Settings:
    room: int  # side of the synthetic rooms
    moto: tuple[int, int]  # (width, height) of the Motorcycle
    demo: int  # size for run_demo
    fractions: tuple[int, ...]  # x-stripe unknown percentages of mar_vs_unknown
    curve_size: str  # size spec of mar_vs_unknown's scenes
    seeds: int  # NP seeds of mar_vs_unknown
    story: bool  # run the main demo (about a minute, most of it the rig's scans)


FULL = _Settings(room=128, moto=(225, 188), demo=128, fractions=(40, 50, 63, 70, 78, 85),
                 curve_size="128", seeds=3, story=True)
QUICK = _Settings(room=32, moto=(64, 40), demo=32, fractions=(50, 78), curve_size="32", seeds=1,
                  story=False)


# ----------------------------------------------------------------------------- figures


def _show(ax, image, title, **kwargs):
    return panel(ax, image, title, fontsize=8, **kwargs)


def _mar(estimate: np.ndarray, truth: np.ndarray, known: np.ndarray) -> float:
    evaluated = ~known & np.isfinite(truth)
    return float(np.mean(np.abs(estimate - truth)[evaluated]))


def fill_order_image(shape: tuple[int, int], order: np.ndarray) -> np.ndarray:
    """When each pixel was synthesized, in [0, 1] (NaN where the range was known).

    Parameters
    ----------
    shape : pair of int
        ``(H, W)``.
    order : ndarray of shape (N, 2), int
        Synthesized pixels ``(row, col)`` in fill order
        (:attr:`refsynth.SynthesisResult.order`).

    Returns
    -------
    ndarray of shape (H, W), float64

    Examples
    --------
    >>> fill_order_image((1, 3), np.array([[0, 2], [0, 0]])).tolist()
    [[1.0, nan, 0.0]]
    """
    when = np.full(shape, np.nan)
    if len(order):
        when[order[:, 0], order[:, 1]] = np.arange(len(order)) / max(len(order) - 1, 1)
    return when


def ordering_figure(
    truth: np.ndarray,
    cases: Sequence[tuple[str, np.ndarray, Mapping[str, object]]],
    *,
    units: str = "",
    title: str | None = None,
) -> Figure:
    """Fig. 7's comparison: per sampling and order, the fill order, the result and the residual.

    ``fig07_ordering.png`` of :func:`make_figures`: priority order (Eqs. 10–12)
    against onion-peel order on the same partial range.

    Parameters
    ----------
    truth : ndarray of shape (H, W)
        Ground-truth range: the colour scale and the residuals (NaN or inf where
        there is none: not scored).
    cases : sequence of (sampling name, partial range, {order name: SynthesisResult})
    units, title : str, optional
        The range unit, after each residual's MAR (Eq. 13); the figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        One row per sampling × order: fill order (blue = early, red = late), synthesized
        range, absolute residual (one colour scale per sampling).

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, _ = example_ramp(unknown=(3, 5))
    >>> results = {"onion": synthesize(truth / truth.max(), partial, ordering="onion")}
    >>> figure = ordering_figure(truth, [("x25", partial, results)])
    >>> [ax.get_title() for ax in figure.axes[:3]]
    ['x25, onion: fill order', 'synthesized range', '|residual|, MAR 0']
    """
    rows = sum(len(results) for _, _, results in cases)
    fig, axes = panel_grid(rows, 3, (3.3 * 3 + 0.6, 2.7 * rows))
    scale = range_scale(truth)
    row = 0
    for sampling, partial, results in cases:
        known = np.isfinite(partial)
        errors = {name: np.where(~known & np.isfinite(truth), np.abs(r.range - truth), np.nan)
                  for name, r in results.items()}
        top = error_top(*errors.values())
        for name, result in results.items():
            _show(axes[row, 0], fill_order_image(truth.shape, result.order),
                  f"{sampling}, {name}: fill order", cmap="turbo", vmin=0, vmax=1,
                  measured=known, colorbar="fill order (0 first, 1 last)")
            _show(axes[row, 1], result.range, "synthesized range",
                  colorbar=unit_label("range", units), **scale)
            mar = _mar(result.range, truth, known)
            _show(axes[row, 2], errors[name], f"|residual|, MAR {mar:.3g} {units}".strip(),
                  cmap=ERROR_CMAP, vmin=0, vmax=top, measured=known,
                  colorbar=unit_label("|residual|", units))
            row += 1
    return finish_figure(fig, title)


def scenes_figure(
    rows: Sequence[tuple[str, np.ndarray, np.ndarray, Mapping[str, np.ndarray]]],
    *,
    units: str = "",
    title: str | None = None,
) -> Figure:
    """One row per scene: partial range, each method's result (with its MAR), ground truth.

    Parameters
    ----------
    rows : sequence of (row name, truth, partial range, {method: synthesized range})
        A method missing from a row leaves its panel empty.
    units : str
        Range unit, after each MAR (Eq. 13).
    title : str, optional
        Above the rows.

    Returns
    -------
    matplotlib.figure.Figure
        Each row has its own colour scale (the scenes differ) and its colour bar, in
        ``units``; the scale spans the percentiles of
        :data:`~refsynth.plotting.layouts.RANGE_PERCENTILES` (arrows where clipped).

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, filled = example_ramp(12, unknown=(4, 8), fill=2.0)
    >>> figure = scenes_figure([("ramp", truth, partial, {"constant": filled})], units="m")
    >>> [ax.get_title() for ax in figure.axes[:3]]
    ['ramp: 33 % unknown', 'constant: MAR 0.317 m', 'ground truth']
    """
    methods = list(dict.fromkeys(m for *_, results in rows for m in results))
    cols = len(methods) + 2
    fig, axes = panel_grid(len(rows), cols, (2.6 * cols + 0.8, 2.5 * len(rows)))
    for i, (name, truth, partial, results) in enumerate(rows):
        known = np.isfinite(partial)
        scale = range_scale(truth)
        _show(axes[i, 0], partial, f"{name}: {100 * (1 - known.mean()):.0f} % unknown", **scale)
        for j, method in enumerate(methods, start=1):
            if method not in results:
                axes[i, j].axis("off")
                continue
            mar = _mar(results[method], truth, known)
            _show(axes[i, j], results[method], f"{method}: MAR {mar:.3g} {units}".strip(),
                  **scale)
        handle = _show(axes[i, -1], truth, "ground truth", **scale)
        shown = np.concatenate([np.ravel(truth), np.ravel(partial),
                                *(np.ravel(r) for r in results.values())])
        bar = fig.colorbar(handle, ax=axes[i, :], fraction=0.03, pad=0.01,
                           extend=colour_bar_extend(shown[None], scale["vmin"], scale["vmax"]))
        bar.set_label(unit_label("range", units), fontsize=8)
        bar.ax.tick_params(labelsize=7)
    return finish_figure(fig, title)


def mar_curve_figure(rows: Sequence[dict], *, title: str | None = None) -> Figure:
    """MAR against the unknown fraction, one line per method, one panel per scene.

    Parameters
    ----------
    rows : sequence of dict
        Aggregated rows of :func:`refsynth.evaluation.aggregation.aggregate` (x-stripe
        samplings); NP variants over several seeds get error bars (± one
        standard deviation).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> rows = [dict(scene="room", units="m", sampling=sampling, unknown_percent=unknown,
    ...              method="nearest", seeds=[0], mar=mar, mar_sd=None)
    ...         for sampling, unknown, mar in [("x20", 25.0, 0.1), ("x40", 37.5, 0.2)]]
    >>> figure = mar_curve_figure(rows)
    >>> figure.axes[0].get_xlabel(), len(figure.axes[0].lines)
    ('unknown range (% of the image), x-stripes', 3)
    """
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig = Figure(figsize=(6.0 * len(scenes), 4.6))
    axes = np.atleast_1d(fig.subplots(1, len(scenes)))
    styles = {m: ("-" if m.startswith(("np", "bp")) else "--") for m in methods}
    markers = "os^vD<>ph*x"
    for ax, scene in zip(axes, scenes):
        units = ""
        for k, method in enumerate(methods):
            series = sorted((r for r in rows if r["scene"] == scene and r["method"] == method),
                            key=lambda r: r["unknown_percent"])
            if not series:
                continue
            units = series[0]["units"]
            x = [r["unknown_percent"] for r in series]
            y = [r["mar"] for r in series]
            err = [r["mar_sd"] or 0.0 for r in series]
            ax.errorbar(x, y, yerr=err, label=method, linestyle=styles[method],
                        marker=markers[k % len(markers)], markersize=4, capsize=2)
        ax.set_xlabel("unknown range (% of the image), x-stripes")
        ax.set_ylabel(f"MAR (Eq. 13), {units}")
        ax.set_title(scene, fontsize=10)
        ax.grid(alpha=0.3)
    axes[-1].legend(fontsize=7, ncol=2)
    return finish_figure(fig, title)


def confidence_figure(
    cases: Sequence[tuple[str, np.ndarray, np.ndarray, object]],
    *,
    bins: int = 10,
    units: str | Sequence[str] = "",
    title: str | None = None,
) -> Figure:
    """BP's confidence against its absolute error: maps, and MAR per confidence decile.

    Parameters
    ----------
    cases : sequence of (name, truth, partial range, BP SynthesisResult)
        Truth and partial range as ndarrays of shape (H, W); the result of
        ``synthesize(..., method="bp")``.
    bins : int, default 10
        Quantile bins of the synthesized pixels' confidence.
    units : str or sequence of str, optional
        The range unit of every case, or one per case: the colour bars' and the
        decile plot's unit.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        Per case: the BP result, its absolute error (up to its 99th percentile,
        an arrow above), its confidence (measured pixels grey), and the MAR of
        the synthesized pixels in each confidence bin (a confidence that means
        something falls from left to right).

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, _ = example_ramp(unknown=(3, 5))
    >>> result = synthesize(truth / truth.max(), partial, method="bp")
    >>> figure = confidence_figure([("ramp", truth, partial, result)], bins=4)
    >>> [ax.get_title() for ax in figure.axes[:3]]
    ['ramp: BP', '|error|', 'confidence (belief)']
    """
    fig, axes = panel_grid(len(cases), 4, (3.3 * 4 + 0.8, 2.9 * len(cases)))
    per_case = [units] * len(cases) if isinstance(units, str) else list(units)
    if len(per_case) != len(cases):
        raise ValueError(f"The parameter `units` must be one string or one per case "
                         f"({len(cases)}), got {len(per_case)}")
    for i, ((name, truth, partial, result), unit) in enumerate(zip(cases, per_case)):
        known = np.isfinite(partial)
        scored = ~known & np.isfinite(truth)
        error = np.where(scored, np.abs(result.range - truth), np.nan)
        _show(axes[i, 0], result.range, f"{name}: BP", colorbar=unit_label("range", unit),
              **range_scale(truth))
        _show(axes[i, 1], error, "|error|", cmap=ERROR_CMAP, vmin=0, vmax=error_top(error),
              measured=known, colorbar=unit_label("|error|", unit))
        _show(axes[i, 2], np.where(known, np.nan, result.confidence), "confidence (belief)",
              cmap="viridis", vmin=0, vmax=1, measured=known, colorbar="confidence (0 to 1)")
        conf, err = result.confidence[scored], error[scored]
        order = np.argsort(conf, kind="stable")
        chunks = np.array_split(order, bins)
        centres = [float(np.mean(conf[c])) for c in chunks if len(c)]
        mars = [float(np.mean(err[c])) for c in chunks if len(c)]
        ax = axes[i, 3]
        ax.plot(centres, mars, marker="o")
        ax.axhline(float(np.mean(err)), color="grey", linestyle=":", label="all")
        ax.set_xlabel("confidence (mean of the decile)", fontsize=8)
        ax.set_ylabel(unit_label("MAR of the decile", unit), fontsize=8)
        ax.set_title("error against confidence", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    return finish_figure(fig, title)


# ----------------------------------------------------------------------------- every figure


def _save(fig: Figure, out: Path, name: str, written: list[Path]) -> None:
    path = out / name
    save_figure(fig, path, dpi=DPI)
    written.append(path)


def _partial(scene, sampling: str) -> np.ndarray:
    """The scene's range where ``sampling`` measures it, NaN elsewhere."""
    return np.where(known_mask(scene, sampling), scene.range, np.nan)


def _np_and_bp(scene, samplings: Sequence[str], kept: str):
    """NP and BP on each sampling (the rows of Figs. 11 and 17), and BP's case on ``kept``.

    Returns ``(rows, case)``: the rows of :func:`scenes_figure`, and ``(name,
    truth, partial, BP result)`` of the sampling ``kept`` for
    :func:`confidence_figure`.
    """
    rows, case = [], None
    for sampling in samplings:
        partial = _partial(scene, sampling)
        bp = synthesize(scene.intensity, partial, method="bp")
        if sampling == kept:
            case = (f"{scene.name}, {sampling}", scene.range, partial, bp)
        rows.append((sampling, scene.range, partial, {
            "NP": synthesize(scene.intensity, partial, seed=0).range, "BP": bp.range}))
    return rows, case


def _pipeline_figures(out: Path, say: Callable[[str], None]) -> list[Path]:
    """The main demo in a temporary folder; its :data:`PIPELINE_FIGURES` copied into ``out``."""
    stages: list[str] = []

    def story_stage(stage: str, fraction: float) -> None:
        if not stages or stages[-1] != stage:
            stages.append(stage)
            say(f"  demo: {stage}")

    with tempfile.TemporaryDirectory(prefix="refsynth-figures-") as folder:
        run_pipeline_demo(Path(folder), seed=0, progress=story_stage)
        return [write_atomic(out / name, (Path(folder) / name).read_bytes())
                for name in PIPELINE_FIGURES]


def make_figures(out: Path, *, quick: bool = False, jobs: int = 1,
                 log: Callable[[str], None] | None = None,
                 progress: ProgressFactory | None = None) -> list[Path]:
    """Write every figure of :data:`FIGURES` into ``out``; return their paths.

    Parameters
    ----------
    out : Path
        The folder (created if missing).
    quick : bool, default False
        Small scenes and no main demo, for tests (see the module docstring).
    jobs : int, default 1
        Local processes for the MAR-against-unknown-fraction grid
        (:func:`refsynth.evaluation.runner.run_cases`); the figures do not depend on it.
    log : callable, optional
        Called with a line of progress text.
    progress : callable, optional
        Passed to :func:`refsynth.plotting.demo.run_demo` (progress during its fills).

    Returns
    -------
    list of Path

    Examples
    --------
    The quick figures take about 15 s on two cores, so this is not run as a test
    (``tests/test_figures.py`` runs it):

    >>> import tempfile
    >>> written = make_figures(Path(tempfile.mkdtemp()), quick=True)  # doctest: +SKIP
    >>> names = [path.name for path in written]  # doctest: +SKIP
    >>> names == [name for name in FIGURES if name not in PIPELINE_FIGURES]  # doctest: +SKIP
    True
    """
    say = log or (lambda text: None)
    settings = QUICK if quick else FULL
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    say("demo figures (refsynth.plotting.demo.run_demo)")
    run_demo(out, size=settings.demo, progress=progress)
    written += [out / name for name in DEMO_FIGURES]

    if settings.story:
        say("the main demo's figures (refsynth.plotting.story.run_pipeline_demo, exactly "
            "what `python -m refsynth demo` writes)")
        written += _pipeline_figures(out, say)

    room = synthetic_room((settings.room, settings.room), seed=0)
    moto = motorcycle(settings.moto)
    grids = ("g24_80", "g10_20", "g5_25", "g3_28") if not quick else ("g3_8", "g5_25")

    say("Fig. 7: priority against onion order")
    cases = []
    for sampling in ("g5_25", "x78"):
        partial = _partial(room, sampling)
        cases.append((sampling, partial, {
            "priority": synthesize(room.intensity, partial, seed=0),
            "onion": synthesize(room.intensity, partial, seed=0, ordering="onion"),
        }))
    _save(ordering_figure(room.range, cases, units=room.units,
                          title=f"Fig. 7 analogue, {room.name}: fill order "
                          "(blue = early, red = late)"),
          out, "fig07_ordering.png", written)

    say("Fig. 11: grid samplings × NP × BP on the room")
    rows, bp_room = _np_and_bp(room, grids, kept="g5_25")
    _save(scenes_figure(rows, units=room.units,
                        title=f"Fig. 11 / Table 1 analogue: {room.name}, grid stripes rw/xw"),
          out, "fig11_samplings_room.png", written)

    say("Fig. 13: no edges / NP / BP on four rooms")
    rows = []
    for seed in range(4):
        scene = room if seed == 0 else synthetic_room((settings.room, settings.room), seed=seed)
        partial = _partial(scene, "g5_25")
        rows.append((scene.name, scene.range, partial, {
            "NP, no edges": synthesize(scene.intensity, partial, seed=0, use_edges=False).range,
            "NP": synthesize(scene.intensity, partial, seed=0).range,
            "BP": synthesize(scene.intensity, partial, method="bp").range,
        }))
    _save(scenes_figure(rows, units=room.units,
                        title="Fig. 13 / Table 3 analogue: grid stripes 5/25"),
          out, "fig13_edges.png", written)

    say("Fig. 16: isophotes off and on, Motorcycle")
    rows = []
    for sampling in ("x63", "x78"):
        partial = _partial(moto, sampling)
        rows.append((sampling, moto.range, partial, {
            "NP, no isophotes": synthesize(moto.intensity, partial, seed=0,
                                           use_isophotes=False).range,
            "NP": synthesize(moto.intensity, partial, seed=0).range,
        }))
    _save(scenes_figure(rows, units=moto.units,
                        title=f"Fig. 16 analogue: {moto.name}, NP without and with isophotes"),
          out, "fig16_isophotes.png", written)

    say("Fig. 17: x-stripes × NP × BP, Motorcycle")
    rows, bp_moto = _np_and_bp(moto, ("x63", "x78", "x85"), kept="x78")
    _save(scenes_figure(rows, units=moto.units,
                        title=f"Fig. 17 / Table 4 analogue: {moto.name}, x-stripes"),
          out, "fig17_samplings_motorcycle.png", written)

    say("MAR against the unknown fraction (every method)")
    samplings = ",".join(f"x{f}" for f in settings.fractions)
    cases = grid_cases([("synthetic,motorcycle", settings.curve_size, samplings, None)],
                       seeds=settings.seeds)
    curve_rows = aggregate(run_cases(cases, jobs=jobs))
    spread = (f"NP variants: mean ± sd over {settings.seeds} seeds" if settings.seeds > 1
              else "NP variants: one seed")
    _save(mar_curve_figure(curve_rows, title=f"MAR against the unknown fraction, x-stripes "
                           f"({spread})"),
          out, "mar_vs_unknown.png", written)

    say("BP confidence against error")
    _save(confidence_figure([bp_room, bp_moto], units=[room.units, moto.units],
                            title="BP: confidence (Eq. 8 belief) against absolute error"),
          out, "bp_confidence.png", written)
    assert [p.name for p in written] == [name for name in FIGURES
                                         if settings.story or name not in PIPELINE_FIGURES]
    return written

