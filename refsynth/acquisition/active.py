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

The bend of the range between columns
-------------------------------------
Where the range is a plane the line is exact; where the surface bends between
``a`` and ``b`` it leaves the line, to second order, by the classical error of
linear interpolation, ``f''/2 · (x − a)(b − x)``. The measured columns say how
much each row bends: the second divided difference across three consecutive
measured columns ``k₀ < k₁ < k₂``,

.. math::

    f[k_0, k_1, k_2] = \\frac{s_{12} - s_{01}}{k_2 - k_0},
    \\qquad s_{ij} = \\frac{R(k_j) - R(k_i)}{k_j - k_i},

is ``f''/2`` of a quadratic row exactly. A gap's bend ``B`` is the mean of
``|f[·]|`` at its two bounds (one at a gap beside the outermost columns)
(:func:`bending`), and the bend term of a pixel ``p`` of the gap ``(a, b)`` is

.. math::

    b(p) = B(p)\\, (x_p - a)(b - x_p),

which falls as a measurement splits the gap (quadratically, where the
uncertainty falls linearly). The scale of ``ε`` in a gap between two measured
columns is the geometric mean ``√(U_s(p) · b(p))`` of the two witnesses,
``U_s`` the uncertainty scaled by the distance as above: large only where the
synthesis is unsure *and* the range bends at the scale of the columns. The
uncertainty map alone is large over whole textured regions, the bend alone at
every depth edge the synthesis already places. Beyond the outermost measured
column, ``b(p) = B(p) d²``, ``d`` the distance to that column (the bend of the
nearest divided difference; the slope a constant misses is not modelled: the
evenly spread first pass of the rig and of the benchmark measures the first and
the last column, which leaves no such gap). With fewer than three measured
columns there is no bend to read, and the scale is ``U_s`` alone.

Only the pixels a measurement can reach count in the sums. A rangefinder
returns nothing from some directions (glass, black surfaces, beyond its range),
and a measured column says which: a pixel counts when its row returned a range
in both measured columns bounding its gap, and not when it returned in neither
(:func:`returning_pixels`). A row that returned nothing on either side is
likely to return nothing from the columns between, and the error of a pixel
no measurement reaches is not removed by measuring. Where the row returned on
one side only, the intensity decides which surface the pixel lies on: it
counts when its grey level is at least as close to that of the bound that
returned as to that of the bound that did not (a dark pole that returns
nothing beside a wall that does).

The picks are greedy: after choosing the best column it is taken as measured
and the gains of the two gaps it leaves are computed again; a pick therefore
lowers the gains of the columns near it (their lines are already shorter), so
the picks spread over the sites with depth profiles rather than bunch.

Every sum is exactly rounded (``math.fsum``), the exponential is
:func:`refsynth.numeric.portable_exp` and the square root is correctly rounded
(IEEE 754): the same picks on every machine.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §5 (active sensing, left as future work)
and §4 (the rig's vertical slices), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math

import numpy as np

from refsynth._checks import check_choice, check_int, check_real_array, grey, to_float
from refsynth.numeric import portable_exp
from refsynth.synthesis import synthesize, validate_inputs

__all__ = ["next_slices", "measured_columns", "returning_pixels", "line_error", "bending",
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


def returning_pixels(partial_range: np.ndarray,
                     intensity: np.ndarray | None = None) -> np.ndarray:
    """The pixels a measurement can reach (the module's notes).

    Each unmeasured pixel whose row returned a range in both measured columns bounding
    its gap (the nearest on its left and on its right; at the borders, the one there is)
    counts, and none whose row returned in neither. Where the row returned on one side
    only, a pixel counts when its grey level (the mean of the channels) is at least as
    close to that of the bound that returned as to that of the bound that did not; without
    ``intensity``, every such pixel counts.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W)
        NaN where unknown; at least one column measured.
    intensity : ndarray of shape (H, W) or (H, W, C), optional
        The registered intensity (as for :func:`refsynth.synthesize`).

    Returns
    -------
    ndarray of shape (H, W), bool
        False on measured columns.

    Raises
    ------
    TypeError, ValueError
        Naming the argument: ``partial_range`` not 2-D, or no pixel measured;
        ``intensity`` not a real numpy array (TypeError), or not (H, W) or (H, W, C) of
        ``partial_range``'s height and width, or not finite.

    Examples
    --------
    Columns 0 and 4 are measured; row 1 returned nothing in either of them, row 0
    only in column 0, where the intensity is bright; column 4 is dark.

    >>> import numpy as np
    >>> partial = np.full((3, 5), np.nan)
    >>> partial[[0, 2], 0] = 1.0; partial[2, 4] = 2.0
    >>> returning_pixels(partial).astype(int).tolist()
    [[0, 1, 1, 1, 0], [0, 0, 0, 0, 0], [0, 1, 1, 1, 0]]
    >>> intensity = np.array([[0.9, 0.8, 0.5, 0.2, 0.1]] * 3)
    >>> returning_pixels(partial, intensity).astype(int).tolist()
    [[0, 1, 1, 0, 0], [0, 0, 0, 0, 0], [0, 1, 1, 1, 0]]
    """
    values = np.asarray(partial_range, dtype=np.float64)
    if values.ndim != 2 or not np.isfinite(values).any():
        raise ValueError("The parameter `partial_range` must be an (H, W) array with at least "
                         f"one measured (finite) pixel, got shape {values.shape}")
    measured = measured_columns(values)
    left, right = _nearest_measured(measured)
    returned = np.isfinite(values)
    on_left, on_right = returned[:, left], returned[:, right]
    counts = on_left | on_right
    if intensity is not None:
        level = _grey_level(intensity, values.shape)
        to_left = np.abs(level - level[:, left])
        to_right = np.abs(level - level[:, right])
        nearer_returning = np.where(on_left, to_left <= to_right, to_right <= to_left)
        counts = (on_left & on_right) | ((on_left ^ on_right) & nearer_returning)
    return counts & ~measured[None, :]


def _grey_level(intensity, shape: tuple[int, int]) -> np.ndarray:
    """The mean of the intensity's channels, read as :func:`refsynth.synthesize` reads it
    (integers scaled by their dtype's maximum), summed left to right (the numeric contract).
    Raises, naming ``intensity``, ``TypeError`` unless a real array and ``ValueError``
    unless finite and (H, W) or (H, W, C) of ``shape``."""
    image = to_float(check_real_array("intensity", intensity, (2, 3)))
    if image.shape[:2] != shape or not np.all(np.isfinite(image)):
        raise ValueError("The parameter `intensity` must be a finite (H, W) or (H, W, C) "
                         f"array with (H, W) = {shape}, got shape {image.shape}")
    return grey(image, weights=None)


def bending(estimate: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Each unmeasured pixel's bend ``B``: how far its row bends between the measured columns.

    The mean of ``|f[k₀, k₁, k₂]|``, the second divided difference of the row across three
    consecutive measured columns (the module's notes), at the two measured columns bounding
    the pixel's gap (at one of them for a gap beside the outermost measured columns; beyond
    the outermost columns, the one nearest). A quadratic row ``α x² + β x + γ`` has
    ``B = |α|`` everywhere.

    Parameters
    ----------
    estimate : ndarray of shape (H, W)
        The range ``R``; only its measured columns are read.
    measured : ndarray of shape (W,), bool
        The measured columns.

    Returns
    -------
    ndarray of shape (H, W), float64
        ``B`` on every unmeasured column; NaN (no estimate) on measured columns, and
        everywhere with fewer than three measured columns.

    Raises
    ------
    ValueError
        Naming the argument: ``estimate`` not a 2-D array, ``measured`` not a bool array
        of shape (W,).

    Examples
    --------
    A row that is flat, then climbs by 1 a column from column 4: ``|f| = 1/8`` at the kink,
    0 at column 8. The gap (0, 4) is bounded by the kink alone (one divided difference), the
    gap (4, 8) takes the mean of both, the gap (8, 12) the 0 at column 8.

    >>> import numpy as np
    >>> row = np.maximum(np.arange(13.0) - 4.0, 0.0)[None, :]
    >>> bending(row, np.isin(np.arange(13), [0, 4, 8, 12]))[0, 1:12:2].tolist()
    [0.125, 0.125, 0.0625, 0.0625, 0.0, 0.0]
    """
    estimate = np.asarray(estimate, dtype=np.float64)
    measured = np.asarray(measured)
    if estimate.ndim != 2:
        raise ValueError("The parameter `estimate` must be an (H, W) array, got shape "
                         f"{estimate.shape}")
    if measured.dtype != bool or measured.shape != estimate.shape[1:]:
        raise ValueError(f"The parameter `measured` must be a ({estimate.shape[1]},) bool "
                         f"array, got {measured.dtype} of shape {measured.shape}")
    known = np.flatnonzero(measured)
    bend = np.full(estimate.shape, np.nan)
    if known.size < 3:
        return bend
    slopes = np.diff(estimate[:, known], axis=1) / np.diff(known)
    second = np.abs(np.diff(slopes, axis=1)) / (known[2:] - known[:-2])  # at known[1:-1]
    for j, (left, right) in enumerate(zip(known[:-1], known[1:])):
        ends = second[:, max(j - 1, 0):min(j + 1, second.shape[1])]
        bend[:, left + 1:right] = ends.mean(axis=1, keepdims=True)
    bend[:, :known[0]] = second[:, :1]      # beyond the outermost columns: the nearest
    bend[:, known[-1] + 1:] = second[:, -1:]
    return bend


class _Gaps:
    """The expected error of the lines across the gaps between measured columns.

    ``left = -1`` / ``right = W`` stand for "no measured column on that side": beyond the
    outermost measured column the line is that column's value. Only the pixels where
    ``counts`` is True enter the sums. The uncertainty, the distances and the bend are those
    of the measured columns the call started from.
    """

    def __init__(self, estimate: np.ndarray, uncertainty: np.ndarray, measured: np.ndarray,
                 counts: np.ndarray, bend: np.ndarray):
        self.counts = counts
        self.estimate = estimate
        self.uncertainty = uncertainty
        self.distance = _distances(measured)  # when the uncertainty was estimated
        self.bend = bend
        self.width = measured.size

    def error(self, left: int, right: int) -> float:
        """``Σ e(p)`` over the columns strictly between ``left`` and ``right``."""
        columns = np.arange(left + 1, right)
        if columns.size == 0:
            return 0.0
        if left < 0:  # a constant beyond the outermost column: the bend term B d²
            line, near = self.estimate[:, [right]], right - columns
            span = near * near
        elif right >= self.width:
            line, near = self.estimate[:, [left]], columns - left
            span = near * near
        else:  # the line between two columns: B (x − a)(b − x)
            t = (columns - left) / (right - left)
            line = self.estimate[:, [left]] * (1.0 - t) + self.estimate[:, [right]] * t
            near = np.minimum(columns - left, right - columns)
            span = (columns - left) * (right - columns)
        bend = self.bend[:, columns] * span
        scale = self.uncertainty[:, columns] * (near / self.distance[columns])
        scale = np.where(np.isnan(bend), scale, np.sqrt(scale * bend))
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
                  counts: np.ndarray | None = None, bend: np.ndarray | None = None
                  ) -> np.ndarray:
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
    bend : ndarray of shape (H, W), optional
        ``B`` (≥ 0, or NaN: no estimate); default :func:`bending` of ``estimate`` and
        ``measured``.

    Returns
    -------
    ndarray of shape (W,), float64
        ``g(c)``; ``-inf`` on measured columns (they are never picked).

    Raises
    ------
    ValueError
        Naming the argument: ``estimate`` not a finite 2-D array, ``uncertainty`` of
        another shape or negative, ``measured`` not of shape (W,) or all False, ``counts``
        or ``bend`` not of the shape of ``estimate`` (or negative).

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
    bend = (bending(estimate, measured) if bend is None
            else np.asarray(bend, dtype=np.float64))
    if bend.shape != estimate.shape or np.any(bend < 0):
        raise ValueError("The parameter `bend` must be an array of the shape of `estimate` "
                         f"{estimate.shape} with values >= 0 or NaN, got shape {bend.shape}")
    gaps = _Gaps(estimate, uncertainty, measured, counts, bend)
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
    uncertainty map how sure it is, the measured columns how much the range bends
    between them, and the rows that returned a range in the measured columns (with
    the intensity where one side did not) which pixels a measurement can reach.
    Each pick is taken as measured before the next, so that the picks spread over
    the sites with depth profiles rather than bunch.

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
       (``result.uncertainty``, 0 where measured); the bend ``B`` of each gap
       from the measured columns (:func:`bending`).
    2. For every unmeasured column ``c`` of the gap ``(a, b)`` compute the error
       its measurement removes, ``g(c)`` (the module's notes): the expected error
       of the line ``L_ab`` against ``R``, with ``ε``'s scale ``√(U · b)``
       (``U`` alone with fewer than three measured columns), less that of the
       lines ``L_ac`` and ``L_cb``, summed over the pixels a measurement can
       reach (:func:`returning_pixels` with the intensity: those whose row
       returned a range in both measured columns bounding their gap, or in one
       of them where the pixel's grey level is at least as near that column's
       as the other's).
    3. Pick ``argmax g`` (ties: the leftmost); take it as measured (the gap
       splits in two, the uncertainty of its columns scales by their new
       distance to a measured column over the old, their bend term by the new
       gap's ``(x − a)(b − x)``) and compute ``g`` again on
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
    return _greedy(result.range, result.uncertainty, measured, n,
                   returning_pixels(values, intensity))


def _greedy(estimate: np.ndarray, uncertainty: np.ndarray, measured: np.ndarray,
            n: int, counts: np.ndarray, bend: np.ndarray | None = None) -> np.ndarray:
    """Step 3 of :func:`next_slices`: ``n`` picks, each taken as measured before the next.

    A pick splits its gap; the uncertainty of the gap's columns scales by their new
    distance to a measured column over the one they had when ``uncertainty`` was
    estimated, and its bend term falls with the new gap's span (the bend ``B`` is fixed
    for the call), so only the two new gaps' gains change. ``counts``: the pixels that
    enter the sums, fixed for the call; ``bend``: default :func:`bending` of ``estimate``
    and ``measured`` (all NaN: no bend term).
    """
    estimate = np.asarray(estimate, dtype=np.float64)
    measured = np.asarray(measured, dtype=bool)
    bend = bending(estimate, measured) if bend is None else np.asarray(bend, np.float64)
    gaps = _Gaps(estimate, np.asarray(uncertainty, dtype=np.float64), measured,
                 np.asarray(counts, dtype=bool), bend)
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
