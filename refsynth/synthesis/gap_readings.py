r"""The gap reading: a column scan's narrow gaps filled by their line (§3.1.1, §3.2).

A sweeping rangefinder (§3.1.1, Fig. 2) measures whole columns: each row of the partial range
is a sequence of measured runs and unmeasured *gaps*, each bounded by a measured pixel on the
left and one on the right. Where the range is smooth across a gap — a wall, a floor, the side
of a box, even seen at an angle — the straight line between the two bounding pixels is close
to the truth, and a value copied from elsewhere (Eq. 5, or BP's MAP label, Eq. 8) can only do
worse: it brings the level, or the staircase, of another place. Where the two bounds differ by
a depth edge, the line smears the edge across the gap, and the intensity (Eq. 2's matches, BP's
observations) can say where the edge lies.

The reading ``gaps="gate"`` of :class:`refsynth.synthesis.readings.Readings` (refsynth's
default; the paper's is ``"copy"``, every unknown pixel as NP or BP filled it) applies
:func:`gap_gate` to NP's or BP's result, after the fill, the same way for both methods:

1. :func:`complete_slices`: the holes of each scanned column (dropouts of the sensor, a
   Kinect's missing depth, a stereo pair's occlusions) are filled along the column, by the line
   between the measured pixels above and below, so that each row's gaps are bounded by the
   columns next to them and not by a column further away;
2. in each row gap (:func:`row_gaps`) with bounds ``l`` and ``r``: if the bounds differ by
   more than :data:`DEFAULT_JUMP` of the larger (a depth edge), the synthesized range clipped to
   ``[min, max]`` of the bounds (a copy from a surface at another depth is brought back; a step
   between them stays where the intensity put it); otherwise (a *smooth* gap) the line between
   the bounds (:func:`row_interpolation`), except in a smooth gap wider than
   :data:`DEFAULT_MAX_GAP` that holds an intensity edge, which gets the mean of the synthesis and
   the line (an object between two columns that agree, which NP and BP can see and the line
   cannot); a gap open at the image's border takes its one bound's value.

The result's confidence, order and (BP) labels stay the fill's: the gate changes the range
only, and :attr:`refsynth.SynthesisResult.uncertainty` is computed on the gated range with
the fill as its ``raw`` estimate.

The gate acts on a *column scan* only (:func:`is_column_scan`: at least half of the unknown
pixels lie in columns with no measured pixel, as with x-stripes and Fig. 2's slices); on any
other sampling (the paper's grids of Table 1, scattered pixels) it returns the synthesis
unchanged.

``python benchmarks/bench_gaps.py ../shared/data --motorcycle --seeds 0,1`` prints, per scene
and sampling, NP and BP with and without the gate beside the nearest, linear, colorization and
joint-bilateral fills (Table 4's protocol at 450 × 375); docs/distance_sampling.md holds the
diagnosis and the table.

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

from refsynth._checks import check_choice, check_int, is_real

__all__ = [
    "GAPS",
    "OPEN_GAPS",
    "WIDE_GAPS",
    "DEFAULT_JUMP",
    "DEFAULT_MAX_GAP",
    "row_gaps",
    "row_interpolation",
    "is_column_scan",
    "complete_slices",
    "gap_gate",
]

#: The values of the reading ``gaps``: NP's or BP's range as filled (the paper), or gated.
GAPS = ("copy", "gate")
#: What :func:`gap_gate` gives a wide smooth gap holding an intensity edge.
WIDE_GAPS = ("mean", "estimate")
#: What :func:`gap_gate` does with a gap open at the image's border (one bound only).
OPEN_GAPS = ("interpolation", "estimate")
#: The relative jump above which :func:`gap_gate` keeps the synthesized range.
DEFAULT_JUMP = 0.1
#: The widest smooth gap :func:`gap_gate` interpolates whatever the intensity edges say.
DEFAULT_MAX_GAP = 6


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

    Within a gap ``R(c) = R(l) + t · (R(r) − R(l))`` with ``t = (c − l) / (r − l)`` (in that
    order of float64 operations: a port must match it bit for bit), ``l`` and ``r`` the
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


def _check_partial(partial_range) -> np.ndarray:
    values = np.asarray(partial_range, dtype=float)
    if values.ndim != 2:
        raise ValueError(f"partial_range must be a 2-D array, got shape {values.shape}")
    return values


def is_column_scan(partial_range: np.ndarray) -> bool:
    """Whether the unknown range is mostly whole unscanned columns (§3.1.1's slices).

    True when at least half of the unknown pixels lie in columns that hold no measured pixel:
    x-stripes (Table 4) and Fig. 2's distance-driven slices are, with or without the sensor's
    holes in the scanned columns; the paper's grids (Table 1), whose every column holds
    measured rows, are not.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.full((4, 6), np.nan); partial[:, ::3] = 1.0
    >>> is_column_scan(partial), is_column_scan(partial.T)
    (True, False)
    """
    known = np.isfinite(_check_partial(partial_range))
    unknown = int((~known).sum())
    in_empty_columns = int((~known[:, ~known.any(axis=0)]).sum())
    return unknown > 0 and 2 * in_empty_columns >= unknown


def complete_slices(partial_range: np.ndarray) -> np.ndarray:
    """The partial range with each scanned column's holes filled along the column.

    A column with at least one measured pixel is a scanned slice; its unknown pixels (the
    sensor's dropouts) get the line between the measured pixels above and below them in the
    column, or the nearest one's value beyond the first and the last
    (:func:`row_interpolation` along the columns). Columns with no measured pixel stay unknown;
    measured pixels are returned unchanged, bit for bit.

    Examples
    --------
    >>> import numpy as np
    >>> nan = np.nan
    >>> complete_slices(np.array([[1.0, nan], [nan, nan], [3.0, nan]])).tolist()
    [[1.0, nan], [2.0, nan], [3.0, nan]]
    """
    values = _check_partial(partial_range)
    scanned = np.isfinite(values).any(axis=0)
    out = values.copy()
    if scanned.any():
        out[:, scanned] = row_interpolation(values[:, scanned].T).T
    return out


def gap_gate(estimate: np.ndarray, partial_range: np.ndarray, *, jump: float = DEFAULT_JUMP,
             max_gap: int | None = DEFAULT_MAX_GAP, edges: np.ndarray | None = None,
             wide_gaps: str = "mean", open_gaps: str = "interpolation") -> np.ndarray:
    """The reading ``gaps="gate"``: a column scan's smooth gaps by their line (a post-pass).

    On a column scan (:func:`is_column_scan`; otherwise ``estimate`` is returned with the
    measured pixels restored), after :func:`complete_slices`, for each unknown pixel whose row
    gap (:func:`row_gaps` of the completed range) has bounds ``l`` and ``r`` on both sides:

    - a *jump* gap, ``|R(r) − R(l)| > jump · max(|R(l)|, |R(r)|)`` (a depth edge between the
      bounds): ``estimate`` clipped to ``[min(R(l), R(r)), max(R(l), R(r))]``;
    - a *smooth* gap: :func:`row_interpolation`'s value, except in a gap wider than
      ``max_gap`` that holds an intensity edge (a pixel of ``edges`` strictly between the
      bounds in its row), where ``estimate`` is averaged with the line (``wide_gaps="mean"``)
      or kept as it is (``"estimate"``), ``0.5 · (estimate + line)``.

    A pixel with a bound on one side only (a gap open at the border) takes that bound's
    value (``open_gaps="interpolation"``) or keeps the estimate; a hole of a scanned column
    takes :func:`complete_slices`'s value.

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
        The intensity edges (:func:`refsynth.synthesize` gives its own: Canny on the grey
        level, §3.2); without them every smooth gap is interpolated.
    wide_gaps : {"mean", "estimate"}
        A smooth gap wider than ``max_gap`` with an edge inside: the mean of the estimate and
        the line, or the estimate.
    open_gaps : {"interpolation", "estimate"}
        A gap with one bound only: the bound's value or the estimate.

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
    values = _check_partial(partial_range)
    estimate = np.asarray(estimate, dtype=float)
    if estimate.shape != values.shape:
        raise ValueError(f"estimate must have partial_range's 2-D shape {values.shape}, "
                         f"got {estimate.shape}")
    if edges is not None and (np.shape(edges) != values.shape
                              or np.asarray(edges).dtype != np.bool_):
        raise ValueError(f"edges must be a bool array of partial_range's shape {values.shape}")
    known = np.isfinite(values)
    if not is_column_scan(values):
        return np.where(known, values, estimate)
    completed = complete_slices(values)
    left, right, width = row_gaps(completed)
    rows = np.arange(values.shape[0])[:, None]
    lv = completed[rows, np.maximum(left, 0)]
    rv = completed[rows, np.maximum(right, 0)]
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
    line = row_interpolation(completed)
    out = np.where(bounded & edge, np.clip(estimate, np.fmin(lv, rv), np.fmax(lv, rv)),
                   estimate)
    out = np.where(smooth, line, out)
    if wide_gaps == "mean":
        out = np.where(wide, 0.5 * (estimate + line), out)
    if open_gaps == "interpolation":
        out = np.where(width < 0, line, out)
    out = np.where(np.isfinite(completed), completed, out)  # the slices' holes
    return np.where(known, values, out)
