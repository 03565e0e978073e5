r"""A lower bound on Eq. 2's intensity term from five sums per window (§3.2.2).

NP's shortlist (:meth:`refsynth.synthesis.filltable.FillTable.shortlist`) needs the whole
Eq. 2 only for the candidates that can be within ``1 + ε`` of the best match, and its
intensity term

.. math:: t_q = \sum_{v \in N} G_v \sum_c (I_{p,v,c} - I_{q,v,c})^2

only for the candidates that a cheaper bound cannot rule out. Cut the window into parts
``P`` (:func:`pinwheel_parts`: the centre and four blocks around it) and let
``S_{P,c}(x) = Σ_{v∈P} G_v I_{x,v,c}`` be the weighted sum of channel ``c`` of ``x``'s
window over ``P``. By Cauchy–Schwarz on each part and channel,
``(Σ_{v∈P} G_v d_v)² ≤ (Σ_{v∈P} G_v)(Σ_{v∈P} G_v d_v²)``, so

.. math:: t_q \ge L_q = \sum_P \sum_c \frac{(S_{P,c}(p) - S_{P,c}(q))^2}{G_P},
          \qquad G_P = \sum_{v \in P} G_v .

A candidate with ``L_q`` above the bound on Eq. 2 is ruled out without gathering its
intensity row (``n² C + 4`` numbers). On the Motorcycle (x-stripes 78 %) about one
candidate in nine survives the five parts: 21.6 of 184 a step at 225×188, 21.0 of 188 at
450×375, the median 7 (``python benchmarks/bench_speed.py --np-steps``).

Per step the bound costs one gather of short rows and one product: each pixel's row holds
its sums and ``Q_x = Σ_j w_j S_j(x)²`` (``j`` runs over the ``5 C`` sums, ``w_j = u / G_P``
with ``u`` the shortlist's unit, :func:`bound_weights`), and with the weights
``[−2 w_j S_j(p) | 1]`` the product gives ``L_q − Q_p`` (:func:`expanded_lower_bounds`).
That expansion is rounded: every term is at most ``Q_p + Q_q ≤ 2 max Q`` in size, and the
at most 16 terms, the stored ``Q`` and the weights add a few roundings of ``2**-53``
each, so the computed value is within ``2**-44 max Q`` of ``L_q``. A candidate is ruled
out only when the computed bound exceeds the threshold ``T`` by more than
``SLACK T + SLACK max Q`` (:data:`SLACK`, ``2**-40``; :func:`margin`), far above that
error, whatever the order a BLAS adds the terms in: no candidate that the exact test keeps
(``t_q ≤ T``) is ever ruled out, so the shortlist keeps the same decisions and distances,
bit for bit. (The margin is some ``10**-12`` of Eq. 2's unit on the Motorcycle; a
window differing from ``p``'s by one level at one pixel lies some ``10**-10`` away.)

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth.numeric import EQ2_UNIT, window_weights

__all__ = ["PARTS", "SLACK", "bound_rows", "bound_weights", "expanded_lower_bounds",
           "lower_bounds", "margin", "part_sums", "part_sums_matrix", "pinwheel_parts"]

#: ``numpy.matvec`` (numpy 2.2 and later), or None.
_matvec = getattr(np, "matvec", None)

#: The parts a window is cut into (:func:`pinwheel_parts`).
PARTS = 5

#: The margin by which a computed bound must exceed the threshold ``T`` to rule a candidate
#: out, relative to ``T`` and to ``max Q`` (:func:`margin`): well above the bound's rounding
#: error (below ``2**-44 max Q``).
SLACK = 2.0**-40


def pinwheel_parts(n: int) -> np.ndarray:
    """The part (0–4) of each offset of the ``n × n`` window: the centre and a pinwheel.

    Part 0 is the centre; 1 the rows above it, from the left edge to the centre column;
    2 the columns right of the centre, from the top to the centre row; 3 the columns left
    of it, from the centre row down; 4 the rows below it, from the centre column right.
    The five parts cover the window once, and for ``n ≥ 3`` each holds ``h (h + 1)``
    offsets (``h = n // 2``).

    Parameters
    ----------
    n : int
        Odd window side.

    Returns
    -------
    ndarray of shape (n, n), int64

    Examples
    --------
    >>> pinwheel_parts(5).tolist()
    [[1, 1, 1, 2, 2], [1, 1, 1, 2, 2], [3, 3, 0, 2, 2], [3, 3, 4, 4, 4], [3, 3, 4, 4, 4]]
    """
    h = n // 2
    row, col = np.mgrid[0:n, 0:n]
    parts = np.zeros((n, n), dtype=np.int64)
    parts[(row < h) & (col <= h)] = 1
    parts[(row <= h) & (col > h)] = 2
    parts[(row >= h) & (col < h)] = 3
    parts[(row > h) & (col >= h)] = 4
    return parts


def part_sums_matrix(n: int, channels: int) -> np.ndarray:
    """The matrix that takes a window's intensity row to its part sums ``S_{P,c}``.

    An intensity row lists the window's levels offset by offset, channels innermost
    (``v C + c``, as :class:`~refsynth.synthesis.filltable.FillTable` stores them); the
    sums are listed part by part, channels innermost (``P C + c``).

    Parameters
    ----------
    n : int
        Odd window side.
    channels : int
        Intensity channels ``C``.

    Returns
    -------
    ndarray of shape (n² C, 5 C), float64
        ``G_v`` at ``(v C + c, P C + c)`` for ``v`` in part ``P``, 0 elsewhere.

    Examples
    --------
    >>> m = part_sums_matrix(3, 1)
    >>> m.shape, m.sum(axis=0).tolist() == [float(g) for g in (
    ...     [window_weights(3).ravel()[pinwheel_parts(3).ravel() == p].sum()
    ...      for p in range(5)])]
    ((9, 5), True)
    """
    g = window_weights(n).ravel().astype(np.float64)
    parts = pinwheel_parts(n).ravel()
    out = np.zeros((n * n * channels, PARTS * channels))
    for c in range(channels):
        out[np.arange(n * n) * channels + c, parts * channels + c] = g
    return out


def part_sums(levels: np.ndarray, n: int, channels: int) -> np.ndarray:
    """The part sums of windows' intensity rows: ``levels @ part_sums_matrix(n, C)``, exactly.

    By ``numpy.matvec`` where numpy has it (2.2 and later), whose loop stays on this thread:
    ``@`` hands a product this size to BLAS's threads, which then keep a second core busy
    for a while (a quarter more CPU time than wall time for NP at 112×94). The sums are of
    integers below ``2**53``: exact in any order, so the same numbers either way.

    Parameters
    ----------
    levels : ndarray of shape (M, n² C), float64
        Integer intensity levels, offset by offset, channels innermost.
    n, channels : int
        Window side and channels.

    Returns
    -------
    ndarray of shape (M, 5 C), float64

    Examples
    --------
    >>> levels = np.arange(18.0).reshape(2, 9)
    >>> bool(np.array_equal(part_sums(levels, 3, 1), levels @ part_sums_matrix(3, 1)))
    True
    """
    matrix = part_sums_matrix(n, channels)
    levels = levels.reshape(-1, n * n * channels)
    if _matvec is None:
        return levels @ matrix
    return _matvec(np.ascontiguousarray(matrix.T), levels)


def bound_weights(n: int, channels: int, divisor: float = 1.0) -> np.ndarray:
    """The weights ``EQ2_UNIT / (G_P d)`` of the squared differences of the part sums.

    With them, :func:`lower_bounds` is in the unit of the shortlist's intensity terms
    (``EQ2_UNIT`` times the integer sum, divided by Eq. 2's channel divisor ``d``). A part
    whose weights are all 0 contributes nothing (its sums are 0 too).

    Parameters
    ----------
    n : int
        Odd window side.
    channels : int
        Intensity channels ``C``.
    divisor : float, optional
        Eq. 2's channel divisor (``C`` for the channels' mean, 1 for their sum).

    Returns
    -------
    ndarray of shape (5 C,), float64

    Examples
    --------
    >>> w = bound_weights(5, 1)
    >>> bool(np.all(w > 0)), w.shape
    (True, (5,))
    """
    g = window_weights(n).ravel().astype(np.float64)
    parts = pinwheel_parts(n).ravel()
    totals = np.repeat(np.bincount(parts, weights=g, minlength=PARTS), channels)
    out = np.zeros(PARTS * channels)
    np.divide(EQ2_UNIT, totals * divisor, out=out, where=totals > 0)
    return out


def lower_bounds(sums_p: np.ndarray, sums_q: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``L_q``: the lower bound on each candidate's intensity term (the module's formula).

    Parameters
    ----------
    sums_p : ndarray of shape (5 C,)
        The target's part sums.
    sums_q : ndarray of shape (M, 5 C)
        The candidates' part sums.
    weights : ndarray of shape (5 C,)
        :func:`bound_weights`.

    Returns
    -------
    ndarray of shape (M,), float64
        At most the candidates' intensity terms, up to a relative ``2**-48``.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> a, b = rng.integers(0, 2**16, (2, 25))
    >>> m, w = part_sums_matrix(5, 1), bound_weights(5, 1)
    >>> t = float((window_weights(5).ravel() * (a - b) ** 2).sum() * EQ2_UNIT)
    >>> bool(lower_bounds(a @ m, (b @ m)[None], w)[0] <= t)
    True
    """
    diff = np.subtract(sums_q, sums_p)
    return np.multiply(diff, diff, out=diff) @ weights


def bound_rows(sums: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Each pixel's row for the expanded bound: its sums and ``Q = Σ_j w_j S_j²``.

    Parameters
    ----------
    sums : ndarray of shape (N, 5 C)
        Part sums (``intensity rows @`` :func:`part_sums_matrix`).
    weights : ndarray of shape (5 C,)
        :func:`bound_weights`.

    Returns
    -------
    ndarray of shape (N, 5 C + 1), float64

    Examples
    --------
    >>> bound_rows(np.array([[2.0, 3.0]]), np.array([1.0, 0.5])).tolist()
    [[2.0, 3.0, 8.5]]
    """
    sums = np.asarray(sums, dtype=np.float64)
    out = np.empty((sums.shape[0], sums.shape[1] + 1))
    np.multiply(np.square(sums), weights, out=out[:, :-1])
    out[:, -1] = out[:, :-1].sum(axis=1)  # on this thread (see part_sums)
    out[:, :-1] = sums
    return out


def margin(rows: np.ndarray) -> float:
    """``SLACK max Q``: the absolute part of the margin (:data:`SLACK`) for these rows.

    Parameters
    ----------
    rows : ndarray of shape (N, 5 C + 1)
        :func:`bound_rows`.

    Returns
    -------
    float

    Examples
    --------
    >>> margin(np.array([[2.0, 3.0, 8.5], [1.0, 1.0, 1.5]])) == 8.5 * SLACK
    True
    """
    return SLACK * float(np.max(rows[:, -1], initial=0.0))


def expanded_lower_bounds(row_p: np.ndarray, rows_q: np.ndarray,
                          weights: np.ndarray) -> np.ndarray:
    """``L_q − Q_p`` by one product, as the shortlist forms it: ``rows_q · [−2 w S(p) | 1]``.

    Parameters
    ----------
    row_p : ndarray of shape (5 C + 1,)
        The target's :func:`bound_rows` row.
    rows_q : ndarray of shape (M, 5 C + 1)
        The candidates' rows.
    weights : ndarray of shape (5 C,)
        :func:`bound_weights`.

    Returns
    -------
    ndarray of shape (M,), float64
        Within ``2**-44 max Q`` of ``lower_bounds(...) − Q_p``.

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> sums = rng.integers(0, 2**34, (3, 5)).astype(float)
    >>> w = bound_weights(5, 1)
    >>> rows = bound_rows(sums, w)
    >>> fast = expanded_lower_bounds(rows[0], rows, w) + rows[0, -1]
    >>> bool(np.all(np.abs(fast - lower_bounds(sums[0], sums, w)) <= margin(rows)))
    True
    """
    return rows_q @ np.append(-2.0 * weights * row_p[:-1], 1.0)
