r"""Non-parametric sampling (NP) range synthesis (§3.2.2, Eqs. 2–5).

For the voxel ``V_p`` chosen next by the fill order (:mod:`refsynth.synthesis.priority`):

.. math::

    A_p = \{ N_q : \|p - q\| \le r,\ R_q \text{ known or synthesized} \}       \quad (3)

    N_{best} = \arg\min_{N_q \in A_p} \|N_p - N_q\|                          \quad (4)

    \Gamma'(R_p) = \{ N_q \in A_p : \|N_p - N_q\| \le (1 + \epsilon)\,
                   \|N_p - N_{best}\| \}                                       \quad (5)

and ``R_p`` is drawn (seeded) from the histogram of the centre ranges of
``Γ'``. Each member of ``Γ'`` counts once in that histogram, so the draw is a
uniform choice of a member. We use ``≤`` in Eq. 5 (the paper writes ``<``) so
that the set always holds the best match, even when its distance is 0.

How each step stays a few numpy calls
-------------------------------------
Expanding the squares of Eq. 2 (:mod:`refsynth.synthesis.similarity`) separates what
belongs to the target ``p`` from what belongs to a candidate ``q``:

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
range term of :mod:`refsynth.synthesis.similarity` needs).

A gap wider than ``r``
----------------------
The fill proceeds along the front ``δΩ``: every voxel it picks has a known or
synthesized 8-neighbour, so ``A_p`` is never empty for ``r ≥ √2``; deep inside
a wide gap the candidates are voxels synthesized earlier, as Eq. 3 allows. If
``A_p`` is empty nonetheless (``1 ≤ r < √2`` with only a diagonal neighbour, or
the onion order), the search widens to every filled voxel within ``d + r`` of
``p``, where ``d`` is the distance to the nearest filled voxel.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eqs. 2–5, doi:10.1007/s11263-007-0108-2.
A. A. Efros and T. K. Leung, "Texture synthesis by non-parametric sampling",
ICCV 1999.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.synthesis.neighbourhood import (
    disc_offsets,
    gaussian_window,
    intensity_patches,
    window_offsets,
)
from refsynth.synthesis.priority import FillFront, onion_order
from refsynth.synthesis.similarity import intensity_scale, range_scale

__all__ = ["np_fill", "eq5_set", "PatchTable"]

#: ε of the mean-filled range term: a prior pseudo-offset of this weight (the
#: Gaussian window sums to 1) whose discrepancy is the whole known span.
_SUPPORT_PRIOR = 1e-4


def eq5_set(distances: np.ndarray, epsilon: float) -> np.ndarray:
    """Eq. 5: indices of the candidates within ``(1 + ε)`` of the best match's distance.

    Parameters
    ----------
    distances : ndarray of shape (M,), M >= 1
        Eq. 2 distances of the candidate set ``A_p``.
    epsilon : float
        ε >= 0.

    Returns
    -------
    ndarray of int
        Indices into ``distances``, ascending; always includes ``argmin``.
    """
    return np.flatnonzero(distances <= (1.0 + epsilon) * distances.min())


class PatchTable:
    """Every voxel's neighbourhood as one row ``[I | V | R | R²]`` (Eq. 2, expanded).

    Rows are indexed by flat position in a frame padded by ``pad`` pixels.
    ``distances(p, candidates)`` evaluates Eq. 2 between ``N_p`` and each
    candidate neighbourhood; ``set_range(p, value)`` records a newly known
    range in every row whose window contains ``p``.

    Parameters
    ----------
    image : ndarray of shape (H, W, C)
        Intensity, normalised.
    range_norm : ndarray of shape (H, W)
        Normalised range, NaN where unknown.
    n : int
        Odd window side.
    pad : int
        Padding of the frame (at least ``n // 2``).
    range_weight : float
        λ of Eq. 2.
    missing_range : {"mean", "ignore"}
        How the range term treats offsets where ``N_p`` has range and the
        candidate has none: ``"mean"`` charges them the mean discrepancy of
        the offsets both have (see :mod:`refsynth.synthesis.similarity`); ``"ignore"``
        is the literal Eq. 2.
    dtype : numpy dtype, default float64
        NP uses float32: half the memory traffic of the per-step gather; the
        expanded squares then carry errors of order 1e-6 λ, far below the
        differences Eq. 5 separates.
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
    ) -> None:
        H, W, C = image.shape
        self.shape = (H + 2 * pad, W + 2 * pad)
        nn = n * n
        g = gaussian_window(n).ravel()
        rows = self.shape[0] * self.shape[1]
        table = np.zeros((rows, nn * C + 3 * nn), dtype=dtype)
        frame = table.reshape(self.shape + (nn * C + 3 * nn,))
        inner = frame[pad : pad + H, pad : pad + W]
        patches = intensity_patches(image, n).reshape(H, W, nn * C)
        inner[:, :, : nn * C] = patches
        h = n // 2
        rpad = np.pad(range_norm, h, mode="constant", constant_values=np.nan)
        rp = sliding_window_view(rpad, (n, n)).reshape(H, W, nn)
        has = np.isfinite(rp)
        base = nn * C
        inner[:, :, base : base + nn] = has
        inner[:, :, base + nn : base + 2 * nn] = np.where(has, rp, 0.0)
        inner[:, :, base + 2 * nn :] = np.where(has, rp, 0.0) ** 2
        self.table = table
        g_int = np.repeat(g, C) / C  # intensity columns are (offset, channel) raveled
        self.self_term = (table[:, :base] ** 2) @ g_int.astype(dtype)
        # weight vector of p = table[p, perm] * coef
        i_cols = np.arange(base)
        v_cols = base + np.arange(nn)
        r_cols = v_cols + nn
        r2_cols = r_cols + nn
        self.perm = np.concatenate([i_cols, r2_cols, r_cols, v_cols])
        lam = float(range_weight)
        self.coef = np.concatenate([-2.0 * g_int, lam * g, -2.0 * lam * g, lam * g]).astype(dtype)
        dr, dc = window_offsets(n)
        offsets = dr * self.shape[1] + dc
        # the rows whose window holds p are p - offset; p sits at that offset's column
        self.update_rows = np.tile(-offsets, 3)
        self.update_cols = np.concatenate([v_cols, r_cols, r2_cols])
        self.nn = nn
        self.v_cols = v_cols
        self.lam = lam
        self.mean_fill = missing_range == "mean"
        # three weight columns at once, W = table[p, perm3] * coef3: the intensity
        # term, the range term over the shared support, and the shared support's
        # weight Σ G V_p V_q (which multiplies the candidate's V columns)
        perm3 = np.zeros((self.perm.size, 3), dtype=np.int64)
        coef3 = np.zeros((self.perm.size, 3), dtype=dtype)
        perm3[:, 0] = perm3[:, 1] = self.perm
        coef3[:base, 0] = self.coef[:base]
        coef3[base:, 1] = self.coef[base:]
        perm3[base : base + nn, 2] = v_cols
        coef3[base : base + nn, 2] = g
        self.perm3, self.coef3 = perm3, coef3

    def _combine(self, terms: np.ndarray, self_terms: np.ndarray, support) -> np.ndarray:
        """Eq. 2 from the products: intensity + range (mean-filled or literal).

        Mean-filled: ``(Σ_S G ΔR² + λε) Σ_A G / (Σ_S G + ε)`` with ε = 1e-4 of the
        window's weight — the mean shared discrepancy charged to every offset the
        target has; with nothing shared, the whole span (λ per unit weight).
        """
        d = terms[..., 0] + self_terms
        range_sum = np.maximum(terms[..., 1], 0.0)
        if self.mean_fill:
            range_sum += self.lam * _SUPPORT_PRIOR
            range_sum *= support / (terms[..., 2] + _SUPPORT_PRIOR)
        d += range_sum
        return np.maximum(d, 0.0, out=d)

    def distances(self, p: int, candidates: np.ndarray) -> np.ndarray:
        """Eq. 2 between ``N_p`` and each candidate (flat padded indices)."""
        weights = self.table[p, self.perm3] * self.coef3
        terms = self.table[candidates] @ weights
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
        terms = np.matmul(self.table[candidates], weights)
        self_terms = self.self_term[candidates] + self.self_term[targets][:, None]
        return self._combine(terms, self_terms, weights[:, :, 2].sum(axis=1)[:, None])

    def set_range(self, p: int, value: float) -> None:
        """Record normalised range ``value`` at flat padded index ``p``."""
        vals = np.repeat(np.array([1.0, value, value * value]), self.nn)
        self.table[self.update_rows + p, self.update_cols] = vals


def _widened_candidates(p: int, filled: np.ndarray, width: int, radius: float) -> np.ndarray:
    """All filled voxels within ``d + radius`` of ``p`` (``d``: distance to the nearest)."""
    flat = np.flatnonzero(filled)
    pr, pc = divmod(p, width)
    dist = np.hypot(flat // width - pr, flat % width - pc)
    return flat[dist <= dist.min() + radius]


def np_fill(
    image: np.ndarray,
    range_values: np.ndarray,
    edges: np.ndarray,
    rng: np.random.Generator,
    *,
    neighbourhood: int = 5,
    radius: float = 10.0,
    epsilon: float = 0.1,
    use_edges: bool = True,
    use_isophotes: bool = True,
    ordering: str = "priority",
    range_weight: float = 16.0,
    missing_range: str = "mean",
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fill the unknown range by NP sampling in the chosen order (§3.2.2, §3.2.4).

    Called by :func:`refsynth.synthesize`, which validates the inputs.

    Parameters
    ----------
    image : ndarray of shape (H, W, C), float
    range_values : ndarray of shape (H, W), NaN where unknown
    edges : ndarray of shape (H, W), bool
    rng : numpy.random.Generator
    neighbourhood, radius, epsilon, use_edges, use_isophotes, ordering, range_weight, progress
        See :func:`refsynth.synthesize`.

    Returns
    -------
    range : ndarray of shape (H, W)
        Dense range; measured values unchanged.
    confidence : ndarray of shape (H, W)
        1 where measured, the Eq. 11 confidence assigned at synthesis elsewhere.
    order : ndarray of shape (N, 2), int64
        Synthesized pixels (row, col) in fill order.
    """
    H, W = range_values.shape
    n = neighbourhood
    known = np.isfinite(range_values)
    low, span = range_scale(range_values)
    range_norm = (range_values - low) / span
    image = image / intensity_scale(image)

    pad = max(int(np.ceil(radius)), n // 2 + 1)
    table = PatchTable(image, range_norm, n, pad, range_weight, missing_range, np.float32)
    front = FillFront(
        known,
        range_norm,
        edges,
        n,
        pad,
        rng,
        use_edges=use_edges,
        use_isophotes=use_isophotes,
    )
    Wp = front.shape[1]
    dr, dc = disc_offsets(radius)
    disc = dr * Wp + dc
    filled = front.filled.ravel()
    values = front.range_norm.ravel()
    # the range in the caller's unit, so that a copied value is copied bit for bit
    original = np.pad(np.where(known, range_values, 0.0), pad).ravel()

    total = int((~known).sum())
    draws = rng.random(total)
    if ordering == "onion":
        schedule = onion_order(known, rng)
        schedule = (schedule // W + pad) * Wp + (schedule % W + pad)
    order = np.empty(total, dtype=np.int64)
    tick = max(1, min(2000, total // 20))
    for step in range(total):
        p = int(schedule[step]) if ordering == "onion" else front.pop()
        candidates = p + disc
        candidates = candidates[filled[candidates]]
        if candidates.size == 0:
            candidates = _widened_candidates(p, filled, Wp, radius)
        d = table.distances(p, candidates)
        best = int(np.argmin(d))
        members = eq5_set(d, epsilon)
        q = int(candidates[members[int(draws[step] * members.size)]])
        value = float(values[q])
        original[p] = original[q]
        confidence = float(front.confidence_at(p) * front.confidence_at(candidates[best]))
        front.fill(p, value, confidence, update=ordering != "onion")
        table.set_range(p, value)
        order[step] = p
        if progress is not None and (step + 1) % tick == 0:
            progress(step + 1, total)
    if progress is not None:
        progress(total, total)

    inner = (slice(pad, pad + H), slice(pad, pad + W))
    out = np.where(known, range_values, original.reshape(front.shape)[inner])
    confidence = front.confidence[inner].copy()
    rows, cols = np.divmod(order, Wp)
    return out, confidence, np.stack([rows - pad, cols - pad], axis=1).astype(np.int64)
