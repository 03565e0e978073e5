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
sequential fill costs a few small array operations, and the highest priority is
kept by :class:`refsynth.synthesis.frontqueue.FrontQueue` (no heap, no stale entries).

References
----------
Torres-Méndez & Dudek (2008), §3.2.4, Eqs. 10–12, Figs. 7, 9, 10,
doi:10.1007/s11263-007-0108-2.
A. Criminisi, P. Pérez and K. Toyama, "Object removal by exemplar-based
inpainting", CVPR 2003 (the notation and the confidence/data-term scheme).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import ndimage

from refsynth._checks import check_int
from refsynth.synthesis.frontqueue import ABSENT, FrontQueue
from refsynth.synthesis.onion import onion_order  # re-exported: Fig. 7's order

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


def box_sum(values: np.ndarray, n: int, out: np.ndarray | None = None) -> np.ndarray:
    """Sum of ``values`` over the n×n window centred on each pixel (zeros outside).

    Parameters
    ----------
    values : ndarray of shape (H, W)
        Any real values (bool is counted as 0/1).
    n : int
        The odd side of the square window summed.
    out : ndarray of shape (H, W), float64, optional
        Where to write the sums (a strided view is fine); default a new array.

    Returns
    -------
    ndarray of shape (H, W), float64
        The sum of ``values`` over each pixel's n×n window (zero outside the image).

    Examples
    --------
    >>> import numpy as np
    >>> box_sum(np.ones((3, 3)), 3).tolist()
    [[4.0, 6.0, 4.0], [6.0, 9.0, 6.0], [4.0, 6.0, 4.0]]
    """
    return ndimage.correlate(np.asarray(values, dtype=np.float64), np.ones((n, n)),
                             output=out, mode="constant", cval=0.0)


def fill_front(filled: np.ndarray) -> np.ndarray:
    """The fill front δΩ: unknown pixels with a filled 8-neighbour.

    Parameters
    ----------
    filled : ndarray of shape (H, W), bool
        Where the range is known or already synthesized.

    Returns
    -------
    ndarray of shape (H, W), bool
        True on δΩ.

    Examples
    --------
    >>> import numpy as np
    >>> filled = np.zeros((3, 4), dtype=bool); filled[:, 0] = True
    >>> fill_front(filled).astype(int).tolist()
    [[0, 1, 0, 0], [0, 1, 0, 0], [0, 1, 0, 0]]
    """
    filled = np.asarray(filled, dtype=bool)
    return ~filled & ndimage.binary_dilation(filled, structure=_EIGHT)


def confidence_term(confidence: np.ndarray, n: int) -> np.ndarray:
    """Eq. 11: mean confidence over ``N_p``, counting the in-image voxels of the window.

    Parameters
    ----------
    confidence : ndarray of shape (H, W)
        Per-pixel confidence ``C(V_i)`` in [0, 1]: 1 where the range was
        measured, a synthesized voxel's own (``C(N_best)``, see the module
        docstring), 0 where the range is still unknown.
    n : int
        The odd side of ``N_p``. ``|N_p|``, the divisor of Eq. 11, counts only
        the window's pixels inside the image, so a fully known window at the
        border has ``C = 1``.

    Returns
    -------
    ndarray of shape (H, W), float64
        ``C(V_p)`` in [0, 1] at every pixel, not only on the front.

    Examples
    --------
    >>> import numpy as np
    >>> confidence = np.zeros((3, 3)); confidence[0, 0] = 1.0
    >>> confidence_term(confidence, 3)[0, 0]   # 1 of the corner's 4 in-image voxels
    np.float64(0.25)
    """
    counts = box_sum(np.ones(confidence.shape), n)
    return box_sum(confidence, n) / counts


def edge_count(edges: np.ndarray, n: int) -> np.ndarray:
    """``E`` of Eq. 10: the number of edge pixels in ``N_p``.

    Parameters
    ----------
    edges : ndarray of shape (H, W), bool
        The Canny edge map (:func:`refsynth.synthesis.canny.canny`), True on
        an edge pixel.
    n : int
        The odd side of ``N_p``, the window whose edge pixels ``E`` counts;
        its part off the image counts no edge (the zeros of :func:`box_sum`).

    Returns
    -------
    ndarray of shape (H, W), float64
        ``E``: the edge pixels in each pixel's window.

    Examples
    --------
    >>> import numpy as np
    >>> edges = np.eye(3, dtype=bool)
    >>> edge_count(edges, 3)[1, 1], edge_count(edges, 1)[0, 1]
    (np.float64(3.0), np.float64(0.0))
    """
    return box_sum(np.asarray(edges, dtype=np.float64), n)


def _pair_differences(range_norm: np.ndarray, filled: np.ndarray, axis: int):
    """Forward differences along ``axis`` where both ends have range, and that indicator.

    The pair (p, p + e) is stored at p; both arrays float64, built in place (two frames).
    """
    r = np.where(filled, range_norm, 0.0)
    head = (slice(None, -1), slice(None)) if axis == 0 else (slice(None), slice(None, -1))
    tail = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
    d, v = np.zeros_like(r), np.zeros_like(r)
    np.subtract(r[tail], r[head], out=d[head])
    del r
    v[head] = filled[tail] & filled[head]
    return np.multiply(d, v, out=d), v


def _pair_sum(values: np.ndarray, n: int, axis: int,
              out: np.ndarray | None = None) -> np.ndarray:
    """Sum, over the n×n window, of pair values stored at the pair's first voxel.

    Only pairs with *both* voxels in the window count: along ``axis`` the first
    voxel lies in the window's first ``n − 1`` rows (columns). ``out`` as in
    :func:`box_sum`.
    """
    kernel = np.ones((n, n))
    if axis == 0:
        kernel[-1, :] = 0.0
    else:
        kernel[:, -1] = 0.0
    return ndimage.correlate(np.asarray(values, dtype=np.float64), kernel, output=out,
                             mode="constant", cval=0.0)


def range_gradient(
    range_norm: np.ndarray, filled: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The range gradient at each pixel from the available range in ``N_p``.

    The mean forward difference over the pairs of vertically (horizontally)
    adjacent voxels of the window (both voxels in it) that both have range; 0
    where there is none.

    Parameters
    ----------
    range_norm : ndarray of shape (H, W)
        Normalised range (any value where not ``filled``).
    filled : ndarray of shape (H, W), bool
        Where range is known or already synthesized.
    n : int
        The odd side of ``N_p``: both pixels of each pair averaged lie in it.

    Returns
    -------
    g_row, g_col : ndarray of shape (H, W)
        The mean range differences along rows and columns over the window's pairs.

    Examples
    --------
    >>> import numpy as np
    >>> ramp = np.tile(np.arange(4.0), (3, 1))          # rises by 1 per column
    >>> g_row, g_col = range_gradient(ramp, np.ones((3, 4), dtype=bool), 3)
    >>> float(g_row[1, 1]), float(g_col[1, 1])
    (0.0, 1.0)
    """
    gradient = []
    for axis in (0, 1):
        d, v = _pair_differences(range_norm, filled, axis)
        gradient.append(_pair_sum(d, n, axis) / np.maximum(_pair_sum(v, n, axis), 1.0))
    return gradient[0], gradient[1]


def front_normals(filled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normal ``n_p`` of the fill front: the normalised Sobel gradient of the mask.

    Zero where the mask is locally flat.

    Parameters
    ----------
    filled : ndarray of shape (H, W), bool
        Where range is known or already synthesized.

    Returns
    -------
    n_row, n_col : ndarray of shape (H, W)
        The unit normal of the front (0, 0 where the mask is flat).

    Examples
    --------
    >>> import numpy as np
    >>> filled = np.zeros((3, 4), dtype=bool); filled[:, :2] = True
    >>> n_row, n_col = front_normals(filled)
    >>> float(n_row[1, 2]), float(n_col[1, 2])   # the filled side is to the left
    (0.0, -1.0)
    """
    mask = np.asarray(filled, dtype=np.float64)
    m_row = ndimage.correlate(mask, _SOBEL_ROW, mode="constant", cval=0.0)
    m_col = ndimage.correlate(mask, _SOBEL_COL, mode="constant", cval=0.0)
    norm = np.sqrt(m_row * m_row + m_col * m_col)
    safe = np.where(norm > 0, norm, 1.0)
    return m_row / safe, m_col / safe


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
        The odd side of ``N_p`` (the window of the isophote's pairs).
    alpha : float, default 1
        The normalisation ``α``.

    Returns
    -------
    ndarray of shape (H, W)
        ``D(V_p)`` in [0, 1]; 1 where the mask is flat (``n_p = 0``:
        :func:`front_normals`), off the front.

    Examples
    --------
    >>> import numpy as np
    >>> filled = np.zeros((5, 5), dtype=bool); filled[:, :2] = True
    >>> float(data_term(np.full((5, 5), 0.5), filled, 3)[2, 2])   # constant range
    1.0
    """
    g_row, g_col = range_gradient(range_norm, filled, n)
    n_row, n_col = front_normals(filled)
    # isophote = gradient rotated by 90 degrees: (g_row, g_col) -> (-g_col, g_row)
    flow = np.abs(-g_col * n_row + g_row * n_col)
    return np.clip(1.0 - flow / alpha, 0.0, 1.0)


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

    Parameters
    ----------
    confidence : ndarray of shape (H, W)
        Per-pixel confidence, 0 where the range is unknown.
    range_norm : ndarray of shape (H, W)
        Range normalised by the span of the known range.
    filled : ndarray of shape (H, W), bool
        Where range is known or already synthesized.
    edges : ndarray of shape (H, W), bool
        The Canny edge map.
    n : int
        The odd side of ``N_p`` (Eqs. 10–12).
    use_edges : bool, default True
        Keep Eq. 10's ``1 / (1 + E)`` term (else ``E = 0``).
    use_isophotes : bool, default True
        Keep Eq. 12's data term (else ``D = 1``).

    Returns
    -------
    ndarray of shape (H, W)
        ``P(V_p)`` on the front, NaN elsewhere.

    Examples
    --------
    >>> import numpy as np
    >>> filled = np.zeros((3, 3), dtype=bool); filled[:, 0] = True
    >>> p = priority(filled.astype(float), np.zeros((3, 3)), filled,
    ...              np.zeros((3, 3), dtype=bool), 3)
    >>> float(p[1, 1]), bool(np.isnan(p[1, 2]))   # C = 3/9, D = 1, E = 0
    (1.3333333333333333, True)
    """
    c = confidence_term(confidence, n)
    d = data_term(range_norm, filled, n) if use_isophotes else np.ones(c.shape)
    e = edge_count(edges, n) if use_edges else np.zeros(c.shape)
    p = c * d + 1.0 / (1.0 + e)
    return np.where(fill_front(filled), p, np.nan)


# fields of FillFront's per-pixel state (last axis), ordered so that Eq. 10 reads contiguous
# slices: [C, Δ_row, Δ_col, m_col, m_row, m_col, −m_row] over [|N_p|, pairs_row, pairs_col]
_CONF, _DROW, _DCOL, _MCOL, _MROW, _MCOL2, _NMROW, _COUNT, _VROW, _VCOL, _NEIGH, _EDGE = range(12)
_FIELDS = 12
#: Subtracted from a closed pixel's ``_NEIGH`` (filled, or off the image), above its largest
#: count (9): the front is then exactly where ``_NEIGH > 0`` (integers: exact)
_CLOSED = 16.0


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
    t[9][near + (_MCOL,)] = t[9][near + (_MCOL2,)] = _SOBEL_COL[::-1, ::-1]
    t[9][near + (_NMROW,)] = -_SOBEL_ROW[::-1, ::-1]
    t[9][near + (_NEIGH,)] = 1.0
    t[9][h + 1, h + 1, _NEIGH] -= _CLOSED  # p itself closes
    return t.reshape(10, -1)


def _eq10(block: np.ndarray, isophotes: bool) -> np.ndarray:
    """Eq. 10 on FillFront's state (fields on the last axis); ``isophotes``: Eq. 12's D."""
    c = block[..., _CONF] / block[..., _COUNT]
    if not isophotes:
        return c + block[..., _EDGE]
    # (g_row, g_col): the pair sums over their counts (a zero count has a zero sum)
    g_row = block[..., _DROW] / np.maximum(block[..., _VROW], 1.0)
    g_col = block[..., _DCOL] / np.maximum(block[..., _VCOL], 1.0)
    m_row, m_col = block[..., _MROW], block[..., _MCOL]
    # the Sobel sums are integers: the norm is 0 (taken as 1) or at least 1
    norm = np.sqrt(np.maximum(m_row * m_row + m_col * m_col, 1.0))
    # Eq. 12 with alpha = 1; the isophote is the gradient turned by 90 degrees
    flow = g_row * m_col - g_col * m_row
    d = 1.0 - np.abs(flow) / norm  # <= 1 by construction
    return c * np.maximum(d, 0.0) + block[..., _EDGE]


class FillFront:
    """The fill front with its priorities (Eqs. 10–12), updated incrementally.

    Works on a frame padded by ``pad`` pixels on every side, so updates near
    the image border need no clipping. Per pixel it keeps, as running sums
    over the n×n window, the confidence (Eq. 11) and the range differences
    with their counts (Eq. 12's isophote), and the Sobel gradient of the
    filled mask (the front normal) and the 3×3 count of filled neighbours
    (less 16 on a closed pixel: the front is where it is positive). These
    live side by side in one pixel-major array, so filling a voxel is one
    small matrix product (:func:`_update_templates`) added to the max(n, 3)²
    block around it (where the sums change), and re-prioritising reads that
    block once and hands its keys to a
    :class:`~refsynth.synthesis.frontqueue.FrontQueue`. The order is that of
    the key ``(tier, −P, tie)``: lowest tier, highest Eq. 10 priority, smallest
    tie-break rank.

    Parameters
    ----------
    known : ndarray of shape (H, W), bool
    range_norm : ndarray of shape (H, W)
        Normalised range (any value where unknown).
    edges : ndarray of shape (H, W), bool
    n : int
        The odd side of ``N_p``, the window every update touches.
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

    Examples
    --------
    >>> import numpy as np
    >>> known = np.zeros((3, 4), dtype=bool); known[:, 0] = True
    >>> front = FillFront(known, np.where(known, 0.5, 0.0), np.zeros((3, 4), dtype=bool),
    ...                   3, 2, np.random.default_rng(0))
    >>> p = front.pop()                        # padded flat index, on column 1 of the image
    >>> divmod(p, front.shape[1])[1] - 2
    1
    >>> front.fill(p, 0.5, 1.0)
    >>> front.filled.sum()
    np.int64(4)
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
        # C order (np.pad keeps a transposed input's): the flat views below need it
        self.filled = np.ascontiguousarray(np.pad(known, pad))
        self.range_norm = np.ascontiguousarray(np.pad(np.where(known, range_norm, 0.0), pad))
        self.confidence = self.filled.astype(np.float64)
        # every field correlated straight into the state (out=), the pair terms one axis at
        # a time: a few frames of temporaries, not dozens (a float64 frame: 34 MB at 2048²)
        state = np.empty(self.shape + (_FIELDS,))
        box_sum(self.confidence, n, out=state[..., _CONF])
        for axis, d_field, v_field in ((0, _DROW, _VROW), (1, _DCOL, _VCOL)):
            d, v = _pair_differences(self.range_norm, self.filled, axis)
            _pair_sum(d, n, axis, out=state[..., d_field])
            _pair_sum(v, n, axis, out=state[..., v_field])
            del d, v
        mask = self.filled.astype(np.float64)
        ndimage.correlate(mask, _SOBEL_ROW, output=state[..., _MROW], mode="constant")
        ndimage.correlate(mask, _SOBEL_COL, output=state[..., _MCOL], mode="constant")
        state[..., _MCOL2] = state[..., _MCOL]
        np.negative(state[..., _MROW], out=state[..., _NMROW])
        box_sum(mask, 3, out=state[..., _NEIGH])
        del mask
        count = box_sum(self.inside, n, out=state[..., _COUNT])
        np.maximum(count, 1.0, out=count)
        edge_pad = np.pad(np.asarray(edges, dtype=bool), pad)
        if use_edges:  # 1 / (1 + E)
            edge = box_sum(edge_pad, n, out=state[..., _EDGE])
            np.add(1.0, edge, out=edge)
            np.divide(1.0, edge, out=edge)
        else:
            state[..., _EDGE] = 1.0
        self.state = state
        self.flat_state = state.reshape(-1, _FIELDS)
        self.reach = k = max(h, 1)
        templates = _update_templates(n).reshape(10, n + 2, n + 2, _FIELDS)
        centre = templates[:, h + 1 - k : h + 2 + k, h + 1 - k : h + 2 + k]
        assert np.count_nonzero(templates) == np.count_nonzero(centre)
        self.templates = centre.reshape(10, -1).copy()
        tiered = use_edges and edges_last
        self.tier = edge_pad.astype(np.int8) if tiered else np.zeros(self.shape, np.int8)
        self.tie = np.ascontiguousarray(rng.permutation(self.inside.size).reshape(self.shape))
        # unknown voxels inside the image; tier 1 (edge voxels) adds -2**63 to the key
        self.open = self.inside & ~self.filled
        self.tier_offset = np.ascontiguousarray(np.where(self.tier != 0, ABSENT, 0), np.int64)
        self.queue = FrontQueue(self.tie.ravel())

        # the front (unknown voxels with a filled 8-neighbour) is where _NEIGH > 0
        np.subtract(state[..., _NEIGH], _CLOSED, out=state[..., _NEIGH], where=~self.open)
        front = state[..., _NEIGH] > 0
        # per step, the single values through memoryviews of the flat frames (Python floats
        # and bools, the same values as numpy's scalars)
        self._filled_mv, self._open_mv, self._range_mv, self._confidence_mv = (
            memoryview(a.reshape(-1)) for a in (self.filled, self.open, self.range_norm,
                                             self.confidence))
        self._state_mv = memoryview(state.reshape(-1))
        flat = np.flatnonzero(front)
        p = _eq10(self.flat_state[flat], use_isophotes)  # Eq. 10 on the front only
        self.queue.set(flat, p.view(np.int64) + self.tier_offset.ravel()[flat])
        #: :meth:`fill` as ``fill_step(p, value, confidence, update=True)`` (NP's loop calls it)
        self.fill_step = self._stepper()

    def priorities(self) -> np.ndarray:
        """Eq. 10 over the padded frame (NaN off the front), for tests and figures."""
        p = _eq10(self.state, self.use_isophotes)
        front = self.inside & ~self.filled & (self.state[..., _NEIGH] > 0)
        return np.where(front, p, np.nan)

    def confidence_at(self, flat: int | np.ndarray) -> np.ndarray | float:
        """Eq. 11 at padded flat index/indices ``flat``."""
        s = self.state.reshape(-1, _FIELDS)
        return s[flat, _CONF] / s[flat, _COUNT]

    def confidence_of(self, flat: int) -> float:
        """Eq. 11 at one padded flat index, as a Python float (:meth:`confidence_at`'s value)."""
        s, at = self._state_mv, flat * _FIELDS
        return s[at + _CONF] / s[at + _COUNT]

    def pop(self) -> int:
        """Remove and return the padded flat index of the highest-priority front voxel.

        Returns -1 when the front is empty.
        """
        return self.queue.pop()

    def fill(self, p: int, value: float, confidence: float, *, update: bool = True) -> None:
        """Record that padded flat index ``p`` received range ``value`` (normalised).

        Adds the change to every running sum on the windows that contain ``p``
        and, when ``update`` is True, re-prioritises the front around it
        (:attr:`fill_step`, which NP's loop calls directly).
        """
        self.fill_step(p, value, confidence, update)

    def _stepper(self) -> Callable[[int, float, float, bool], None]:
        """:meth:`fill` as a closure over its arrays, views and constants.

        A step runs about thirty numpy calls on a few dozen numbers, so the Python around
        them counts: the closure reads its operands from local names, where methods would
        look each one up on ``self`` at every step. Re-prioritising the block is
        :func:`_eq10` (Eqs. 10–12) on it, field-major, in buffers: the same operations.
        """
        width, side = self.shape[1], 2 * self.reach + 1
        filled, r = self._filled_mv, self._range_mv  # flat, by memoryview
        is_open, confidences = self._open_mv, self._confidence_mv
        # the templates' coefficients: confidence, 4 pairs' difference and count, mask (1)
        coef = np.array([0.0] * 9 + [1.0])
        c_mv = memoryview(coef)
        templates, reach = self.templates, self.reach
        offset = reach * (width + 1)  # p less its block's top-left pixel
        field_frame = self.state.transpose(2, 0, 1)  # field-major, as the step reads a block
        change = np.empty(templates.shape[1])  # a fill's change to the block
        change_fields = change.reshape(side, side, _FIELDS).transpose(2, 0, 1)  # field-major
        add, maximum, divide, multiply = np.add, np.maximum, np.divide, np.multiply
        subtract, sqrt, absolute, greater, where = (np.subtract, np.sqrt, np.abs, np.greater,
                                                    np.where)
        # the block's flat offsets from its top-left pixel (1-d indices: cheap to scatter)
        block_offsets = (np.arange(side)[:, None] * width + np.arange(side)[None, :]).ravel()
        at_array = np.zeros((), dtype=np.int64)  # the block's top-left pixel, as a 0-d array
        take_tier, take_tie = self.tier_offset.reshape(-1).take, self.tie.reshape(-1).take
        shift = np.array(self.queue.shift)  # a slot's block: slot >> shift
        right_shift, set_in_blocks = np.right_shift, self.queue.set_in_blocks
        # Eq. 10's buffers on the block, field-major, and their views (about a µs each)
        fields, products = np.empty((_FIELDS, side, side)), np.empty((4, side, side))
        quotient, divisors, pair = (np.empty((7, side, side)), np.ones((7, side, side)),
                                    np.empty((2, side, side)))
        counts, count_divisors = fields[_COUNT : _VCOL + 1], divisors[:3]
        numerators, gradient, normal = fields[_CONF : _NMROW + 1], quotient[1:5], quotient[3:7]
        left, right, flow, norm = products[0::2], products[1::2], pair[0], pair[1]
        c, edge, neigh = quotient[0], fields[_EDGE], fields[_NEIGH].reshape(-1)
        keys = pair[0].view(np.int64).reshape(-1)  # the block's priorities, as int64
        # the constants as arrays: a ufunc takes a Python scalar by a slower path (0.3 µs)
        ones3, one, zero = np.ones((3, side, side)), np.ones((side, side)), np.zeros((side, side))
        zeros, absent = np.zeros(side * side), np.full(side * side, ABSENT, dtype=np.int64)
        isophotes = self.use_isophotes  # else Eq. 10 by _eq10, D = 1

        def step(p: int, value: float, confidence: float, update: bool = True) -> None:
            c_mv[0] = confidence
            # the pairs (i, j-1)-(i, j), (i, j)-(i, j+1), (i-1, j)-(i, j), (i, j)-(i+1, j)
            c_mv[1], c_mv[2] = (value - r[p - 1], 1.0) if filled[p - 1] else (0.0, 0.0)
            c_mv[3], c_mv[4] = (r[p + 1] - value, 1.0) if filled[p + 1] else (0.0, 0.0)
            c_mv[5], c_mv[6] = (value - r[p - width], 1.0) if filled[p - width] else (0.0, 0.0)
            c_mv[7], c_mv[8] = (r[p + width] - value, 1.0) if filled[p + width] else (0.0, 0.0)
            filled[p] = True
            is_open[p] = False
            r[p] = value
            confidences[p] = confidence
            # the templates' support: the central max(n, 3)² of the (n+2)² block, so no
            # other voxel's sums, and hence priority, change
            at = p - offset
            row, col = divmod(at, width)
            block = field_frame[:, row : row + side, col : col + side]
            coef.dot(templates, out=change)
            add(block, change_fields, block)
            if not update:
                return
            # every voxel of the block gets its key afresh: Eq. 10 on the front, absent
            # elsewhere; the block's pixels by flat index
            at_array[()] = at
            pixels = add(block_offsets, at_array)
            if isophotes:
                # one product forms g · m and m² (m_c² − (−m_r²), exact)
                fields[...] = block
                # [C, Δ_row, Δ_col, m] / [|N_p|, pairs_row, pairs_col, 1, ...]: c, g, m
                maximum(counts, ones3, out=count_divisors)
                divide(numerators, divisors, quotient)
                multiply(gradient, normal, products)  # g_r m_c, g_c m_r, m_c², −m_r²
                subtract(left, right, pair)  # the flow, the squared norm
                maximum(norm, one, out=norm)
                sqrt(norm, norm)
                absolute(flow, flow)
                divide(flow, norm, flow)
                subtract(one, flow, flow)
                maximum(flow, zero, out=flow)
                multiply(c, flow, flow)
                add(flow, edge, flow)  # Eq. 10, its bits read as the keys
                block_keys, on = keys, greater(neigh, zeros)  # on the front
            else:
                block_keys = _eq10(block.transpose(1, 2, 0), False).view(np.int64).ravel()
                on = (block[_NEIGH] > 0).ravel()
            block_keys += take_tier(pixels)
            slots = take_tie(pixels)
            set_in_blocks(slots, right_shift(slots, shift), where(on, block_keys, absent))

        return step
