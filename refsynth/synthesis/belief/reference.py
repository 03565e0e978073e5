r"""BP as printed: the algorithm of Fig. 6 (§3.2.3, Eqs. 6–9), node by node, label by label.

The plain version of ``refsynth.synthesize(..., method="bp")``: one function per step of
Fig. 6 in the paper's order — 1 :func:`patches`, 2 :func:`training_candidates` (Eq. 2,
:func:`eq2`), 3 :func:`log_phi` (Eq. 7), 4 :func:`log_psi` (Eq. 6), 5 :func:`send` and
:func:`beliefs` (Eq. 9), 6 :func:`map_and_confidence` (Eq. 8) — in float64, looping over
nodes and labels, with the paper's readings as its defaults. With them it equals
``synthesize(..., method="bp", observation="measured", training_radius="fixed",
range_copy="value", missing_range="ignore", tolerance=0.0)``, that is
``synthesize(..., method="bp", readings="paper")``, bit for bit:
the range, the confidence, the labels, Φ, Ψ, the messages and the beliefs.

The float sequences a port must reproduce (the numeric contract, :mod:`refsynth.numeric`):

- Intensity and range on the ``2**-16`` grids of their spans (:func:`quantise_intensity`
  over all channels, :func:`quantise_range` over the measured range); Eq. 2's window is the
  integer table :func:`window_weights`. Eq. 2 is then ``(si · 2**-50) + λ (sr · 2**-50)``
  with ``si = Σ_v G_v Σ_c ΔI²``, ``sr = Σ_{v∈S} G_v ΔR²``: exact integer sums, so any
  summation order gives the same bits.
- ``log Φ = (−d) / ((2 σ_i) σ_i)``, ``log Ψ = (−ms) / ((2 σ_s) σ_s)``, with ``ms`` Eq. 6's
  mean square ``(Σ (a − b)² · 2**-32) / count`` (an exact integer sum, then one scaling and
  one division; ``0.0`` when the patches share no measured pixel, so ``log Ψ = −0.0``).
- A node's unary term: ``log Φ``, then the measured neighbours' ``log Ψ`` added one at a
  time in the order right, left, below, above.
- A belief: ``unary + ((((0 + M_left) + M_up) + M_right) + M_down)`` (the absent ones left out).
- The message ``i → j``: ``h = b_i − M_ji`` (the sender's belief less the receiver's
  message), ``m(x_j) = max_l (log Ψ(l, x_j) + h_l)``, then ``m − max m``.
- Sum-product: ``t = log Ψ + h``, ``top = max_l t``, ``m = log(Σ_l exp(t − top)) + top``,
  then ``m − (log(Σ exp(m − max m)) + max m)``, with :func:`portable_exp`,
  :func:`portable_log` and sums over the labels from left to right.
- The confidence: ``p = exp(b − max b)``, ``p = p / Σ p`` (left to right), the pooled sum
  ``Σ_l (p_l if |q_l − q_MAP| ≤ 0.01 · 2**16 else 0)`` (left to right, ``q`` the centre
  ranges on the integer grid), clipped to 1.

No label is moved by an offset (the paper copies values): no shifted patch, no lift.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eqs. 6–9, Fig. 6, doi:10.1007/s11263-007-0108-2.
Freeman, Pasztor & Carmichael, "Learning low-level vision", IJCV 40:25–47 (2000).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from refsynth.numeric import (
    INTENSITY_BITS,
    NO_RANGE,
    RANGE_BITS,
    left_to_right_sum,
    portable_exp,
    portable_log,
    quantise_grey,
    quantise_intensity,
    quantise_range,
    window_weights,
)
from refsynth.synthesis.canny import canny
from refsynth.synthesis.neighbourhood import disc_offsets
from refsynth.synthesis.similarity import eq2_distance

__all__ = ["BeliefReference", "Patches", "bp_reference", "patches", "eq2",
           "training_candidates", "log_phi", "overlap_mean_square", "log_psi", "send",
           "beliefs", "map_and_confidence", "VALUE_TOLERANCE"]

VALUE_TOLERANCE = 0.01  #: centres this close (a fraction of the span) are one hypothesis
#: The edge-constraint rule's readings (:func:`bp_reference`) and Eq. 9's products.
EDGE_RULES = ("deaf", "silent")
PRODUCTS = ("max", "sum")


@dataclass(frozen=True)
class Patches:
    """Step 1: quantised intensity ``qi`` (mirrored beyond the border) and range ``qr``
    (:data:`NO_RANGE` where unknown or off the image), padded by ``h = n // 2``: pixel
    (r, c)'s patch is ``[r : r + n, c : c + n]``; ``window``: Eq. 2's integer Gaussian."""

    qi: np.ndarray
    qr: np.ndarray
    window: np.ndarray
    n: int

    def intensity(self, r, c):
        return self.qi[r : r + self.n, c : c + self.n]

    def range(self, r, c):
        return self.qr[r : r + self.n, c : c + self.n]


@dataclass(frozen=True)
class BeliefReference:
    """What :func:`bp_reference` returns, laid out as BP's fast result
    (:class:`refsynth.synthesis.belief.fill.BPResult`).

    Nodes are the unknown pixels in raster order (``order``); pairs the 4-neighbour pairs
    of nodes, horizontal then vertical, each in raster order. ``candidates`` (N, k, 2) the
    labels' centres, ``distances`` (N, k) their Eq. 2 distances, ``unary`` (N, k) log Φ plus
    the measured neighbours' log Ψ, ``log_psi`` (E, k, k), ``messages`` (2E, k) (row ``e``
    goes ``pairs[e, 0] → pairs[e, 1]``, row ``E + e`` back), ``beliefs`` (N, k) log,
    unnormalised, ``labels`` (N,) the MAP labels, ``candidate_values`` (N, k) the labels'
    centre ranges, ``iterations`` the sweeps run, ``edges`` the edge map used.
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    candidates: np.ndarray
    distances: np.ndarray
    unary: np.ndarray
    pairs: np.ndarray
    log_psi: np.ndarray
    messages: np.ndarray
    beliefs: np.ndarray
    labels: np.ndarray
    candidate_values: np.ndarray
    iterations: int
    edges: np.ndarray


def patches(intensity, partial_range, n: int, colour: bool = True) -> Patches:
    r"""Fig. 6, step 1: the registered images divided into n×n patches (quantised).

    The intensity is brought to ``rint(2**16 (I − min) / span)`` over all channels (its grey
    level with ``colour=False``), the range to the same grid of the measured span.
    """
    qi = quantise_intensity(intensity)
    if not colour:
        qi = quantise_grey(qi)[:, :, None]
    qr = quantise_range(partial_range)[0]
    h = n // 2
    return Patches(np.pad(qi, ((h, h), (h, h), (0, 0)), mode="symmetric"),
                   np.pad(qr, h, constant_values=NO_RANGE), window_weights(n), n)


def eq2(frame: Patches, p, q, range_weight: float = 1.0) -> float:
    r"""Eq. 2 between the observation ``y_p`` and the training patch at ``q`` (literal).

    .. math:: \|N_p - N_q\| = \sum_v G_v \left[ \sum_c (I^p_{v,c} - I^q_{v,c})^2
              + \lambda (R^p_v - R^q_v)^2 \right]

    the range term only where both have range, on the integer grids: the shared
    :func:`~refsynth.synthesis.similarity.eq2_distance` (exact integer sums, then
    ``(si · 2**-50) + λ (sr · 2**-50)``).
    """
    return eq2_distance(frame.intensity(*p), frame.range(*p), frame.intensity(*q),
                        frame.range(*q), frame.window, range_weight, "ignore", "sum")


def training_candidates(frame: Patches, known, p, k: int, radius: float,
                        range_weight: float = 1.0):
    r"""Fig. 6, step 2: the ``k`` training patches closest to ``y_p`` by Eq. 2.

    .. math:: A_p = \{ N_q : \|p - q\| \le r,\ q \text{ measured} \}, \qquad
              x_p^1, \dots, x_p^k = \text{the } k \text{ smallest } \|N_p - N_q\|

    Ranked by (distance, raster index of the offset in the disc) — a stable sort. The paper
    is silent when ``A_p`` holds fewer than ``k``: the radius doubles until ``k`` are found,
    every measured pixel is in the disc, or ``ceil(r)`` reaches ``max(H, W) + 2 pad`` (``pad
    = max(ceil(r₀), h + 1)``); still too few: the last one found repeats. Returns the
    centres and their distances.
    """
    H, W = known.shape
    pad = max(math.ceil(radius), frame.n // 2 + 1)
    r_t, total = float(radius), int(known.sum())
    while True:
        dr, dc = disc_offsets(r_t)
        dist = []
        for a, b in zip((p[0] + dr).tolist(), (p[1] + dc).tolist(), strict=True):
            inside = 0 <= a < H and 0 <= b < W and known[a, b]
            dist.append(eq2(frame, p, (a, b), range_weight) if inside else math.inf)
        kk = min(k, len(dist))
        ranked = sorted(range(len(dist)), key=lambda i: (dist[i], i))[:kk]
        finite = sum(math.isfinite(dist[i]) for i in ranked)
        if (kk == k and finite == k) or math.ceil(r_t) >= max(H, W) + 2 * pad or total <= finite:
            break
        r_t *= 2.0
    keep = [ranked[min(j, max(finite, 1) - 1, kk - 1)] for j in range(k)]
    return ([(p[0] + int(dr[i]), p[1] + int(dc[i])) for i in keep], [dist[i] for i in keep])


def log_phi(distance: float, sigma_i: float) -> float:
    r"""Fig. 6, step 3, Eq. 7: the local evidence of a label, as a logarithm.

    .. math:: \Phi(x_i^l, y_i) = \exp\left(-\frac{|y_i^l - y_i|^2}{2\sigma_i^2}\right)

    ``|y^l − y|²`` is Eq. 2's distance; computed as ``(−d) / ((2 σ_i) σ_i)``.
    """
    return -distance / (2.0 * sigma_i * sigma_i)


def overlap_mean_square(first, second, direction: str) -> float:
    r"""Eq. 6's ``|d_jk^l − d_kj^m|²``: the mean squared difference of two range patches.

    .. math:: |d_{jk}^l - d_{kj}^m|^2 = \frac{1}{|S|} \sum_{v \in S} (R^l_v - R^m_v)^2

    over the pixels ``S`` that the patches of neighbours ``first`` (left, or above) and
    ``second`` share and where both have range: ``(Σ (a − b)² · 2**-32) / |S|`` on the
    integer grid (exact sum, one scaling, one division); 0 with ``S`` empty (Ψ = 1).
    """
    a, b = (first[:, 1:], second[:, :-1]) if direction == "h" else (first[1:], second[:-1])
    both = (a != NO_RANGE) & (b != NO_RANGE)
    count = int(both.sum())
    if count == 0:
        return 0.0
    d = np.where(both, a - b, 0)
    return (int(np.sum(d * d)) * 2.0 ** (-2 * RANGE_BITS)) / count


def log_psi(first, second, direction: str, sigma_s: float) -> float:
    r"""Fig. 6, step 4, Eq. 6: the compatibility of two neighbours' labels, as a logarithm.

    .. math:: \Psi(x_k^l, x_j^m) = \exp\left(-\frac{|d_{jk}^l - d_{kj}^m|^2}{2\sigma_s^2}\right)

    Computed as ``(−ms) / ((2 σ_s) σ_s)`` of :func:`overlap_mean_square`. A measured
    neighbour is a fixed node: this against its own patch is its message, a unary term.
    """
    return -overlap_mean_square(first, second, direction) / (2.0 * sigma_s * sigma_s)


def send(psi, h, sender_axis: int, product: str = "max"):
    r"""Eq. 9: one message, ``⊕`` over the sender's labels, normalised (``Z``).

    .. math:: M_{ij}(x_j) = Z \bigoplus_{x_i} \Psi(x_i, x_j)\, \Phi(x_i, y_i)
              \prod_{k \in N(i) \setminus j} M_{ki}(x_i)

    In logs, ``h = log Φ + Σ_{k≠j} log M_ki`` is the sender's belief less ``M_ji``; ``psi``
    is ``log Ψ`` with the sender's labels on ``sender_axis``. Max-product: ``m = max_l
    (log Ψ + h_l)``, then ``m − max m``. Sum-product: ``top = max_l t``, ``m = log Σ_l
    exp(t − top) + top``, then ``m − (log Σ exp(m − max m) + max m)``, sums left to right.
    """
    t = psi + (h[:, None] if sender_axis == 0 else h[None, :])
    if product == "max":
        m = t.max(axis=sender_axis)
        return m - m.max()
    top = t.max(axis=sender_axis)
    terms = portable_exp(t - np.expand_dims(top, sender_axis))
    m = portable_log(left_to_right_sum(terms, axis=sender_axis)) + top
    return m - (portable_log(left_to_right_sum(portable_exp(m - m.max()))) + m.max())


def beliefs(unary, messages, incoming):
    r"""Eq. 8's product, as logarithms: ``b_i = log Φ_i + Σ_j log M_ji`` of every node.

    .. math:: b_i(x_i) = \Phi(x_i, y_i) \prod_{j \in N(i)} M_{ji}(x_i)

    ``incoming[i]`` lists the message rows into ``i`` in the order left, up, right, down;
    their sum starts at 0 and runs in that order, then is added to the unary term.
    """
    out = np.zeros(unary.shape)
    for i, rows in enumerate(incoming):
        total = np.zeros(unary.shape[1])
        for row in rows:
            total = total + messages[row]
        out[i] = unary[i] + total
    return out


def map_and_confidence(belief, values, qvalues):
    r"""Fig. 6, step 6, Eq. 8: the MAP label, its centre range and its confidence.

    .. math:: x_i^{MAP} = \arg\max_{x_i} \Phi(x_i, y_i) \prod_{j \in N(i)} M_{ji}(x_i)

    The first maximum; the range is its patch's centre value (``values``). The confidence
    is the normalised belief ``p = exp(b − max b) / Σ exp(b − max b)`` (left to right)
    pooled, left to right, over the labels whose centres on the integer grid (``qvalues``)
    lie within ``VALUE_TOLERANCE · 2**16`` of the MAP's, then clipped to 1.
    """
    best = int(np.argmax(belief))
    p = portable_exp(belief - belief.max())
    p = p / left_to_right_sum(p)
    same = np.abs(qvalues - qvalues[best]) <= VALUE_TOLERANCE * 2.0**RANGE_BITS
    return best, float(values[best]), min(float(left_to_right_sum(np.where(same, p, 0.0))), 1.0)


def bp_reference(intensity, partial_range, *, neighbourhood: int = 5, radius: float = 10.0,
                 candidates: int = 8, sigma_i: float = 0.1, sigma_s: float = 0.2,
                 iterations: int = 50, tolerance: float | None = None, product: str = "max",
                 range_weight: float = 1.0, colour: bool = True, edges=None,
                 canny_sigma: float = 0.8, use_edges: bool = True,
                 edge_rule: str = "silent") -> BeliefReference:
    r"""Range synthesis by the MRF-BP algorithm of Fig. 6, as printed (§3.2.3).

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, C), real
        The registered intensity (any offset and scale: it is quantised to its span).
    partial_range : ndarray of shape (H, W), float
        The measured range, NaN where unknown (the hidden nodes to estimate).
    neighbourhood, radius, candidates : int, float, int
        The patch side ``n`` (5), the training radius ``r`` (the paper's 10) and ``k`` (8).
    sigma_i, sigma_s, range_weight : float
        σ_i of Eq. 7 (on Eq. 2's distance), σ_s of Eq. 6 (on the span), λ of Eq. 2.
    iterations, tolerance : int, float or None
        The sweeps of Eq. 9 (the paper's 50); with ``tolerance``, stop once no message
        moved by more than it (None: every sweep; a sweep that moved nothing is a fixed
        point, so ``tolerance=0`` changes only ``iterations``).
    product : {"max", "sum"}, default "max"
        Max-product (MAP, Freeman et al.'s reading of the lost ``⊕``) or sum-product.
    colour : bool, default True
        Eq. 2 on the colour channels (summed), or on the grey level.
    edges, canny_sigma, use_edges : ndarray of bool (H, W) or None, float, bool
        The intensity edges (None: Canny of σ = ``canny_sigma`` on the grey level brought
        to [0, 1], as :func:`refsynth.synthesize`); ``use_edges=False`` ignores them.
    edge_rule : {"silent", "deaf"}, default "silent"
        ``"silent"`` (§3.2.3's rule word for word): a node on an edge sends nothing but
        still receives. ``"deaf"``: a node on an edge neither sends nor receives. Measured
        neighbours' terms join the unary term in the order right, left, below, above.

    Returns
    -------
    BeliefReference

    Examples
    --------
    >>> image = np.tile(np.linspace(0, 1, 8), (6, 1))
    >>> partial = np.where(np.arange(8) % 3 == 0, 2.0, np.nan) + np.zeros((6, 1))
    >>> out = bp_reference(image, partial, radius=3.0, iterations=5)
    >>> bool(np.all(out.range == 2.0)), out.labels.shape
    (True, (30,))
    """
    for name, value, allowed in (("product", product, PRODUCTS),
                                 ("edge_rule", edge_rule, EDGE_RULES)):
        if value not in allowed:
            raise ValueError(f"The parameter `{name}` must be one of {allowed}, got {value!r}")
    image = np.atleast_3d(np.asarray(intensity, dtype=np.float64))  # (H, W, C)
    range_values = np.asarray(partial_range, dtype=np.float64)
    if image.shape[:2] != range_values.shape or range_values.ndim != 2:
        raise ValueError(f"The parameter `partial_range` must have shape {image.shape[:2]}, "
                         f"got {range_values.shape}")
    if edges is None:
        grey = quantise_grey(quantise_intensity(image)) * 2.0**-INTENSITY_BITS
        edges = canny(grey, sigma=canny_sigma)
    edges = np.asarray(edges, dtype=bool) & bool(use_edges)
    (H, W), k, h = range_values.shape, candidates, neighbourhood // 2
    known = np.isfinite(range_values)
    frame = patches(image, range_values, neighbourhood, colour)           # step 1
    nodes = [(r, c) for r in range(H) for c in range(W) if not known[r, c]]
    node_of = {p: i for i, p in enumerate(nodes)}
    N = len(nodes)
    cands, dists, unary = np.zeros((N, k, 2), np.int64), np.zeros((N, k)), np.zeros((N, k))
    deaf = edge_rule == "deaf"
    for i, (r, c) in enumerate(nodes):
        cand, dist = training_candidates(frame, known, (r, c), k, radius, range_weight)
        cands[i], dists[i] = cand, dist                                   # step 2
        unary[i] = [log_phi(d, sigma_i) for d in dist]                    # step 3
        labels_q = [frame.range(a, b) for a, b in cand]
        # a measured neighbour's message, in the order right, left, below, above
        for dr, dc, direction, node_first in ((0, 1, "h", True), (0, -1, "h", False),
                                              (1, 0, "v", True), (-1, 0, "v", False)):
            a, b = r + dr, c + dc  # no measured node there, or the edge rule stops it:
            if not (0 <= a < H and 0 <= b < W and known[a, b]) or edges[a, b] or (
                    deaf and edges[r, c]):
                continue
            fixed = frame.range(a, b)
            for label, patch in enumerate(labels_q):                      # step 4, fixed
                pair = (patch, fixed) if node_first else (fixed, patch)
                unary[i, label] = unary[i, label] + log_psi(*pair, direction, sigma_s)
    pairs = [(node_of[(r, c)], node_of[(r + dr, c + dc)], direction)   # raster order
             for direction, dr, dc in (("h", 0, 1), ("v", 1, 0)) for r, c in nodes
             if (r + dr, c + dc) in node_of]
    E = len(pairs)
    psi = np.zeros((E, k, k))
    for e, (a, b, direction) in enumerate(pairs):                         # step 4
        psi[e] = [[log_psi(frame.range(*cands[a, la]), frame.range(*cands[b, lb]), direction,
                           sigma_s) for lb in range(k)] for la in range(k)]
    row_of = {(a, b): e for e, (a, b, _) in enumerate(pairs)}  # message a -> b: row e,
    row_of |= {(b, a): E + e for e, (a, b, _) in enumerate(pairs)}  # b -> a: row E + e
    incoming = [[row_of[(node_of[q], i)] for q in ((r, c - 1), (r - 1, c), (r, c + 1), (r + 1, c))
                 if q in node_of] for i, (r, c) in enumerate(nodes)]  # left, up, right, down
    on_edge = [bool(edges[p]) for p in nodes]
    messages = np.zeros((2 * E, k))
    done = 0
    while done < iterations:                                              # step 5
        done += 1
        belief = beliefs(unary, messages, incoming)
        new = np.zeros((2 * E, k))
        for e, (a, b, _) in enumerate(pairs):
            if not on_edge[a] and not (deaf and on_edge[b]):              # a -> b
                new[e] = send(psi[e], belief[a] - messages[E + e], 0, product)
            if not on_edge[b] and not (deaf and on_edge[a]):              # b -> a
                new[E + e] = send(psi[e], belief[b] - messages[e], 1, product)
        change = float(np.max(np.abs(new - messages), initial=0.0))
        messages = new
        if tolerance is not None and change <= tolerance:
            break
    belief = beliefs(unary, messages, incoming)                           # step 6
    values = np.where(known, range_values, 0.0)[cands[..., 0], cands[..., 1]]
    qvalues = frame.qr[cands[..., 0] + h, cands[..., 1] + h]
    out, conf, labels = range_values.copy(), known.astype(np.float64), np.zeros(N, np.int64)
    for i, (r, c) in enumerate(nodes):
        labels[i], out[r, c], conf[r, c] = map_and_confidence(belief[i], values[i], qvalues[i])
    return BeliefReference(out, conf, np.array(nodes, np.int64).reshape(-1, 2), cands,
                           dists, unary, np.array([p[:2] for p in pairs], np.int64).reshape(-1, 2),
                           psi, messages, belief, labels, values, done, edges)
