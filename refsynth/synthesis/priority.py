r"""The synthesis order (§3.2.4, Eqs. 10–12), and the onion-peel order (Fig. 7).

Each unknown voxel ``V_p`` on the fill front ``δΩ`` (unknown, with a known or
already synthesized 8-neighbour) gets the priority

.. math::

    P(V_p) = C(V_p)\,D(V_p) + \frac{1}{1 + E}                          \quad (10)

    C(V_p) = \frac{\sum_{i \in N_p \cap \zeta} C(V_i)}{|N_p|}           \quad (11)

    D(V_p) = 1 - \frac{|\nabla I^\perp_p \cdot n_p|}{\alpha}           \quad (12)

* ``E`` counts the Canny edge pixels in ``N_p``; pixels *on* an edge are
  synthesized last (they form a second tier: they are taken only when no
  non-edge pixel is left on the front; ``edges_last=False`` drops the tier and
  keeps only the ``1 / (1 + E)`` term).
* ``C`` is 1 where range was measured and 0 where it is unknown. ``|N_p|``
  counts the voxels of ``N_p`` that lie in the image, so a fully known window
  has ``C = 1`` also at the border. When ``V_p`` is synthesized it receives
  ``C(N_best)``, the Eq. 11 confidence of the neighbourhood it matched best —
  "the confidence of the augmented voxel which most resemble the neighborhood
  of ``V_p`` is assigned to ``C(V_p)``" (``confidence_update="best"``, the
  default); ``"product"`` gives ``C(V_p) · C(N_best)``, which decays with
  distance from measured data (:mod:`refsynth.synthesis.nonparametric`).
* ``∇I⊥_p`` is the isophote *of the range*: the mean range gradient over the
  pairs of horizontally (vertically) adjacent voxels of ``N_p`` that both have
  range, rotated by 90°. Both voxels of a pair lie in ``N_p``, so the term
  reaches equally far on every side: mirroring the input mirrors the order.
  ``n_p`` is the unit normal of the front, the normalised Sobel gradient of
  the filled mask. The range is normalised by the
  span of the known range, so ``α = 1``. Note the ``1 −``: unlike Criminisi et
  al. (2003), an isophote flowing into the hole *lowers* the priority,
  deferring voxels near depth discontinuities.
* Ties are broken by a seeded random permutation of the pixels.

The numeric contract (:mod:`refsynth.numeric`): the range is a multiple of
``2**-16`` and a synthesized confidence of ``2**-40``, so every running sum
below is exact and equals a fresh sum in any order; ``‖n_p‖`` is
``sqrt(m_row² + m_col²)`` (libm's ``hypot`` is not correctly rounded).

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

from refsynth._checks import check_int

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


def _pair_sum(values: np.ndarray, n: int, axis: int) -> np.ndarray:
    """Sum, over the n×n window, of pair values stored at the pair's first voxel.

    Only pairs with *both* voxels in the window count: along ``axis`` the first
    voxel lies in the window's first ``n − 1`` rows (columns).
    """
    kernel = np.ones((n, n))
    if axis == 0:
        kernel[-1, :] = 0.0
    else:
        kernel[:, -1] = 0.0
    return ndimage.correlate(np.asarray(values, dtype=np.float64), kernel, mode="constant",
                             cval=0.0)


def range_gradient(
    range_norm: np.ndarray, filled: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The range gradient at each pixel from the available range in ``N_p``.

    The mean forward difference over the pairs of vertically (horizontally)
    adjacent voxels of the window (both voxels in it) that both have range; 0
    where there is none.

    Returns
    -------
    g_row, g_col : ndarray of shape (H, W)
    """
    d_row, v_row, d_col, v_col = _pair_differences(range_norm, filled)
    g_row = _pair_sum(d_row, n, 0) / np.maximum(_pair_sum(v_row, n, 0), 1.0)
    g_col = _pair_sum(d_col, n, 1) / np.maximum(_pair_sum(v_col, n, 1), 1.0)
    return g_row, g_col


def front_normals(filled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normal ``n_p`` of the fill front: the normalised Sobel gradient of the mask.

    Zero where the mask is locally flat.
    """
    mask = np.asarray(filled, dtype=np.float64)
    m_row = ndimage.correlate(mask, _SOBEL_ROW, mode="constant", cval=0.0)
    m_col = ndimage.correlate(mask, _SOBEL_COL, mode="constant", cval=0.0)
    norm = np.sqrt(m_row * m_row + m_col * m_col)
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


# fields of FillFront's per-pixel state (last axis)
_CONF, _DROW, _VROW, _DCOL, _VCOL, _MROW, _MCOL, _NEIGH, _COUNT, _EDGE = range(10)
_FIELDS = 10


def _update_templates(n: int) -> np.ndarray:
    """How filling one voxel changes the running sums on the (n+2)×(n+2) block around it.

    Row ``k`` of the result is the change for a unit value of coefficient ``k``
    of ``[confidence, left Δ, left pair, right Δ, right pair, up Δ, up pair,
    down Δ, down pair, mask]``, raveled over (row, col, field).
    """
    m = n + 2
    t = np.zeros((10, m, m, _FIELDS))
    centre = (slice(1, n + 1), slice(1, n + 1))
    t[0][centre + (_CONF,)] = 1.0
    # a pair counts in the windows that hold both its voxels: the new voxel p's
    # window, less the column (row) on the side away from its partner
    t[1][1 : n + 1, 1:n, _DCOL] = 1.0       # (p - e_col, p): windows left of p's edge
    t[2][1 : n + 1, 1:n, _VCOL] = 1.0
    t[3][1 : n + 1, 2 : n + 1, _DCOL] = 1.0  # (p, p + e_col)
    t[4][1 : n + 1, 2 : n + 1, _VCOL] = 1.0
    t[5][1:n, 1 : n + 1, _DROW] = 1.0       # (p - e_row, p)
    t[6][1:n, 1 : n + 1, _VROW] = 1.0
    t[7][2 : n + 1, 1 : n + 1, _DROW] = 1.0  # (p, p + e_row)
    t[8][2 : n + 1, 1 : n + 1, _VROW] = 1.0
    h = n // 2
    near = (slice(h, h + 3), slice(h, h + 3))
    t[9][near + (_MROW,)] = _SOBEL_ROW[::-1, ::-1]
    t[9][near + (_MCOL,)] = _SOBEL_COL[::-1, ::-1]
    t[9][near + (_NEIGH,)] = 1.0
    return t.reshape(10, -1)


class FillFront:
    """The fill front with its priorities (Eqs. 10–12), updated incrementally.

    Works on a frame padded by ``pad`` pixels on every side, so updates near
    the image border need no clipping. Per pixel it keeps, as running sums
    over the n×n window, the confidence (Eq. 11) and the range differences
    with their counts (Eq. 12's isophote), and the Sobel gradient of the
    filled mask (the front normal) and the 3×3 count of filled neighbours
    (the front). These live side by side in one pixel-major array, so filling
    a voxel is one small matrix product (:func:`_update_templates`) added to
    the (n+2)×(n+2) block around it, and re-prioritising reads that block once.

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
    edges_last : bool, default True
        With ``use_edges``: edge voxels form a second tier, taken only when no
        other voxel is left on the front; False keeps only Eq. 10's
        ``1 / (1 + E)`` term.
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
        edges_last: bool = True,
    ) -> None:
        h = n // 2
        pad = check_int("pad", pad, minimum=h + 1)  # n // 2 + 1
        self.n, self.h, self.pad = n, h, pad
        self.use_edges, self.use_isophotes = use_edges, use_isophotes
        H, W = known.shape
        self.shape = (H + 2 * pad, W + 2 * pad)
        self.inside = np.pad(np.ones((H, W), dtype=bool), pad)
        self.filled = np.pad(known, pad)
        self.range_norm = np.pad(np.where(known, range_norm, 0.0), pad)
        self.confidence = self.filled.astype(np.float64)
        state = np.empty(self.shape + (_FIELDS,))
        state[..., _CONF] = box_sum(self.confidence, n)
        d_row, v_row, d_col, v_col = _pair_differences(self.range_norm, self.filled)
        state[..., _DROW], state[..., _VROW] = _pair_sum(d_row, n, 0), _pair_sum(v_row, n, 0)
        state[..., _DCOL], state[..., _VCOL] = _pair_sum(d_col, n, 1), _pair_sum(v_col, n, 1)
        mask = self.filled.astype(np.float64)
        state[..., _MROW] = ndimage.correlate(mask, _SOBEL_ROW, mode="constant")
        state[..., _MCOL] = ndimage.correlate(mask, _SOBEL_COL, mode="constant")
        state[..., _NEIGH] = box_sum(mask, 3)
        state[..., _COUNT] = np.maximum(box_sum(self.inside, n), 1.0)
        edge_pad = np.pad(np.asarray(edges, dtype=bool), pad)
        state[..., _EDGE] = 1.0 / (1.0 + box_sum(edge_pad, n)) if use_edges else 1.0
        self.state = state
        self.templates = _update_templates(n)
        tiered = use_edges and edges_last
        self.tier = edge_pad.astype(np.int8) if tiered else np.zeros(self.shape, np.int8)
        self.tie = rng.permutation(self.inside.size).reshape(self.shape)
        self.current = np.full(self.shape, np.nan)

        front = self.inside & ~self.filled & (state[..., _NEIGH] > 0)
        p = self._priority(state)
        self.current[front] = p[front]
        flat = np.flatnonzero(front)
        self.heap: list[tuple[int, float, int, int]] = list(
            zip(
                self.tier.ravel()[flat].tolist(),
                (-p.ravel()[flat]).tolist(),
                self.tie.ravel()[flat].tolist(),
                flat.tolist(),
            )
        )
        heapq.heapify(self.heap)

    # -- Eq. 10 on a block of the state ---------------------------------------
    def _priority(self, block: np.ndarray) -> np.ndarray:
        c = block[..., _CONF] / block[..., _COUNT]
        if not self.use_isophotes:
            return c + block[..., _EDGE]
        g_row = block[..., _DROW] / np.maximum(block[..., _VROW], 1.0)
        g_col = block[..., _DCOL] / np.maximum(block[..., _VCOL], 1.0)
        m_row, m_col = block[..., _MROW], block[..., _MCOL]
        norm = np.sqrt(m_row * m_row + m_col * m_col)
        norm[norm == 0] = 1.0
        # Eq. 12 with alpha = 1; the isophote is the gradient turned by 90 degrees
        d = 1.0 - np.abs(g_row * m_col - g_col * m_row) / norm  # <= 1 by construction
        return c * np.maximum(d, 0.0) + block[..., _EDGE]

    def priorities(self) -> np.ndarray:
        """Eq. 10 over the padded frame (NaN off the front), for tests and figures."""
        p = self._priority(self.state)
        front = self.inside & ~self.filled & (self.state[..., _NEIGH] > 0)
        return np.where(front, p, np.nan)

    def confidence_at(self, flat: int | np.ndarray) -> np.ndarray | float:
        """Eq. 11 at padded flat index/indices ``flat``."""
        s = self.state.reshape(-1, _FIELDS)
        return s[flat, _CONF] / s[flat, _COUNT]

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

        Adds the change to every running sum on the windows that contain ``p``
        and, when ``update`` is True, re-prioritises the front around it.
        """
        i, j = divmod(p, self.shape[1])
        filled, r = self.filled, self.range_norm
        coef = [confidence, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        # the pairs (i, j-1)-(i, j), (i, j)-(i, j+1), (i-1, j)-(i, j), (i, j)-(i+1, j)
        if filled[i, j - 1]:
            coef[1], coef[2] = value - r[i, j - 1], 1.0
        if filled[i, j + 1]:
            coef[3], coef[4] = r[i, j + 1] - value, 1.0
        if filled[i - 1, j]:
            coef[5], coef[6] = value - r[i - 1, j], 1.0
        if filled[i + 1, j]:
            coef[7], coef[8] = r[i + 1, j] - value, 1.0
        filled[i, j] = True
        r[i, j] = value
        self.confidence[i, j] = confidence
        k = self.h + 1
        rows, cols = slice(i - k, i + k + 1), slice(j - k, j + k + 1)
        block = self.state[rows, cols]
        block += (np.array(coef) @ self.templates).reshape(block.shape)
        if update:
            self._reprioritise(block, rows, cols, i - k, j - k)

    def _reprioritise(self, block, rows, cols, top: int, left: int) -> None:
        front = (block[..., _NEIGH] > 0) & self.inside[rows, cols] & ~self.filled[rows, cols]
        p = self._priority(block)
        current = self.current[rows, cols]
        changed = front & (p != current)
        li, lj = np.nonzero(changed)
        if li.size == 0:
            return
        new = p[li, lj]
        current[li, lj] = new
        flat = ((li + top) * self.shape[1] + (lj + left)).tolist()
        entries = zip(
            self.tier[rows, cols][li, lj].tolist(),
            (-new).tolist(),
            self.tie[rows, cols][li, lj].tolist(),
            flat,
        )
        push, heap = heapq.heappush, self.heap
        for entry in entries:
            push(heap, entry)
