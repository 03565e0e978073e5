"""Figures in the paper's layouts (Figs. 11–17).

Every function returns a :class:`matplotlib.figure.Figure` built without
pyplot's global state, so it works under any backend (tests use Agg) and the
caller decides where to save it.

References
----------
Torres-Méndez & Dudek (2008), §3.3, Figs. 11–17, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from refsynth._files import write_atomic

__all__ = ["range_scale", "panel", "finish_figure", "save_figure", "result_figure",
           "comparison_figure", "methods_figure"]

RANGE_CMAP = "viridis"
ERROR_CMAP = "magma"
#: The neutral grey of measured pixels in the panels that show only synthesized ones
#: (residuals, confidence, fill order): no colour map of refsynth's contains it, so a
#: measured pixel never reads as a value on the colour bar.
MEASURED_COLOUR = (0.6, 0.6, 0.6)
#: Range panels' colour limits: these percentiles of the shown values (an outlier does not
#: stretch the scale; the colour bar's arrows say that values lie beyond).
RANGE_PERCENTILES = (0.5, 99.5)
#: Error panels' colour limit: this percentile of the shown errors.
ERROR_PERCENTILE = 99.0

__all__ += ["MEASURED_COLOUR", "unit_label", "error_top", "colour_bar_extend",
            "panel_grid"]


def unit_label(quantity: str, units: str = "") -> str:
    """A colour bar's label: the quantity and its unit, ``"range units"`` when unknown.

    Parameters
    ----------
    quantity : str
        What the bar measures, e.g. ``"range"`` (a disparity map's: its ``units``) or
        ``"|residual|"``.
    units : str
        The scene's range unit (``"m"``, ``"disparity (px)"`` …); empty when unknown.

    Returns
    -------
    str

    Examples
    --------
    >>> unit_label("range", "m"), unit_label("|residual|", "disparity (px)")
    ('range (m)', '|residual| (disparity px)')
    >>> unit_label("range", "disparity (px)"), unit_label("range")
    ('disparity (px)', 'range (range units)')
    """
    if quantity == "range" and units.startswith("disparity"):
        return units  # a disparity map's "range" is a disparity
    unit = (units or "range units").replace("(", "").replace(")", "").strip()
    return f"{quantity} ({unit})"


def range_scale(*images: np.ndarray | None) -> dict:
    """``imshow`` keywords for range: the range colour map over the images' finite values.

    The limits are the :data:`RANGE_PERCENTILES` of the values (nearest rank, so
    each limit is a value shown): one outlier does not stretch the scale; the
    colour bar of :func:`panel` then ends in an arrow on the clipped side.

    Parameters
    ----------
    *images : ndarray or None
        Range images (NaN and inf are ignored; None is skipped).

    Returns
    -------
    dict
        ``cmap``, ``vmin``, ``vmax``: the panels drawn with it share one scale.

    Examples
    --------
    >>> range_scale(np.array([[1.0, np.nan], [np.inf, 2.5]]), None)
    {'cmap': 'viridis', 'vmin': 1.0, 'vmax': 2.5}
    >>> ramp = np.append(np.linspace(1.0, 2.0, 999), 50.0)  # one outlier in a thousand
    >>> range_scale(ramp)["vmax"] < 2.0
    True
    """
    values = np.concatenate([im[np.isfinite(im)].ravel() for im in images if im is not None])
    low, high = np.percentile(values, RANGE_PERCENTILES, method="nearest")
    return dict(cmap=RANGE_CMAP, vmin=float(low), vmax=float(high))


def error_top(*errors: np.ndarray) -> float:
    """The top of an error panel's colour scale: the :data:`ERROR_PERCENTILE` of the errors.

    Parameters
    ----------
    *errors : ndarray
        Absolute errors, NaN where not shown (measured or not scored).

    Returns
    -------
    float
        Above 0 (1.0 when every error is 0 or none is shown).

    Examples
    --------
    >>> error_top(np.append(np.full(999, 0.1), 40.0), np.array([np.nan]))
    0.1
    """
    values = np.concatenate([np.asarray(e, dtype=np.float64).ravel() for e in errors])
    values = values[np.isfinite(values)]
    if values.size == 0:
        return 1.0
    return float(np.percentile(values, ERROR_PERCENTILE, method="nearest")) or 1.0


def colour_bar_extend(image: np.ndarray, vmin: float, vmax: float) -> str:
    """Which ends of a colour bar need an arrow: where shown values lie beyond its limits.

    Parameters
    ----------
    image : ndarray of shape (H, W)
        The values shown (NaN and inf are ignored).
    vmin, vmax : float
        The colour limits.

    Returns
    -------
    {"neither", "min", "max", "both"}
        The ``extend`` of :meth:`matplotlib.figure.Figure.colorbar`.

    Examples
    --------
    >>> colour_bar_extend(np.array([[0.0, 5.0, np.nan]]), 0.0, 2.0)
    'max'
    """
    values = image[np.isfinite(image)] if image.ndim == 2 else np.empty(0)
    low, high = bool(np.any(values < vmin)), bool(np.any(values > vmax))
    return {(False, False): "neither", (True, False): "min", (False, True): "max",
            (True, True): "both"}[(low, high)]


def _measured_overlay(ax, measured: np.ndarray, blank: np.ndarray, fontsize: float) -> None:
    """Paint ``measured`` pixels :data:`MEASURED_COLOUR` over the image; say so below it.

    ``blank``: the other pixels without a value (no ground truth to score them against),
    left white and, if there are any, named in the legend too.
    """
    rgba = np.zeros((*measured.shape, 4))
    rgba[measured] = (*MEASURED_COLOUR, 1.0)
    ax.imshow(rgba, interpolation="nearest")
    handles = [Patch(facecolor=MEASURED_COLOUR, edgecolor="none", label="measured")]
    if np.any(blank & ~measured):
        handles.append(Patch(facecolor="white", edgecolor="0.3", linewidth=0.5,
                             label="white: no truth"))
    ax.legend(handles=handles, ncols=len(handles), columnspacing=1.0,
              loc="upper left", bbox_to_anchor=(0.0, 0.0), fontsize=fontsize - 1,
              frameon=False, borderaxespad=0.1, handlelength=1.0, handleheight=0.8,
              borderpad=0.1)


def panel(ax, image, title: str, *, fontsize: float = 9, colorbar: bool | str = False,
          measured: np.ndarray | None = None, **kwargs):
    """One panel of a figure: ``image`` on ``ax``, without interpolation or ticks, titled.

    A 2-D image (or one channel, (H, W, 1)) is drawn in grey unless ``cmap``
    is given; ``kwargs`` go to ``ax.imshow``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    image : ndarray of shape (H, W), (H, W, 1) or (H, W, 3)
        Intensity, range (NaN is left blank) or a boolean mask.
    title : str
        The panel's title.
    fontsize : float, default 9
        Of the title.
    colorbar : bool or str, default False
        Put a colour bar beside the panel; a string is the bar's label (give the
        unit: :func:`unit_label`). The bar ends in an arrow on each side where
        shown values lie beyond the colour limits (``vmin``, ``vmax``).
    measured : ndarray of shape (H, W), bool, optional
        Pixels painted :data:`MEASURED_COLOUR` over the image (a grey in no
        colour map), with a legend entry "measured" below the panel: for the
        panels that show only synthesized pixels. Other pixels left blank (NaN:
        no ground truth to score them) stay white, and the legend says so.
    **kwargs
        Passed to ``ax.imshow`` (``cmap``, ``vmin``, ``vmax`` …).

    Returns
    -------
    matplotlib.image.AxesImage
        The image's handle (for a colour bar drawn later).

    Examples
    --------
    >>> figure = Figure()
    >>> handle = panel(figure.add_subplot(), np.eye(3), "identity", cmap="viridis",
    ...                colorbar="range (m)", vmax=0.5)
    >>> type(handle).__name__, handle.axes.get_title(), len(figure.axes)
    ('AxesImage', 'identity', 2)
    >>> colour_bar = handle.colorbar
    >>> colour_bar.ax.get_ylabel(), colour_bar.extend
    ('range (m)', 'max')
    """
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 2 and "cmap" not in kwargs:
        kwargs["cmap"] = "gray"
    handle = ax.imshow(image, interpolation="nearest", **kwargs)
    if measured is not None:
        blank = ~np.isfinite(image) if image.ndim == 2 else np.zeros(image.shape[:2], bool)
        _measured_overlay(ax, np.asarray(measured, dtype=bool), blank, fontsize)
    ax.set_title(title, fontsize=fontsize)
    ax.set_xticks([])
    ax.set_yticks([])
    if colorbar is not False:
        label = colorbar if isinstance(colorbar, str) else None
        shown = image if measured is None else np.where(measured, np.nan, image)
        extend = colour_bar_extend(np.asarray(shown, dtype=np.float64), handle.norm.vmin,
                                   handle.norm.vmax)
        bar = ax.figure.colorbar(handle, ax=ax, fraction=0.046, pad=0.02, extend=extend)
        if label:
            bar.set_label(label, fontsize=fontsize - 1)
        bar.ax.tick_params(labelsize=fontsize - 1)
    return handle


def panel_grid(rows: int, cols: int, figsize: tuple[float, float]) -> tuple[Figure, np.ndarray]:
    """A figure of ``rows`` × ``cols`` panels whose columns stay aligned (constrained layout).

    The constrained layout gives every panel of a column the same width, so a
    panel with a colour bar is as wide as those above and below it (the bar
    takes its room from the whole column).

    Parameters
    ----------
    rows, cols : int
    figsize : pair of float
        Inches.

    Returns
    -------
    (matplotlib.figure.Figure, ndarray of Axes of shape (rows, cols))

    Examples
    --------
    >>> figure, axes = panel_grid(2, 3, (6.0, 4.0))
    >>> axes.shape, figure.get_layout_engine().__class__.__name__
    ((2, 3), 'ConstrainedLayoutEngine')
    """
    fig = Figure(figsize=figsize, layout="constrained")
    fig.get_layout_engine().set(w_pad=0.03, h_pad=0.03, wspace=0.02, hspace=0.02)
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def finish_figure(fig: Figure, title: str | None = None) -> Figure:
    """The last step of every layout: the figure's title, if any, and its layout.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure, its panels drawn.
    title : str, optional
        Its title (``suptitle``).

    Returns
    -------
    matplotlib.figure.Figure
        ``fig`` itself.

    Examples
    --------
    >>> finish_figure(Figure(), "empty").get_suptitle()
    'empty'
    """
    if title:
        fig.suptitle(title)
    if fig.get_layout_engine() is None:  # a figure of panel_grid keeps its constrained layout
        fig.tight_layout()
    return fig


def save_figure(fig: Figure, path: str | os.PathLike, *, dpi: float) -> Path:
    """Save ``fig`` to ``path`` all or nothing, in the format its suffix names.

    Every figure refsynth writes is saved here: the image is rendered into
    a temporary file beside ``path`` and renamed over it once complete
    (:func:`refsynth._files.write_atomic`).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or path-like
        The file; its suffix (``.png``, ``.pdf``, ``.svg`` …) names the format.
    dpi : float
        Dots per inch.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OSError
        Naming ``path``, if it cannot be written (the previous file is then
        intact).

    Examples
    --------
    >>> import tempfile
    >>> path = save_figure(Figure(figsize=(1, 1)), Path(tempfile.mkdtemp()) / "a.png", dpi=10)
    >>> path.read_bytes()[:4]
    b'\\x89PNG'
    """
    path = Path(path)
    kind = path.suffix[1:].lower() or None
    return write_atomic(path, lambda stream: fig.savefig(stream, format=kind, dpi=dpi))


def result_figure(
    intensity: np.ndarray,
    edges: np.ndarray,
    partial_range: np.ndarray,
    result: np.ndarray,
    truth: np.ndarray | None = None,
    *,
    units: str = "",
    title: str | None = None,
    uncertainty: np.ndarray | None = None,
) -> Figure:
    """The paper's layout: intensity, edges, partial range, result, ground truth, residual.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The intensity image, in [0, 1].
    edges : ndarray of shape (H, W), bool
        Its Canny edges (the edge term of Eq. 10, §3.2.4).
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range given to the synthesis.
    result : ndarray of shape (H, W)
        The synthesized range.
    truth : ndarray of shape (H, W), optional
        Ground truth; without it the figure has four panels.
    units : str
        Range unit: the result's colour bar and the residual's MAR (Eq. 13).
    title : str, optional
        Above the panels.
    uncertainty : ndarray of shape (H, W), optional
        The expected absolute error (:attr:`refsynth.SynthesisResult.uncertainty`): one
        more panel, beside the residual, on the residual's colour scale.

    Returns
    -------
    matplotlib.figure.Figure
        Range panels share one colour scale; the residual (and the uncertainty) another.

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, filled = example_ramp()
    >>> figure = result_figure(truth / 2.5, np.zeros((8, 8), bool), partial, filled, truth,
    ...                        units="m")
    >>> print("; ".join(ax.get_title() for ax in figure.axes[2:6]))
    partial range (38 % unknown); synthesized range; ground truth; |residual|, MAR 0.283 m
    """
    panels = (6 if truth is not None else 4) + (uncertainty is not None)
    aspect = partial_range.shape[1] / partial_range.shape[0]
    if aspect > 2:  # a panorama: one panel per row
        fig, axes = panel_grid(panels, 1, (9.0, panels * (9.0 / aspect + 0.75)))
        axes = axes.ravel()
    else:
        cols = -(-panels // 2)
        fig, axes = panel_grid(2, cols, (3.4 * cols, 3.2 * 2))
        axes = axes.ravel()
        for spare in axes[panels:]:
            spare.axis("off")
    scale = range_scale(partial_range, result, truth)
    panel(axes[0], np.clip(intensity, 0, 1) if np.ndim(intensity) == 3 else intensity, "intensity")
    panel(axes[1], edges, "Canny edges (σ = 0.8)")
    known = np.isfinite(partial_range)
    panel(axes[2], partial_range, f"partial range ({100 * (1 - known.mean()):.0f} % unknown)",
          **scale)
    panel(axes[3], result, "synthesized range", colorbar=unit_label("range", units), **scale)
    top = None
    if truth is not None:
        panel(axes[4], truth, "ground truth", **scale)
        residual = np.where(known | ~np.isfinite(truth), np.nan, np.abs(result - truth))
        mar = np.nanmean(residual)
        top = error_top(residual)
        panel(axes[5], residual, f"|residual|, MAR {mar:.3g} {units}".strip(), cmap=ERROR_CMAP,
              vmin=0, vmax=top, measured=known, colorbar=unit_label("|residual|", units))
    if uncertainty is not None:
        _uncertainty_panel(axes[panels - 1], uncertainty, known, units, top)
    return finish_figure(fig, title)


def _uncertainty_panel(ax, uncertainty: np.ndarray, known: np.ndarray, units: str,
                       top: float | None) -> None:
    """The expected |error| of the synthesized pixels, on the residual's scale ``top``."""
    shown = np.where(known, np.nan, uncertainty)
    mean = float(np.nanmean(shown)) if (~known).any() else 0.0
    panel(ax, shown, f"uncertainty, mean {mean:.3g} {units}".strip(), cmap=ERROR_CMAP, vmin=0,
          vmax=error_top(shown) if top is None else top, measured=known,
          colorbar=unit_label("expected |error|", units))


def comparison_figure(
    truth: np.ndarray,
    partials: Mapping[str, np.ndarray],
    results: Mapping[tuple[str, str], np.ndarray],
    *,
    units: str = "",
    title: str | None = None,
) -> Figure:
    """A grid: one row per sampling (partial range, then each method's result).

    ``demo_comparison.png`` of :func:`refsynth.plotting.demo.run_demo`: every
    sampling × method of the demo's table, at a glance.

    Parameters
    ----------
    truth : ndarray of shape (H, W)
        Ground-truth range, the last panel of each row; each result's MAR is
        against it (NaN or inf where there is none: not scored).
    partials : mapping of sampling name to partial range
        Each an ndarray of shape (H, W), NaN where unknown.
    results : mapping of (sampling name, method name) to synthesized range
        Each an ndarray of shape (H, W); a missing pair leaves its panel empty.
    units, title : str, optional
        The range unit, after each MAR; the figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        Each result panel's title gives its MAR (Eq. 13) over the unknown
        pixels; every panel has one colour scale (no colour bars).

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, filled = example_ramp()
    >>> figure = comparison_figure(truth, {"x38": partial}, {("x38", "constant"): filled})
    >>> [ax.get_title() for ax in figure.axes[:2]]
    ['x38: 38 % unknown', 'constant: MAR 0.283']
    """
    methods = list(dict.fromkeys(m for _, m in results))
    rows, cols = len(partials), len(methods) + 2
    fig, axes = panel_grid(rows, cols, (2.6 * cols + 0.6, 2.6 * rows))
    scale = range_scale(truth, *partials.values())
    for row, (name, partial) in enumerate(partials.items()):
        known = np.isfinite(partial)
        panel(axes[row, 0], partial, f"{name}: {100 * (1 - known.mean()):.0f} % unknown", **scale)
        evaluated = ~known & np.isfinite(truth)
        for col, method in enumerate(methods, start=1):
            est = results.get((name, method))
            if est is None:
                axes[row, col].axis("off")
                continue
            mar = float(np.mean(np.abs(est - truth)[evaluated]))
            panel(axes[row, col], est, f"{method}: MAR {mar:.3g} {units}".strip(), **scale)
        handle = panel(axes[row, -1], truth, "ground truth", **scale)
    shown = np.concatenate([np.ravel(truth), *(np.ravel(p) for p in partials.values())])
    bar = fig.colorbar(handle, ax=axes, shrink=0.8, fraction=0.03, pad=0.01,
                       extend=colour_bar_extend(shown[None], scale["vmin"], scale["vmax"]))
    bar.set_label(unit_label("range", units))
    return finish_figure(fig, title)


def methods_figure(
    truth: np.ndarray,
    partial_range: np.ndarray,
    results: Mapping[str, tuple[np.ndarray, np.ndarray]],
    *,
    units: str = "",
    title: str | None = None,
) -> Figure:
    """One row per method: its result, its absolute residual and its confidence map.

    ``demo_np_bp.png`` of :func:`refsynth.plotting.demo.run_demo`: NP's and
    BP's results, where each went wrong, and how sure each was there.

    Parameters
    ----------
    truth : ndarray of shape (H, W)
        Ground-truth range, which the residuals are against (NaN or inf where
        there is none: not scored).
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range given to every method.
    results : mapping of method name to (range, confidence) or (range, confidence, uncertainty)
        Each ndarrays of shape (H, W): the synthesized range, a confidence in [0, 1] and,
        optionally, the expected absolute error (a fourth column, on the residuals' scale).
    units : str
        Range unit, after each residual's MAR (Eq. 13).
    title : str, optional
        Above the rows.

    Returns
    -------
    matplotlib.figure.Figure
        Residual panels share one colour scale, so the methods compare at a glance.

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, filled = example_ramp()
    >>> figure = methods_figure(truth, partial, {"constant": (filled, np.ones((8, 8)))})
    >>> len(figure.axes)  # three panels and their colour bars
    6
    """
    rows = len(results)
    cols = 4 if any(len(value) > 2 for value in results.values()) else 3
    fig, axes = panel_grid(rows, cols, (3.5 * cols, 3.1 * rows))
    scale = range_scale(truth, partial_range)
    known = np.isfinite(partial_range)
    unknown = ~known & np.isfinite(truth)
    residuals = {m: np.where(unknown, np.abs(value[0] - truth), np.nan)
                 for m, value in results.items()}
    top = error_top(*residuals.values())
    for row, (method, (estimate, confidence, *rest)) in enumerate(results.items()):
        panel(axes[row, 0], estimate, f"{method}: synthesized range",
              colorbar=unit_label("range", units), **scale)
        mar = float(np.nanmean(residuals[method]))
        panel(axes[row, 1], residuals[method], f"|residual|, MAR {mar:.3g} {units}".strip(),
              cmap=ERROR_CMAP, vmin=0, vmax=top, measured=known,
              colorbar=unit_label("|residual|", units))
        panel(axes[row, 2], np.where(known, np.nan, confidence), "confidence", cmap="viridis",
              vmin=0, vmax=1, measured=known, colorbar="confidence (0 to 1)")
        if rest:
            _uncertainty_panel(axes[row, 3], rest[0], known, units, top)
        elif cols == 4:
            axes[row, 3].axis("off")
    return finish_figure(fig, title)
