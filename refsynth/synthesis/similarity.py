r"""Eq. 2: the distance between two partial neighbourhoods (§3.2.2), literally.

.. math:: \|N_a - N_b\| = \sum_{v} G(\sigma, v - v_0) \left[ \sum_{c=1}^{C}
          (I^a_{v,c} - I^b_{v,c})^2 + \lambda \, (R^a_v - R^b_v)^2 \right]

The sum runs over the offsets ``v`` of the n×n window. The range term counts only where
*both* neighbourhoods have range (never at the centre of the neighbourhood being filled).
:func:`eq2_distance` is Eq. 2, written once, on the numeric contract's integer grids
(:mod:`refsynth.numeric`); :func:`neighbourhood_distance` takes normalised floats to those
grids and calls it. The fast form, a whole candidate set at once and bit for bit the same,
is :class:`refsynth.synthesis.patch_table.PatchTable` (and NP's
:class:`refsynth.synthesis.filltable.FillTable`).

Normalisation (the paper leaves it open): the intensity is divided by its span over the
whole image and the range by the span of the *known* range, so both lie in [0, 1]; the
intensity term sums the colour channels as Eq. 2 does (``channels="sum"``; ``"mean"``
averages them, which weighs the range term C times more: on the Motorcycle's choosing
split NP's MAR was 0.467 / 0.700 / 0.790 px with the mean against 0.400 / 0.624 / 0.742
with the sum at 63 / 78 / 85 %, 3 seeds). The range term's weight ``λ`` (``range_weight``)
is 1, the two normalised terms weighing the same; λ = 16 raises NP's MAR on the Motorcycle
(450×375, x-stripes 63 / 78 / 85 %, 3 seeds) at every fraction (0.692 / 0.813 / 0.979
against 0.531 / 0.723 / 0.858 px) and leaves BP's within 1 %
(``benchmarks/audit_departures.py``). ``λ = 0`` is an intensity match.

Missing range (a departure, ``missing_range="mean"``; ``"ignore"`` is Eq. 2 as written).
As written, Eq. 2 rewards a candidate for *lacking* range: where the target ``N_a`` has
range and the candidate none, the term is dropped, so on stripe samplings intensity noise
picks candidates beside unknown range many rows away. refsynth charges those offsets the
mean discrepancy of the offsets both have:

.. math:: \lambda \, \frac{\sum_{v \in S} G_v (R^a_v - R^b_v)^2 + \varepsilon}
          {\sum_{v \in S} G_v + \varepsilon} \sum_{v \in A} G_v

``S`` the offsets both have, ``A`` those the target has, ε = 10⁻⁴ a prior pseudo-offset
whose discrepancy is the whole span (with ``S`` empty every offset the target has costs
``λ`` per unit weight). It equals Eq. 2 when the candidate has range wherever the target
has. On the development rooms (seeds 100–102, 128×128) it lowered NP's MAR on every
sampling tried — grid 5/25: 0.221 → 0.144 m, x-stripes at 40 / 63 / 78 % unknown: 0.092 →
0.049, 0.327 → 0.079, 0.411 → 0.127 m. (A fixed penalty per missing offset favoured
candidates with the same *pattern* of missing range and copied values down narrow gaps.)

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth._checks import check_choice
from refsynth.numeric import (
    INTENSITY_BITS,
    NO_RANGE,
    RANGE_BITS,
    WINDOW_BITS,
    combine_eq2,
    window_weights,
)

__all__ = ["intensity_scale", "range_scale", "eq2_distance", "neighbourhood_distance"]

#: The treatments of missing range in Eq. 2's range term (see above).
MISSING_RANGE = ("mean", "ignore")
#: Eq. 2's intensity term over the colour channels: their sum (the paper's) or their mean.
CHANNELS = ("sum", "mean")


def intensity_scale(image: np.ndarray) -> float:
    """The span of an intensity image (max − min), or 1 for a constant image.

    >>> intensity_scale(np.array([0.25, 0.75])), intensity_scale(np.full(3, 5.0))
    (0.5, 1.0)
    """
    span = float(np.max(image) - np.min(image))
    return span if span > 0 else 1.0


def range_scale(range_image: np.ndarray) -> tuple[float, float]:
    """``(min, max − min)`` of the known (finite) range, the span 1 if constant.

    >>> range_scale(np.array([2.0, np.nan, 6.0]))
    (2.0, 4.0)
    """
    known = range_image[np.isfinite(range_image)]
    low = float(known.min())
    span = float(known.max()) - low
    return low, (span if span > 0 else 1.0)


def eq2_distance(qi_a: np.ndarray, qr_a: np.ndarray, qi_b: np.ndarray, qr_b: np.ndarray,
                 window: np.ndarray, range_weight: float = 1.0, missing_range: str = "mean",
                 channels: str = "sum") -> float:
    r"""Eq. 2 between two quantised neighbourhoods, literally (§3.2.2).

    .. math:: \|N_a - N_b\| = \sum_v G_v \left[ \sum_c (I^a_{v,c} - I^b_{v,c})^2
              + \lambda (R^a_v - R^b_v)^2 \right]

    The one literal Eq. 2: the references (:mod:`~refsynth.synthesis.nonparametric.reference`,
    :mod:`~refsynth.synthesis.belief.reference`) compute it, and
    :class:`~refsynth.synthesis.patch_table.PatchTable` and the fast fills equal it bit for bit.

    Parameters
    ----------
    qi_a, qi_b : ndarray of int, shape (n, n, C)
        Quantised intensity (:func:`refsynth.numeric.quantise_intensity`).
    qr_a, qr_b : ndarray of int, shape (n, n)
        Quantised range (:func:`refsynth.numeric.quantise_range`),
        :data:`~refsynth.numeric.NO_RANGE` where unknown; ``a`` is the target, ``b`` the candidate.
    window : ndarray of int, shape (n, n)
        :func:`refsynth.numeric.window_weights`.
    range_weight : float, default 1
        λ.
    missing_range : {"mean", "ignore"}, default "mean"
        ``"ignore"``: Eq. 2 as written; ``"mean"``: the departure above (not symmetric).
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's sum over the colour channels, or their mean.

    Returns
    -------
    float
        Four exact integer sums — ``si = Σ_v G_v Σ_c ΔI²``, ``sr = Σ_{v∈S} G_v ΔR²``,
        ``ws = Σ_{v∈S} G_v``, ``wa = Σ_{v∈A} G_v`` (``S``: the offsets where both have range,
        ``A``: where the target has) — turned into the distance by
        :func:`refsynth.numeric.combine_eq2`: ``(si·u)/C' + λ(sr·u)`` with ``"ignore"``,
        ``(si·u)/C' + (λ(sr·u) + λε) · ((wa·w)/(ws·w + ε))`` with ``"mean"`` (``u = 2**-50``,
        ``w = 2**-18``, ``C'`` 1 or ``C``). The sums are exact, so their order is free.

    Examples
    --------
    >>> from refsynth.numeric import window_weights
    >>> qi = np.zeros((3, 3, 1), dtype=np.int64); qr = np.full((3, 3), -1)
    >>> d = eq2_distance(qi, qr, qi + 2**16, qr, window_weights(3), missing_range="ignore")
    >>> d == int(window_weights(3).sum()) * 2.0**-18   # ΔI = 1 everywhere: the window's sum
    True
    """
    check_choice("missing_range", missing_range, MISSING_RANGE)
    check_choice("channels", channels, CHANNELS)
    has_a, has_b = qr_a != NO_RANGE, qr_b != NO_RANGE
    shared = has_a & has_b
    di = qi_a - qi_b
    dr = np.where(shared, qr_a - qr_b, 0)
    si = int(np.sum(window[:, :, None] * di * di))
    sr = int(np.sum(window * dr * dr))
    divisor = qi_a.shape[2] if channels == "mean" else 1   # Eq. 2 sums the channels
    return combine_eq2(si, sr, int(np.sum(window[shared])), int(np.sum(window[has_a])),
                       divisor, range_weight, missing_range)


def neighbourhood_distance(intensity_a: np.ndarray, range_a: np.ndarray,
                           intensity_b: np.ndarray, range_b: np.ndarray, *,
                           range_weight: float = 1.0, window: np.ndarray | None = None,
                           missing_range: str = "ignore", channels: str = "sum") -> float:
    """Eq. 2 for one pair of neighbourhoods given as normalised floats.

    A convenience for reading Eq. 2 on floats: the values go to the numeric contract's
    grids (``rint(2**16 x)``, the window ``rint(2**18 G)``) and :func:`eq2_distance`
    computes the distance. So the result is Eq. 2 of the values rounded to ``2**-16``,
    exactly what NP and BP compute.

    Parameters
    ----------
    intensity_a, intensity_b : ndarray of shape (n, n) or (n, n, C)
        Normalised intensity, finite.
    range_a, range_b : ndarray of shape (n, n)
        Normalised range (``>= 0``), NaN where unknown.
    range_weight : float, default 1
        λ.
    window : ndarray of shape (n, n), optional
        The Gaussian window ``G`` (weights summing to 1, e.g.
        :func:`refsynth.synthesis.neighbourhood.gaussian_window`); default
        :func:`refsynth.numeric.window_weights` ``· 2**-18``.
    missing_range : {"ignore", "mean"}, default "ignore"
        ``"ignore"``: Eq. 2 as written; ``"mean"``: the departure above.
    channels : {"sum", "mean"}, default "sum"
        The intensity term summed over the colour channels (Eq. 2) or averaged.

    Returns
    -------
    float

    Examples
    --------
    >>> a = np.zeros((3, 3)); r = np.full((3, 3), np.nan)
    >>> neighbourhood_distance(a, r, a, r)
    0.0
    >>> d = neighbourhood_distance(a, r, a + 0.5, r)   # ΔI² = 1/4 everywhere: G's sum / 4
    >>> d == int(window_weights(3).sum()) * 2.0**-20, round(d, 4)
    (True, 0.25)
    """
    ia, ib = (np.asarray(x, dtype=np.float64) for x in (intensity_a, intensity_b))
    if ia.ndim == 2:
        ia, ib = ia[:, :, None], ib[:, :, None]
    ra, rb = (np.asarray(x, dtype=np.float64) for x in (range_a, range_b))
    g = window_weights(len(ra) if ra.ndim else 1) if window is None else np.rint(
        np.asarray(window, dtype=np.float64) * 2.0**WINDOW_BITS).astype(np.int64)
    if ia.shape != ib.shape or ra.shape != rb.shape or not ra.shape == g.shape == ia.shape[:2]:
        raise ValueError("The neighbourhoods and the window must have matching shapes, got "
                         f"{ia.shape}, {ib.shape}, {ra.shape}, {rb.shape}, {g.shape}")
    if not (np.isfinite(ia).all() and np.isfinite(ib).all()):
        raise ValueError("The parameters `intensity_a` and `intensity_b` must be finite")
    if np.any(ra < 0) or np.any(rb < 0):
        raise ValueError("The parameters `range_a` and `range_b` must be >= 0 (normalised)")

    def grid(values: np.ndarray, bits: int) -> np.ndarray:
        return np.rint(np.where(np.isfinite(values), values, 0.0) * 2.0**bits).astype(np.int64)

    qr_a, qr_b = (np.where(np.isfinite(r), grid(r, RANGE_BITS), NO_RANGE) for r in (ra, rb))
    return eq2_distance(grid(ia, INTENSITY_BITS), qr_a, grid(ib, INTENSITY_BITS), qr_b, g,
                        range_weight, missing_range, channels)
