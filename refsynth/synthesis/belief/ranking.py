r"""The ranking of BP's candidate search (§3.2.3, Fig. 6, step 2): the stable order.

Fig. 6, step 2 keeps each node's ``k`` closest training patches by Eq. 2.
refsynth ranks them as a stable sort does — ties in the raster order of the
disc's offsets — so that the candidates are the same on every machine
(``np.argpartition``'s order is whatever its selection algorithm, SIMD-dispatched,
leaves). :func:`stable_smallest` finds the sort's first ``k`` with a partition;
:func:`smallest_measured` ranks each node on its measured offsets alone, every
other offset of its disc being ∞ (:mod:`refsynth.synthesis.belief.search`).

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

__all__ = ["smallest_measured", "stable_smallest"]


def stable_smallest(values: np.ndarray, count: int) -> np.ndarray:
    """``np.argsort(values, axis=1, kind="stable")[:, :count]``, by a partition.

    The ``count`` smallest of a row in the stable order are those below its
    ``count``-th value and, of those equal to it, the first in index order;
    sorted stably by value, they are the sort's first ``count`` (the index order
    is looked at only in the rows with ties at that value). Rows with fewer than
    ``count`` values that are not NaN are sorted outright.

    Parameters
    ----------
    values : ndarray of float, shape (B, M)
    count : int
        ``1 ≤ count ≤ M``.

    Returns
    -------
    ndarray of int64, shape (B, count)

    Examples
    --------
    >>> stable_smallest(np.array([[3.0, 1.0, 2.0, 1.0, np.inf]]), 3).tolist()
    [[1, 3, 2]]
    """
    values = np.asarray(values)
    b, m = values.shape
    if b == 0:
        return np.zeros((0, count), dtype=np.int64)
    if count >= m:
        return np.argsort(values, axis=1, kind="stable")[:, :count]
    kth = np.partition(values, count - 1, axis=1)[:, count - 1 : count]
    take = values <= kth
    surplus = take.sum(axis=1) - count  # ties at the count-th value, or a NaN (below 0)
    if surplus.any():
        tied = np.flatnonzero(surplus > 0)
        equal = values[tied] == kth[tied]
        # of those equal to it, the first in index order
        need = count - (values[tied] < kth[tied]).sum(axis=1)
        take[tied] &= ~equal | (np.cumsum(equal, axis=1) <= need[:, None])
        nan_rows = np.isnan(kth[:, 0]) | (surplus < 0)
    else:
        nan_rows = np.zeros(b, dtype=bool)
    out = np.empty((b, count), dtype=np.int64)
    ok = ~nan_rows
    if ok.all():
        out = _sorted_by_value(values, take, count)
    elif ok.any():
        out[ok] = _sorted_by_value(values[ok], take[ok], count)
    if nan_rows.any():
        out[nan_rows] = np.argsort(values[nan_rows], axis=1, kind="stable")[:, :count]
    return out


def _sorted_by_value(values, take, count):
    """The columns ``take`` marks (``count`` a row), in index order, sorted stably by value."""
    rows = np.arange(take.shape[0])[:, None]
    cols = np.nonzero(take)[1].reshape(-1, count)  # in index order
    return cols[rows, np.argsort(values[rows, cols], axis=1, kind="stable")]



def smallest_measured(values: np.ndarray, bi: np.ndarray, mi: np.ndarray, b: int, m: int,
                      count: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`stable_smallest` of the rows ``d`` (B, M) that are ∞ but ``d[bi, mi] = values``.

    Ranks each row's measured entries alone: ``(bi, mi)`` run node by node in raster
    order, so a row's measured entries packed to the left keep their order, and when a
    row holds at least ``count`` of them, all finite, its ``count`` smallest are among
    them (every other entry is ∞). Any other row (a short or non-finite one) is ranked
    in full.

    Parameters
    ----------
    values : ndarray of float, shape (P,)
        The measured entries' distances.
    bi, mi : ndarray of int, shape (P,)
        Their rows (nodes, ascending) and columns (disc offsets, ascending in a row).
    b, m : int
        The rows and columns of ``d``.
    count : int
        How many to keep, ``0 ≤ count ≤ m``.

    Returns
    -------
    best : ndarray of int64, shape (B, count)
        ``stable_smallest(d, count)``.
    distances : ndarray of float64, shape (B, count)
        ``d``'s values there.

    Examples
    --------
    >>> best, d = smallest_measured(np.array([2.0, 1.0, 2.0]), np.array([0, 0, 0]),
    ...                             np.array([1, 3, 4]), 1, 5, 2)
    >>> best.tolist(), d.tolist()
    ([[3, 1]], [[1.0, 2.0]])
    """
    best = np.zeros((b, count), dtype=np.int64)
    bd = np.full((b, count), np.inf)
    if count == 0:
        return best, bd
    counts = np.bincount(bi, minlength=b)
    full = counts < count
    if not np.isfinite(values).all():
        full[bi[~np.isfinite(values)]] = True
    if not full.all():
        # each row's measured entries, packed to the left in their order (∞ after)
        starts = np.cumsum(counts) - counts
        width = int(counts.max())
        packed = np.full(b * width, np.inf)
        packed[bi * width + (np.arange(bi.size) - np.repeat(starts, counts))] = values
        packed = packed.reshape(b, width)
        ok = ~full
        if full.any():
            packed, starts = packed[ok], starts[ok]
        at = starts[:, None] + stable_smallest(packed, count)  # the entries chosen
        best[ok], bd[ok] = mi[at], values[at]
    if full.any():
        # the rows in full: ∞ at every unmeasured offset
        row = np.cumsum(full) - 1
        mine = full[bi]
        d = np.full((int(full.sum()), m), np.inf)
        d[row[bi[mine]], mi[mine]] = values[mine]
        chosen = stable_smallest(d, count)
        best[full] = chosen
        bd[full] = np.take_along_axis(d, chosen, axis=1)
    return best, bd
