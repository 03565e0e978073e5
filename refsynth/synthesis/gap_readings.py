r"""Range synthesis across a row scan's gaps, with the interpolation as its floor (§3.1.1, §3.2).

A sweeping rangefinder (§3.1.1, Fig. 2) measures whole columns: each row of the partial range
is a sequence of measured runs and unmeasured *gaps*, each bounded by a measured pixel on the
left and one on the right. Where the range is smooth across a gap — a wall, a floor, the side
of a box, even seen at an angle — the straight line between the two bounding pixels is close
to the truth, and a value copied from elsewhere (Eq. 5, or BP's MAP label, Eq. 8) can only do
worse: it brings the level, or the staircase, of another place. Where the two bounds differ by
a depth edge, the line smears the edge across the gap, and the intensity (Eq. 2's matches, BP's
observations) can say where the edge lies. These functions wrap :func:`refsynth.synthesize` (NP
or BP, any of its options) with transforms that need nothing inside its kernels:

- :func:`row_gaps` (each unknown pixel's gap) and :func:`row_interpolation` (the linear fill
  along each row between the bounding pixels);
- :func:`gap_gate`, a post-pass on any dense estimate, and :func:`gated_synthesis`, which runs
  :func:`refsynth.synthesize` and then the post-pass: in a gap whose bounds differ by more
  than ``jump`` times the larger bound (a depth edge), the synthesized range clipped to the
  range of the two bounds (a copy from a surface at another depth is brought back to the
  nearer bound; a step between them is kept where the intensity put it); in a *smooth* gap,
  the row interpolation — except in a smooth gap wider than ``max_gap`` holding an intensity
  edge, where the mean of the synthesis and the line (an object between two columns that
  agree); a gap open at the border takes its bound's value;
- :func:`residual_synthesis`: synthesize ``partial − interpolation`` and add the interpolation
  back. Every source pixel of Eq. 3 (and every label of Fig. 6) then holds a residual of 0,
  so the result is the interpolation exactly: kept, and tested, as the proof that this
  reading adds nothing, not as a reading to use.

The paper's reading is :func:`refsynth.synthesize` itself; :func:`gated_synthesis` is a
departure, measured against it and against the classical fills of
:mod:`refsynth.evaluation.baselines` on the Motorcycle and on real indoor frames by
``benchmarks/bench_gaps.py``.

Measured (``benchmarks/bench_gaps.py``, Table 4's protocol at 450 × 375, seed 0; ratio of MAR
to the best of the nearest, linear, colorization and joint-bilateral fills, geometric mean over
18 cases: the Motorcycle, three NYU Depth v2 frames, a Kinect v2 room and the Middlebury
Reindeer × x-stripes 63 / 78 % and Fig. 2's distance sampling at 60 %): NP 1.59 → 0.92, BP
1.46 → 0.90; indoors NP 1.78 → 1.04, BP 1.62 → 1.02, the worst case an NYU frame's distance
sampling (NP 2.35 → 1.53; the line itself is 1.45 there, the Delaunay fill 1.0: raw Kinect
holes break the rows). On the Motorcycle's x-stripes (63 / 78 / 85 %) NP 0.303 / 0.463 / 0.624
→ 0.280 / 0.462 / 0.618 px, BP 0.282 / 0.439 / 0.594 → 0.273 / 0.449 / 0.603. Interpolating
every smooth gap (``max_gap=None``) won more indoors and lost 6–8 % on the Motorcycle's 11- and
17-px gaps, where NP sees parts of the machine between columns that agree.

The test of a jump, ``|R(r) − R(l)| > jump · max(|R(l)|, |R(r)|)``, is relative: the same for
depth in any unit and for disparity (a relative change of depth is the same relative change of
disparity), and independent of the gap's width.

References
----------
Torres-Méndez & Dudek (2008), §3.1.1 (Fig. 2's slices), §3.2.2 (Eqs. 2–5), §3.2.3 (Fig. 6),
§3.3.1 (Eq. 13), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from refsynth._checks import check_choice, check_int, is_real
from refsynth.numeric import INTENSITY_BITS, quantise_grey, quantise_intensity
from refsynth.synthesis.canny import canny
from refsynth.synthesis.limits import validate_inputs

__all__ = [
    "INTERPOLATIONS",
    "OPEN_GAPS",
    "WIDE_GAPS",
    "DEFAULT_JUMP",
    "DEFAULT_MAX_GAP",
    "row_gaps",
    "row_interpolation",
    "gap_gate",
    "gated_synthesis",
    "residual_synthesis",
]

#: The interpolations :func:`residual_synthesis` accepts.
INTERPOLATIONS = ("linear", "nearest")
#: What :func:`gap_gate` gives a wide smooth gap holding an intensity edge.
WIDE_GAPS = ("mean", "estimate")
#: What :func:`gap_gate` does with a gap open at the image's border (one bound only).
OPEN_GAPS = ("interpolation", "estimate")
#: The relative jump above which :func:`gap_gate` keeps the synthesized range.
DEFAULT_JUMP = 0.1
#: The widest smooth gap :func:`gap_gate` interpolates whatever the intensity edges say.
DEFAULT_MAX_GAP = 6


def _synthesize():
    """:func:`refsynth.synthesize`, imported when called: the module's post-pass
    (:func:`gap_gate`) stays importable by :mod:`refsynth.synthesis.api` itself."""
    from refsynth.synthesis.api import synthesize

    return synthesize


def _check_jump(jump) -> float:
    """``jump`` as a float in ``[0, inf]``, or raise naming it."""
    if not is_real(jump):
        raise TypeError(f"The parameter `jump` must be a real number, got {type(jump).__name__}")
    if not float(jump) >= 0.0:
        raise ValueError(f"The parameter `jump` must be a number in [0, inf], got {jump}")
    return float(jump)


def _bounds(known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the nearest known column at or left of it, and at or right (−1: none)."""
    width = known.shape[1]
    cols = np.broadcast_to(np.arange(width), known.shape)
    left = np.maximum.accumulate(np.where(known, cols, -1), axis=1)
    right = np.where(known, cols, width)[:, ::-1]
    right = np.minimum.accumulate(right, axis=1)[:, ::-1]
    right = np.where(right == width, -1, right)
    return left, right


def row_gaps(partial_range: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each unknown pixel's gap along its row: its bounding columns and its width.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W), floating, NaN where unknown
        The measured range.

    Returns
    -------
    left, right : ndarray of shape (H, W), int
        The column of the nearest measured pixel at or left of (right of) each pixel in its
        row, −1 where there is none. A measured pixel is its own bound.
    width : ndarray of shape (H, W), int
        ``right − left − 1`` for an unknown pixel with a measured pixel on both sides (its
        gap's width in pixels), 0 for a measured pixel, and −1 for an unknown pixel with no
        measured pixel on one side (a gap open at the image's border).

    Examples
    --------
    >>> import numpy as np
    >>> nan = np.nan
    >>> row_gaps(np.array([[nan, 1.0, nan, nan, 4.0]]))[2].tolist()
    [[-1, 0, 2, 2, 0]]
    """
    values = np.asarray(partial_range, dtype=float)
    if values.ndim != 2:
        raise ValueError(f"partial_range must be a 2-D array, got shape {values.shape}")
    known = np.isfinite(values)
    left, right = _bounds(known)
    width = np.where((left >= 0) & (right >= 0), right - left - 1, -1)
    return left, right, np.where(known, 0, width)


def row_interpolation(partial_range: np.ndarray) -> np.ndarray:
    """The linear fill along each row between the measured pixels bounding each gap.

    Within a gap ``R(c) = R(l) + (c − l)(R(r) − R(l)) / (r − l)``, ``l`` and ``r`` the
    bounding columns (:func:`row_gaps`); a gap open at the border takes its one bounding
    value; a row with no measured pixel is filled the same way along its column from the
    rows that have one (and so on to the nearest filled row). Measured pixels are returned
    unchanged, bit for bit.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W), floating, NaN where unknown
        The measured range; at least one pixel must be measured.

    Returns
    -------
    ndarray of shape (H, W), float64
        The dense range.

    Examples
    --------
    >>> import numpy as np
    >>> row_interpolation(np.array([[1.0, np.nan, np.nan, 4.0]]))[0].tolist()
    [1.0, 2.0, 3.0, 4.0]
    """
    values = np.asarray(partial_range, dtype=float)
    if values.ndim != 2:
        raise ValueError(f"partial_range must be a 2-D array, got shape {values.shape}")
    known = np.isfinite(values)
    if not known.any():
        raise ValueError("partial_range must have at least one measured (finite) pixel")
    out = _along_rows(values, known)
    empty = ~known.any(axis=1)
    if empty.any():
        filled = ~empty[:, None] & np.ones(values.shape, bool)
        out = _along_rows(np.where(filled, out, np.nan).T, filled.T).T
    return np.where(known, values, out)


def _along_rows(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Linear between the bounding known pixels, constant beyond them (rows without any: NaN)."""
    left, right = _bounds(known)
    rows = np.arange(values.shape[0])[:, None]
    cols = np.arange(values.shape[1])[None, :]
    lv = values[rows, np.maximum(left, 0)]
    rv = values[rows, np.maximum(right, 0)]
    span = np.maximum(right - left, 1)
    t = (cols - left) / span
    both = (left >= 0) & (right >= 0)
    out = np.where(both, lv + t * (rv - lv), np.where(left >= 0, lv, rv))
    return np.where((left < 0) & (right < 0), np.nan, out)


def _interpolate(partial: np.ndarray, interpolation: str) -> np.ndarray:
    if interpolation == "linear":
        return row_interpolation(partial)
    known = np.isfinite(partial)
    _, (rows, cols) = ndimage.distance_transform_edt(~known, return_indices=True)
    return partial[rows, cols]


def residual_synthesis(intensity: np.ndarray, partial_range: np.ndarray, *,
                       interpolation: str = "linear", **synth_options) -> np.ndarray:
    """Synthesize the range's departure from an interpolation, then add the interpolation back.

    ``R = T + S(I, P − T)``: ``T`` the interpolation of the partial range ``P``
    (:func:`row_interpolation`, or the nearest measured value), ``S`` :func:`refsynth.synthesize`
    (Eqs. 2–5 or Fig. 6) run on the residual, which is 0 at every measured pixel.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The registered intensity image.
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range.
    interpolation : {"linear", "nearest"}
        The trend ``T``.
    **synth_options
        Keywords of :func:`refsynth.synthesize` (``method``, ``seed``, ...).

    Returns
    -------
    ndarray of shape (H, W), float64
        The dense range; measured pixels unchanged.

    Notes
    -----
    Every pixel NP or BP can copy from holds a residual of 0 — the measured ones by
    construction, the synthesized ones because they copied one — so the synthesized
    residual is 0 everywhere and ``R = T`` exactly (up to the offset copy's rounding on the
    grid of the residual's span, which is 0): the residual reading is the interpolation,
    whatever the intensity says (measured by ``benchmarks/bench_gaps.py``: the row
    interpolation's MAR, bit for bit).
    """
    check_choice("interpolation", interpolation, INTERPOLATIONS)
    _, values = validate_inputs(intensity, partial_range)
    trend = _interpolate(values, interpolation)
    known = np.isfinite(values)
    residual = np.where(known, values - trend, np.nan)
    synthesized = _synthesize()(intensity, residual, **synth_options).range
    return np.where(known, values, trend + synthesized)


def _canny_edges(image: np.ndarray, canny_sigma: float) -> np.ndarray:
    """Canny edges as :func:`refsynth.synthesize` detects them: the grey level brought to [0, 1]."""
    levels = quantise_grey(quantise_intensity(image)) * 2.0**-INTENSITY_BITS
    return canny(levels, sigma=canny_sigma)


def gap_gate(estimate: np.ndarray, partial_range: np.ndarray, *, jump: float = DEFAULT_JUMP,
             max_gap: int | None = DEFAULT_MAX_GAP, edges: np.ndarray | None = None,
             wide_gaps: str = "mean", open_gaps: str = "interpolation") -> np.ndarray:
    """Interpolate the smooth gaps of each row, clip the estimate in the others (a post-pass).

    For an unknown pixel whose row gap (:func:`row_gaps`) has bounds ``l`` and ``r`` on both
    sides:

    - a *jump* gap, ``|R(r) − R(l)| > jump · max(|R(l)|, |R(r)|)`` (a depth edge between the
      bounds): ``estimate`` clipped to ``[min(R(l), R(r)), max(R(l), R(r))]``;
    - a *smooth* gap: :func:`row_interpolation`'s value, except in a gap wider than
      ``max_gap`` that holds an intensity edge (a pixel of ``edges`` strictly between the
      bounds in its row), where ``estimate`` is averaged with the line (``wide_gaps="mean"``)
      or kept as it is (``"estimate"``): an object between two measured columns that agree
      (a part of the Motorcycle in front of its background) is what NP and BP can see and
      the line cannot.

    Parameters
    ----------
    estimate : ndarray of shape (H, W)
        A dense range (NP's or BP's result, or any fill), finite where ``partial_range`` is not.
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range the estimate was made from.
    jump : float, default 0.1
        The relative difference of the two bounds above which a gap holds a depth edge, in
        ``[0, inf]``: 0 clips every bounded gap, ``inf`` makes every bounded gap smooth.
    max_gap : int or None, default 6
        The widest smooth gap interpolated whatever ``edges`` say, in pixels; ``None``: every
        smooth gap is interpolated.
    edges : ndarray of shape (H, W), bool, optional
        The intensity edges (:func:`gated_synthesis` gives :func:`refsynth.synthesize`'s:
        Canny on the grey level, §3.2); without them every smooth gap is interpolated.
    wide_gaps : {"mean", "estimate"}
        A smooth gap wider than ``max_gap`` with an edge inside: the mean of the estimate and
        :func:`row_interpolation`'s value, or the estimate.
    open_gaps : {"interpolation", "estimate"}
        A gap with one bound only (at the border, or beside a row's hole): take the bound's
        value (:func:`row_interpolation`'s; the default, measured better on the screening
        scenes of ``benchmarks/bench_gaps.py``) or keep the estimate.

    Returns
    -------
    ndarray of shape (H, W), float64
        The dense range; measured pixels hold ``partial_range``'s values.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, 1.0, np.nan, 9.0, np.nan]])
    >>> gap_gate(np.array([[3.0, 5.0, 1.0, 20.0, 9.0, 7.0]]), partial).tolist()
    [[1.0, 1.0, 1.0, 9.0, 9.0, 9.0]]
    """
    jump = _check_jump(jump)
    if max_gap is not None:
        max_gap = check_int("max_gap", max_gap, minimum=0)
    check_choice("wide_gaps", wide_gaps, WIDE_GAPS)
    check_choice("open_gaps", open_gaps, OPEN_GAPS)
    values = np.asarray(partial_range, dtype=float)
    estimate = np.asarray(estimate, dtype=float)
    if values.ndim != 2 or estimate.shape != values.shape:
        raise ValueError(f"estimate must have partial_range's 2-D shape {values.shape}, "
                         f"got {estimate.shape}")
    if edges is not None and (np.shape(edges) != values.shape
                              or np.asarray(edges).dtype != np.bool_):
        raise ValueError(f"edges must be a bool array of partial_range's shape {values.shape}")
    known = np.isfinite(values)
    left, right, width = row_gaps(values)
    rows = np.arange(values.shape[0])[:, None]
    lv = values[rows, np.maximum(left, 0)]
    rv = values[rows, np.maximum(right, 0)]
    bounded = width > 0
    with np.errstate(invalid="ignore"):
        edge = np.abs(rv - lv) > jump * np.fmax(np.abs(lv), np.abs(rv))
    smooth = bounded & ~edge
    wide = np.zeros(values.shape, bool)
    if edges is not None and max_gap is not None:
        counts = np.concatenate([np.zeros((values.shape[0], 1), np.int64),
                                 np.cumsum(edges, axis=1)], axis=1)
        inside = counts[rows, np.maximum(right, 0)] - counts[rows, np.maximum(left, 0) + 1]
        wide = smooth & (width > max_gap) & (inside > 0)
        smooth &= ~wide
    interpolated = row_interpolation(values)
    out = np.where(bounded & edge, np.clip(estimate, np.fmin(lv, rv), np.fmax(lv, rv)),
                   estimate)
    out = np.where(smooth, interpolated, out)
    if wide_gaps == "mean":
        out = np.where(wide, 0.5 * (estimate + interpolated), out)
    if open_gaps == "interpolation":
        out = np.where(width < 0, interpolated, out)
    return np.where(known, values, out)


def gated_synthesis(intensity: np.ndarray, partial_range: np.ndarray, *,
                    jump: float = DEFAULT_JUMP, max_gap: int | None = DEFAULT_MAX_GAP,
                    wide_gaps: str = "mean", open_gaps: str = "interpolation",
                    **synth_options) -> np.ndarray:
    """:func:`refsynth.synthesize`, then :func:`gap_gate` with the intensity's Canny edges.

    Parameters
    ----------
    intensity, partial_range : ndarray
        As for :func:`refsynth.synthesize`.
    jump, max_gap, wide_gaps, open_gaps
        As for :func:`gap_gate` (checked before any work).
    **synth_options
        Keywords of :func:`refsynth.synthesize` (``method``, ``seed``, ...); its ``edges``
        (or the Canny edges at its ``canny_sigma``) are the gate's too.

    Returns
    -------
    ndarray of shape (H, W), float64
        The dense range; measured pixels unchanged.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.tile([1.0, np.nan, np.nan, 4.0, np.nan, 5.0], (6, 1))
    >>> gated_synthesis(np.zeros((6, 6)), partial, jump=10.0)[0].tolist()
    [1.0, 2.0, 3.0, 4.0, 4.5, 5.0]
    """
    _check_jump(jump)
    if max_gap is not None:
        check_int("max_gap", max_gap, minimum=0)
    check_choice("wide_gaps", wide_gaps, WIDE_GAPS)
    check_choice("open_gaps", open_gaps, OPEN_GAPS)
    image, values = validate_inputs(intensity, partial_range)
    synthesized = _synthesize()(intensity, values, **synth_options).range
    edges = synth_options.get("edges")
    if edges is None:
        edges = _canny_edges(image, synth_options.get("canny_sigma", 0.8))
    return gap_gate(synthesized, values, jump=jump, max_gap=max_gap, edges=edges,
                    wide_gaps=wide_gaps, open_gaps=open_gaps)
