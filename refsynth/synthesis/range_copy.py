r"""What NP copies from the neighbourhood it drew (§3.2.2, Eq. 5): the value, or the value shifted.

Eq. 5 draws a neighbourhood ``N_q`` from ``Γ'`` and gives ``p`` the centre range of ``N_q``
(``range_copy="value"``, the paper's reading, Efros & Leung's). A copied value is a value
measured elsewhere: on a slanted surface — a floor, a wall seen at an angle, the body of the
Motorcycle — the value at ``q`` is not the value at ``p``, however well the two neighbourhoods
match, and a gap fills with a staircase of copies.

**A departure** (``range_copy="offset"``): when the range that ``N_p`` and ``N_q`` share
differs by about the same amount ``Δ`` at every offset — the same surface, shifted in depth —
``p`` gets ``R_q + Δ``. On the integer grids of the numeric contract (:mod:`refsynth.numeric`:
the range ``q_r`` on ``2**-16`` of the measured span, Eq. 2's window ``G`` as integers), with
``S`` the offsets ``v`` at which both windows have range (measured or synthesized; none off the
image) and ``δ_v = q_r(p + v) − q_r(q + v)``,

.. math::

    A = \sum_{v \in S} G_v, \qquad B = \sum_{v \in S} G_v\, \delta_v, \qquad
    \Delta = \operatorname{round}(B / A),

the exact quotient rounded half to even, and the shift is taken only when every difference is
within :data:`OFFSET_TOLERANCE` of the mean, ``|A δ_v − B| ≤ 2^{16 − 7} A`` for every
``v ∈ S`` (``2**-7`` of the span, an integer test): a window that straddles a depth edge, whose
differences disagree, copies the value as the paper does. ``q_r(p) = q_r(q) + Δ`` is clipped
to the measured span ``[0, 2**16]``, and the range in the caller's unit is that of ``q`` plus
``(q_r(p) − q_r(q)) · span / 2**16``, clipped to the measured minimum and maximum (``q``'s
value is measured or derived from one, so it is off the grid by up to half a step). Where
``S`` is empty, the differences disagree or ``Δ``
is 0, ``p`` gets ``q``'s value bit for bit, as with ``"value"``. Eqs. 2–5 and 10–12 are
computed as before, on the range written so far: only the value written differs (and with it,
through Eq. 2 and the isophotes of Eq. 12, the later matches and the order). The shifted value
stays within the measured span, so a surface that recedes beyond the farthest measured depth is
cut there (Eq. 2's integer sums stay below ``2**53``).

Measured (the Motorcycle's x-stripes, MAR in disparity px at 63 / 78 / 85 % unknown, NP
mean ± sd over seeds 0–2)::

    python benchmarks/audit_departures.py --split choose --variants np-value-copy,np-offset-copy

=================  =======================================  ===================================
split, size        ``"value"`` (Eq. 5)                      ``"offset"`` (the default)
=================  =======================================  ===================================
choose, 450×375    0.400±0.010 / 0.624±0.011 / 0.742±0.009  0.289±0.001 / 0.511±0.007 / 0.656±0.006
report, 450×375    0.408 / 0.589 / 0.738                    0.300 / 0.473 / 0.636
report, 741×500    0.373 / 0.599 / 0.799                    0.243 / 0.485 / 0.730
=================  =======================================  ===================================

(``--split report``; on the synthetic room's grids 10/20 and 5/25, 0.114 / 0.153 m against
0.069 / 0.091 m.) Without the agreement test a first trial won at 63 % and lost at 85 %.

**BP's labels** (``method="bp"``, the default preset's): a label of Fig. 6 is a measured
patch, and its centre is a value measured elsewhere, as Eq. 5's copy is. Each label ``l`` of
node ``i`` gets the shift ``Δ_il`` above, between ``i``'s observation (the measured range
around ``i`` or, with BP's default ``observation="np"``, that range completed by NP's fill;
with ``"colorization"``, by the colorization fill) and ``l``'s measured patch
(:func:`offset_shifts`, all labels at once). Eq. 6 compares the two labels' patches each
moved by its shift (Ψ sees differences only, so the shifts are added with a common lift
that keeps every moved value ``≥ 0``: :data:`refsynth.synthesis.belief.model.SHIFT_LIFT`), a
measured neighbour's term compares the
moved patch with the measured one, and the MAP label (Eq. 8) gives its centre plus its shift
(:func:`shifted_values`, NP's arithmetic and clipping); the pooled confidence and
``candidate_values`` use the moved centres. Eq. 2's ranking and Φ are unchanged. Measured
on the colorization fill's observations (BP deterministic: one run; NP mean over
seeds 0–2 in brackets)::

    python benchmarks/audit_departures.py --split choose --variants bp-value-copy,bp-offset-copy \
        --seeds 0
    python benchmarks/audit_departures.py --split choose --sizes 741x500 \
        --variants bp-value-copy,bp-offset-copy --seeds 0

=================  =====================  =====================  ===========================
split, size        ``"value"``            ``"offset"``           NP
=================  =====================  =====================  ===========================
choose, 450×375    0.314 / 0.511 / 0.689  0.283 / 0.491 / 0.663  (0.289 / 0.511 / 0.656)
choose, 741×500    0.309 / 0.521 / 0.725  0.258 / 0.487 / 0.708  (0.252 / 0.474 / 0.638)
=================  =====================  =====================  ===========================

Lower at every fraction and both sizes (by 10 / 4 / 4 % on the choosing split, beyond the
README's 3 % tie band for BP; by 16 / 7 / 2 % at 741×500), so it is BP's default; it does
not make BP beat NP at 85 %. ``observation="colorization-completed"`` with it gave
0.277 / 0.489 / 0.651 and 0.248 / 0.472 / 0.696: lower again by 0.4–4 %, not made the
default (it still loses to NP at 85 % on the larger size). The README's audit has the report
split.

**BP's agreement** (``offset_tolerance``, BP only): the test above at ``2**-k`` of the
span instead of NP's :data:`OFFSET_TOLERANCE` (``2**-7``), any power of two from ``2**-16`` to
1 (:func:`check_offset_tolerance`; the slack ``2**(16 − k)`` stays a whole number on the
grid). :func:`default_offset_tolerance`: NP's ``2**-7`` with the measured or colorization-filled
observations, where a looser agreement loses on the Motorcycle, and
:data:`NP_OBSERVATION_TOLERANCE` (``2**-3``) with ``observation="np"``, where NP's dense fill
is the observation and the looser agreement wins (measured in
:mod:`refsynth.synthesis.belief.observation`).

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eqs. 2–5, doi:10.1007/s11263-007-0108-2.
A. A. Efros and T. K. Leung, "Texture synthesis by non-parametric sampling", ICCV 1999.
"""

from __future__ import annotations

import math

import numpy as np

from refsynth._checks import check_real
from refsynth.numeric import RANGE_BITS

__all__ = ["RANGE_COPIES", "OFFSET_TOLERANCE", "OFFSET_BITS", "NP_OBSERVATION_TOLERANCE",
           "check_offset_tolerance", "default_offset_tolerance", "offset_shift", "offset_shifts",
           "shifted_value", "shifted_values", "round_half_even"]

#: What :func:`refsynth.synthesize` (NP) copies from the drawn neighbourhood: ``"value"``, its
#: centre range (Eq. 5 as printed); ``"offset"``, that value shifted by the two windows'
#: consistent difference in range (the departure above).
RANGE_COPIES = ("value", "offset")

#: The agreement the shift needs: every difference within ``2**-OFFSET_BITS`` of the span.
OFFSET_BITS = 7
#: :data:`OFFSET_BITS` as a fraction of the measured range's span (about 0.8 %).
OFFSET_TOLERANCE = 2.0**-OFFSET_BITS

#: BP's agreement when NP's fill completes its observations (``observation="np"``):
#: ``2**-3`` of the span (about 12 %; see the module docstring).
NP_OBSERVATION_TOLERANCE = 2.0**-3

_FULL = 2**RANGE_BITS


def check_offset_tolerance(value) -> float:
    """``offset_tolerance``, checked: a power of two from ``2**-16`` to 1 (the agreement's
    slack, ``tolerance · 2**16``, is then a whole number on the range's grid).

    >>> check_offset_tolerance(0.125)
    0.125
    >>> check_offset_tolerance(0.1)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: The parameter `offset_tolerance` must be a power of two ... got 0.1
    """
    value = check_real("offset_tolerance", value)
    if not (2.0**-RANGE_BITS <= value <= 1.0 and math.frexp(value)[0] == 0.5):
        raise ValueError("The parameter `offset_tolerance` must be a power of two from "
                         f"2**-16 to 1 (e.g. 0.125 = 2**-3), got {value!r}")
    return value


def default_offset_tolerance(observation: str | None) -> float:
    """BP's agreement for its ``observation``: :data:`NP_OBSERVATION_TOLERANCE` on NP's fill
    (``"np"``, or None: the default preset's observation), :data:`OFFSET_TOLERANCE` (NP's
    own) otherwise.

    >>> default_offset_tolerance("np"), default_offset_tolerance("colorization")
    (0.125, 0.0078125)
    >>> default_offset_tolerance(None)
    0.125
    """
    return NP_OBSERVATION_TOLERANCE if observation in (None, "np") else OFFSET_TOLERANCE


def _slack(tolerance: float) -> int:
    """The agreement on the range's integer grid: ``tolerance · 2**16`` (a whole number)."""
    return int(tolerance * _FULL)


def offset_shift(target: np.ndarray, source: np.ndarray, has_target: np.ndarray,
                 has_source: np.ndarray, weights: np.ndarray,
                 tolerance: float = OFFSET_TOLERANCE) -> int:
    """``Δ`` of the two windows (see above), or 0 when it is not taken.

    Parameters
    ----------
    target, source : ndarray of float64, shape (n·n,)
        ``q_r`` of the windows of ``p`` and ``q`` in the same order (any value where a window
        has no range), whole numbers.
    has_target, has_source : ndarray of bool, shape (n·n,)
        Where each window has range.
    weights : ndarray of float64, shape (n·n,)
        Eq. 2's window :func:`~refsynth.numeric.window_weights`, whole numbers.
    tolerance : float, default :data:`OFFSET_TOLERANCE`
        The agreement, a fraction of the span (:func:`check_offset_tolerance`).

    Returns
    -------
    int
        The shift on the range's integer grid.

    Notes
    -----
    Every product and sum is a whole number below ``2**53`` (weights below ``2**18``,
    differences below ``2**17``, 25 or 49 terms), so the float64 sums are exact in any order;
    the quotient is rounded by integer arithmetic.

    Examples
    --------
    A plane one step deeper at every offset, and one with a depth edge:

    >>> g = np.ones(4)
    >>> both = np.ones(4, dtype=bool)
    >>> offset_shift(np.array([10.0, 11, 12, 13]), np.array([9.0, 10, 11, 12]), both, both, g)
    1
    >>> offset_shift(np.array([10.0, 11, 9000, 13]), np.array([9.0, 10, 11, 12]), both, both, g)
    0
    """
    shared = has_target & has_source
    if not shared.any():
        return 0
    g = weights[shared]
    delta = target[shared] - source[shared]
    a = float(np.dot(g, np.ones_like(g)))
    b = float(np.dot(g, delta))
    if float(np.max(np.abs(delta * a - b))) > _slack(tolerance) * a:
        return 0
    return round_half_even(int(b), int(a))


def offset_shifts(target: np.ndarray, source: np.ndarray, weights: np.ndarray,
                  tolerance: float = OFFSET_TOLERANCE) -> np.ndarray:
    """:func:`offset_shift` of many pairs of windows at once.

    Parameters
    ----------
    target, source : ndarray of int64, shape (N, n·n)
        ``q_r`` of the windows, ``< 0`` where a window has no range.
    weights : ndarray, shape (n·n,)
        Eq. 2's window :func:`~refsynth.numeric.window_weights`, whole numbers.
    tolerance : float, default :data:`OFFSET_TOLERANCE`
        The agreement, a fraction of the span (:func:`check_offset_tolerance`).

    Returns
    -------
    ndarray of int64, shape (N,)
        Each pair's shift, 0 where it is not taken (exactly :func:`offset_shift`'s).

    Examples
    --------
    >>> t = np.array([[10, 11, 12, 13], [10, 11, 9000, 13], [-1, -1, 5, 6]])
    >>> s = np.array([[9, 10, 11, 12], [9, 10, 11, 12], [1, 2, -1, -1]])
    >>> offset_shifts(t, s, np.ones(4)).tolist()
    [1, 0, 0]
    """
    target = np.asarray(target, dtype=np.int64)
    source = np.asarray(source, dtype=np.int64)
    g = np.asarray(weights).astype(np.int64)
    shared = (target >= 0) & (source >= 0)
    gs = np.where(shared, g, 0)
    delta = np.where(shared, target - source, 0)
    a = gs.sum(axis=1)
    b = (gs * delta).sum(axis=1)
    spread = np.where(shared, np.abs(delta * a[:, None] - b[:, None]), 0).max(axis=1, initial=0)
    taken = (a > 0) & (spread <= _slack(tolerance) * a)
    safe = np.where(a > 0, a, 1)
    quotient, remainder = np.divmod(b, safe)
    twice = 2 * remainder
    quotient = quotient + ((twice > safe) | ((twice == safe) & (quotient % 2 == 1)))
    return np.where(taken, quotient, 0).astype(np.int64)


def shifted_value(q_source: int, shift: int) -> int:
    """``q_r(q) + Δ`` clipped to the measured span ``[0, 2**16]``.

    Examples
    --------
    >>> shifted_value(65000, 1000), shifted_value(12, -20), shifted_value(7, 3)
    (65536, 0, 10)
    """
    return min(max(int(q_source) + int(shift), 0), _FULL)


def shifted_values(q_source: np.ndarray, shift: np.ndarray, source: np.ndarray, span: float,
                   low: float, high: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`shifted_value` of many values, on the grid and in the caller's unit.

    Parameters
    ----------
    q_source : ndarray of int
        ``q_r`` of the copied centres.
    shift : ndarray of int, the same shape
        Their shifts (:func:`offset_shifts`).
    source : ndarray of float64, the same shape
        The copied centres' range in the caller's unit.
    span, low, high : float
        The measured range's span, minimum and maximum.

    Returns
    -------
    q : ndarray of int64
        ``q_r(q) + Δ`` clipped to ``[0, 2**16]``.
    values : ndarray of float64
        ``source + (q − q_source) · span / 2**16`` clipped to ``[low, high]`` where the value
        moved; ``source`` bit for bit where it did not (NP's arithmetic, in the same order).

    Examples
    --------
    >>> q, v = shifted_values(np.array([100, 65000]), np.array([0, 1000]),
    ...                       np.array([1.0, 2.0]), 1.0, 1.0, 2.0)
    >>> q.tolist(), v.tolist()
    ([100, 65536], [1.0, 2.0])
    """
    was = np.asarray(q_source).astype(np.int64)
    now = np.clip(was + np.asarray(shift, dtype=np.int64), 0, _FULL)
    moved = now != was
    values = np.array(source, dtype=np.float64, copy=True)
    step = span * 2.0**-RANGE_BITS
    values[moved] = np.clip((now - was)[moved] * step + values[moved], low, high)
    return now, values


def round_half_even(numerator: int, denominator: int) -> int:
    """``numerator / denominator`` (``denominator > 0``) rounded half to even, exactly.

    >>> [round_half_even(n, 2) for n in (-3, -1, 1, 3, 5)]
    [-2, 0, 0, 2, 2]
    """
    quotient, remainder = divmod(numerator, denominator)
    twice = 2 * remainder
    if twice > denominator or (twice == denominator and quotient % 2):
        quotient += 1
    return quotient
