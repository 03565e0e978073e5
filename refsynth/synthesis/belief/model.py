r"""BP's model (§3.2.3, Eqs. 6–7, Fig. 6, steps 3–4): Φ, Ψ and the grid of nodes.

Eq. 7, the local evidence of a label, and Eq. 6, the compatibility of two
neighbouring nodes' labels, both in the log domain:

.. math:: \log \Phi(x_i^l, y_i) = -\frac{|y_i^l - y_i|^2}{2\sigma_i^2}, \qquad
          \log \Psi(x_k^l, x_j^m) = -\frac{|d_{jk}^l - d_{kj}^m|^2}{2\sigma_s^2}

``|d − d'|²`` is the *mean* squared difference over the pixels the two
candidate patches share where both have range (Ψ = 1 where none):
:func:`pair_compatibilities` for two unknown neighbours (k × k),
:func:`fixed_neighbour_terms` for an unknown node beside a measured one (whose
message is a fixed unary term). :func:`grid_edges` lists the pairs of the
4-neighbourhood. :func:`refsynth.synthesis.belief.fill.bp_fill` assembles them.

The numeric contract (:mod:`refsynth.numeric`): the range is on the ``2**-16``
grid of its span, so the expanded squares of Eq. 6 are integer sums, exact in
any order (matrix products included), and one scaling and one division make
the mean.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eqs. 6–7, Fig. 6,
doi:10.1007/s11263-007-0108-2.
W. T. Freeman, E. C. Pasztor and O. T. Carmichael, "Learning low-level
vision", IJCV 40:25–47 (2000) (overlap compatibilities).
"""

from __future__ import annotations

import numpy as np

from refsynth.numeric import RANGE_BITS

__all__ = ["phi", "psi", "pair_compatibilities", "fixed_neighbour_terms", "grid_edges",
           "Compatibilities", "COMPATIBILITIES"]

#: The readings of Eq. 6's mean square: over the overlap alone (the default), or with the
#: two patches' centres as one more shared pixel (a departure,
#: :mod:`refsynth.synthesis.belief.centres`).
COMPATIBILITIES = ("overlap", "overlap-centres")

_PSI_BLOCK = 512  # pairs per block of Eq. 6: about 0.3 MB per temporary, in the cache


# -- steps 3 and 4: compatibilities ----------------------------------------------------


def phi(distance: np.ndarray, sigma_i: float) -> np.ndarray:
    r"""Eq. 7 in the log domain: ``log Φ = −|y^l − y|² / (2σ_i²)``.

    Parameters
    ----------
    distance : array_like of float
        ``|y^l − y|²``, the Eq. 2 distance of the observation patches (plus
        the proximity prior).
    sigma_i : float
        σ_i of Eq. 7, > 0.

    Returns
    -------
    ndarray of float64, the shape of ``distance``

    Examples
    --------
    >>> phi(np.array([0.0, 0.5]), 0.5).tolist()
    [-0.0, -1.0]
    """
    return -np.asarray(distance, dtype=np.float64) / (2.0 * sigma_i * sigma_i)


def psi(mean_square: np.ndarray, sigma_s: float) -> np.ndarray:
    r"""Eq. 6 in the log domain: ``log Ψ = −|d^l − d^m|² / (2σ_s²)``.

    The compatibility of two labels of neighbouring nodes: 0 (Ψ = 1) where
    their patches agree on every pixel they share.

    Parameters
    ----------
    mean_square : array_like of float
        ``|d^l − d^m|²``, from :func:`pair_compatibilities` or
        :func:`fixed_neighbour_terms`.
    sigma_s : float
        σ_s of Eq. 6, > 0.

    Returns
    -------
    ndarray of float64
        ``log Ψ``, the shape of ``mean_square``.

    Examples
    --------
    >>> psi(np.array([0.5, 0.0]), 0.5).tolist()
    [-1.0, -0.0]
    """
    return -np.asarray(mean_square, dtype=np.float64) / (2.0 * sigma_s * sigma_s)


def _overlap_mean_square(a: np.ndarray, b: np.ndarray, quantised: bool = False,
                         centres: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Mean squared difference, over the entries both have, of every row pair.

    ``a``: (E, K, F), ``b``: (E, L, F), normalised range, NaN = missing (or, with
    ``quantised``, the range already on the grid, −1 = missing). Returns (E, K, L);
    0 where two rows share no entry. The range is put on the contract's grid,
    ``rint(2**16 x)``: the expanded squares are then integer sums, exact in any
    order, and one scaling and one division make the mean.

    ``centres`` (quantised only; the departure ``"overlap-centres"``,
    :mod:`refsynth.synthesis.belief.centres`): ``(ca, cb)``, (E, K) and (E, L), the
    two patches' centre ranges on the grid (−1 = missing); each pair where both
    are present counts their squared difference as one more shared entry.
    """
    if quantised:
        va, vb = a >= 0, b >= 0
        a0, b0 = np.maximum(a, 0.0), np.maximum(b, 0.0)  # 0 where missing
    else:
        va = np.isfinite(a)
        vb = np.isfinite(b)
        # rint of the finite values only (rint of NaN is slow); 0 where missing
        a0 = np.rint(np.where(va, a, 0.0) * 2.0**RANGE_BITS)
        b0 = np.rint(np.where(vb, b, 0.0) * 2.0**RANGE_BITS)
    return _overlap_sums(a0, va, b0, vb, centres)


def _overlap_sums(a0: np.ndarray, va: np.ndarray, b0: np.ndarray, vb: np.ndarray,
                  centres: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """:func:`_overlap_mean_square` of rows on the grid, 0 where missing (``a0``, ``b0``),
    with their masks of present entries (``va``, ``vb``, bool)."""
    va = va.astype(np.float64)
    vb = vb.astype(np.float64)
    bt = np.swapaxes(b0, 1, 2)
    s = np.matmul(a0 * a0, np.swapaxes(vb, 1, 2))
    s -= 2.0 * np.matmul(a0, bt)
    s += np.matmul(va, bt * bt)
    count = np.matmul(va, np.swapaxes(vb, 1, 2))
    if centres is not None:  # integers below 2**33: exact
        ca, cb = (np.asarray(c, dtype=np.float64) for c in centres)
        both = (ca[:, :, None] >= 0) & (cb[:, None, :] >= 0)
        s += np.where(both, (ca[:, :, None] - cb[:, None, :]) ** 2, 0.0)
        count += both
    s *= 2.0 ** (-2 * RANGE_BITS)
    return np.divide(s, count, out=np.zeros_like(s), where=count > 0)


def _overlap(patches: np.ndarray, direction: str, side: str) -> np.ndarray:
    """The part of (…, n, n) patches that a 4-neighbour's patch also covers."""
    if direction == "h":  # neighbour one column to the right
        return patches[..., :, 1:] if side == "left" else patches[..., :, :-1]
    return patches[..., 1:, :] if side == "left" else patches[..., :-1, :]


def pair_compatibilities(
    patches_j: np.ndarray, patches_k: np.ndarray, direction: str, *, quantised: bool = False
) -> np.ndarray:
    """Mean square of Eq. 6 between every candidate of ``j`` and of its neighbour ``k``.

    Parameters
    ----------
    patches_j, patches_k : ndarray of shape (E, K, n, n)
        Range patches (normalised, NaN = missing) of the candidates of the
        edges' first and second nodes.
    direction : {"h", "v"}
        ``k`` lies one pixel right of ``j`` (``"h"``) or one pixel below
        (``"v"``).
    quantised : bool, default False
        The patches hold the range already on the contract's grid,
        ``rint(2**16 x)`` of the normalised range, and −1 where it is missing
        (what :func:`bp_fill` passes; the same result).

    Returns
    -------
    ndarray of shape (E, K, K), float64
        ``|d_jk^l − d_kj^m|²`` for ``l`` at ``j`` and ``m`` at ``k``, on the
        range quantised to ``2**-16`` (exact).

    Examples
    --------
    Two 3×3 candidates of horizontal neighbours: the right two columns of the
    first against the left two of the second, which differ by 0.25 in one of
    their six shared pixels:

    >>> j = np.full((1, 1, 3, 3), 0.5)
    >>> k = j.copy(); k[0, 0, 1, 0] = 0.75
    >>> bool(pair_compatibilities(j, k, "h")[0, 0, 0] == 0.25**2 / 6)
    True
    """
    e, kk = patches_j.shape[:2]
    a = _overlap(patches_j, direction, "left").reshape(e, kk, -1)
    b = _overlap(patches_k, direction, "right").reshape(e, patches_k.shape[1], -1)
    return _overlap_mean_square(a, b, quantised)


def fixed_neighbour_terms(
    candidate_patches: np.ndarray, fixed_patch: np.ndarray, direction: str, fixed_side: str,
    *, quantised: bool = False, centres: bool = False,
) -> np.ndarray:
    """Eq. 6's mean square between each candidate and a measured neighbour's patch.

    A measured node is fixed, so its message is Ψ evaluated at its own patch:
    a unary term on the unknown node.

    Parameters
    ----------
    candidate_patches : ndarray of shape (E, K, n, n)
        Range patches (normalised, NaN = missing) of the unknown node's ``K``
        candidates.
    fixed_patch : ndarray of shape (E, 1, n, n)
        The measured neighbour's own range patch.
    direction : {"h", "v"}
        The pair is horizontal (``"h"``) or vertical (``"v"``).
    fixed_side : {"left", "right"}
        The fixed node is the edge's first (``"left"``: the left or upper
        pixel) or its second node.
    quantised : bool, default False
        As in :func:`pair_compatibilities`.
    centres : bool, default False
        **A departure** (``compatibility="overlap-centres"``,
        :mod:`refsynth.synthesis.belief.centres`; needs ``quantised``): the
        candidate's centre range and the measured neighbour's own count as one
        more shared pixel.

    Returns
    -------
    ndarray of shape (E, K)
        The mean squares of Eq. 6, exact as in :func:`pair_compatibilities`.

    Examples
    --------
    >>> cand = np.stack([np.full((3, 3), 0.5), np.full((3, 3), 0.75)])[None]
    >>> fixed = np.full((1, 1, 3, 3), 0.5)
    >>> fixed_neighbour_terms(cand, fixed, "v", "left").tolist()
    [[0.0, 0.0625]]
    """
    e, kk = candidate_patches.shape[:2]
    pair = None
    if centres:
        h = candidate_patches.shape[-1] // 2
        pair = (candidate_patches[:, :, h, h], fixed_patch[:, :, h, h])
    if fixed_side == "left":
        a = _overlap(fixed_patch, direction, "left").reshape(e, 1, -1)
        b = _overlap(candidate_patches, direction, "right").reshape(e, kk, -1)
        return _overlap_mean_square(a, b, quantised,
                                    None if pair is None else pair[::-1])[:, 0, :]
    a = _overlap(candidate_patches, direction, "left").reshape(e, kk, -1)
    b = _overlap(fixed_patch, direction, "right").reshape(e, 1, -1)
    return _overlap_mean_square(a, b, quantised, pair)[:, :, 0]


# -- the grid ------------------------------------------------------------------------------


def grid_edges(unknown: np.ndarray) -> dict[str, np.ndarray]:
    """The 4-neighbour pairs of an (H, W) grid, by kind.

    Parameters
    ----------
    unknown : ndarray of bool, shape (H, W)
        The pixels to synthesize (BP's hidden nodes).

    Returns
    -------
    dict
        ``"h"`` and ``"v"``: (E, 2) flat indices of pairs of unknown pixels
        (right and lower neighbour second); ``"h_fixed"``, ``"v_fixed"``:
        (E, 2) pairs with exactly one unknown pixel, in the same orientation.

    Examples
    --------
    >>> pairs = grid_edges(np.array([[True, True], [False, True]]))
    >>> pairs["h"].tolist(), pairs["v"].tolist(), pairs["h_fixed"].tolist()
    ([[0, 1]], [[1, 3]], [[2, 3]])
    """
    H, W = unknown.shape
    idx = np.arange(H * W).reshape(H, W)
    out = {}
    for name, a, b in (
        ("h", idx[:, :-1], idx[:, 1:]),
        ("v", idx[:-1, :], idx[1:, :]),
    ):
        ua, ub = unknown.ravel()[a.ravel()], unknown.ravel()[b.ravel()]
        pairs = np.stack([a.ravel(), b.ravel()], axis=1)
        out[name] = pairs[ua & ub]
        out[name + "_fixed"] = pairs[ua ^ ub]
    return out


# -- Ψ on demand ---------------------------------------------------------------------------


#: Added to every range value of a shifted label's patch (and of a fixed neighbour's) before
#: Eq. 6, so that a value moved below 0 does not read as missing (−1).
SHIFT_LIFT = 2**18


class Compatibilities:
    """``log Ψ`` (Eq. 6) of any pairs, from their candidates' range patches.

    The sends of :func:`~refsynth.synthesis.belief.messages.belief_propagation` call it
    block by block, so the whole (E, k, k) table is never held; ``all()`` makes it
    (for :attr:`refsynth.synthesis.belief.fill.BPResult.log_psi`). Each pair's Ψ is the same
    function of its own patches wherever it is computed, so the numbers are those
    of one table.

    Parameters
    ----------
    plane : ndarray of float, shape (H + n − 1, W + n − 1)
        The range on the contract's grid, ``rint(2**16 x)``, −1 where unknown,
        padded by ``n // 2`` with −1: pixel ``(r, c)``'s patch is
        ``plane[r : r + n, c : c + n]``.
    n : int
        The patch side.
    labels : ndarray of int, shape (N, k)
        Flat indices (``row · W + col``) of each node's candidates.
    width : int
        ``W``.
    pairs : ndarray of int, shape (E, 2)
        Node indices of each pair: the horizontal pairs first, then the vertical.
    n_h : int
        The number of horizontal pairs.
    sigma_s : float
        σ_s of Eq. 6.
    centres : bool, default False
        **A departure** (``compatibility="overlap-centres"``,
        :mod:`refsynth.synthesis.belief.centres`): the two candidates' centre
        ranges count as one more shared pixel of Eq. 6's mean square.

    Examples
    --------
    Two horizontal neighbours whose single candidates are the same flat field:

    >>> q = np.pad(np.full((3, 4), 100.0), 1, constant_values=-1.0)
    >>> psi_of = Compatibilities(q, 3, np.array([[5], [6]]), 4, np.array([[0, 1]]), 1, 0.2)
    >>> psi_of(np.array([0])).tolist(), psi_of.all().shape
    ([[[-0.0]]], (1, 1, 1))
    """

    def __init__(self, plane, n, labels, width, pairs, n_h, sigma_s, centres=False,
                 shifts=None):
        self.plane, self.n, self.shifts = plane, n, shifts
        self.labels, self.width, self.pairs = labels, width, pairs
        self.n_h, self.sigma_s, self.centres = n_h, sigma_s, centres
        self.k = labels.shape[1]
        self._views()

    def _views(self):
        # the plane, flat, and the flat offsets from a patch's corner of the pixels it
        # shares with its right ("h") or lower ("v") neighbour's patch, and back
        self._flat = np.ascontiguousarray(self.plane).ravel()
        n, wp = self.n, self.plane.shape[1]
        grid = np.arange(n)[:, None] * wp + np.arange(n)[None, :]
        self._shared = {"h": (grid[:, 1:].ravel(), grid[:, :-1].ravel()),
                        "v": (grid[1:, :].ravel(), grid[:-1, :].ravel())}

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_flat"] = None  # a view would pickle whole: rebuilt from the plane
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._views()

    def _of(self, nodes, offsets):
        """The shared pixels of the candidates' patches of ``nodes``, (m, k, n(n − 1)):
        their values on the grid, 0 where missing, and where they are present."""
        labels = self.labels[nodes]
        # a label's patch corner in the plane: row · (W + n − 1) + col
        corner = labels + (labels // self.width) * (self.plane.shape[1] - self.width)
        values = np.take(self._flat, corner[:, :, None] + offsets)
        present = values >= 0
        if self.shifts is None:
            return np.maximum(values, 0.0), present
        # the offset copy's labels: each patch moved by its shift, all lifted by SHIFT_LIFT
        # so that a moved value stays >= 0 (Eq. 6 compares differences: the lift cancels)
        lifted = values + (self.shifts[nodes] + SHIFT_LIFT)[:, :, None]
        return np.where(present, lifted, 0.0), present

    def __call__(self, edges: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``log Ψ`` of the pairs ``edges`` (indices into ``pairs``), (m, k, k), in ``out``."""
        edges = np.asarray(edges)
        if out is None:
            out = np.empty((edges.size, self.k, self.k))
        for start in range(0, edges.size, _PSI_BLOCK):
            self._block(edges[start : start + _PSI_BLOCK], out[start : start + _PSI_BLOCK])
        return out

    def _block(self, block: np.ndarray, out: np.ndarray) -> None:
        # Eq. 6 as pair_compatibilities computes it, on the shared pixels read straight
        # from the plane (the first node's patch, left side; the second's, right side)
        sigma_s = self.sigma_s
        for direction, s in (("h", block < self.n_h), ("v", block >= self.n_h)):
            if s.any():
                left, right = self._shared[direction]
                pj = self._of(self.pairs[block[s], 0], left)
                pk = self._of(self.pairs[block[s], 1], right)
                pair = None
                if self.centres:  # the departure: the centres as one more shared pixel
                    middle = np.array([(self.n // 2) * (self.plane.shape[1] + 1)])
                    pair = tuple(np.where(present, value, -1.0)[:, :, 0] for value, present in (
                        self._of(self.pairs[block[s], end], middle) for end in (0, 1)))
                out[s] = psi(_overlap_sums(*pj, *pk, centres=pair), sigma_s)

    def all(self) -> np.ndarray:
        """The whole table, (E, k, k)."""
        e = self.pairs.shape[0]
        out = np.empty((e, self.k, self.k))
        for start in range(0, e, _PSI_BLOCK):
            self._block(np.arange(start, min(start + _PSI_BLOCK, e)),
                        out[start : start + _PSI_BLOCK])
        return out


