r"""The median reading: each synthesized pixel takes the median of its window (after §3.2).

NP (Eq. 5) and BP (Eq. 8) decide each unknown pixel on its own: a copied value, a MAP label.
Where the decision is uncertain — on a depth edge that the intensity places only roughly, on
a surface whose neighbouring pixels drew their values from different sources — the result
holds isolated values from the wrong side of an edge or the wrong surface: speckle, to which
the mean absolute residual (Eq. 13) is sensitive. The median of a small window removes an
isolated value and keeps a straight edge where it is; it is the usual last step of dense
depth estimation from stereo (a 3 × 3 median of the disparity map).

The reading ``median`` of :class:`refsynth.synthesis.readings.Readings` is the window's side:
``0`` (the paper's: no median, every pixel as the method filled it and the reading ``gaps``
left it) or an odd size (refsynth's default 3). :func:`median_pass` applies it after the
reading ``gaps``, the same way for NP and BP and on any sampling. Measured pixels are never
changed, but they take part in the windows of their unknown neighbours; a window is cut at
the image's border by repeating the border pixels (``scipy.ndimage.median_filter``'s
``mode="nearest"``). A median selects one of the window's values, so the result is
bit-identical on every machine.

``python benchmarks/bench_gaps.py ../shared/data --motorcycle --seeds 0,1`` prints NP and BP
with it (``np``, ``bp``: the default) and without it (``np-gate``, ``bp-gate``: the gate alone)
beside the classical fills, and ``--medians 5`` a larger window; docs/distance_sampling.md
holds the table.

References
----------
Torres-Méndez & Dudek (2008), §3.2 (Eqs. 5 and 8), §3.3.1 (Eq. 13),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from refsynth._checks import check_int

__all__ = ["DEFAULT_MEDIAN", "MAX_MEDIAN", "check_median", "median_pass"]

#: refsynth's window side (the paper's reading is 0: no median).
DEFAULT_MEDIAN = 3
#: The largest window side :func:`median_pass` takes.
MAX_MEDIAN = 15


def check_median(size) -> int:
    """``size`` as an int: 0, or an odd number from 3 to :data:`MAX_MEDIAN`; else raise.

    Examples
    --------
    >>> check_median(3)
    3
    >>> check_median(4)
    Traceback (most recent call last):
    ...
    ValueError: The reading `median` must be 0 or an odd number from 3 to 15, got 4
    """
    size = check_int("median", size)
    if size != 0 and not (3 <= size <= MAX_MEDIAN and size % 2 == 1):
        raise ValueError(f"The reading `median` must be 0 or an odd number from 3 to "
                         f"{MAX_MEDIAN}, got {size}")
    return size


def median_pass(estimate: np.ndarray, partial_range: np.ndarray,
                size: int = DEFAULT_MEDIAN) -> np.ndarray:
    """Each unknown pixel of ``estimate`` replaced by the median of its ``size × size`` window.

    Parameters
    ----------
    estimate : ndarray of shape (H, W)
        A dense range (NP's or BP's result, after the reading ``gaps``), finite everywhere.
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range: its finite pixels are returned unchanged.
    size : int, default 3
        The window's side, odd, from 3 to :data:`MAX_MEDIAN`; 0 returns ``estimate`` with the
        measured pixels restored.

    Returns
    -------
    ndarray of shape (H, W), float64
        The range after the pass.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.full((3, 3), np.nan); partial[:, 0] = 1.0
    >>> estimate = np.ones((3, 3)); estimate[1, 1] = 9.0   # an isolated wrong value
    >>> median_pass(estimate, partial).tolist()
    [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]
    """
    size = check_median(size)
    values = np.asarray(partial_range, dtype=float)
    estimate = np.asarray(estimate, dtype=float)
    if values.ndim != 2 or estimate.shape != values.shape:
        raise ValueError(f"estimate and partial_range must be 2-D arrays of one shape, got "
                         f"{estimate.shape} and {values.shape}")
    known = np.isfinite(values)
    if not np.isfinite(estimate[~known]).all():
        raise ValueError("estimate must be finite on every unknown pixel of partial_range")
    base = np.where(known, values, estimate)
    if size == 0:
        return base
    return np.where(known, values, ndimage.median_filter(base, size=size, mode="nearest"))
