"""Active sensing: which columns to measure next, where the synthesis is least sure (§5).

The paper closes (§5) on what it left undone: "it may be desirable to apply an
active sensing technique so that a more dense sampling is done in sites having
more objects with different depth profiles and a sparse sampling in sites with
none (e.g. walls)". :func:`next_slices` does this for a rig that measures whole
columns (the vertical slices of §4): it synthesizes the range once from what is
measured and ranks the unmeasured columns by how much error measuring them is
expected to remove.

The model of what a measurement removes
---------------------------------------
Between two measured columns ``a < b`` a row's range is known at both ends; the
plainest guess between them is the straight line ``L_ab`` joining the two
(beyond the outermost measured column, that column's value). A site with no
depth profile of its own — a wall, a floor — lies on that line; an object
before it does not. The synthesis ``R`` says where the truth leaves the line,
and its uncertainty map ``U`` (:attr:`refsynth.SynthesisResult.uncertainty`,
each pixel's expected absolute error, 0 where measured) says how far ``R``
may itself be off. Taking the truth at pixel ``p`` to be ``R(p) + ε`` with
``ε`` Laplace-distributed of mean absolute value ``U(p)``, the expected
error of the line there is

.. math::

    e(p) = E\\,|L(p) - R(p) - ε| = |δ| + U(p)\\, e^{-|δ| / U(p)},
    \\qquad δ = L(p) - R(p),

(``|δ|`` where ``U(p) = 0``): ``|δ|`` where the synthesis is sure, ``U(p)``
where the line and the synthesis agree. Measuring column ``c`` of the gap
``(a, b)`` replaces the line ``L_ab`` by ``L_ac`` and ``L_cb`` (the truth at
``c`` taken as ``R``'s), sets the error of column ``c`` to 0, and brings every
column ``c'`` of the gap closer to a measured one: its uncertainty scales by
``d_new(c') / d(c')``, ``d`` the distance to the nearest measured column. The
error measuring ``c`` removes is

.. math::

    g(c) = \\sum_{p \\in (a, b)} e_{ab}(p) - \\sum_{p \\in (a, c)} e_{ac}(p)
           - \\sum_{p \\in (c, b)} e_{cb}(p).

Columns outside the gap keep their error.

Only the pixels a measurement can reach count in the sums. A rangefinder
returns nothing from some directions (glass, black surfaces, beyond its range),
and a measured column says which: a pixel counts when its row returned a range
in the nearest measured column on its left or on its right
(:func:`returning_pixels`). A row that returned nothing on either side is
likely to return nothing from the columns between, and the error of a pixel
no measurement reaches is not removed by measuring.

The picks are greedy: after choosing the best column it is taken as measured
and the gains of the two gaps it leaves are computed again; a pick therefore
lowers the gains of the columns near it (their lines are already shorter), so
the picks spread over the sites with depth profiles rather than bunch.

Every sum is exactly rounded (``math.fsum``) and the exponential is
:func:`refsynth.numeric.portable_exp`: the same picks on every machine.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §5 (active sensing, left as future work)
and §4 (the rig's vertical slices), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math

import numpy as np

from refsynth._checks import check_choice, check_int
from refsynth.numeric import portable_exp
from refsynth.synthesis import synthesize, validate_inputs

__all__ = ["next_slices", "measured_columns", "returning_pixels", "line_error",
           "expected_gain"]


def measured_columns(partial_range: np.ndarray) -> np.ndarray:
    """Which columns hold at least one measured (finite) pixel.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W)
        NaN where unknown.

    Returns
    -------
    ndarray of shape (W,), bool

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.full((2, 4), np.nan); partial[0, 1] = 1.0
    >>> measured_columns(partial).tolist()
    [False, True, False, False]
    """
    return np.isfinite(np.asarray(partial_range, dtype=np.float64)).any(axis=0)


def line_error(deviation: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The expected absolute error of a line that is ``δ`` off the synthesis: ``E|δ − ε|``.

    ``ε`` Laplace-distributed with mean absolute value ``scale`` (the module's ``e(p)``):
    ``|δ| + scale · exp(−|δ| / scale)``, and ``|δ|`` where ``scale`` is 0.

    Parameters
    ----------
    deviation, scale : ndarray of the same shape
        ``δ`` (any sign) and ``U`` (≥ 0).

    Returns
    -------
    ndarray, float64

    Examples
    --------
    >>> import numpy as np
    >>> line_error(np.array([0.0, 2.0, 3.0]), np.array([1.0, 0.0, 1.0])).round(4).tolist()
    [1.0, 2.0, 3.0498]
    """
    size = np.abs(np.asarray(deviation, dtype=np.float64))
    scale = np.asarray(scale, dtype=np.float64)
    sure = scale <= 0
    safe = np.where(sure, 1.0, scale)
    return size + np.where(sure, 0.0, safe * portable_exp(-size / safe))


def _nearest_measured(measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each column's nearest measured column on its left and on its right (itself if
    measured; beyond the outermost measured column, that column on both sides)."""
    known = np.flatnonzero(measured)
    where = np.searchsorted(known, np.arange(measured.size))
    return (known[np.clip(where - 1, 0, known.size - 1)],
            known[np.clip(where, 0, known.size - 1)])


def _distances(measured: np.ndarray) -> np.ndarray:
    """Each column's distance (in columns) to the nearest measured one (0 on measured ones)."""
    columns = np.arange(measured.size)
    left, right = _nearest_measured(measured)
    return np.minimum(np.abs(columns - left), np.abs(columns - right)).astype(np.float64)


def returning_pixels(partial_range: np.ndarray) -> np.ndarray:
    """The pixels a measurement can reach: each unmeasured pixel whose row returned a range
    in the nearest measured column on its left or on its right (the module's notes).

    Parameters
    ----------
    partial_range : ndarray of shape (H, W)
        NaN where unknown; at least one column measured.

    Returns
    -------
    ndarray of shape (H, W), bool
        False on measured columns.

    Raises
    ------
    ValueError
        Naming ``partial_range``: not 2-D, or no pixel measured.

    Examples
    --------
    Columns 0 and 4 are measured; row 1 returned nothing in either of them, row 0
    only in column 0.

    >>> import numpy as np
    >>> partial = np.full((3, 5), np.nan)
    >>> partial[[0, 2], 0] = 1.0; partial[2, 4] = 2.0
    >>> returning_pixels(partial).astype(int).tolist()
    [[0, 1, 1, 1, 0], [0, 0, 0, 0, 0], [0, 1, 1, 1, 0]]
    """
    values = np.asarray(partial_range, dtype=np.float64)
    if values.ndim != 2 or not np.isfinite(values).any():
        raise ValueError("The parameter `partial_range` must be an (H, W) array with at least "
                         f"one measured (finite) pixel, got shape {values.shape}")
    measured = measured_columns(values)
    left, right = _nearest_measured(measured)
    returned = np.isfinite(values)
    return (returned[:, left] | returned[:, right]) & ~measured[None, :]


class _Gaps:
    """The expected error of the lines across the gaps between measured columns.

    ``left = -1`` / ``right = W`` stand for "no measured column on that side": beyond the
    outermost measured column the line is that column's value. Only the pixels where
    ``counts`` is True enter the sums.
    """

    def __init__(self, estimate: np.ndarray, uncertainty: np.ndarray, measured: np.ndarray,
                 counts: np.ndarray):
        self.counts = counts
        self.estimate = estimate
        self.uncertainty = uncertainty
        self.distance = _distances(measured)  # when the uncertainty was estimated
        self.width = measured.size

    def error(self, left: int, right: int) -> float:
        """``Σ e(p)`` over the columns strictly between ``left`` and ``right``."""
        columns = np.arange(left + 1, right)
        if columns.size == 0:
            return 0.0
        if left < 0:
            line, near = self.estimate[:, [right]], right - columns
        elif right >= self.width:
            line, near = self.estimate[:, [left]], columns - left
        else:
            t = (columns - left) / (right - left)
            line = self.estimate[:, [left]] * (1.0 - t) + self.estimate[:, [right]] * t
            near = np.minimum(columns - left, right - columns)
        scale = self.uncertainty[:, columns] * (near / self.distance[columns])
        error = line_error(line - self.estimate[:, columns], scale)
        return math.fsum(error[self.counts[:, columns]].tolist())

    def gains(self, left: int, right: int) -> np.ndarray:
        """``g(c)`` for every column ``c`` strictly between ``left`` and ``right``."""
        before = self.error(left, right)
        return np.array([before - self.error(left, c) - self.error(c, right)
                         for c in range(left + 1, right)], dtype=np.float64)


def _gaps_of(measured: np.ndarray) -> list[tuple[int, int]]:
    """``(left, right)`` of every run of unmeasured columns (``-1`` / ``W`` at the borders)."""
    bounds = [-1, *np.flatnonzero(measured).tolist(), measured.size]
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b - a > 1]


def expected_gain(estimate: np.ndarray, uncertainty: np.ndarray, measured: np.ndarray,
                  counts: np.ndarray | None = None) -> np.ndarray:
    """The expected error that measuring each column removes (the module's ``g(c)``).

    Parameters
    ----------
    estimate : ndarray of shape (H, W)
        The synthesized range ``R`` (finite everywhere).
    uncertainty : ndarray of shape (H, W)
        ``U``: each pixel's expected absolute error of ``R`` (≥ 0; 0 where measured).
    measured : ndarray of shape (W,), bool
        The measured columns (at least one).
    counts : ndarray of shape (H, W), bool, optional
        The pixels that enter the sums (:func:`returning_pixels` in
        :func:`next_slices`); default every pixel.

    Returns
    -------
    ndarray of shape (W,), float64
        ``g(c)``; ``-inf`` on measured columns (they are never picked).

    Raises
    ------
    ValueError
        Naming the argument: ``estimate`` not a finite 2-D array, ``uncertainty`` of
        another shape or negative, ``measured`` not of shape (W,) or all False, ``counts``
        not of the shape of ``estimate``.

    Examples
    --------
    A ramp that bends between two measured columns: measuring the corner
    removes the most (with a sure synthesis, all of the line's error).

    >>> import numpy as np
    >>> estimate = np.array([[0.0, 1.0, 2.0, 3.0, 3.0, 3.0, 3.0]])
    >>> measured = np.array([True, False, False, False, False, False, True])
    >>> expected_gain(estimate, np.zeros((1, 7)), measured).round(6).tolist()
    [-inf, 1.5, 3.0, 4.5, 3.0, 1.5, -inf]
    """
    estimate = np.asarray(estimate, dtype=np.float64)
    uncertainty = np.asarray(uncertainty, dtype=np.float64)
    measured = np.asarray(measured, dtype=bool)
    if estimate.ndim != 2 or not np.all(np.isfinite(estimate)):
        raise ValueError("The parameter `estimate` must be a finite (H, W) array, got shape "
                         f"{estimate.shape}")
    if uncertainty.shape != estimate.shape or not np.all(uncertainty >= 0):
        raise ValueError("The parameter `uncertainty` must be an array of the shape of "
                         f"`estimate` {estimate.shape} with values >= 0, got shape "
                         f"{uncertainty.shape}")
    if measured.shape != estimate.shape[1:] or not measured.any():
        raise ValueError(f"The parameter `measured` must be a ({estimate.shape[1]},) bool "
                         f"array with at least one True, got shape {measured.shape}")
    counts = (np.ones(estimate.shape, dtype=bool) if counts is None
              else np.asarray(counts, dtype=bool))
    if counts.shape != estimate.shape:
        raise ValueError("The parameter `counts` must be a bool array of the shape of "
                         f"`estimate` {estimate.shape}, got shape {counts.shape}")
    gaps = _Gaps(estimate, uncertainty, measured, counts)
    gain = np.full(gaps.width, -np.inf)
    for left, right in _gaps_of(measured):
        gain[left + 1:right] = gaps.gains(left, right)
    return gain


def next_slices(
    intensity: np.ndarray,
    partial_range: np.ndarray,
    n: int,
    *,
    method: str = "bp",
    seed: int = 0,
    **synth_options,
) -> np.ndarray:
    """The ``n`` unmeasured columns whose measurement is expected to lower the error most (§5).

    One call of :func:`refsynth.synthesize` fills the range from what is
    measured. The columns are then picked greedily by the error their
    measurement is expected to remove from the line across their gap (see the
    module's notes): the synthesis says where the range leaves that line, its
    uncertainty map how sure it is, and the rows that returned a range in the
    measured columns which pixels a measurement can reach. Each pick is taken as measured before the
    next, so that the picks spread over the sites with depth profiles rather
    than bunch.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The registered intensity (as for :func:`refsynth.synthesize`).
    partial_range : ndarray of shape (H, W), floating
        The measured range, NaN where unknown. A column with any finite pixel
        counts as measured.
    n : int
        How many columns to return: at least 1, at most the number of
        unmeasured columns.
    method : {"np", "bp"}, default "bp"
        The synthesis that decides (§3.2.2 or §3.2.3).
    seed : int, default 0
        Passed to :func:`refsynth.synthesize`: the same call gives the same columns.
    **synth_options
        Any other keyword of :func:`refsynth.synthesize` (``neighbourhood``,
        ``radius``, ``readings``, ...).

    Returns
    -------
    ndarray of shape (n,), int64
        Unmeasured column indices, best first, without repeats.

    Raises
    ------
    TypeError, ValueError
        Naming the argument, before any work: ``n`` not an integer in
        ``[1, number of unmeasured columns]``, ``method`` not ``"np"`` or
        ``"bp"``, the shapes or values :func:`refsynth.synthesize` refuses.

    Notes
    -----
    1. Synthesize the dense range ``R`` (NP or BP) and its uncertainty ``U``
       (``result.uncertainty``, 0 where measured).
    2. For every unmeasured column ``c`` of the gap ``(a, b)`` compute the error
       its measurement removes, ``g(c)`` (the module's notes): the expected error
       of the line ``L_ab`` against ``R``, ``U`` over the gap, less that of the
       lines ``L_ac`` and ``L_cb``, summed over the pixels a measurement can
       reach (:func:`returning_pixels`: those whose row returned a range in a
       measured column bounding their gap).
    3. Pick ``argmax g`` (ties: the leftmost); take it as measured (the gap
       splits in two, the uncertainty of its columns scales by their new
       distance to a measured column over the old) and compute ``g`` again on
       the two new gaps; repeat until ``n`` columns are picked.

    The gains of a gap of ``L`` unmeasured columns cost ``O(H · L²)``: from a
    first pass of evenly spread columns (gaps of a few columns) the greedy pass
    is a small part of the call, but from a handful of measured columns on a
    wide image it can take longer than the synthesis.

    References
    ----------
    Torres-Méndez & Dudek (2008), §5 (active sensing), doi:10.1007/s11263-007-0108-2.

    Examples
    --------
    >>> import numpy as np
    >>> from refsynth.acquisition import next_slices
    >>> intensity = np.zeros((12, 24)); intensity[3:9, 15:20] = 1.0   # an object, right
    >>> truth = np.full((12, 24), 3.0); truth[3:9, 15:20] = 1.5        # before a flat wall
    >>> partial = np.full((12, 24), np.nan); partial[:, ::6] = truth[:, ::6]
    >>> picks = next_slices(intensity, partial, 2, method="np")
    >>> picks.dtype, bool(np.all(picks > 12)), bool(np.all(np.isnan(partial[:, picks])))
    (dtype('int64'), True, True)
    """
    check_choice("method", method, ("np", "bp"))
    _, values = validate_inputs(intensity, partial_range)
    measured = measured_columns(values)
    unmeasured = int(np.count_nonzero(~measured))
    if unmeasured == 0:
        raise ValueError("The parameter `partial_range` must leave at least one column "
                         "unmeasured (all NaN), got every column measured")
    n = check_int("n", n, minimum=1, maximum=unmeasured)
    result = synthesize(intensity, partial_range, method=method, seed=seed, **synth_options)
    return _greedy(result.range, result.uncertainty, measured, n, returning_pixels(values))


def _greedy(estimate: np.ndarray, uncertainty: np.ndarray, measured: np.ndarray,
            n: int, counts: np.ndarray) -> np.ndarray:
    """Step 3 of :func:`next_slices`: ``n`` picks, each taken as measured before the next.

    A pick splits its gap; the uncertainty of the gap's columns scales by their new
    distance to a measured column over the one they had when ``uncertainty`` was
    estimated, so only the two new gaps' gains change. ``counts``: the pixels that enter
    the sums, fixed for the call.
    """
    gaps = _Gaps(np.asarray(estimate, dtype=np.float64),
                 np.asarray(uncertainty, dtype=np.float64), np.asarray(measured, dtype=bool),
                 np.asarray(counts, dtype=bool))
    gain = np.full(gaps.width, -np.inf)
    owner = np.full(gaps.width, -1, dtype=np.int64)  # each unmeasured column's gap's left bound
    bounds: dict[int, int] = {}
    for left, right in _gaps_of(measured):
        gain[left + 1:right] = gaps.gains(left, right)
        owner[left + 1:right], bounds[left] = left, right
    picks = np.empty(n, dtype=np.int64)
    for k in range(n):
        best = int(np.argmax(gain))  # the first maximum: the leftmost of ties
        left = int(owner[best])
        right = bounds.pop(left)
        gain[best], owner[best] = -np.inf, -1
        for a, b in ((left, best), (best, right)):
            if b - a > 1:
                gain[a + 1:b] = gaps.gains(a, b)
                owner[a + 1:b], bounds[a] = a, b
        picks[k] = best
    return picks
