"""Active sensing: which columns to measure next, where the synthesis is least sure (§5).

The paper closes (§5) on what it left undone: "it may be desirable to apply an
active sensing technique so that a more dense sampling is done in sites having
more objects with different depth profiles and a sparse sampling in sites with
none (e.g. walls)". :func:`next_slices` does this for a rig that measures whole
columns (the vertical slices of §4): it synthesizes the range once from what is
measured, estimates each pixel's expected error, and ranks the unmeasured
columns by how much of that error measuring them is expected to remove.

The model of what a measurement removes
---------------------------------------
A synthesized pixel's error grows with its distance to the nearest measured
column (the measured columns bound every gap; between them the range is
guessed). Measuring column ``c`` sets the error of column ``c`` to 0 and
brings every column ``c'`` of the same gap closer to a measured one: its
distance ``d(c')`` to the nearest measured column becomes
``min(d(c'), |c − c'|)``. With each column's error taken proportional to that
distance, the error measuring ``c`` removes is

.. math::

    g(c) = \\sum_{c'} U(c') \\, \\max\\Bigl(0,\\; 1 - \\frac{|c - c'|}{d(c')}\\Bigr),

where ``U(c')`` is the summed expected error of column ``c'`` (the term for
``c' = c`` is ``U(c)``; columns beyond the gap's bounding measured columns
have ``d(c') ≤ |c − c'|`` and contribute nothing). The picks are greedy: after
choosing the best column it is taken as measured — its own error drops to 0,
its neighbours' errors shrink by ``d_new / d_old`` and their distances
update — and the gains are computed again. A pick therefore damps the columns
near it by exactly the gap it splits, so the picks spread rather than bunch.

The expected error of each pixel is the synthesis's own uncertainty map
(:attr:`refsynth.SynthesisResult.uncertainty`: the expected absolute error in the
range's unit, 0 on measured pixels, :mod:`refsynth.synthesis.uncertainty`).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §5 (active sensing, left as future work)
and §4 (the rig's vertical slices), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth._checks import check_choice, check_int
from refsynth.synthesis import SynthesisResult, synthesize, validate_inputs

__all__ = ["next_slices", "measured_columns", "expected_gain"]


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


def _distances(measured: np.ndarray) -> np.ndarray:
    """Each column's distance (in columns) to the nearest measured one (0 on measured ones)."""
    columns = np.arange(measured.size)
    known = np.flatnonzero(measured)
    where = np.searchsorted(known, columns)
    left = known[np.clip(where - 1, 0, known.size - 1)]
    right = known[np.clip(where, 0, known.size - 1)]
    return np.minimum(np.abs(columns - left), np.abs(columns - right)).astype(np.float64)


def expected_gain(column_error: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """The expected error that measuring each column removes (the module's ``g(c)``).

    Parameters
    ----------
    column_error : ndarray of shape (W,)
        ``U(c)``: each column's summed expected error (≥ 0; 0 on measured columns).
    measured : ndarray of shape (W,), bool
        The measured columns (at least one).

    Returns
    -------
    ndarray of shape (W,), float64
        ``g(c)``; ``-inf`` on measured columns (they are never picked).

    Examples
    --------
    >>> import numpy as np
    >>> measured = np.array([True, False, False, False, True])
    >>> expected_gain(np.array([0.0, 1.0, 1.0, 1.0, 0.0]), measured).tolist()
    [-inf, 1.5, 1.0, 1.5, -inf]
    """
    error = np.asarray(column_error, dtype=np.float64)
    distance = _distances(measured)
    columns = np.arange(error.size, dtype=np.float64)
    apart = np.abs(columns[:, None] - columns[None, :])  # |c − c'|, rows c, columns c'
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(distance[None, :] > 0,
                         np.clip(1.0 - apart / distance[None, :], 0.0, None), 0.0)
    gain = share @ error
    gain[measured] = -np.inf
    return gain


def _expected_error(result: SynthesisResult) -> np.ndarray:
    """Each pixel's expected absolute error of ``result.range``, 0 on measured pixels.

    The synthesis's own uncertainty map, in the range's unit
    (:func:`refsynth.synthesis.uncertainty.uncertainty_map`).
    """
    return result.uncertainty


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
    measured; its uncertainty map (each pixel's expected absolute error) is
    summed per column, and the columns are picked greedily by the expected error their
    measurement removes from their own column and from the columns of their
    gap (see the module's notes), each pick taken as measured before the next,
    so that the picks spread over the uncertain parts rather than bunch.

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
        The synthesis whose uncertainty decides (§3.2.2 or §3.2.3).
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
    1. Synthesize the dense range ``R`` (NP or BP).
    2. Take each pixel's expected absolute error ``e`` (``result.uncertainty``, 0
       where measured) and sum it per column: ``U(c) = Σ_rows e``.
    3. For every unmeasured column ``c`` compute the error its measurement
       removes, ``g(c) = Σ_c' U(c') max(0, 1 − |c − c'| / d(c'))``, ``d(c')`` the
       distance of ``c'`` to the nearest measured column.
    4. Pick ``argmax g`` (ties: the leftmost); take it as measured (``U`` of the
       pick becomes 0, ``U(c')`` of its gap scales by the new distance over the
       old one); repeat until ``n`` columns are picked.

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
    column_error = _expected_error(result).sum(axis=0)
    return _greedy(column_error, measured, n)


def _greedy(column_error: np.ndarray, measured: np.ndarray, n: int) -> np.ndarray:
    """Step 4 of :func:`next_slices`: ``n`` picks, each taken as measured before the next."""
    error = np.asarray(column_error, dtype=np.float64).copy()
    measured = measured.copy()
    picks = np.empty(n, dtype=np.int64)
    for k in range(n):
        gain = expected_gain(error, measured)
        best = int(np.argmax(gain))  # the first maximum: the leftmost of ties
        before = _distances(measured)
        measured[best] = True
        after = _distances(measured)
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.where(before > 0, error * after / before, 0.0)
        picks[k] = best
    return picks
