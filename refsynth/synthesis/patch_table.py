r"""Eq. 2, expanded: the distance from one neighbourhood to a whole candidate set at once.

The fast form of :func:`refsynth.synthesis.similarity.eq2_distance` (the literal Eq. 2,
§3.2.2), bit for bit. NP (:mod:`refsynth.synthesis.nonparametric`) and BP
(:mod:`refsynth.synthesis.belief.fill`) evaluate Eq. 2 for every candidate of a pixel with
:class:`PatchTable` (NP's narrower :class:`refsynth.synthesis.filltable.FillTable` holds the
same integers). Expanding the squares separates what belongs to the target ``p`` from what
belongs to a candidate ``q``:

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
range term needs).

The numeric contract (:mod:`refsynth.numeric`): the table holds the intensity
and the range quantised to ``2**-16`` as float64 *integers*, and the Gaussian
window as the integer table :func:`refsynth.numeric.window_weights`. Every
partial sum of the expanded squares is then an integer below ``2**53``, so the
products are exact whatever BLAS, thread count or SIMD width computes them,
and :func:`refsynth.numeric.combine_eq2` turns the four sums into the distance
by the same IEEE operations as :func:`~refsynth.synthesis.similarity.eq2_distance`
(``tests/test_similarity.py`` checks the two equal under every reading of
``missing_range`` and ``channels``).

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.numeric import INTENSITY_BITS, RANGE_BITS, combine_eq2, window_weights
from refsynth.synthesis.neighbourhood import intensity_patches, window_offsets

__all__ = ["PatchTable"]


class PatchTable:
    """Every voxel's neighbourhood as one row ``[I | V | R | R²]`` (Eq. 2, expanded).

    Rows are indexed by flat position in a frame padded by ``pad`` pixels.
    ``distances(p, candidates)`` evaluates Eq. 2 between ``N_p`` and each
    candidate neighbourhood (in float64, bit for bit
    :func:`~refsynth.synthesis.similarity.eq2_distance` of each pair);
    ``set_range(p, value)`` records a newly known range in every row whose
    window contains ``p``.

    The rows hold ``I`` and ``R`` on the integer grid of the numeric contract,
    ``rint(2**16 x)`` of the normalised values given (and ``R²`` exactly), so
    that Eq. 2 is exact in any summation order (the module's docstring).

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
        the offsets both have (:mod:`refsynth.synthesis.similarity`);
        ``"ignore"`` is the literal Eq. 2.
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
