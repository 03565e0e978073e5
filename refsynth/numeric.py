r"""refsynth's numeric contract: the exact numbers behind every decision.

No decision of range synthesis — an argmin of Eq. 4, the threshold of Eq. 5, the fill order of
Eqs. 10–12, BP's ranking and argmax, Canny's edges — may depend on the order in which numpy,
BLAS or the CPU's SIMD units choose to add up floating-point numbers. So every quantity that
feeds a decision is *exact*, and then any summation order gives the same bits:

1. The intensity and the range are quantised to ``2**-16`` of their span
   (:func:`quantise_intensity`, :func:`quantise_range`):
   ``q = rint(2**16 (x − min) / (max − min))``, an integer in ``[0, 2**16]``. An offset or a
   positive scale of the input, or an integer image against the same image as floats, gives
   the same ``q``.
2. Eq. 2's Gaussian window is an integer table summing to about ``2**18``
   (:func:`window_weights`), so Eq. 2 is four sums of integer products below ``2**53``: exact
   in float64 whatever the order, BLAS included. :func:`combine_eq2` turns them into the
   distance with a fixed sequence of IEEE operations.
3. A synthesized pixel's confidence is rounded to ``2**-40`` (:func:`on_confidence_grid`), so
   the window sums of Eq. 11 are exact in any order.
4. Exponentials and logarithms are :func:`portable_exp` and :func:`portable_log`, built from
   IEEE ``+ − × ÷`` and ``ldexp``/``frexp`` only, and sums over labels run left to right
   (:func:`left_to_right_sum`): the same bits on every CPU and library.
5. No BLAS product (``@``, ``dot``, ``einsum``, ``matmul``) on non-integer data; the grey
   conversion is an explicit three-term sum (:func:`refsynth._checks.grey`).

This module is the bottom layer that :mod:`refsynth.synthesis` (the fast code and the literal
reference :mod:`refsynth.synthesis.reference`) and the scene loaders share.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.4, Eqs. 2–12, doi:10.1007/s11263-007-0108-2.
W. J. Cody and W. Waite, *Software Manual for the Elementary Functions*, Prentice-Hall (1980)
(the argument reduction of :func:`portable_exp`).
"""

from __future__ import annotations

import math

import numpy as np

from refsynth._checks import BT709, grey

__all__ = [
    "INTENSITY_BITS",
    "RANGE_BITS",
    "WINDOW_BITS",
    "CONFIDENCE_BITS",
    "SUPPORT_PRIOR",
    "NO_RANGE",
    "EQ2_UNIT",
    "WEIGHT_UNIT",
    "quantise_intensity",
    "quantise_grey",
    "quantise_range",
    "window_weights",
    "combine_eq2",
    "on_confidence_grid",
    "portable_exp",
    "portable_log",
    "left_to_right_sum",
]

INTENSITY_BITS = 16  #: the normalised intensity is a multiple of 2**-INTENSITY_BITS
RANGE_BITS = 16  #: the normalised range is a multiple of 2**-RANGE_BITS
WINDOW_BITS = 18  #: Eq. 2's Gaussian window sums to about 2**WINDOW_BITS
CONFIDENCE_BITS = 40  #: a synthesized confidence is a multiple of 2**-CONFIDENCE_BITS
SUPPORT_PRIOR = 1e-4  #: ε of the mean-filled range term (see refsynth.synthesis.similarity)
NO_RANGE = -1  #: a quantised range array holds this where the range is unknown
EQ2_UNIT = 2.0 ** -(2 * RANGE_BITS + WINDOW_BITS)  #: one unit of an integer Eq. 2 sum
WEIGHT_UNIT = 2.0**-WINDOW_BITS  #: one unit of the integer window

_LN2_HIGH = 6.93147180369123816490e-01  # ln 2 split for Cody–Waite: the high part is exact
_LN2_LOW = 1.90821492927058770002e-10
_LOG2E = 1.4426950408889634


# ----------------------------------------------------------------------------- quantisation


def quantise_intensity(image: np.ndarray) -> np.ndarray:
    """Intensity → int64 in ``[0, 2**16]``: ``rint(2**16 (I − min I) / (max I − min I))``.

    The minimum and maximum run over all pixels and channels; a constant image maps to 0.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C), real
        Finite intensity, any offset and scale.

    Returns
    -------
    ndarray of int64, the shape of ``image``

    Examples
    --------
    >>> quantise_intensity(np.array([[10.0, 12.0, 14.0]])).tolist()
    [[0, 32768, 65536]]
    """
    image = np.asarray(image, dtype=np.float64)
    low = float(np.min(image))
    span = float(np.max(image)) - low
    span = span if span > 0 else 1.0
    return np.rint((image - low) / span * 2.0**INTENSITY_BITS).astype(np.int64)


def quantise_grey(q_intensity: np.ndarray, weights: np.ndarray = BT709) -> np.ndarray:
    """The grey level of a quantised image, quantised again: int64 (H, W) in ``[0, 2**16]``.

    ``quantise_intensity(grey(q))`` with :func:`refsynth._checks.grey` (an explicit
    ``(w0 R + w1 G) + w2 B``, the same bits everywhere). A grey image (one channel) comes back
    unchanged. This is the intensity that Canny sees, and Eq. 2's with ``colour=False``.

    Parameters
    ----------
    q_intensity : ndarray of int, shape (H, W, C) or (H, W)
        From :func:`quantise_intensity`.
    weights : ndarray of shape (3,), default BT.709
        Luminance weights for a colour image.
    """
    q = np.asarray(q_intensity)
    return quantise_intensity(grey(q.astype(np.float64), weights))


def quantise_range(range_values: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Range → ``(q, low, span)``: ``q = rint(2**16 (R − low) / span)`` over the known range.

    ``low`` and ``span`` are the minimum and the span (max − min, 1 if constant) of the finite
    values; ``q`` is int64 with :data:`NO_RANGE` where the range is unknown (NaN).

    Examples
    --------
    >>> q, low, span = quantise_range(np.array([[2.0, np.nan, 4.0]]))
    >>> q.tolist(), low, span
    ([[0, -1, 65536]], 2.0, 2.0)
    """
    range_values = np.asarray(range_values, dtype=np.float64)
    known = np.isfinite(range_values)
    low = float(np.min(range_values[known]))
    span = float(np.max(range_values[known])) - low
    span = span if span > 0 else 1.0
    q = np.rint((np.where(known, range_values, low) - low) / span * 2.0**RANGE_BITS)
    return np.where(known, q, NO_RANGE).astype(np.int64), low, span


def window_weights(n: int) -> np.ndarray:
    r"""Eq. 2's Gaussian window as int64: ``rint(2**18 G_v)``, ``G ∝ exp(−|v|²/2σ²)``, σ = n/6.4.

    The exponentials are :func:`portable_exp`, normalised by their left-to-right sum in raster
    order; for every odd ``n ≤ 31`` the table equals the rounded
    :func:`refsynth.synthesis.neighbourhood.gaussian_window`.

    >>> int(window_weights(5)[2, 2]), int(window_weights(5).sum())
    (68443, 262151)
    """
    sigma = n / 6.4
    h = n // 2
    e = [float(portable_exp(-(i * i + j * j) / (2.0 * sigma * sigma)))
         for i in range(-h, h + 1) for j in range(-h, h + 1)]
    total = 0.0
    for value in e:  # left to right, raster order
        total += value
    return np.array([round(value / total * 2.0**WINDOW_BITS) for value in e],
                    dtype=np.int64).reshape(n, n)


# ----------------------------------------------------------------------------- Eq. 2, Eq. 11


def combine_eq2(si, sr, ws, wa, channels: int, range_weight: float, missing_range: str):
    r"""Eq. 2 from its four exact integer sums, by a fixed sequence of IEEE operations.

    ``si = Σ_v G_v Σ_c ΔI²``, ``sr = Σ_{v∈S} G_v ΔR²`` (``S``: the offsets where both
    neighbourhoods have range), ``ws = Σ_{v∈S} G_v``, ``wa = Σ_{v∈A} G_v`` (``A``: the offsets
    where the target has range), all on the integer grids of :func:`quantise_intensity`,
    :func:`quantise_range` and :func:`window_weights`. Python ints or float64 arrays holding
    integers (below ``2**53``) give the same bits.

    ``channels`` divides the intensity sum: 1 for Eq. 2's sum over the colour channels
    (``channels="sum"`` in :func:`refsynth.synthesize`, the default), ``C`` for their mean.

    ``"ignore"``: ``(si·u)/C + λ(sr·u)`` (the literal Eq. 2, ``u`` = :data:`EQ2_UNIT`);
    ``"mean"``: ``(si·u)/C + (λ(sr·u) + λε) · ((wa·w)/(ws·w + ε))`` with ``w`` =
    :data:`WEIGHT_UNIT` and ε = :data:`SUPPORT_PRIOR` (see :mod:`refsynth.synthesis.similarity`).
    """
    intensity = (si * EQ2_UNIT) / channels
    range_term = range_weight * (sr * EQ2_UNIT)
    if missing_range == "mean":
        range_term = (range_term + range_weight * SUPPORT_PRIOR) * (
            (wa * WEIGHT_UNIT) / (ws * WEIGHT_UNIT + SUPPORT_PRIOR))
    return intensity + range_term


def on_confidence_grid(value):
    """Round a confidence to a multiple of ``2**-40`` (so the sums of Eq. 11 are exact).

    >>> on_confidence_grid(1 / 3) * 2**40 == round(2**40 / 3)
    True
    """
    out = np.rint(np.asarray(value, dtype=np.float64) * 2.0**CONFIDENCE_BITS)
    out = out * 2.0**-CONFIDENCE_BITS
    return float(out) if out.ndim == 0 else out


# ----------------------------------------------------------------------------- exp, log, sums


def portable_exp(x):
    """``exp(x)`` from IEEE ``+ − × ÷`` and ``ldexp`` only: the same bits on every machine.

    ``x = k ln 2 + r`` (Cody–Waite, ``|r| ≤ ln 2 / 2``), ``exp(r)`` by Horner on the Taylor
    series to degree 13, then ``2**k``. Within a few ulp of ``numpy.exp``; 0 below −745.

    >>> float(portable_exp(0.0)), float(portable_exp(2.0)) == float(np.exp(2.0))
    (1.0, True)
    """
    x = np.asarray(x, dtype=np.float64)
    z = np.maximum(x, -746.0)  # the result is 0 below -745; keeps the series finite (NaN stays)
    k = np.rint(z * _LOG2E)
    r = (z - k * _LN2_HIGH) - k * _LN2_LOW
    p = np.full_like(x, 1.0 / math.factorial(13))
    for j in range(12, -1, -1):
        p = p * r + 1.0 / math.factorial(j)
    k = np.clip(np.nan_to_num(k, nan=0.0), -1100, 1100).astype(np.int64)
    return np.where(x < -745.0, 0.0, np.ldexp(p, k))


def portable_log(x):
    """``log(x)`` for ``x > 0`` from IEEE ``+ − × ÷`` and ``frexp`` only.

    ``x = f 2**e`` with ``f`` in ``[√½, √2)``, ``log f = 2 atanh((f − 1)/(f + 1))`` by its
    series to degree 31, then ``e ln 2`` added in two parts.

    >>> float(portable_log(1.0))
    0.0
    """
    x = np.asarray(x, dtype=np.float64)
    f, e = np.frexp(x)
    low = f < 0.7071067811865476
    f = np.where(low, 2.0 * f, f)
    e = np.where(low, e - 1, e).astype(np.float64)
    z = (f - 1.0) / (f + 1.0)
    z2 = z * z
    s = np.full_like(x, 1.0 / 31.0)
    for j in range(29, 0, -2):
        s = s * z2 + 1.0 / j
    return (e * _LN2_HIGH + 2.0 * z * s) + e * _LN2_LOW


def left_to_right_sum(values: np.ndarray, axis: int = -1) -> np.ndarray:
    """The sum along ``axis``, ``((0 + x0) + x1) + …``, in that order (numpy's ``sum`` regroups).

    >>> left_to_right_sum(np.array([[1.0, 2.0, 3.0]]), axis=1).tolist()
    [6.0]
    """
    values = np.asarray(values, dtype=np.float64)
    total = np.zeros(tuple(np.delete(values.shape, axis % values.ndim)))
    for index in range(values.shape[axis]):
        total = total + np.take(values, index, axis=axis)
    return total
