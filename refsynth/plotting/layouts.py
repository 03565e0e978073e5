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

from refsynth._files import write_atomic

__all__ = ["range_scale", "panel", "finish_figure", "save_figure", "result_figure",
           "comparison_figure", "methods_figure"]

RANGE_CMAP = "viridis"
ERROR_CMAP = "magma"


def range_scale(*images: np.ndarray | None) -> dict:
    """``imshow`` keywords for range: the range colour map over the images' finite values.

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
    """
    values = np.concatenate([im[np.isfinite(im)].ravel() for im in images if im is not None])
    return dict(cmap=RANGE_CMAP, vmin=float(values.min()), vmax=float(values.max()))


def panel(ax, image, title: str, *, fontsize: float = 9, colorbar: bool | str = False, **kwargs):
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
        Put a colour bar beside the panel; a string is the bar's label.
    **kwargs
        Passed to ``ax.imshow`` (``cmap``, ``vmin``, ``vmax`` …).

    Returns
    -------
    matplotlib.image.AxesImage
        The image's handle (for a colour bar drawn later).

    Examples
    --------
    >>> figure = Figure()
    >>> handle = panel(figure.add_subplot(), np.eye(3), "identity", cmap="viridis", colorbar=True)
    >>> type(handle).__name__, handle.axes.get_title(), len(figure.axes)
    ('AxesImage', 'identity', 2)
    """
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 2 and "cmap" not in kwargs:
        kwargs["cmap"] = "gray"
    handle = ax.imshow(image, interpolation="nearest", **kwargs)
    ax.set_title(title, fontsize=fontsize)
    ax.set_xticks([])
    ax.set_yticks([])
    if colorbar is not False:
        label = colorbar if isinstance(colorbar, str) else None
        ax.figure.colorbar(handle, ax=ax, fraction=0.046, pad=0.04, label=label)
    return handle


def finish_figure(fig: Figure, title: str | None = None) -> Figure:
    """The last step of every layout: the figure's title, if any, and a tight layout.

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

    Returns
    -------
    matplotlib.figure.Figure
        Range panels share one colour scale; the residual has its own.

    Examples
    --------
    >>> from refsynth.plotting.examples import example_ramp
    >>> truth, partial, filled = example_ramp()
    >>> figure = result_figure(truth / 2.5, np.zeros((8, 8), bool), partial, filled, truth,
    ...                        units="m")
    >>> print("; ".join(ax.get_title() for ax in figure.axes[2:6]))
    partial range (38 % unknown); synthesized range; ground truth; |residual|, MAR 0.283 m
    """
    panels = 6 if truth is not None else 4
    aspect = partial_range.shape[1] / partial_range.shape[0]
    if aspect > 2:  # a panorama: one panel per row
        fig = Figure(figsize=(9.0, panels * (9.0 / aspect + 0.6)))
        axes = fig.subplots(panels, 1).ravel()
    else:
        cols = 3 if panels == 6 else 2
        fig = Figure(figsize=(3.2 * cols, 3.0 * 2))
        axes = fig.subplots(2, cols).ravel()
    scale = range_scale(partial_range, result, truth)
    panel(axes[0], np.clip(intensity, 0, 1) if np.ndim(intensity) == 3 else intensity, "intensity")
    panel(axes[1], edges, "Canny edges (σ = 0.8)")
    known = np.isfinite(partial_range)
    panel(axes[2], partial_range, f"partial range ({100 * (1 - known.mean()):.0f} % unknown)",
          **scale)
    panel(axes[3], result, "synthesized range", colorbar=units or True, **scale)
    if truth is not None:
        panel(axes[4], truth, "ground truth", **scale)
        residual = np.where(known | ~np.isfinite(truth), np.nan, np.abs(result - truth))
        mar = np.nanmean(residual)
        panel(axes[5], residual, f"|residual|, MAR {mar:.3g} {units}".strip(), cmap=ERROR_CMAP,
              colorbar=True)
    return finish_figure(fig, title)


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
    fig = Figure(figsize=(2.6 * cols, 2.6 * rows))
    axes = np.atleast_2d(fig.subplots(rows, cols))
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
        panel(axes[row, -1], truth, "ground truth", **scale)
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
    results : mapping of method name to (range, confidence)
        Each two ndarrays of shape (H, W): the synthesized range and a confidence in [0, 1].
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
    fig = Figure(figsize=(3.3 * 3, 3.0 * rows))
    axes = np.atleast_2d(fig.subplots(rows, 3))
    scale = range_scale(truth, partial_range)
    unknown = ~np.isfinite(partial_range) & np.isfinite(truth)
    residuals = {m: np.where(unknown, np.abs(r - truth), np.nan) for m, (r, _) in results.items()}
    top = max(float(np.nanpercentile(e, 99)) for e in residuals.values()) or 1.0
    for row, (method, (estimate, confidence)) in enumerate(results.items()):
        panel(axes[row, 0], estimate, f"{method}: synthesized range", colorbar=True, **scale)
        mar = float(np.nanmean(residuals[method]))
        panel(axes[row, 1], residuals[method], f"|residual|, MAR {mar:.3g} {units}".strip(),
              cmap=ERROR_CMAP, vmin=0, vmax=top, colorbar=True)
        panel(axes[row, 2], confidence, "confidence", cmap="viridis", vmin=0, vmax=1,
              colorbar=True)
    return finish_figure(fig, title)
