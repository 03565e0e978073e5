r"""The synthesis order (§3.2.4, Eqs. 10–12), and the onion-peel order (Fig. 7).

Each unknown voxel ``V_p`` on the fill front ``δΩ`` (unknown, with a known or
already synthesized 8-neighbour) gets the priority

.. math::

    P(V_p) = C(V_p)\,D(V_p) + \frac{1}{1 + E}                          \quad (10)

    C(V_p) = \frac{\sum_{i \in N_p \cap \zeta} C(V_i)}{|N_p|}           \quad (11)

    D(V_p) = 1 - \frac{|\nabla I^\perp_p \cdot n_p|}{\alpha}           \quad (12)

* ``E`` counts the Canny edge pixels in ``N_p``; pixels *on* an edge are
  synthesized last (they form a second tier: they are taken only when no
  non-edge pixel is left on the front).
* ``C`` is 1 where range was measured and 0 where it is unknown. ``|N_p|``
  counts the voxels of ``N_p`` that lie in the image, so a fully known window
  has ``C = 1`` also at the border. When ``V_p`` is synthesized it receives
  ``C(V_p) · C(N_best)``: its Eq. 11 confidence at that moment times the Eq. 11
  confidence of the neighbourhood it matched best — our reading of "the
  confidence of the augmented voxel which most resemble the neighborhood of
  ``V_p`` is assigned to ``C(V_p)``". Both factors lie in [0, 1], so
  confidence decays with distance from measured data.
* ``∇I⊥_p`` is the isophote *of the range*: the mean range gradient over the
  pairs of horizontally (vertically) adjacent voxels of ``N_p`` that both have
  range, rotated by 90°. ``n_p`` is the unit normal of the front, the
  normalised Sobel gradient of the filled mask. The range is normalised by the
  span of the known range, so ``α = 1``. Note the ``1 −``: unlike Criminisi et
  al. (2003), an isophote flowing into the hole *lowers* the priority,
  deferring voxels near depth discontinuities.
* Ties are broken by a seeded random permutation of the pixels.

The functions below compute each term over the whole image; :class:`FillFront`
keeps the same quantities up to date incrementally as voxels are filled (box
sums updated on the n×n window around each new voxel), so each step of the
sequential fill costs a few small array operations and heap pushes.

References
----------
Torres-Méndez & Dudek (2008), §3.2.4, Eqs. 10–12, Figs. 7, 9, 10,
doi:10.1007/s11263-007-0108-2.
A. Criminisi, P. Pérez and K. Toyama, "Object removal by exemplar-based
inpainting", CVPR 2003 (the notation and the confidence/data-term scheme).
"""

from __future__ import annotations

import heapq

import numpy as np
from scipy import ndimage

__all__ = [
    "box_sum",
    "fill_front",
    "confidence_term",
    "edge_count",
    "range_gradient",
    "front_normals",
    "data_term",
    "priority",
    "onion_order",
    "FillFront",
]

_SOBEL_ROW = np.array([[-1.0, -2.0, -1.0], [0.0, 0.0, 0.0], [1.0, 2.0, 1.0]])
_SOBEL_COL = _SOBEL_ROW.T.copy()
_EIGHT = np.ones((3, 3), dtype=bool)


def box_sum(values: np.ndarray, n: int) -> np.ndarray:
    """Sum of ``values`` over the n×n window centred on each pixel (zeros outside)."""
    return ndimage.correlate(
        np.asarray(values, dtype=np.float64), np.ones((n, n)), mode="constant", cval=0.0
    )


def fill_front(filled: np.ndarray) -> np.ndarray:
    """The fill front δΩ: unknown pixels with a filled 8-neighbour."""
    filled = np.asarray(filled, dtype=bool)
    return ~filled & ndimage.binary_dilation(filled, structure=_EIGHT)


def confidence_term(confidence: np.ndarray, n: int) -> np.ndarray:
    """Eq. 11: mean confidence over ``N_p``, counting the in-image voxels of the window.

    Parameters
    ----------
    confidence : ndarray of shape (H, W)
        Per-pixel confidence, 0 where the range is unknown.
    n : int
        Odd window side.
    """
    counts = box_sum(np.ones(confidence.shape), n)
    return box_sum(confidence, n) / counts


def edge_count(edges: np.ndarray, n: int) -> np.ndarray:
    """``E`` of Eq. 10: the number of edge pixels in ``N_p``."""
    return box_sum(np.asarray(edges, dtype=np.float64), n)


def _pair_differences(range_norm: np.ndarray, filled: np.ndarray):
    """Forward differences along rows and columns, and where both ends have range.

    The difference of the pair (p, p + e) is stored at p.
    """
    r = np.where(filled, range_norm, 0.0)
    d_col = np.zeros_like(r)
    v_col = np.zeros_like(r)
    d_col[:, :-1] = r[:, 1:] - r[:, :-1]
    v_col[:, :-1] = filled[:, 1:] & filled[:, :-1]
    d_row = np.zeros_like(r)
    v_row = np.zeros_like(r)
    d_row[:-1, :] = r[1:, :] - r[:-1, :]
    v_row[:-1, :] = filled[1:, :] & filled[:-1, :]
    return d_row * v_row, v_row, d_col * v_col, v_col


def range_gradient(
    range_norm: np.ndarray, filled: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The range gradient at each pixel from the available range in ``N_p``.

    The mean forward difference over the pairs of vertically (horizontally)
    adjacent voxels in the window that both have range; 0 where there is none.

    Returns
    -------
    g_row, g_col : ndarray of shape (H, W)
    """
    d_row, v_row, d_col, v_col = _pair_differences(range_norm, filled)
    g_row = box_sum(d_row, n) / np.maximum(box_sum(v_row, n), 1.0)
    g_col = box_sum(d_col, n) / np.maximum(box_sum(v_col, n), 1.0)
    return g_row, g_col


def front_normals(filled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normal ``n_p`` of the fill front: the normalised Sobel gradient of the mask.

    Zero where the mask is locally flat.
    """
    mask = np.asarray(filled, dtype=np.float64)
    m_row = ndimage.correlate(mask, _SOBEL_ROW, mode="constant", cval=0.0)
    m_col = ndimage.correlate(mask, _SOBEL_COL, mode="constant", cval=0.0)
    norm = np.hypot(m_row, m_col)
    safe = np.where(norm > 0, norm, 1.0)
    return m_row / safe, m_col / safe


def _data_term(g_row, g_col, n_row, n_col, alpha: float = 1.0):
    # isophote = gradient rotated by 90 degrees: (g_row, g_col) -> (-g_col, g_row)
    flow = np.abs(-g_col * n_row + g_row * n_col)
    return np.clip(1.0 - flow / alpha, 0.0, 1.0)


def data_term(
    range_norm: np.ndarray, filled: np.ndarray, n: int, alpha: float = 1.0
) -> np.ndarray:
    """Eq. 12: ``D = 1 − |∇I⊥_p · n_p| / α``, clipped to [0, 1].

    Parameters
    ----------
    range_norm : ndarray of shape (H, W)
        Range normalised by the span of the known range (so ``α = 1``).
    filled : ndarray of shape (H, W), bool
        Where range is known or already synthesized.
    n : int
        Odd window side.
    alpha : float, default 1
        The normalisation ``α``.
    """
    g_row, g_col = range_gradient(range_norm, filled, n)
    n_row, n_col = front_normals(filled)
    return _data_term(g_row, g_col, n_row, n_col, alpha)


def priority(
    confidence: np.ndarray,
    range_norm: np.ndarray,
    filled: np.ndarray,
    edges: np.ndarray,
    n: int,
    *,
    use_edges: bool = True,
    use_isophotes: bool = True,
) -> np.ndarray:
    """Eq. 10 over the whole image: ``P = C · D + 1 / (1 + E)``; NaN off the front.

    With ``use_edges=False`` the edge term is dropped (``E = 0``); with
    ``use_isophotes=False`` ``D = 1``.
    """
    c = confidence_term(confidence, n)
    d = data_term(range_norm, filled, n) if use_isophotes else np.ones(c.shape)
    e = edge_count(edges, n) if use_edges else np.zeros(c.shape)
    p = c * d + 1.0 / (1.0 + e)
    return np.where(fill_front(filled), p, np.nan)


def onion_order(known: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The onion-peel order (Fig. 7): layer by layer from the known region inwards.

    A pixel's layer is its chessboard distance to the nearest known pixel; the
    schedule is fixed before synthesis starts. Within a layer the order is a
    seeded random permutation.

    Returns
    -------
    ndarray of shape (N,)
        Flat indices of the unknown pixels, in fill order.
    """
    layer = ndimage.distance_transform_cdt(~known, metric="chessboard")
    unknown = np.flatnonzero(~known)
    tie = rng.permutation(unknown.size)
    return unknown[np.lexsort((tie, layer.ravel()[unknown]))]


class FillFront:
    """The fill front with its priorities (Eqs. 10–12), updated incrementally.

    Works on a frame padded by ``pad`` pixels on every side, so updates near
    the image border need no clipping. Quantities kept as running box sums
    over the n×n window: the confidence (Eq. 11), the range differences and
    their counts (Eq. 12's isophote), the Sobel gradient of the filled mask
    (the front normal) and the 3×3 count of filled neighbours (the front).

    Parameters
    ----------
    known : ndarray of shape (H, W), bool
    range_norm : ndarray of shape (H, W)
        Normalised range (any value where unknown).
    edges : ndarray of shape (H, W), bool
    n : int
        Odd window side.
    pad : int
        Padding of the frame, at least ``n // 2 + 1``.
    rng : numpy.random.Generator
        Breaks ties between equal priorities.
    use_edges, use_isophotes : bool
        As in :func:`priority`.
    """

    def __init__(
        self,
        known: np.ndarray,
        range_norm: np.ndarray,
        edges: np.ndarray,
        n: int,
        pad: int,
        rng: np.random.Generator,
        *,
        use_edges: bool = True,
        use_isophotes: bool = True,
    ) -> None:
        h = n // 2
        if pad < h + 1:
            raise ValueError(f"`pad` must be at least n // 2 + 1 = {h + 1}, got {pad}")
        self.n, self.h, self.pad = n, h, pad
        self.use_edges, self.use_isophotes = use_edges, use_isophotes
        H, W = known.shape
        self.shape = (H + 2 * pad, W + 2 * pad)
        box = np.pad(np.ones((H, W)), pad)
        self.inside = np.pad(np.ones((H, W), dtype=bool), pad)
        self.filled = np.pad(known, pad)
        self.range_norm = np.pad(np.where(known, range_norm, 0.0), pad)
        self.confidence = self.filled.astype(np.float64)
        # running sums over the n x n window
        self.conf_sum = box_sum(self.confidence, n)
        self.window_count = box_sum(box, n)
        d_row, v_row, d_col, v_col = _pair_differences(self.range_norm, self.filled)
        self.drow_sum, self.vrow_sum = box_sum(d_row, n), box_sum(v_row, n)
        self.dcol_sum, self.vcol_sum = box_sum(d_col, n), box_sum(v_col, n)
        mask = self.filled.astype(np.float64)
        self.mask_row = ndimage.correlate(mask, _SOBEL_ROW, mode="constant")
        self.mask_col = ndimage.correlate(mask, _SOBEL_COL, mode="constant")
        self.filled_neighbours = box_sum(mask, 3)
        edge_pad = np.pad(np.asarray(edges, dtype=bool), pad)
        self.edge_term = 1.0 / (1.0 + box_sum(edge_pad, n)) if use_edges else np.ones(self.shape)
        self.tier = edge_pad.astype(np.int8) if use_edges else np.zeros(self.shape, np.int8)
        self.tie = rng.permutation(self.inside.size).reshape(self.shape)
        self.current = np.full(self.shape, np.nan)
        self.heap: list[tuple[int, float, int, int]] = []
        self._wr = self._wc = slice(0, 0)

        front = self.inside & ~self.filled & (self.filled_neighbours > 0)
        p = self._priority(slice(None), slice(None))
        self.current[front] = p[front]
        flat = np.flatnonzero(front)
        self.heap = list(
            zip(
                self.tier.ravel()[flat].tolist(),
                (-p.ravel()[flat]).tolist(),
                self.tie.ravel()[flat].tolist(),
                flat.tolist(),
            )
        )
        heapq.heapify(self.heap)

    # -- Eq. 10 on a block of the frame ---------------------------------------
    def _priority(self, rows: slice, cols: slice) -> np.ndarray:
        c = self.conf_sum[rows, cols] / np.maximum(self.window_count[rows, cols], 1.0)
        if self.use_isophotes:
            g_row = self.drow_sum[rows, cols] / np.maximum(self.vrow_sum[rows, cols], 1.0)
            g_col = self.dcol_sum[rows, cols] / np.maximum(self.vcol_sum[rows, cols], 1.0)
            m_row, m_col = self.mask_row[rows, cols], self.mask_col[rows, cols]
            norm = np.hypot(m_row, m_col)
            norm = np.where(norm > 0, norm, 1.0)
            d = _data_term(g_row, g_col, m_row / norm, m_col / norm)
        else:
            d = 1.0
        return c * d + self.edge_term[rows, cols]

    def confidence_at(self, flat: int | np.ndarray) -> np.ndarray | float:
        """Eq. 11 at padded flat index/indices ``flat``."""
        return self.conf_sum.flat[flat] / self.window_count.flat[flat]

    def pop(self) -> int:
        """Remove and return the padded flat index of the highest-priority front voxel.

        Returns -1 when the front is empty.
        """
        heap, current, filled = self.heap, self.current.ravel(), self.filled.ravel()
        while heap:
            _, neg_p, _, p = heapq.heappop(heap)
            if not filled[p] and current[p] == -neg_p:
                return p
        return -1

    def fill(self, p: int, value: float, confidence: float, *, update: bool = True) -> None:
        """Record that padded flat index ``p`` received range ``value`` (normalised).

        Updates every running sum on the windows that contain ``p`` and, when
        ``update`` is True, re-prioritises the front around it.
        """
        W = self.shape[1]
        i, j = divmod(p, W)
        h = self.h
        filled, r = self.filled, self.range_norm
        filled[i, j] = True
        r[i, j] = value
        self.confidence[i, j] = confidence
        rows, cols = slice(i - h, i + h + 1), slice(j - h, j + h + 1)
        self.conf_sum[rows, cols] += confidence
        # pairs (i, j-1)-(i, j) and (i, j)-(i, j+1), (i-1, j)-(i, j) and (i, j)-(i+1, j)
        if filled[i, j - 1]:
            self.dcol_sum[rows, j - 1 - h : j + h] += value - r[i, j - 1]
            self.vcol_sum[rows, j - 1 - h : j + h] += 1.0
        if filled[i, j + 1]:
            self.dcol_sum[rows, cols] += r[i, j + 1] - value
            self.vcol_sum[rows, cols] += 1.0
        if filled[i - 1, j]:
            self.drow_sum[i - 1 - h : i + h, cols] += value - r[i - 1, j]
            self.vrow_sum[i - 1 - h : i + h, cols] += 1.0
        if filled[i + 1, j]:
            self.drow_sum[rows, cols] += r[i + 1, j] - value
            self.vrow_sum[rows, cols] += 1.0
        near_r, near_c = slice(i - 1, i + 2), slice(j - 1, j + 2)
        self.mask_row[near_r, near_c] += _SOBEL_ROW[::-1, ::-1]
        self.mask_col[near_r, near_c] += _SOBEL_COL[::-1, ::-1]
        self.filled_neighbours[near_r, near_c] += 1.0
        if update:
            self._reprioritise(i, j)

    def _reprioritise(self, i: int, j: int) -> None:
        k = self.h + 1
        rows, cols = slice(i - k, i + k + 1), slice(j - k, j + k + 1)
        front = (
            self.inside[rows, cols]
            & ~self.filled[rows, cols]
            & (self.filled_neighbours[rows, cols] > 0)
        )
        if not front.any():
            return
        p = self._priority(rows, cols)
        current = self.current[rows, cols]
        changed = front & (p != current)
        if not changed.any():
            return
        current[changed] = p[changed]
        li, lj = np.nonzero(changed)
        W = self.shape[1]
        flat = ((li + (i - k)) * W + (lj + (j - k))).tolist()
        neg = (-p[changed]).tolist()
        tier = self.tier[rows, cols][changed].tolist()
        tie = self.tie[rows, cols][changed].tolist()
        push = heapq.heappush
        heap = self.heap
        for entry in zip(tier, neg, tie, flat):
            push(heap, entry)
