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
6. Eq. 8, the MAP label of each node,
   ``x_i = argmax Φ(x_i, y_i) Π_j M_ji(x_i)``; the centre of its range patch is
   the synthesized range. The pixel's confidence is the normalised belief of
   that label, pooled with the labels whose centre range is the same (within
   ``VALUE_TOLERANCE`` of the known span): different training patches often
   propose the same range, and splitting the belief between them would read
   as doubt about the range where there is none.

Everything is array operations over all nodes × k (× k for Ψ and the
messages), in chunks that bound the memory.

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

from refsynth.synthesis.neighbourhood import disc_offsets
from refsynth.synthesis.similarity import PatchTable, intensity_scale, range_scale

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

_CHUNK_FLOATS = 1 << 24  # about 64 MB of float32 per temporary block

#: Candidates whose centre ranges differ by at most this fraction of the known
#: range's span count as one range hypothesis in the confidence map.
VALUE_TOLERANCE = 0.01


@dataclass(frozen=True)
class BPResult:
    """What :func:`bp_fill` returns (wrapped by :func:`refsynth.synthesize`)."""

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    iterations: int
    candidate_values: np.ndarray
    labels: np.ndarray


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
        Padded flat indices of the candidates' centres, best first. Where the
        whole image holds fewer than ``k`` training patches, the last one
        repeats.
    distances : ndarray of float32, shape (N, k)
        Their Eq. 2 distances.
    """
    width = shape[1]
    n_nodes = nodes.size
    labels = np.zeros((n_nodes, k), dtype=np.int64)
    dist = np.full((n_nodes, k), np.inf, dtype=np.float32)
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
                d += (proximity / radius**2) * (dr**2 + dc**2).astype(np.float32)
            d[~valid] = np.inf
            kk = min(k, d.shape[1])
            part = np.argpartition(d, kk - 1, axis=1)[:, :kk]
            pd = np.take_along_axis(d, part, axis=1)
            order = np.argsort(pd, axis=1, kind="stable")
            best = np.take_along_axis(part, order, axis=1)
            bd = np.take_along_axis(pd, order, axis=1)
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
    return -np.asarray(distance, dtype=np.float64) / (2.0 * sigma_i**2)


def psi(mean_square: np.ndarray, sigma_s: float) -> np.ndarray:
    r"""Eq. 6 in the log domain: ``log Ψ = −|d^l − d^m|² / (2σ_s²)``."""
    return -np.asarray(mean_square, dtype=np.float64) / (2.0 * sigma_s**2)


def _overlap_mean_square(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean squared difference, over the entries both have, of every row pair.

    ``a``: (E, K, F), ``b``: (E, L, F), NaN = missing. Returns (E, K, L);
    0 where two rows share no entry.
    """
    va = np.isfinite(a).astype(np.float32)
    vb = np.isfinite(b).astype(np.float32)
    a0 = np.where(va > 0, a, 0.0).astype(np.float32)
    b0 = np.where(vb > 0, b, 0.0).astype(np.float32)
    bt = np.swapaxes(b0, 1, 2)
    s = np.matmul(a0 * a0, np.swapaxes(vb, 1, 2))
    s -= 2.0 * np.matmul(a0, bt)
    s += np.matmul(va, bt * bt)
    count = np.matmul(va, np.swapaxes(vb, 1, 2))
    np.maximum(s, 0.0, out=s)
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
    ndarray of shape (E, K, K), float32
        ``|d_jk^l − d_kj^m|²`` for ``l`` at ``j`` and ``m`` at ``k``.
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


# -- step 5: belief propagation ----------------------------------------------------------


def belief_propagation(
    unary: np.ndarray,
    pairs: np.ndarray,
    log_psi: np.ndarray,
    *,
    silent: np.ndarray | None = None,
    iterations: int = 50,
    tolerance: float = 1e-4,
    product: str = "max",
    damping: float = 0.0,
    return_messages: bool = False,
):
    """Synchronous loopy BP in the log domain (Eq. 9); returns beliefs (Eq. 8).

    Parameters
    ----------
    unary : ndarray of shape (N, K)
        ``log Φ`` plus the terms of fixed neighbours, per node and label.
    pairs : ndarray of shape (E, 2), int
        Node indices of each undirected edge ``(a, b)``.
    log_psi : ndarray of shape (E, K, K)
        ``log Ψ[e, l, m]`` for label ``l`` at ``a`` and ``m`` at ``b``.
    silent : ndarray of shape (N,), bool, optional
        Nodes that send no message (the edge-constraint rule).
    iterations : int
        At most this many synchronous sweeps.
    tolerance : float
        Stop when no message changes by more than this (log domain).
    product : {"max", "sum"}
        Max-product (MAP) or sum-product (marginals).
    damping : float in [0, 1)
        Each new message is ``(1 − damping)·new + damping·old`` (log domain);
        0 is the plain synchronous schedule.
    return_messages : bool
        Also return the final messages.

    Returns
    -------
    beliefs : ndarray of shape (N, K)
        Unnormalised log beliefs ``unary + Σ incoming messages``.
    iterations : int
        The sweeps done.
    messages : ndarray of shape (2E, K), only with ``return_messages``
        Log messages; row ``e < E`` goes from ``pairs[e, 0]`` to
        ``pairs[e, 1]``, row ``E + e`` back. Each is normalised: its maximum
        (max-product) or its log-sum-exp (sum-product) is 0.
    """
    n, k = unary.shape
    e = pairs.shape[0]
    a, b = pairs[:, 0], pairs[:, 1]
    # directed messages: [0, e) go a -> b, [e, 2e) go b -> a
    messages = np.zeros((2 * e + 1, k), dtype=np.float32)  # the last row: "no message"
    src = np.concatenate([a, b])
    dst = np.concatenate([b, a])
    rev = np.concatenate([np.arange(e, 2 * e), np.arange(e)])
    # incoming messages of each node: up to 4 (the 4-neighbourhood)
    order = np.argsort(dst, kind="stable")
    counts = np.bincount(dst, minlength=n)
    slot = np.arange(2 * e) - np.repeat(np.cumsum(counts) - counts, counts)
    incoming = np.full((n, max(int(counts.max(initial=0)), 1)), 2 * e, dtype=np.int64)
    incoming[dst[order], slot] = order
    sends = np.ones(2 * e, dtype=bool) if silent is None else ~silent[src]
    unary = unary.astype(np.float32)
    log_psi = np.asarray(log_psi, dtype=np.float32)
    done = 0
    for done in range(1, iterations + 1):  # noqa: B007 - the count is returned
        belief = unary + messages[incoming].sum(axis=1)
        h = belief[src] - messages[rev]  # leave out the receiver's own message
        new = np.empty((2 * e, k), dtype=np.float32)
        _send(new[:e], h[:e], log_psi, axis=1, product=product)
        _send(new[e:], h[e:], log_psi, axis=2, product=product)
        new[~sends] = 0.0
        if damping:
            new *= 1.0 - damping
            new += damping * messages[:-1]
        change = float(np.max(np.abs(new - messages[:-1]), initial=0.0))
        messages[:-1] = new
        if change <= tolerance:
            break
    belief = (unary + messages[incoming].sum(axis=1)).astype(np.float64)
    if return_messages:
        return belief, done, messages[:-1].copy()
    return belief, done


def _send(out: np.ndarray, h: np.ndarray, log_psi: np.ndarray, *, axis: int, product: str):
    """One direction of Eq. 9 for a block of edges, normalised (max or log-sum = 0)."""
    k = h.shape[1]
    chunk = max(1, _CHUNK_FLOATS // (k * k))
    for start in range(0, h.shape[0], chunk):
        sl = slice(start, start + chunk)
        if axis == 1:  # sender is the first node: its label indexes rows of psi
            t = log_psi[sl] + h[sl, :, None]
        else:
            t = log_psi[sl] + h[sl, None, :]
        if product == "max":
            m = t.max(axis=axis)
            m -= m.max(axis=1, keepdims=True)
        else:
            top = t.max(axis=axis, keepdims=True)
            m = np.log(np.exp(t - top).sum(axis=axis)) + np.squeeze(top, axis=axis)
            m -= _logsumexp(m)[:, None]
        out[sl] = m


def _logsumexp(x: np.ndarray) -> np.ndarray:
    top = x.max(axis=1)
    return np.log(np.exp(x - top[:, None]).sum(axis=1)) + top


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
    range_weight: float = 16.0,
    missing_range: str = "mean",
    proximity: float = 1.0,
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
        candidate).
    """
    H, W = range_values.shape
    n = neighbourhood
    h = n // 2
    known = np.isfinite(range_values)
    low, span = range_scale(range_values)
    range_norm = (range_values - low) / span
    image = image / intensity_scale(image)
    pad = max(int(np.ceil(radius)), h + 1)
    table = PatchTable(image, range_norm, n, pad, range_weight, missing_range, np.float32)
    Hp, Wp = H + 2 * pad, W + 2 * pad
    known_pad = np.pad(known, pad).ravel()
    unknown = ~known
    flat = np.flatnonzero(unknown)
    rows, cols = np.divmod(flat, W)
    nodes = (rows + pad) * Wp + (cols + pad)
    total = 5
    step = 0

    def tick():
        nonlocal step
        step += 1
        if progress is not None:
            progress(step, total)

    # step 2: candidates, and step 3: log Phi
    labels, dist = candidates(table, nodes, known_pad, (Hp, Wp), k, radius, proximity)
    unary = phi(dist, sigma_i).astype(np.float32)
    tick()
    # range patches of the padded frame (NaN outside measured range)
    rpad = np.pad(np.where(known, range_norm, np.nan), pad + h, constant_values=np.nan)
    patches = sliding_window_view(rpad, (n, n))  # (Hp, Wp, n, n), a view
    patches = patches.reshape(Hp * Wp, n, n)
    cand_rows, cand_cols = np.divmod(labels, Wp)

    node_of = np.full(H * W, -1, dtype=np.int64)
    node_of[flat] = np.arange(flat.size)
    pairs_all = grid_edges(unknown)
    # step 4: fixed neighbours -> unary terms
    for direction in ("h", "v"):
        fixed_pairs = pairs_all[direction + "_fixed"]
        if fixed_pairs.size == 0:
            continue
        first_unknown = unknown.ravel()[fixed_pairs[:, 0]]
        for side, which in (("right", first_unknown), ("left", ~first_unknown)):
            sel = fixed_pairs[which]
            if sel.size == 0:
                continue
            node_pix = sel[:, 0] if side == "right" else sel[:, 1]
            fixed_pix = sel[:, 1] if side == "right" else sel[:, 0]
            fr, fc = np.divmod(fixed_pix, W)
            node = node_of[node_pix]
            chunk = max(1, _CHUNK_FLOATS // (k * n * n * 4))
            for start in range(0, node.size, chunk):
                s = slice(start, start + chunk)
                cp = patches[labels[node[s]]]
                fp = patches[((fr[s] + pad) * Wp + fc[s] + pad)][:, None]
                ms = fixed_neighbour_terms(cp, fp, direction, side)
                # each node has one such neighbour per direction and side
                unary[node[s]] += psi(ms, sigma_s).astype(np.float32)
    tick()
    # step 4: k x k compatibilities between unknown neighbours
    pair_list, psi_list = [], []
    for direction in ("h", "v"):
        pairs = node_of[pairs_all[direction]]
        if pairs.size == 0:
            continue
        out = np.empty((pairs.shape[0], k, k), dtype=np.float32)
        chunk = max(1, _CHUNK_FLOATS // (k * k * 4))
        for start in range(0, pairs.shape[0], chunk):
            s = slice(start, start + chunk)
            pj = patches[labels[pairs[s, 0]]]
            pk = patches[labels[pairs[s, 1]]]
            out[s] = psi(pair_compatibilities(pj, pk, direction), sigma_s)
        pair_list.append(pairs)
        psi_list.append(out)
    pairs = np.concatenate(pair_list) if pair_list else np.zeros((0, 2), np.int64)
    log_psi = np.concatenate(psi_list) if psi_list else np.zeros((0, k, k), np.float32)
    del psi_list
    tick()
    # step 5: messages; the edge-constraint rule silences edge nodes
    silent = edges.ravel()[flat] if use_edges else None
    belief, done = belief_propagation(
        unary, pairs, log_psi, silent=silent, iterations=iterations,
        tolerance=tolerance, product=product, damping=damping,
    )
    tick()
    # step 6: MAP label, its centre range, and its normalised belief
    best = np.argmax(belief, axis=1)
    belief -= belief.max(axis=1, keepdims=True)
    prob = np.exp(belief)
    prob /= prob.sum(axis=1, keepdims=True)
    centre = np.where(known, range_values, 0.0)
    cand_values = centre[cand_rows - pad, cand_cols - pad]
    out = range_values.copy()
    out[unknown] = cand_values[np.arange(flat.size), best]
    confidence = known.astype(np.float64)
    # the belief that the range is the chosen value: candidates whose centres lie
    # within VALUE_TOLERANCE of the known span of it are the same range hypothesis
    chosen = cand_values[np.arange(flat.size), best]
    same = np.abs(cand_values - chosen[:, None]) <= VALUE_TOLERANCE * span
    confidence[unknown] = np.minimum((prob * same).sum(axis=1), 1.0)
    tick()
    return BPResult(
        range=out,
        confidence=confidence,
        order=np.stack([rows, cols], axis=1).astype(np.int64),
        iterations=done,
        candidate_values=cand_values,
        labels=best,
    )
