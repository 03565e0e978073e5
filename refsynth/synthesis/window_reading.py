r"""The window reading: the neighbourhood's side chosen by the width of a column scan's gaps.

§3.3 fixes the MRF neighbourhood (§3.2.1) for every experiment: "windows of 5 × 5 pixels,
unless otherwise indicated", and indicates one exception: in Fig. 11 and Table 1, "for the
first three cases the size of the neighborhood is set to be 5 × 5 pixels and for the last
case 3 × 3 pixels", the last case being the sparsest sampling. The paper gives no rule for
when the smaller window applies.

The reading ``window`` of :class:`refsynth.synthesis.readings.Readings` gives one, for the
samplings of §3.1.1 (a sweeping rangefinder's whole columns, Fig. 2's slices, Table 4's
stripes), where the unknown range lies in gaps between scanned columns:

- ``"fixed"`` (the paper's): the ``neighbourhood`` :func:`refsynth.synthesize` is given, 5 by
  default, whatever the sampling;
- ``"gaps"`` (refsynth's default): when ``synthesize`` is not given a ``neighbourhood``, 3 on
  a column scan (:func:`~refsynth.synthesis.gap_readings.is_column_scan`) whose
  :func:`typical_gap` is at most :data:`NARROW_GAP` columns (no wider than the default 5 × 5
  window), 5 on any other sampling. A ``neighbourhood`` given explicitly is always used.

Why it can help (the measurements below decide, not this): on Fig. 2's slices most gaps are
one to three columns wide, and a 5 × 5 window centred in such a gap reaches over the measured
columns on both sides, so that Eq. 2 ranks the candidates mostly by the range around the gap
rather than by the pixel's own surroundings, which the 3 × 3 window keeps to. In a wider gap
the larger window's context wins.

Measured on the choosing scenes (Table 4's protocol at 450 × 375, NP and BP after the default
post-passes, seeds 0 and 1; ``python benchmarks/bench_gaps.py ../shared/data --motorcycle
--seeds 0,1 --samplings x63,x70,x78,distance60 --windows`` prints the table of
docs/distance_sampling.md): the 3 × 3 window won on every scene type on Fig. 2's slices at
60 % (typical gap 2) and on x-stripes at 63 % (gap 5), losing on one case (an NYU frame's
slices, 0.93 → 0.97 of the best classical fill); on x-stripes at 70 and 78 % (gaps of 7 and
11) it won on the Middlebury scenes and lost on three of the four indoor frames.

The typical gap is a median of integers and the test an integer comparison, so the choice is
the same on every machine.

References
----------
Torres-Méndez & Dudek (2008), §3.1.1 (Fig. 2), §3.2.1, §3.3 and Fig. 11 / Table 1 (the 3 × 3
window of the sparsest case), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth._checks import check_choice
from refsynth.synthesis.gap_readings import complete_slices, is_column_scan, row_gaps

__all__ = ["WINDOWS", "DEFAULT_NEIGHBOURHOOD", "NARROW_NEIGHBOURHOOD", "NARROW_GAP",
           "typical_gap", "choose_neighbourhood"]

#: The values of the reading ``window``: the given neighbourhood (the paper), or by the gaps.
WINDOWS = ("fixed", "gaps")
#: The neighbourhood's side when none is given (§3.3: "windows of 5 × 5 pixels").
DEFAULT_NEIGHBOURHOOD = 5
#: The side ``window="gaps"`` takes on a column scan with narrow gaps (Fig. 11's last case).
NARROW_NEIGHBOURHOOD = 3
#: The widest typical gap, in columns, that ``window="gaps"`` calls narrow.
NARROW_GAP = 5


def typical_gap(partial_range: np.ndarray) -> int:
    """The median width of the row gaps over a column scan's unknown pixels (0 if none).

    Each unknown pixel with a measured pixel on both sides in its row (after
    :func:`~refsynth.synthesis.gap_readings.complete_slices` fills the scanned columns' holes)
    counts its gap's width (:func:`~refsynth.synthesis.gap_readings.row_gaps`); the median
    is taken over those pixels, so a wide gap counts as often as it has pixels. Of an even
    number of widths, the lower middle one.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W), floating, NaN where unknown
        The measured range.

    Returns
    -------
    int
        The typical width in columns; 0 when no unknown pixel is bounded on both sides.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.full((4, 12), np.nan); partial[:, ::3] = 1.0
    >>> typical_gap(partial)
    2
    """
    values = np.asarray(partial_range, dtype=float)
    if values.ndim != 2:
        raise ValueError(f"partial_range must be a 2-D array, got shape {values.shape}")
    width = row_gaps(complete_slices(values))[2]
    widths = np.sort(width[width > 0], kind="stable")
    return int(widths[(widths.size - 1) // 2]) if widths.size else 0


def choose_neighbourhood(partial_range: np.ndarray, window: str = "gaps") -> int:
    """The neighbourhood's side :func:`refsynth.synthesize` uses when it is given none.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W), floating, NaN where unknown
        The measured range.
    window : {"gaps", "fixed"}, default "gaps"
        The reading ``window``: ``"fixed"`` always gives :data:`DEFAULT_NEIGHBOURHOOD`;
        ``"gaps"`` gives :data:`NARROW_NEIGHBOURHOOD` on a column scan whose
        :func:`typical_gap` is between 1 and :data:`NARROW_GAP`, else
        :data:`DEFAULT_NEIGHBOURHOOD`.

    Returns
    -------
    int
        3 or 5.

    Examples
    --------
    >>> import numpy as np
    >>> slices = np.full((8, 24), np.nan); slices[:, ::3] = 1.0      # gaps of 2 columns
    >>> stripes = np.full((8, 24), np.nan); stripes[:, ::12] = 1.0   # gaps of 11
    >>> choose_neighbourhood(slices), choose_neighbourhood(stripes)
    (3, 5)
    >>> choose_neighbourhood(slices, "fixed"), choose_neighbourhood(slices.T)   # rows scanned
    (5, 5)
    """
    window = check_choice("window", window, WINDOWS)
    values = np.asarray(partial_range, dtype=float)
    if window == "fixed" or not is_column_scan(values):
        return DEFAULT_NEIGHBOURHOOD
    gap = typical_gap(values)
    return NARROW_NEIGHBOURHOOD if 1 <= gap <= NARROW_GAP else DEFAULT_NEIGHBOURHOOD
