r"""Eq. 2: the distance between two partial neighbourhoods (§3.2.2).

.. math::

    \|N_a - N_b\| = \sum_{v} G(\sigma, v - v_0)
        \left[ \sum_{c=1}^{C} (I^a_{v,c} - I^b_{v,c})^2
               + \lambda \, (R^a_v - R^b_v)^2 \right]

The sum runs over the offsets ``v`` of the n×n window. Each term uses only the
data that *both* neighbourhoods have at ``v``: the range term is dropped where
either neighbourhood has no range (in particular at the centre of the
neighbourhood being synthesized).

Normalisation (our choice; the paper leaves it open)
-----------------------------------------------------
Intensity and range live in different units. refsynth divides the intensity by
its span over the whole image and the range by the span of the *known* range, so
both lie in [0, 1], and sums the intensity term over the colour channels, as Eq.
2 does (``channels="sum"``; ``"mean"`` averages them so that grey and colour
images weigh the same, which weighs the range term C times more: on the
Motorcycle's choosing split NP's MAR was 0.467 / 0.700 / 0.790 px with the mean
against 0.400 / 0.624 / 0.742 with the sum at 63 / 78 / 85 %, 3 seeds). The
range term then gets the weight ``λ`` (``range_weight``, default 1: the two
normalised terms weigh the same, the paper's reading). λ = 16, chosen on
synthetic rooms, loses on the Motorcycle (450×375, x-stripes 63 / 78 / 85 %, 3
seeds): it raises NP's MAR at every fraction (0.692 / 0.813 / 0.979 against
0.531 / 0.723 / 0.858 px with the literal Eq. 2) and leaves BP's within 1 %
(``benchmarks/audit_departures.py``). With ``λ = 0`` Eq. 2 reduces to an
intensity match.

Missing range (a departure from the paper)
------------------------------------------
Eq. 2 as written rewards a candidate for *lacking* range: where ``N_p`` has
range and the candidate has none, the range term is simply dropped, so a
candidate at the image border, or beside unknown range, pays nothing for the
range it cannot compare, and on stripe samplings intensity noise then picks
candidates many rows away. refsynth instead charges those offsets the *mean*
discrepancy of the offsets both neighbourhoods have (``missing_range="mean"``,
the default): the range term becomes

.. math:: \lambda \, \frac{\sum_{v \in S} G_v (R^a_v - R^b_v)^2}{\sum_{v \in S} G_v}
          \sum_{v \in A} G_v

with ``S`` the offsets both have and ``A`` those the target ``N_a`` has (in
the code the fraction carries a prior pseudo-offset of weight ε = 10⁻⁴ whose
discrepancy is the whole span, so that with ``S`` empty every offset the
target has costs ``λ`` per unit weight). It equals Eq. 2 when the candidate
has range wherever the target has. On the development rooms (seeds 100–102, 128×128) it lowered NP's
MAR on every sampling tried — grid 5/25: 0.221 → 0.144 m, x-stripes at 40 /
63 / 78 % unknown: 0.092 → 0.049, 0.327 → 0.079, 0.411 → 0.127 m. (A fixed
penalty per missing offset, tried first, helped on wide gaps but favoured
candidates with the same *pattern* of missing range — the pixel just above,
in the same gap — and so copied values down narrow gaps in long streaks.)
``missing_range="ignore"`` gives the literal Eq. 2.

Eq. 2, expanded (how NP and BP evaluate it)
-------------------------------------------
:func:`neighbourhood_distance` is the literal reading of Eq. 2, one pair at a
time. NP (:mod:`refsynth.synthesis.nonparametric`) and BP
(:mod:`refsynth.synthesis.bp`) evaluate the same sum for a whole candidate set
at once with :class:`PatchTable`. Expanding the squares separates what belongs
to the target ``p`` from what belongs to a candidate ``q``:

.. math::

    \|N_p - N_q\| = s_p + s_q - 2\sum_v \tfrac{G_v}{C} I_p I_q
        + \lambda \sum_v G_v \left[ V_p R_q^2 - 2 R_p R_q + R_p^2 V_q \right]

with ``s = Σ_v (G_v / C) Σ_c I²``, ``V`` the has-range indicator and ``R`` the
normalised range stored as 0 where unknown. So every candidate's row of
``[I | V | R | R²]`` (a precomputed patch array, updated in place on the n×n
windows around each newly filled voxel) is multiplied by one weight vector
built from ``p``'s row: the whole candidate set costs one gather and one
matrix–vector product (three columns: the intensity term, the range term over
the shared support, and the shared support's weight, which the mean-filled
range term needs). The tests check that the two forms agree.

The numeric contract (:mod:`refsynth.numeric`): the table holds the intensity
and the range quantised to ``2**-16`` as float64 *integers*, and the Gaussian
window as the integer table :func:`refsynth.numeric.window_weights`. Every
partial sum of the expanded squares is then an integer below ``2**53``, so the
products are exact whatever BLAS, thread count or SIMD width computes them,
and :func:`refsynth.numeric.combine_eq2` turns the four sums into the distance
by a fixed sequence of IEEE operations: bit for bit the literal Eq. 2 on the same grid,
:func:`eq2_distance`, which the literal references compute.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth._checks import check_choice
from refsynth.numeric import (
    INTENSITY_BITS,
    NO_RANGE,
    RANGE_BITS,
    SUPPORT_PRIOR,
    combine_eq2,
    window_weights,
)
from refsynth.synthesis.neighbourhood import gaussian_window, intensity_patches, window_offsets

__all__ = ["intensity_scale", "range_scale", "neighbourhood_distance", "eq2_distance",
           "PatchTable"]

#: The treatments of missing range in Eq. 2's range term (see above).
MISSING_RANGE = ("mean", "ignore")
#: Eq. 2's intensity term over the colour channels: their sum (the paper's) or their mean.
CHANNELS = ("sum", "mean")

#: ε of the mean-filled range term: a prior pseudo-offset of this weight (the
#: Gaussian window sums to 1) whose discrepancy is the whole known span.
_SUPPORT_PRIOR = SUPPORT_PRIOR


# ----------------------------------------------------------------------------- the scales


def intensity_scale(image: np.ndarray) -> float:
    """The span of an intensity image (max − min), or 1 for a constant image.

    Parameters
    ----------
    image : ndarray
        Intensity, any shape.

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> intensity_scale(np.array([0.25, 0.75])), intensity_scale(np.full(3, 5.0))
    (0.5, 1.0)
    """
    span = float(np.max(image) - np.min(image))
    return span if span > 0 else 1.0


def range_scale(range_image: np.ndarray) -> tuple[float, float]:
    """Offset and span of the known range: ``(min, max − min)``, span 1 if constant.

    Parameters
    ----------
    range_image : ndarray
        Range, NaN where unknown; at least one finite value.

    Returns
    -------
    low, span : float

    Examples
    --------
    >>> import numpy as np
    >>> range_scale(np.array([2.0, np.nan, 6.0]))
    (2.0, 4.0)
    """
    known = range_image[np.isfinite(range_image)]
    low = float(known.min())
    span = float(known.max()) - low
    return low, (span if span > 0 else 1.0)


# ----------------------------------------------------------------------------- Eq. 2, literal


def neighbourhood_distance(
    intensity_a: np.ndarray,
    range_a: np.ndarray,
    intensity_b: np.ndarray,
    range_b: np.ndarray,
    *,
    range_weight: float = 1.0,
    window: np.ndarray | None = None,
    missing_range: str = "ignore",
    channels: str = "sum",
) -> float:
    """Eq. 2 for one pair of partial neighbourhoods.

    Parameters
    ----------
    intensity_a, intensity_b : ndarray of shape (n, n) or (n, n, C)
        Normalised intensity; NaN where a voxel has no intensity (off the image).
    range_a, range_b : ndarray of shape (n, n)
        Normalised range, NaN where unknown.
    range_weight : float, default 1
        The weight λ of the range term.
    window : ndarray of shape (n, n), optional
        The Gaussian window ``G``; default :func:`refsynth.synthesis.neighbourhood.gaussian_window`.
    missing_range : {"ignore", "mean"}
        ``"ignore"`` (default here): the literal Eq. 2. ``"mean"``: offsets
        where ``a`` has range and ``b`` has none cost the mean discrepancy of
        the shared ones (NP's and BP's default, see above). Not symmetric.
    channels : {"sum", "mean"}, default "sum"
        The intensity term summed over the colour channels (Eq. 2) or
        averaged over them.

    Returns
    -------
    float
        The weighted sum of squared differences over the shared support.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.zeros((3, 3)); r = np.full((3, 3), np.nan)
    >>> neighbourhood_distance(a, r, a, r)
    0.0
    """
    ia = np.asarray(intensity_a, dtype=np.float64)
    ib = np.asarray(intensity_b, dtype=np.float64)
    if ia.ndim == 2:
        ia, ib = ia[:, :, None], ib[:, :, None]
    ra = np.asarray(range_a, dtype=np.float64)
    rb = np.asarray(range_b, dtype=np.float64)
    check_choice("missing_range", missing_range, MISSING_RANGE)
    if ia.shape != ib.shape or ra.shape != rb.shape or ra.shape != ia.shape[:2]:
        raise ValueError(
            "The neighbourhoods must have matching shapes, got "
            f"{ia.shape}, {ib.shape}, {ra.shape}, {rb.shape}"
        )
    n = ra.shape[0]
    g = gaussian_window(n) if window is None else np.asarray(window, dtype=np.float64)
    di = ia - ib
    intensity_term = np.where(np.isfinite(di), di, 0.0) ** 2
    intensity_term = intensity_term.sum(axis=2)
    if channels == "mean":
        intensity_term = intensity_term / ia.shape[2]
    dr = ra - rb
    shared = np.isfinite(dr)
    range_term = float(np.sum(g * np.where(shared, dr, 0.0) ** 2))
    if missing_range == "mean":
        target = float(np.sum(g[np.isfinite(ra)]))
        support = float(np.sum(g[shared]))
        range_term = (range_term + _SUPPORT_PRIOR) * target / (support + _SUPPORT_PRIOR)
    return float(np.sum(g * intensity_term) + range_weight * range_term)


def eq2_distance(
    qi_a: np.ndarray,
    qr_a: np.ndarray,
    qi_b: np.ndarray,
    qr_b: np.ndarray,
    window: np.ndarray,
    range_weight: float = 1.0,
    missing_range: str = "mean",
    channels: str = "sum",
) -> float:
    r"""Eq. 2 between two quantised neighbourhoods, literally, on the numeric contract's grid.

    .. math:: \|N_a - N_b\| = \sum_v G(\sigma, v - v_0) \left[ \sum_c
              (I^a_{v,c} - I^b_{v,c})^2 + \lambda (R^a_v - R^b_v)^2 \right]

    This is the Eq. 2 that the literal references
    (:mod:`refsynth.synthesis.nonparametric.reference`, :mod:`refsynth.synthesis.reference`)
    compute and that :class:`PatchTable` and the fast fills equal bit for bit.

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
        ``"ignore"``: Eq. 2 as written; ``"mean"``: the departure above.
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's sum over the colour channels, or their mean.

    Returns
    -------
    float
        Four exact integer sums — ``si = Σ_v G_v Σ_c ΔI²``, ``sr = Σ_{v∈S} G_v ΔR²``,
        ``ws = Σ_{v∈S} G_v``, ``wa = Σ_{v∈A} G_v`` (``S``: the offsets where both have range,
        ``A``: where the target has) — turned into the distance by
        :func:`refsynth.numeric.combine_eq2`. The sums are exact, so their order is free.

    Examples
    --------
    >>> from refsynth.numeric import window_weights
    >>> qi = np.zeros((3, 3, 1), dtype=np.int64); qr = np.full((3, 3), -1)
    >>> d = eq2_distance(qi, qr, qi + 2**16, qr, window_weights(3), missing_range="ignore")
    >>> d == int(window_weights(3).sum()) * 2.0**-18   # ΔI = 1 everywhere: the window's sum
    True
    """
    has_a, has_b = qr_a != NO_RANGE, qr_b != NO_RANGE
    shared = has_a & has_b
    di = qi_a - qi_b
    dr = np.where(shared, qr_a - qr_b, 0)
    si = int(np.sum(window[:, :, None] * di * di))
    sr = int(np.sum(window * dr * dr))
    divisor = qi_a.shape[2] if channels == "mean" else 1   # Eq. 2 sums the channels
    return combine_eq2(si, sr, int(np.sum(window[shared])), int(np.sum(window[has_a])),
                       divisor, range_weight, missing_range)


# ----------------------------------------------------------------------------- Eq. 2, expanded


class PatchTable:
    """Every voxel's neighbourhood as one row ``[I | V | R | R²]`` (Eq. 2, expanded).

    Rows are indexed by flat position in a frame padded by ``pad`` pixels.
    ``distances(p, candidates)`` evaluates Eq. 2 between ``N_p`` and each
    candidate neighbourhood; ``set_range(p, value)`` records a newly known
    range in every row whose window contains ``p``.

    The rows hold ``I`` and ``R`` on the integer grid of the numeric contract,
    ``rint(2**16 x)`` of the normalised values given (and ``R²`` exactly), so
    that Eq. 2 is exact in any summation order (see above).

    Parameters
    ----------
    image : ndarray of shape (H, W, C)
        Intensity normalised to [0, 1] (NP and BP pass the quantised
        intensity, ``q · 2**-16``, which the table recovers exactly).
    range_norm : ndarray of shape (H, W)
        Range normalised to [0, 1] (NP and BP pass ``q · 2**-16``), NaN where
        unknown.
    n : int
        Odd window side.
    pad : int
        Padding of the frame (at least ``n // 2``).
    range_weight : float
        λ of Eq. 2.
    missing_range : {"mean", "ignore"}
        How the range term treats offsets where ``N_p`` has range and the
        candidate has none: ``"mean"`` charges them the mean discrepancy of
        the offsets both have (see above); ``"ignore"`` is the literal
        Eq. 2.
    dtype : numpy dtype, default float64
        float64 holds the integers exactly (the contract). float32 halves the
        memory traffic but rounds ``R²`` and the sums: for experiments only.
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's intensity term summed over the colour channels (the paper's)
        or averaged over them.

    Examples
    --------
    >>> import numpy as np
    >>> image = np.zeros((3, 3, 1)); image[1, 1] = 1.0
    >>> table = PatchTable(image, np.full((3, 3), 0.5), 3, 1, 1.0, "ignore")
    >>> p = 2 * 5 + 2                                  # the centre, in the padded frame
    >>> d = table.distances(p, np.array([p, p + 1]))
    >>> float(d[0]), bool(d[1] > 0)                    # itself at 0; its neighbour further
    (0.0, True)
    """

    def __init__(
        self,
        image: np.ndarray,
        range_norm: np.ndarray,
        n: int,
        pad: int,
        range_weight: float,
        missing_range: str = "mean",
        dtype=np.float64,
        channels: str = "sum",
    ) -> None:
        H, W, C = image.shape
        self.shape = (H + 2 * pad, W + 2 * pad)
        self.channels = C
        self.divisor = C if channels == "mean" else 1  # Eq. 2's channel sum, or their mean
        nn = n * n
        g = window_weights(n).ravel().astype(np.float64)
        rows = self.shape[0] * self.shape[1]
        table = np.zeros((rows, nn * C + 3 * nn), dtype=dtype)
        frame = table.reshape(self.shape + (nn * C + 3 * nn,))
        inner = frame[pad : pad + H, pad : pad + W]
        levels = np.rint(np.asarray(image, dtype=np.float64) * 2.0**INTENSITY_BITS)
        inner[:, :, : nn * C] = intensity_patches(levels, n).reshape(H, W, nn * C)
        h = n // 2
        rq = np.rint(np.asarray(range_norm, dtype=np.float64) * 2.0**RANGE_BITS)
        rpad = np.pad(rq, h, mode="constant", constant_values=np.nan)
        rp = sliding_window_view(rpad, (n, n)).reshape(H, W, nn)
        has = np.isfinite(rp)
        base = nn * C
        inner[:, :, base : base + nn] = has
        inner[:, :, base + nn : base + 2 * nn] = np.where(has, rp, 0.0)
        inner[:, :, base + 2 * nn :] = np.where(has, rp, 0.0) ** 2
        self.table = table
        g_int = np.repeat(g, C)  # intensity columns are (offset, channel) raveled
        self.self_term = (table[:, :base] ** 2) @ g_int.astype(dtype)  # Σ G Σ_c I², exact
        # weight vector of p = table[p, perm] * coef
        i_cols = np.arange(base)
        v_cols = base + np.arange(nn)
        r_cols = v_cols + nn
        r2_cols = r_cols + nn
        self.perm = np.concatenate([i_cols, r2_cols, r_cols, v_cols])
        self.coef = np.concatenate([-2.0 * g_int, g, -2.0 * g, g]).astype(dtype)
        dr, dc = window_offsets(n)
        offsets = dr * self.shape[1] + dc
        # the rows whose window holds p are p - offset; p sits at that offset's column
        self.update_rows = np.tile(-offsets, 3)
        self.update_cols = np.concatenate([v_cols, r_cols, r2_cols])
        self.nn = nn
        self.base = base
        self.v_cols = v_cols
        self.lam = float(range_weight)
        self.missing_range = missing_range
        # three weight columns, W = table[p, perm3] * coef3: the intensity term, the
        # range term over the shared support, and the shared support's weight
        # Σ G V_p V_q (which multiplies the candidate's V columns)
        perm3 = np.zeros((self.perm.size, 3), dtype=np.int64)
        coef3 = np.zeros((self.perm.size, 3), dtype=dtype)
        perm3[:, 0] = perm3[:, 1] = self.perm
        coef3[:base, 0] = self.coef[:base]
        coef3[base:, 1] = self.coef[base:]
        perm3[base : base + nn, 2] = v_cols
        coef3[base : base + nn, 2] = g
        self.perm3, self.coef3 = perm3, coef3

    def _combine(self, terms: np.ndarray, self_terms: np.ndarray, support) -> np.ndarray:
        """Eq. 2 from the four exact sums (:func:`refsynth.numeric.combine_eq2`).

        ``terms[..., 0] + self_terms`` is ``Σ G Σ_c ΔI²``, ``terms[..., 1]`` the range
        term ``Σ_S G ΔR²``, ``terms[..., 2]`` the shared weight ``Σ_S G`` and
        ``support`` the target's ``Σ_A G``. Mean-filled:
        ``(λ Σ_S G ΔR² + λε) Σ_A G / (Σ_S G + ε)`` with ε = 1e-4 of the window's
        weight — the mean shared discrepancy charged to every offset the target
        has; with nothing shared, the whole span (λ per unit weight).
        """
        return combine_eq2(terms[..., 0] + self_terms, terms[..., 1], terms[..., 2], support,
                           self.divisor, self.lam, self.missing_range)

    def distances(self, p: int, candidates: np.ndarray) -> np.ndarray:
        """Eq. 2 between ``N_p`` and each candidate (flat padded indices)."""
        weights = self.table[p, self.perm3] * self.coef3
        rows, base, nn = self.table[candidates], self.base, self.nn
        terms = np.empty((rows.shape[0], 3))
        # one matrix-vector product per weight column, on the column block it touches
        # (two thirds of the (columns x 3) weights are zeros); exact on integers
        terms[:, 0] = rows[:, :base] @ weights[:base, 0]
        terms[:, 1] = rows[:, base:] @ weights[base:, 1]
        terms[:, 2] = rows[:, base : base + nn] @ weights[base : base + nn, 2]
        support = weights[:, 2].sum()
        return self._combine(terms, self.self_term[candidates] + self.self_term[p], support)

    def batch_distances(self, targets: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """:meth:`distances` for many targets at once (BP's candidate search).

        Parameters
        ----------
        targets : ndarray of int, shape (B,)
        candidates : ndarray of int, shape (B, M)

        Returns
        -------
        ndarray of shape (B, M)
        """
        weights = self.table[targets[:, None, None], self.perm3] * self.coef3
        rows, base, nn = self.table[candidates], self.base, self.nn
        terms = np.empty(rows.shape[:2] + (3,))
        terms[..., 0] = np.matmul(rows[..., :base], weights[:, :base, 0, None])[..., 0]
        terms[..., 1] = np.matmul(rows[..., base:], weights[:, base:, 1, None])[..., 0]
        terms[..., 2] = np.matmul(rows[..., base : base + nn],
                                  weights[:, base : base + nn, 2, None])[..., 0]
        self_terms = self.self_term[candidates] + self.self_term[targets][:, None]
        return self._combine(terms, self_terms, weights[:, :, 2].sum(axis=1)[:, None])

    def set_range(self, p: int, value: float) -> None:
        """Record normalised range ``value`` (a multiple of ``2**-16``) at padded index ``p``."""
        q = float(np.rint(value * 2.0**RANGE_BITS))
        vals = np.repeat(np.array([1.0, q, q * q]), self.nn)
        self.table[self.update_rows + p, self.update_cols] = vals
