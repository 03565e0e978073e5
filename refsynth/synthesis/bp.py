r"""Range synthesis by belief propagation (§3.2.3, Eqs. 6–9, Fig. 6).

The algorithm of Fig. 6, step by step:

1. Divide the intensity and the incomplete range image into n×n patches: the
   hidden node ``x_i`` of each pixel ``i`` whose range is unknown is the range
   patch centred there, its observation ``y_i`` the patch of intensity and of
   whatever range is already known (:func:`candidates`). Pixels with measured
   range are fixed nodes: their belief never changes, and they constrain their
   unknown neighbours through Ψ (:func:`fixed_neighbour_terms`).
2. For each ``y_i``, find the ``k`` closest patches among the local training
   set — the patches centred on measured pixels within ``r`` of ``i`` — by the
   distance of Eq. 2 (intensity, plus the range known in ``y_i``, with NP's
   mean-filled range term; :mod:`refsynth.synthesis.similarity`). Their range patches are the
   ``k`` labels of node ``i``. When fewer than ``k`` training patches lie
   within ``r`` (a gap wider than ``r``), the search radius doubles until ``k``
   are found or the whole image is searched.
3. Eq. 7, the local evidence of each label:

   .. math:: \Phi(x_i^l, y_i) = \exp\left(-\frac{|y_i^l - y_i|^2}{2\sigma_i^2}\right)

4. Eq. 6, a ``k × k`` compatibility per pair of 4-neighbours, from the range
   the two candidate patches give the pixels they share:

   .. math:: \Psi(x_k^l, x_j^m) = \exp\left(-\frac{|d_{jk}^l - d_{kj}^m|^2}{2\sigma_s^2}\right)

   ``|d − d'|²`` is the *mean* squared difference over the shared pixels
   where both patches have range (training patches are partial near unknown
   range); with no such pixel, Ψ = 1.
5. Messages, Eq. 9, in the log domain and normalised every iteration
   (max-product by default, sum-product as an option), on a synchronous
   schedule:

   .. math:: M_{ij}(x_j) = Z \max_{x_i} \Psi(x_i, x_j)\, \Phi(x_i, y_i)
             \prod_{k \in N(i) \setminus j} M_{ki}(x_i)

   **Edge-constraint rule**: a node sends a message once it has heard from
   all its other neighbours *except those labelled as edges* — so nodes on an
   intensity edge send no messages, and evidence does not flow across edges.
   refsynth's default reading, ``edge_rule="silent"``: a node on an edge sends
   nothing, measured nodes included (an unknown one no message, a measured one
   no Ψ term on its unknown neighbours), but still listens. ``"paper"``: no
   message crosses an edge at all — a node on an edge neither sends nor
   receives (no message, no term of a measured neighbour), so its belief is
   its own evidence Φ alone.
6. Eq. 8, the MAP label of each node,
   ``x_i = argmax Φ(x_i, y_i) Π_j M_ji(x_i)``; the centre of its range patch is
   the synthesized range. The pixel's confidence is the normalised belief of
   that label, pooled with the labels whose centre range is the same (within
   ``VALUE_TOLERANCE`` of the known span): different training patches often
   propose the same range, and splitting the belief between them would read
   as doubt about the range where there is none.

Everything is array operations over all nodes × k (× k for Ψ and the
messages), in chunks that bound the memory.

The numeric contract (:mod:`refsynth.numeric`): the candidates are ranked by
the exact Eq. 2 of :class:`~refsynth.synthesis.similarity.PatchTable` (stable
sort: ties by the raster order of the disc offsets), Eq. 6's mean squares are
exact integer sums over the quantised range, and BP runs in float64 in the log
domain. Max-product needs only ``+ − max``; a node's incoming messages are
added in the order left, up, right, down, and the fixed neighbours' terms to
the unary term in the order right, left, below, above. Sum-product and the
confidence use :func:`~refsynth.numeric.portable_exp` /
:func:`~refsynth.numeric.portable_log` and sums over the labels from left to
right. So the output is the same on any machine, and the same as the literal
reference :func:`refsynth.synthesis.reference.bp_reference`: every array of
:class:`BPResult` included.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eqs. 6–9, Fig. 6,
doi:10.1007/s11263-007-0108-2.
W. T. Freeman, E. C. Pasztor and O. T. Carmichael, "Learning low-level
vision", IJCV 40:25–47 (2000) (patch candidates, overlap compatibilities).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.numeric import (
    INTENSITY_BITS,
    RANGE_BITS,
    left_to_right_sum,
    portable_exp,
    quantise_grey,
    quantise_intensity,
    quantise_range,
)
from refsynth.synthesis.messages import belief_propagation
from refsynth.synthesis.neighbourhood import disc_offsets
from refsynth.synthesis.similarity import PatchTable

__all__ = [
    "BPResult",
    "bp_fill",
    "candidates",
    "phi",
    "psi",
    "pair_compatibilities",
    "fixed_neighbour_terms",
    "grid_edges",
    "belief_propagation",
]

_CHUNK_FLOATS = 1 << 24  # about 128 MB of float64 per temporary block

#: The readings of the edge-constraint rule (see above).
EDGE_RULES = ("silent", "paper")

#: Candidates whose centre ranges differ by at most this fraction of the known
#: range's span count as one range hypothesis in the confidence map.
VALUE_TOLERANCE = 0.01


@dataclass(frozen=True)
class BPResult:
    """What :func:`bp_fill` returns (and :attr:`refsynth.SynthesisResult.bp` holds).

    Laid out as :class:`refsynth.synthesis.reference.BPReference`: the nodes are the
    unknown pixels in raster order (the rows of ``order``); the pairs are the
    4-neighbour pairs of unknown pixels, horizontal then vertical, each in raster
    order.

    Attributes
    ----------
    range, confidence, order
        As in :class:`refsynth.SynthesisResult`.
    iterations : int
        The sweeps done.
    candidate_values : ndarray of shape (N, k)
        The centre range of every candidate (label), in the caller's unit.
    labels : ndarray of shape (N,), int64
        The MAP label of each node (Eq. 8, the first maximum).
    candidates : ndarray of shape (N, k, 2), int64
        The (row, col) of every candidate's centre, best-ranked first.
    unary : ndarray of shape (N, k)
        ``log Φ`` (Eq. 7) plus the terms of measured neighbours.
    pairs : ndarray of shape (E, 2), int64
        Node indices of each pair.
    log_psi : ndarray of shape (E, k, k)
        ``log Ψ`` (Eq. 6), label of ``pairs[e, 0]`` first.
    messages : ndarray of shape (2E, k)
        The final log messages: row ``e`` goes ``pairs[e, 0] → pairs[e, 1]``, row
        ``E + e`` back.
    beliefs : ndarray of shape (N, k)
        The unnormalised log beliefs ``unary + Σ incoming messages``.
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    iterations: int
    candidate_values: np.ndarray
    labels: np.ndarray
    candidates: np.ndarray | None = None
    unary: np.ndarray | None = None
    pairs: np.ndarray | None = None
    log_psi: np.ndarray | None = None
    messages: np.ndarray | None = None
    beliefs: np.ndarray | None = None


# -- step 2: candidates -----------------------------------------------------------------


def candidates(
    table: PatchTable,
    nodes: np.ndarray,
    known: np.ndarray,
    shape: tuple[int, int],
    k: int,
    radius: float,
    proximity: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` closest training patches of each node, by Eq. 2 (Fig. 6, step 2).

    Parameters
    ----------
    table : PatchTable
        Patch rows of the padded frame (intensity and known range).
    nodes : ndarray of int, shape (N,)
        Padded flat indices of the unknown pixels.
    known : ndarray of bool
        Padded flat mask of the measured pixels (the training set's centres).
    shape : (int, int)
        Shape of the padded frame.
    k : int
        Number of candidates per node.
    radius : float
        Search radius ``r``; doubled for a node until it has ``k`` candidates.
    proximity : float
        μ of the spatial prior ``μ (|p − q| / r)²`` added to Eq. 2 (a
        departure from the paper, which ranks by the observation alone).

    Returns
    -------
    labels : ndarray of int, shape (N, k)
        Padded flat indices of the candidates' centres, best first (ties in the
        raster order of the disc offsets). Where the whole image holds fewer
        than ``k`` training patches, the last one repeats.
    distances : ndarray of float64, shape (N, k)
        Their Eq. 2 distances (plus the proximity prior).
    """
    width = shape[1]
    n_nodes = nodes.size
    labels = np.zeros((n_nodes, k), dtype=np.int64)
    dist = np.full((n_nodes, k), np.inf)
    todo = np.arange(n_nodes)
    r = float(radius)
    total_known = int(known.sum())
    while todo.size:
        dr, dc = disc_offsets(r)
        offsets = dr * width + dc
        pad = int(np.ceil(r))
        chunk = max(1, _CHUNK_FLOATS // (offsets.size * table.table.shape[1]))
        found = np.zeros(todo.size, dtype=bool)
        for start in range(0, todo.size, chunk):
            sl = slice(start, start + chunk)
            rows, cols = np.divmod(nodes[todo[sl]], width)
            rr, cc = rows[:, None] + dr[None, :], cols[:, None] + dc[None, :]
            valid = (rr >= 0) & (rr < shape[0]) & (cc >= 0) & (cc < width)
            idx = np.where(valid, rr * width + cc, 0)
            valid &= known[idx]
            d = table.batch_distances(nodes[todo[sl]], idx)
            if proximity:
                d = d + (proximity / (radius * radius)) * (dr * dr + dc * dc).astype(np.float64)
            d[~valid] = np.inf
            kk = min(k, d.shape[1])
            # a stable sort: ties in the raster order of the offsets (argpartition's
            # order is whatever its selection algorithm, SIMD-dispatched, leaves)
            best = np.argsort(d, axis=1, kind="stable")[:, :kk]
            bd = np.take_along_axis(d, best, axis=1)
            enough = np.isfinite(bd[:, -1]) if kk == k else np.zeros(bd.shape[0], bool)
            exhausted = pad >= max(shape) or total_known <= np.isfinite(bd).sum(axis=1)
            take = enough | exhausted
            rows_sel = todo[sl][take]
            cand = np.take_along_axis(idx, best, axis=1)[take]
            cd = bd[take]
            # too few training patches in the whole image: repeat the last finite one
            if kk < k or not np.all(np.isfinite(cd)):
                cand, cd = _pad_candidates(cand, cd, k)
            labels[rows_sel] = cand
            dist[rows_sel] = cd
            found[sl] = take
        todo = todo[~found]
        r *= 2.0
    return labels, dist


def _pad_candidates(cand: np.ndarray, cd: np.ndarray, k: int):
    finite = np.isfinite(cd)
    count = np.maximum(finite.sum(axis=1), 1)
    cols = np.minimum(np.arange(k)[None, :], count[:, None] - 1)
    cols = np.minimum(cols, cand.shape[1] - 1)
    return np.take_along_axis(cand, cols, axis=1), np.take_along_axis(cd, cols, axis=1)


# -- steps 3 and 4: compatibilities ----------------------------------------------------


def phi(distance: np.ndarray, sigma_i: float) -> np.ndarray:
    r"""Eq. 7 in the log domain: ``log Φ = −|y^l − y|² / (2σ_i²)``.

    ``distance`` is ``|y^l − y|²``, the Eq. 2 distance of the observation
    patches.
    """
    return -np.asarray(distance, dtype=np.float64) / (2.0 * sigma_i * sigma_i)


def psi(mean_square: np.ndarray, sigma_s: float) -> np.ndarray:
    r"""Eq. 6 in the log domain: ``log Ψ = −|d^l − d^m|² / (2σ_s²)``."""
    return -np.asarray(mean_square, dtype=np.float64) / (2.0 * sigma_s * sigma_s)


def _overlap_mean_square(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean squared difference, over the entries both have, of every row pair.

    ``a``: (E, K, F), ``b``: (E, L, F), normalised range, NaN = missing. Returns
    (E, K, L); 0 where two rows share no entry. The range is put on the contract's
    grid, ``rint(2**16 x)``: the expanded squares are then integer sums, exact in
    any order, and one scaling and one division make the mean.
    """
    va = np.isfinite(a).astype(np.float64)
    vb = np.isfinite(b).astype(np.float64)
    a0 = np.where(va > 0, np.rint(a * 2.0**RANGE_BITS), 0.0)
    b0 = np.where(vb > 0, np.rint(b * 2.0**RANGE_BITS), 0.0)
    bt = np.swapaxes(b0, 1, 2)
    s = np.matmul(a0 * a0, np.swapaxes(vb, 1, 2))
    s -= 2.0 * np.matmul(a0, bt)
    s += np.matmul(va, bt * bt)
    count = np.matmul(va, np.swapaxes(vb, 1, 2))
    s *= 2.0 ** (-2 * RANGE_BITS)
    return np.divide(s, count, out=np.zeros_like(s), where=count > 0)


def _overlap(patches: np.ndarray, direction: str, side: str) -> np.ndarray:
    """The part of (…, n, n) patches that a 4-neighbour's patch also covers."""
    if direction == "h":  # neighbour one column to the right
        return patches[..., :, 1:] if side == "left" else patches[..., :, :-1]
    return patches[..., 1:, :] if side == "left" else patches[..., :-1, :]


def pair_compatibilities(
    patches_j: np.ndarray, patches_k: np.ndarray, direction: str
) -> np.ndarray:
    """Mean square of Eq. 6 between every candidate of ``j`` and of its neighbour ``k``.

    Parameters
    ----------
    patches_j, patches_k : ndarray of shape (E, K, n, n)
        Range patches (normalised, NaN = missing) of the candidates of the
        edges' first and second nodes; ``k`` lies one pixel right of ``j``
        (``direction="h"``) or one pixel below (``"v"``).

    Returns
    -------
    ndarray of shape (E, K, K), float64
        ``|d_jk^l − d_kj^m|²`` for ``l`` at ``j`` and ``m`` at ``k``, on the
        range quantised to ``2**-16`` (exact).
    """
    e, kk = patches_j.shape[:2]
    a = _overlap(patches_j, direction, "left").reshape(e, kk, -1)
    b = _overlap(patches_k, direction, "right").reshape(e, patches_k.shape[1], -1)
    return _overlap_mean_square(a, b)


def fixed_neighbour_terms(
    candidate_patches: np.ndarray, fixed_patch: np.ndarray, direction: str, fixed_side: str
) -> np.ndarray:
    """Eq. 6's mean square between each candidate and a measured neighbour's patch.

    A measured node is fixed, so its message is Ψ evaluated at its own patch:
    a unary term on the unknown node. ``fixed_side`` says whether the fixed
    node is the edge's first (``"left"``: left or upper) or second node.

    Returns
    -------
    ndarray of shape (E, K)
    """
    e, kk = candidate_patches.shape[:2]
    if fixed_side == "left":
        a = _overlap(fixed_patch, direction, "left").reshape(e, 1, -1)
        b = _overlap(candidate_patches, direction, "right").reshape(e, kk, -1)
        return _overlap_mean_square(a, b)[:, 0, :]
    a = _overlap(candidate_patches, direction, "left").reshape(e, kk, -1)
    b = _overlap(fixed_patch, direction, "right").reshape(e, 1, -1)
    return _overlap_mean_square(a, b)[:, :, 0]


# -- the grid ------------------------------------------------------------------------------


def grid_edges(unknown: np.ndarray) -> dict[str, np.ndarray]:
    """The 4-neighbour pairs of an (H, W) grid, by kind.

    Returns
    -------
    dict
        ``"h"`` and ``"v"``: (E, 2) flat indices of pairs of unknown pixels
        (right and lower neighbour second); ``"h_fixed"``, ``"v_fixed"``:
        (E, 2) pairs with exactly one unknown pixel, in the same orientation.
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


# -- the whole algorithm -------------------------------------------------------------------


def bp_fill(
    image: np.ndarray,
    range_values: np.ndarray,
    edges: np.ndarray,
    *,
    neighbourhood: int = 5,
    radius: float = 10.0,
    k: int = 8,
    sigma_i: float = 0.1,
    sigma_s: float = 0.2,
    iterations: int = 50,
    tolerance: float = 1e-4,
    product: str = "max",
    damping: float = 0.0,
    use_edges: bool = True,
    range_weight: float = 1.0,
    missing_range: str = "mean",
    proximity: float = 1.0,
    colour: bool = True,
    edge_rule: str = "silent",
    progress: Callable[[int, int], None] | None = None,
) -> BPResult:
    """Fill the unknown range by the MRF-BP algorithm of Fig. 6.

    Called by :func:`refsynth.synthesize`, which validates the inputs and
    documents the parameters (``k`` is its ``candidates``). BP is
    deterministic: no random choice is made.

    Returns
    -------
    BPResult
        ``range`` (measured values unchanged), ``confidence`` (1 where
        measured; the normalised belief of the MAP label elsewhere), ``order``
        (the synthesized pixels in raster order), ``iterations``,
        ``candidate_values`` ((N, k) centre range of every candidate, in the
        caller's unit, rows in ``order``), ``labels`` ((N,) index of the MAP
        candidate), and the model and its messages (see :class:`BPResult`).
    """
    H, W = range_values.shape
    n = neighbourhood
    h = n // 2
    known = np.isfinite(range_values)
    # the contract: intensity and range on the 2**-16 grids of their spans
    rq, _, span = quantise_range(range_values)
    range_norm = np.where(known, rq * 2.0**-RANGE_BITS, np.nan)
    levels = quantise_intensity(image)
    if not colour:
        levels = quantise_grey(levels)[:, :, None]
    pad = max(int(np.ceil(radius)), h + 1)
    table = PatchTable(levels * 2.0**-INTENSITY_BITS, range_norm, n, pad, range_weight,
                       missing_range)
    Hp, Wp = H + 2 * pad, W + 2 * pad
    known_pad = np.pad(known, pad).ravel()
    unknown = ~known
    flat = np.flatnonzero(unknown)
    rows, cols = np.divmod(flat, W)
    nodes = (rows + pad) * Wp + (cols + pad)
    on_edge = (np.asarray(edges, dtype=bool) & use_edges).ravel()
    deaf = on_edge[flat] if edge_rule == "paper" else np.zeros(flat.size, dtype=bool)
    total = 5
    step = 0

    def tick():
        nonlocal step
        step += 1
        if progress is not None:
            progress(step, total)

    # step 2: candidates, and step 3: log Phi
    labels, dist = candidates(table, nodes, known_pad, (Hp, Wp), k, radius, proximity)
    unary = phi(dist, sigma_i)
    tick()
    # range patches of the padded frame (NaN outside measured range)
    rpad = np.pad(range_norm, pad + h, constant_values=np.nan)
    patches = sliding_window_view(rpad, (n, n))  # (Hp, Wp, n, n), a view
    patches = patches.reshape(Hp * Wp, n, n)
    cand_rows, cand_cols = np.divmod(labels, Wp)

    node_of = np.full(H * W, -1, dtype=np.int64)
    node_of[flat] = np.arange(flat.size)
    pairs_all = grid_edges(unknown)
    # step 4: fixed neighbours -> unary terms, in the order right, left, below, above;
    # the edge rule: a measured node on an edge sends no term (and, with the paper's
    # rule, a node on an edge receives none)
    for direction in ("h", "v"):
        fixed_pairs = pairs_all[direction + "_fixed"]
        if fixed_pairs.size == 0:
            continue
        first_unknown = unknown.ravel()[fixed_pairs[:, 0]]
        for side, which in (("right", first_unknown), ("left", ~first_unknown)):
            sel = fixed_pairs[which]
            node_pix = sel[:, 0] if side == "right" else sel[:, 1]
            fixed_pix = sel[:, 1] if side == "right" else sel[:, 0]
            keep = ~on_edge[fixed_pix] & ~deaf[node_of[node_pix]]
            node_pix, fixed_pix = node_pix[keep], fixed_pix[keep]
            if node_pix.size == 0:
                continue
            fr, fc = np.divmod(fixed_pix, W)
            node = node_of[node_pix]
            chunk = max(1, _CHUNK_FLOATS // (k * n * n * 4))
            for start in range(0, node.size, chunk):
                s = slice(start, start + chunk)
                cp = patches[labels[node[s]]]
                fp = patches[((fr[s] + pad) * Wp + fc[s] + pad)][:, None]
                ms = fixed_neighbour_terms(cp, fp, direction, side)
                # each node has one such neighbour per direction and side
                unary[node[s]] += psi(ms, sigma_s)
    tick()
    # step 4: k x k compatibilities between unknown neighbours
    pair_list, psi_list = [], []
    for direction in ("h", "v"):
        pairs = node_of[pairs_all[direction]]
        if pairs.size == 0:
            continue
        out = np.empty((pairs.shape[0], k, k))
        chunk = max(1, _CHUNK_FLOATS // (k * k * 4))
        for start in range(0, pairs.shape[0], chunk):
            s = slice(start, start + chunk)
            pj = patches[labels[pairs[s, 0]]]
            pk = patches[labels[pairs[s, 1]]]
            out[s] = psi(pair_compatibilities(pj, pk, direction), sigma_s)
        pair_list.append(pairs)
        psi_list.append(out)
    pairs = np.concatenate(pair_list) if pair_list else np.zeros((0, 2), np.int64)
    log_psi = np.concatenate(psi_list) if psi_list else np.zeros((0, k, k))
    del psi_list
    tick()
    # step 5: messages; the edge-constraint rule silences (and deafens) edge nodes
    belief, done, messages = belief_propagation(
        unary, pairs, log_psi, silent=on_edge[flat] if use_edges else None,
        deaf=deaf if edge_rule == "paper" else None, iterations=iterations,
        tolerance=tolerance, product=product, damping=damping, return_messages=True,
    )
    tick()
    # step 6: MAP label, its centre range, and its normalised belief
    best = np.argmax(belief, axis=1)
    prob = portable_exp(belief - belief.max(axis=1, keepdims=True))
    prob = prob / left_to_right_sum(prob, axis=1)[:, None]
    centre = np.where(known, range_values, 0.0)
    cand_values = centre[cand_rows - pad, cand_cols - pad]
    out = range_values.copy()
    out[unknown] = cand_values[np.arange(flat.size), best]
    confidence = known.astype(np.float64)
    # the belief that the range is the chosen value: candidates whose centres lie
    # within VALUE_TOLERANCE of the known span of it are the same range hypothesis
    chosen = cand_values[np.arange(flat.size), best]
    same = np.abs(cand_values - chosen[:, None]) <= VALUE_TOLERANCE * span
    pooled = left_to_right_sum(np.where(same, prob, 0.0), axis=1)
    confidence[unknown] = np.minimum(pooled, 1.0)
    tick()
    return BPResult(
        range=out,
        confidence=confidence,
        order=np.stack([rows, cols], axis=1).astype(np.int64),
        iterations=done,
        candidate_values=cand_values,
        labels=best,
        candidates=np.stack([cand_rows - pad, cand_cols - pad], axis=-1).astype(np.int64),
        unary=unary,
        pairs=pairs.astype(np.int64),
        log_psi=log_psi,
        messages=messages,
        beliefs=belief,
    )
