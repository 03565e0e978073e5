"""A tiny case for the figures' Examples: a range ramp with unknown columns (§3.3).

Every layout of :mod:`refsynth.plotting.layouts` and :mod:`refsynth.plotting.figures`
draws a ground truth, a partial range and a fill; their examples draw this one,
small enough that the MAR in a title can be checked by hand.

References
----------
Torres-Méndez & Dudek (2008), §3.3 (Eq. 13), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

__all__ = ["example_ramp"]


def example_ramp(
    size: int = 8, unknown: tuple[int, int] = (3, 6), fill: float = 1.5
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A square range ramp, some of its columns unknown, and those filled with a constant.

    Parameters
    ----------
    size : int, default 8
        The side, pixels.
    unknown : pair of int, default (3, 6)
        The unknown columns, ``unknown[0]:unknown[1]``.
    fill : float, default 1.5
        The constant "synthesized" range of the unknown columns.

    Returns
    -------
    truth : ndarray of shape (size, size)
        ``1 + (row + col) / 10``.
    partial : ndarray of shape (size, size)
        ``truth`` with the unknown columns NaN.
    filled : ndarray of shape (size, size)
        ``partial`` with NaN replaced by ``fill``.

    Examples
    --------
    >>> truth, partial, filled = example_ramp(4, (1, 2), 2.0)
    >>> partial[0].tolist(), filled[0].tolist()
    ([1.0, nan, 1.2, 1.3], [1.0, 2.0, 1.2, 1.3])
    """
    truth = 1.0 + np.add.outer(np.arange(float(size)), np.arange(float(size))) / 10
    partial = truth.copy()
    partial[:, unknown[0] : unknown[1]] = np.nan
    return truth, partial, np.where(np.isnan(partial), fill, partial)
