r"""The literal reference: Eq. 2, NP (Eqs. 3–5, 10–12) and BP (Eqs. 6–9) as plainly as the paper.

This module is the definition that the fast code (:mod:`refsynth.synthesis.nonparametric`,
:mod:`refsynth.synthesis.priority`, :mod:`refsynth.synthesis.belief.fill`) and any port must
match bit for bit. It loops over pixels, candidates and labels in Python, in the order the
paper reads; it is slow (use it on images up to about 32 × 32) and has no cleverness.

The numeric contract
--------------------
No decision (an argmin, the Eq. 5 threshold, the fill order, BP's argmax) may depend on the
order of a floating-point reduction, so the quantities that feed decisions are *exact*:

1. The normalised intensity and the normalised range are quantised to ``2**-16``
   (:func:`quantise_intensity`, :func:`quantise_range`): ``q = rint(2**16 (x − min) / span)``.
   An offset, or an integer image against the same image as floats, gives the same ``q``.
2. The Gaussian window of Eq. 2 is an integer table summing to about ``2**18``
   (:func:`window_weights`). Eq. 2 is then a sum of integer products, exact below ``2**53``
   in float64 whatever the summation order (BLAS included); a few IEEE operations in a fixed
   order turn it into the distance (:func:`combine_eq2`).
3. A synthesized pixel's confidence is rounded to ``2**-40`` (:func:`on_confidence_grid`), so
   the window sums of Eq. 11 are exact in any order; the range differences of Eq. 12 are
   multiples of ``2**-16`` and exact too. The priority is one fixed formula
   (:func:`priority_terms`);
   ``‖n_p‖`` is ``sqrt(m_row² + m_col²)``, not ``hypot``.
4. BP works in float64, log domain. Max-product needs only ``+``, ``−`` and ``max``; the sums
   over a node's (at most four) incoming messages run in the fixed order left, up, right,
   down. Where an exponential or a logarithm is needed (sum-product, BP's confidence) it is
   :func:`portable_exp` / :func:`portable_log`: IEEE ``+ − × ÷`` and ``ldexp`` only, so the
   same on every CPU and library.
5. Ties: the first candidate in raster order of the disc offsets (Eq. 4, BP's ranking);
   equal priorities by the seeded permutation ``tie`` (Eqs. 10–12).

The helpers of the contract live in :mod:`refsynth.numeric` and are re-exported here.

Every reading of :class:`refsynth.synthesis.readings.Readings` is implemented here as plainly
as the rest, with **refsynth's readings as the defaults** (the default preset, so that
``fast == reference`` is tested under every reading): ``confidence_update`` (Eq. 11's
update), ``colour`` (Eq. 2 on the colour channels or on grey), ``edges_last`` (NP's edge
tier) and ``edge_rule`` (BP's edge-constraint rule); and BP's ``observation`` and
``training_radius`` (Fig. 6's step 2), whose defaults are departures that won on real data
(:func:`bp_reference`). NP with the paper's readings as its defaults, in the paper's order,
is :mod:`refsynth.synthesis.nonparametric.reference`.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.4, Eqs. 2–12, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from refsynth.numeric import (
    CONFIDENCE_BITS,
    INTENSITY_BITS,
    NO_RANGE,
    RANGE_BITS,
    SUPPORT_PRIOR,
    WINDOW_BITS,
    combine_eq2,
    on_confidence_grid,
    portable_exp,
    portable_log,
    quantise_grey,
    quantise_intensity,
    quantise_range,
    window_weights,
)
from refsynth.synthesis.completion import portable_colorization
from refsynth.synthesis.gap_readings import gap_gate
from refsynth.synthesis.median_pass import median_pass
from refsynth.synthesis.similarity import eq2_distance
from refsynth.synthesis.window_reading import choose_neighbourhood

__all__ = [
    "quantise_intensity", "quantise_grey", "quantise_range", "window_weights", "portable_exp",
    "portable_log", "combine_eq2", "on_confidence_grid", "eq2_distance", "confidence_term",
    "priority_terms", "disc_offsets", "overlap_mean_square", "gap_depth_reference",
    "np_reference", "bp_reference", "NPReference", "BPReference", "offset_shift",
    "INTENSITY_BITS", "RANGE_BITS", "WINDOW_BITS", "CONFIDENCE_BITS", "SUPPORT_PRIOR",
    "NO_RANGE", "VALUE_TOLERANCE",
]

VALUE_TOLERANCE = 0.01             #: BP: centres this close (of the span) are one hypothesis
_SOBEL_ROW = ((-1, -2, -1), (0, 0, 0), (1, 2, 1))


# -- the numeric contract (the helpers live in refsynth.numeric) ---------------------------


def disc_offsets(radius: float) -> list[tuple[int, int]]:
    """Eq. 3's offsets ``v ≠ 0`` with ``|v|² ≤ r²``, in raster order (row, then column)."""
    k = int(math.floor(radius))
    return [(dr, dc) for dr in range(-k, k + 1) for dc in range(-k, k + 1)
            if dr * dr + dc * dc <= radius * radius and (dr, dc) != (0, 0)]


class _Frame:
    """The quantised image and range, padded by ``n // 2`` so that every window can be cut out.

    Intensity is mirrored beyond the border (as :func:`~refsynth.synthesis.neighbourhood.
    intensity_patches`); there is no range off the image. ``qr`` is updated as NP fills.
    With ``colour=False`` the intensity is the quantised grey level (:func:`quantise_grey`).
    """

    def __init__(self, image, range_values, n, colour=True):
        self.n, self.h = n, n // 2
        self.shape = range_values.shape
        pad = ((self.h, self.h), (self.h, self.h))
        qi = quantise_intensity(image)
        if not colour:   # Eq. 2 on the grey level (one channel)
            qi = quantise_grey(qi)[:, :, None]
        self.qi = np.pad(qi, pad + ((0, 0),), mode="symmetric")
        qr, self.low, self.span = quantise_range(range_values)
        self.qr = np.pad(qr, pad, constant_values=NO_RANGE)
        self.window = window_weights(n)

    def inside(self, r, c):
        return 0 <= r < self.shape[0] and 0 <= c < self.shape[1]

    def patch(self, r, c):
        """The intensity (n, n, C) and range (n, n) windows centred on (r, c)."""
        return self.qi[r : r + self.n, c : c + self.n], self.qr[r : r + self.n, c : c + self.n]


# -- NP: Eqs. 3–5 in the order of Eqs. 10–12 -----------------------------------------------


@dataclass(frozen=True)
class NPReference:
    """What :func:`np_reference` returns (same meaning as :func:`refsynth.synthesize`'s)."""

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    trace: list | None = None


def _window_sum(values, r, c, h):
    """Σ of ``values`` over the in-image part of the window of half-side ``h`` at (r, c)."""
    return values[max(r - h, 0) : r + h + 1, max(c - h, 0) : c + h + 1].sum()


def confidence_term(conf, r, c, n):
    """Eq. 11: ``C(p) = Σ_{i ∈ N_p ∩ ζ} C(V_i) / |N_p|`` (|N_p|: the in-image voxels)."""
    H, W = conf.shape
    h = n // 2
    count = (min(r + h, H - 1) - max(r - h, 0) + 1) * (min(c + h, W - 1) - max(c - h, 0) + 1)
    return float(_window_sum(conf, r, c, h)) / count   # an exact sum: multiples of 2**-40


def priority_terms(r, c, filled, qr, conf, edge_count, n, *, use_isophotes=True):
    r"""The terms of Eq. 10 at a front voxel: ``(C, D, 1 / (1 + E))``; ``P = C · max(D, 0) + that``.

    ``C`` is Eq. 11. ``D = 1 − |g_row m_col − g_col m_row| / ‖m‖`` is Eq. 12 with α = 1: ``g``
    the mean forward difference of the quantised range, ``(R_b − R_a) 2**-16``, over the
    vertically (``g_row``) or horizontally (``g_col``) adjacent filled pairs ``(a, b)`` that lie
    in ``N_p`` (both voxels: the window is the same on every side, so mirroring the input
    mirrors D); ``m`` the Sobel gradient of the filled mask (the front normal); D = 1 with
    ``use_isophotes=False``. ``edge_count`` is ``E``, or None without edges (the term is then 1).
    """
    H, W = filled.shape
    h = n // 2
    e_term = 1.0 if edge_count is None else 1.0 / (1.0 + edge_count)
    if not use_isophotes:
        return confidence_term(conf, r, c, n), 1.0, e_term
    sum_row = count_row = sum_col = count_col = 0
    rows = range(max(r - h, 0), min(r + h, H - 1) + 1)
    cols = range(max(c - h, 0), min(c + h, W - 1) + 1)
    for i in rows:
        for j in cols:
            if i + 1 in rows and filled[i, j] and filled[i + 1, j]:
                sum_row, count_row = sum_row + int(qr[i + 1, j] - qr[i, j]), count_row + 1
            if j + 1 in cols and filled[i, j] and filled[i, j + 1]:
                sum_col, count_col = sum_col + int(qr[i, j + 1] - qr[i, j]), count_col + 1
    g_row = (sum_row * 2.0**-RANGE_BITS) / max(count_row, 1)
    g_col = (sum_col * 2.0**-RANGE_BITS) / max(count_col, 1)
    m_row = m_col = 0
    for a in range(3):
        for b in range(3):
            i, j = r + a - 1, c + b - 1
            if 0 <= i < H and 0 <= j < W and filled[i, j]:
                m_row, m_col = m_row + _SOBEL_ROW[a][b], m_col + _SOBEL_ROW[b][a]
    norm = math.sqrt(m_row * m_row + m_col * m_col) or 1.0
    d_term = 1.0 - abs(g_row * m_col - g_col * m_row) / norm
    return confidence_term(conf, r, c, n), d_term, e_term


def offset_shift(frame, p, q, source=None, tolerance=2.0**-7) -> int:
    r"""Δ of :mod:`refsynth.synthesis.range_copy`: the windows' consistent range difference.

    Over the offsets ``v`` where both windows have range, ``A = Σ G_v``, ``B = Σ G_v δ_v``
    with ``δ_v = q_r(p + v) − q_r(q + v)``; 0 if there is none, or if some
    ``|A δ_v − B| > 2**16 t A`` (the agreement ``t = tolerance``, a power of two: NP's
    ``2**-7``); else ``B / A`` rounded half to even (Python integers). ``q``'s window is
    read from ``source`` (BP: the measured frame, ``p``'s from the observations') when
    given, else from ``frame``.
    """
    (pr, pc), (qr_, qc), n = p, q, frame.n
    source = frame if source is None else source
    a = b = 0
    deltas = []
    for i in range(n):
        for j in range(n):
            at_p, at_q = int(frame.qr[pr + i, pc + j]), int(source.qr[qr_ + i, qc + j])
            if at_p != NO_RANGE and at_q != NO_RANGE:
                g = int(frame.window[i, j])
                a, b = a + g, b + g * (at_p - at_q)
                deltas.append(at_p - at_q)
    slack = int(Fraction(tolerance) * 2**RANGE_BITS)
    if a == 0 or any(abs(a * d - b) > slack * a for d in deltas):
        return 0
    return round(Fraction(b, a))


def _onion_schedule(known, rng):
    """Fig. 7: layer (chessboard distance to the known region) by layer, seeded within one."""
    H, W = known.shape
    unknown = [(r, c) for r in range(H) for c in range(W) if not known[r, c]]
    sources = [(r, c) for r in range(H) for c in range(W) if known[r, c]]
    layer = [min(max(abs(r - a), abs(c - b)) for a, b in sources) for r, c in unknown]
    tie = rng.permutation(len(unknown))
    return [unknown[i] for i in sorted(range(len(unknown)), key=lambda i: (layer[i], tie[i]))]


def np_reference(image, range_values, edges, rng, *, neighbourhood=None, radius=10.0, epsilon=0.1,
                 use_edges=True, use_isophotes=True, ordering="priority", range_weight=1.0,
                 missing_range="mean", confidence_update="best", colour=True,
                 edges_last=True, channels="sum", range_copy="offset", gaps="gate",
                 median=3, window="gaps", trace=False) -> NPReference:
    r"""NP range synthesis, one voxel at a time (§3.2.2, §3.2.4).

    For the front voxel ``p`` of highest priority (Eq. 10; with ``edges_last``, edge voxels
    in a second tier; equal keys by the seeded ``tie``), or the onion schedule (Fig. 7):

    .. math:: A_p = \{N_q : |p - q| \le r,\ R_q \text{ filled}\}                 \quad (3)

    .. math:: N_{best} = \arg\min_{A_p} \|N_p - N_q\|                              \quad (4)

    .. math:: \Gamma' = \{N_q \in A_p : \|N_p - N_q\| \le (1 + \epsilon)
              \|N_p - N_{best}\|\}                                                  \quad (5)

    ``R_p`` is the centre range of a uniformly drawn member of Γ' (the draw ``u`` picks member
    ``floor(u |Γ'|)``). If ``A_p`` is empty the search widens to the filled voxels within
    ``d + r``, ``d`` the distance to the nearest. ``p`` then gets the confidence
    ``C(N_best)`` (``confidence_update="best"``, the default: Eq. 11 as the text reads) or
    ``C(p) · C(N_best)`` (``"product"``), on the confidence grid. With
    ``range_copy="offset"`` (a departure, :mod:`refsynth.synthesis.range_copy`) the drawn
    centre is shifted by the windows' consistent difference in range (:func:`offset_shift`).

    Parameters
    ----------
    image : ndarray of shape (H, W, C), float
        As :func:`refsynth.synthesize` passes it (integers scaled to [0, 1]).
    range_values : ndarray of shape (H, W), NaN where unknown
    edges : ndarray of shape (H, W), bool
    rng : numpy.random.Generator
        Consumed as the fast code does: ``permutation`` of the padded frame (the ties), then
        one ``random`` per unknown pixel (the Eq. 5 draws), then the onion permutation.
    neighbourhood, radius, epsilon, use_edges, use_isophotes, ordering, range_weight, missing_range
        See :func:`refsynth.synthesize`.
    confidence_update : {"product", "best"}
        The confidence a synthesized voxel receives (above).
    colour : bool
        Eq. 2 on the colour channels (True) or on the grey level (:func:`quantise_grey`).
    channels : {"sum", "mean"}
        Eq. 2's intensity term: the sum over the colour channels (the paper's) or their mean.
    edges_last : bool
        With ``use_edges``: edge voxels form a second tier (True) or only count in ``E``.
    range_copy : {"value", "offset"}
        The drawn centre's value, or that value shifted (above).
    gaps : {"copy", "gate"}
        After the fill (the range only, not the trace's steps): as filled, or
        :func:`~refsynth.synthesis.gap_readings.gap_gate` with the edges used (a departure).
    median : int
        After ``gaps``: 0, or the window side of
        :func:`~refsynth.synthesis.median_pass.median_pass` (a departure).
    window : {"gaps", "fixed"}
        Without a ``neighbourhood``: :func:`~refsynth.synthesis.window_reading.choose_neighbourhood`
        (a departure: 3 on a column scan with narrow gaps, else 5).
    trace : bool
        Also record every step (pixel, priority, candidates, distances, Γ', draw, source).

    Returns
    -------
    NPReference
        ``range``, ``confidence``, ``order`` ((N, 2) int64) and ``trace`` (list of dicts).
    """
    H, W = range_values.shape
    if neighbourhood is None:
        neighbourhood = choose_neighbourhood(range_values, window)
    n, h = neighbourhood, neighbourhood // 2
    frame = _Frame(image, range_values, n, colour)
    known = np.isfinite(range_values)
    filled, qr = known.copy(), frame.qr[h : h + H, h : h + W]   # a view: fills show in frame
    conf = known.astype(np.float64)
    out = range_values.copy()
    pad = max(int(math.ceil(radius)), h + 1)
    tie = rng.permutation((H + 2 * pad) * (W + 2 * pad)).reshape(H + 2 * pad, W + 2 * pad)
    tie = tie[pad : pad + H, pad : pad + W]
    total = int((~known).sum())
    draws = rng.random(total)
    schedule = _onion_schedule(known, rng) if ordering == "onion" else None
    edge_count = [[int(_window_sum(edges.astype(np.int64), r, c, h)) for c in range(W)]
                  for r in range(H)]
    offsets = disc_offsets(radius)
    order, steps = [], [] if trace else None
    for step in range(total):
        if schedule is not None:
            p, terms = schedule[step], None
        else:   # Eqs. 10–12: the front voxel with the smallest (tier, −P, tie)
            key = p = terms = None
            for r in range(H):
                for c in range(W):
                    front = not filled[r, c] and filled[max(r - 1, 0) : r + 2,
                                                        max(c - 1, 0) : c + 2].any()
                    if not front:
                        continue
                    C, D, E = priority_terms(r, c, filled, qr, conf,
                                             edge_count[r][c] if use_edges else None, n,
                                             use_isophotes=use_isophotes)
                    P = C * max(D, 0.0) + E                                       # Eq. 10
                    k = (int(use_edges and edges_last and edges[r, c]), -P, int(tie[r, c]))
                    if key is None or k < key:
                        key, p, terms = k, (r, c), (C, D, E, P)
        r, c = p
        candidates = [(r + dr, c + dc) for dr, dc in offsets
                      if frame.inside(r + dr, c + dc) and filled[r + dr, c + dc]]
        if not candidates:   # a gap wider than r: widen to d + r
            near = [(a, b) for a in range(H) for b in range(W) if filled[a, b]]
            dist = [math.sqrt((a - r) ** 2 + (b - c) ** 2) for a, b in near]
            candidates = [q for q, d in zip(near, dist) if d <= min(dist) + radius]
        target = frame.patch(r, c)
        distances = [eq2_distance(*target, *frame.patch(a, b), frame.window, range_weight,
                                  missing_range, channels) for a, b in candidates]
        best = distances.index(min(distances))                        # Eq. 4, first minimum
        threshold = (1.0 + epsilon) * distances[best]
        members = [i for i, d in enumerate(distances) if d <= threshold]   # Eq. 5
        source = candidates[members[int(draws[step] * len(members))]]
        c_best = confidence_term(conf, *candidates[best], n)
        new = c_best if confidence_update == "best" else confidence_term(conf, r, c, n) * c_best
        value, copied = qr[source], out[source]
        if range_copy == "offset":
            shifted = min(max(int(value) + offset_shift(frame, p, source), 0), 2**RANGE_BITS)
            if shifted != value:   # the caller's unit, clipped to the measured span
                low, high = np.nanmin(range_values), np.nanmax(range_values)
                value, copied = shifted, min(max(float(copied + (shifted - int(qr[source])) * (
                    frame.span * 2.0**-RANGE_BITS)), float(low)), float(high))
        filled[r, c], qr[r, c], out[r, c] = True, value, copied
        conf[r, c] = on_confidence_grid(new)
        order.append(p)
        if trace:
            steps.append(dict(pixel=p, terms=terms, candidates=candidates, distances=distances,
                              best=best, members=members, draw=float(draws[step]),
                              source=source, confidence=conf[r, c]))
    out = _after_fill(out, range_values, edges, use_edges, gaps, median)
    return NPReference(out, conf, np.array(order, dtype=np.int64).reshape(-1, 2), steps)


def _after_fill(out, range_values, edges, use_edges, gaps, median):
    """The readings after the fill (both methods): ``gaps``, as filled or gated with the
    edges the fill used (:func:`refsynth.synthesis.gap_readings.gap_gate`), then ``median``
    (:func:`refsynth.synthesis.median_pass.median_pass`, when not 0)."""
    if gaps == "gate":
        out = gap_gate(out, range_values, edges=np.asarray(edges, bool) & bool(use_edges))
    return median_pass(out, range_values, median) if median else out


# -- BP: the algorithm of Fig. 6 (Eqs. 6–9) --------------------------------------------------


@dataclass(frozen=True)
class BPReference:
    """What :func:`bp_reference` returns.

    ``range``, ``confidence``, ``order`` (raster) as :func:`refsynth.synthesize`; per node
    (unknown pixels in raster order): ``labels`` (N,) the MAP label, ``candidates`` (N, k, 2)
    the (row, col) of each label's centre, ``candidate_values`` (N, k), ``unary`` (N, k)
    (log Φ plus the fixed neighbours' terms), ``beliefs`` (N, k) (log, unnormalised); per
    4-neighbour pair of unknown pixels (horizontal pairs then vertical, raster order):
    ``pairs`` (E, 2) node indices, ``log_psi`` (E, k, k) and ``messages`` (2E, k): row ``e``
    goes ``pairs[e, 0] → pairs[e, 1]``, row ``E + e`` back; ``iterations`` the sweeps done;
    ``trace`` (with ``trace=True``) the messages and the largest change after every sweep;
    ``observed`` (H, W) int64 the observations' range on the measured range's grid (the
    measured range, and with a completing ``observation`` the fill's; ``NO_RANGE`` where
    none).
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    labels: np.ndarray
    candidates: np.ndarray
    candidate_values: np.ndarray
    unary: np.ndarray
    pairs: np.ndarray
    log_psi: np.ndarray
    messages: np.ndarray
    beliefs: np.ndarray
    iterations: int
    trace: list | None = None
    observed: np.ndarray | None = None


def overlap_mean_square(first, second, direction, shifts=(0, 0)):
    r"""Eq. 6's ``|d_jk^l − d_kj^m|²``: the mean squared difference of two range patches over
    the pixels they share (``first`` left of / above ``second``) where both have range; 0 if
    there is none (Ψ = 1). The integer sum is exact; one division makes the mean. With the
    offset copy each patch's range is moved by its label's shift, ``shifts = (Δ_l, Δ_m)``."""
    if direction == "h":
        a, b = first[:, 1:], second[:, :-1]
    else:
        a, b = first[1:, :], second[:-1, :]
    both = (a != NO_RANGE) & (b != NO_RANGE)
    count = int(both.sum())
    if count == 0:
        return 0.0
    d = np.where(both, (a + int(shifts[0])) - (b + int(shifts[1])), 0)
    return (int(np.sum(d * d)) * 2.0 ** (-2 * RANGE_BITS)) / count


def _bp_candidates(observed, frame, known, r, c, k, radius, proximity, range_weight,
                   missing_range, side, channels="sum"):
    """Fig. 6, step 2: the ``k`` training patches (measured centres) closest to node (r, c).

    Ranked by Eq. 2 between the observation (``observed``'s patch) and the training patch
    (``frame``'s), plus ``μ |v|² / r²``, ties by the raster order of the offsets; the radius
    doubles until ``k`` are found, every measured pixel is in the disc, or ``ceil(r) ≥ side``
    (the padded frame's longer side). Too few: the last one repeats.
    """
    total_known = int(known.sum())
    target = observed.patch(r, c)
    r_t = radius
    while True:
        offsets = disc_offsets(r_t)
        dist = []
        for dr, dc in offsets:
            if not (frame.inside(r + dr, c + dc) and known[r + dr, c + dc]):
                dist.append(math.inf)
                continue
            d = eq2_distance(*target, *frame.patch(r + dr, c + dc), frame.window, range_weight,
                             missing_range, channels)
            if proximity:
                d = d + (proximity / (radius * radius)) * (dr * dr + dc * dc)
            dist.append(d)
        kk = min(k, len(offsets))
        ranked = sorted(range(len(offsets)), key=lambda i: (dist[i], i))[:kk]
        finite = sum(math.isfinite(dist[i]) for i in ranked)
        if (kk == k and finite == k) or math.ceil(r_t) >= side or total_known <= finite:
            break
        r_t *= 2.0
    keep = [ranked[min(j, max(finite, 1) - 1, kk - 1)] for j in range(k)]
    return [(r + offsets[i][0], c + offsets[i][1]) for i in keep], [dist[i] for i in keep]


def _send(t, axis, product):
    """Eq. 9 for one message: ``⊕`` over the sender's labels (``axis``), then normalised."""
    if product == "max":
        m = t.max(axis=axis)
        return m - m.max()
    top = t.max(axis=axis)
    terms = portable_exp(t - np.expand_dims(top, axis))
    m = np.zeros_like(top)
    for label in range(t.shape[axis]):      # left to right over the sender's labels
        m = m + np.take(terms, label, axis=axis)
    m = portable_log(m) + top
    z = 0.0
    for value in portable_exp(m - m.max()):
        z += value
    return m - (float(portable_log(z)) + m.max())


def _observed_frame(frame, image, range_values, observation, colour, np_range=None):
    """The observations ``y_i``: ``frame`` itself, or its range completed by the fill.

    With ``observation="colorization"`` (or ``"-completed"``) every unknown pixel's range is
    ``max(rint(2**16 f), 0)``, ``f`` the colorization fill
    (:func:`refsynth.synthesis.completion.portable_colorization`) of the quantised range
    ``q_r / 2**16`` guided by the quantised intensity ``q_i / 2**16`` (the fill reduces
    colour to grey itself; with ``colour=False`` the grey level of Eq. 2); with ``"np"``
    ``f = (D − low) / span`` of NP's result ``np_range`` (``low``, ``span``: the measured
    range's minimum and span); the measured range is kept.
    """
    if observation == "measured":
        return frame
    q_range, low, span = quantise_range(range_values)
    if observation == "np":
        fill = (np_range - low) / span
    else:
        q_intensity = quantise_intensity(image)
        if not colour:
            q_intensity = quantise_grey(q_intensity)
        q_intensity = q_intensity * 2.0**-INTENSITY_BITS
        fill = portable_colorization(
            q_intensity, np.where(q_range == NO_RANGE, np.nan, q_range * 2.0**-RANGE_BITS))
    observed = _Frame(image, range_values, frame.n, colour)
    inner = observed.qr[frame.h : frame.h + frame.shape[0], frame.h : frame.h + frame.shape[1]]
    for r, c in zip(*np.nonzero(inner == NO_RANGE)):
        inner[r, c] = max(round(float(fill[r, c]) * 2.0**RANGE_BITS), 0)
    return observed


def gap_depth_reference(known, r, c) -> int:
    """``⌊d⌋``: the distance from (r, c) to the nearest measured pixel, floored (0: none)."""
    rows, cols = np.nonzero(known)
    if rows.size == 0:
        return 0
    return math.isqrt(int(np.min((rows - r) ** 2 + (cols - c) ** 2)))   # integers: exact


def bp_reference(image, range_values, edges, *, neighbourhood=None, radius=10.0, k=8,
                 sigma_i=0.1, sigma_s=0.2, iterations=50, tolerance=1e-4, product="max",
                 damping=0.0, use_edges=True, range_weight=1.0, missing_range="mean",
                 proximity=0.0, colour=True, edge_rule="silent", channels="sum",
                 observation="np", training_radius="gap", range_copy="offset",
                 offset_tolerance=None, gaps="gate", median=3, window="gaps", rng=None,
                 trace=False) -> BPReference:
    r"""BP range synthesis, the algorithm of Fig. 6, node by node (§3.2.3).

    1. Nodes: the unknown pixels; fixed nodes: the measured ones.
    2. Labels of node ``i``: its ``k`` closest training patches (:func:`_bp_candidates`),
       ranked by Eq. 2 against its observation ``y_i``. refsynth's defaults depart from
       Fig. 6 here (measured in :mod:`refsynth.synthesis.belief.observation` and
       :mod:`refsynth.synthesis.belief.gap_radius`): with ``observation="np"`` (the default)
       :func:`np_reference` (NP's defaults, drawing on ``rng``) fills the range
       first and its result completes ``y_i``'s unknown range (:func:`_observed_frame`);
       with ``"colorization"`` the colorization fill completes it
       (``"colorization-completed"``: the training patches' too, in Eq. 2 only); and with
       ``training_radius="gap"`` the disc's radius is ``r + ⌊d_i⌋``
       (:func:`gap_depth_reference`; the prior μ then divides by that radius squared).
       ``observation="measured"``, ``training_radius="fixed"`` and ``range_copy="value"``
       (below) is Fig. 6 as printed.
    3. Eq. 7, ``log Φ(x_i^l, y_i) = −d_l / 2σ_i²`` with ``d_l`` the ranking distance.
    4. Eq. 6, ``log Ψ = −|d^l − d^m|² / 2σ_s²`` (:func:`overlap_mean_square`) for each pair
       of unknown 4-neighbours; a measured neighbour adds ``log Ψ`` against its own patch to
       the unary term, in the order right, left, below, above.
    5. Eq. 9, synchronous sweeps: ``b_i = unary_i + Σ M_·i`` (incoming in the order left,
       up, right, down), ``h = b_i − M_ji``, ``M_ij(x_j) = max_{x_i} [log Ψ + h]`` minus its
       maximum (sum-product: log-sum-exp); stop when no message moved by more than
       ``tolerance``. The edge rule (with ``use_edges``): a node on an edge, measured or
       not, sends nothing — an unknown one no message, a measured one no term in step 4
       (``edge_rule="silent"``); with ``"deaf"`` it also receives nothing (no message and
       no fixed-neighbour term), so that no message crosses an edge.
    6. Eq. 8, ``x_i = argmax b_i`` (the first maximum); its centre range is the result, its
       belief pooled over labels proposing the same range (within 1 % of the span) the
       confidence.

    With ``range_copy="offset"`` (refsynth's default, a departure:
    :mod:`refsynth.synthesis.range_copy`) every label ``l`` of node ``i`` carries the shift
    ``Δ_il`` of NP's offset copy between ``y_i``'s range (the observations: measured or
    completed) and the label's measured patch (:func:`offset_shift`); its patch's range is
    moved by ``Δ_il`` in every term of step 4, and its centre in step 6 (clipped to the
    measured span, as NP's). ``"value"`` is Fig. 6's labels as printed. The shift's
    agreement is ``offset_tolerance``; None: ``2**-3`` with ``observation="np"``, else
    NP's ``2**-7``.

    Parameters are :func:`refsynth.synthesize`'s (``k`` is ``candidates``); ``image``,
    ``range_values``, ``edges`` and ``colour`` as in :func:`np_reference`; ``edge_rule`` is
    ``"silent"`` or ``"deaf"`` (above); ``rng`` (a ``numpy.random.Generator``, used with
    ``observation="np"`` only) as in :func:`np_reference`; without a ``neighbourhood``,
    ``window`` chooses it as there. Returns :class:`BPReference`.
    """
    H, W = range_values.shape
    if neighbourhood is None:
        neighbourhood = choose_neighbourhood(range_values, window)
    h = neighbourhood // 2
    frame = _Frame(image, range_values, neighbourhood, colour)
    np_range = None
    if observation == "np":  # NP first, at its defaults, with BP's shared options
        if not isinstance(rng, np.random.Generator):
            raise TypeError("observation='np' needs `rng`, a numpy Generator")
        np_range = np_reference(image, range_values, edges, rng, neighbourhood=neighbourhood,
                                radius=radius, use_edges=use_edges, range_weight=range_weight,
                                missing_range=missing_range, colour=colour,
                                channels=channels, gaps="copy", median=0).range
    observed = _observed_frame(frame, image, range_values, observation, colour, np_range)
    agreement = offset_tolerance
    if agreement is None:
        agreement = 2.0**-3 if observation == "np" else 2.0**-7
    training = observed if observation == "colorization-completed" else frame
    on_edge = np.asarray(edges, dtype=bool) & use_edges
    deaf = edge_rule == "deaf"
    known = np.isfinite(range_values)
    pad = max(int(math.ceil(radius)), h + 1)
    nodes = [(r, c) for r in range(H) for c in range(W) if not known[r, c]]
    node_of = {p: i for i, p in enumerate(nodes)}
    N = len(nodes)
    cands, unary = np.zeros((N, k, 2), np.int64), np.zeros((N, k))
    shifts = np.zeros((N, k), np.int64)       # Δ of each label (0: Fig. 6's value copy)
    for i, (r, c) in enumerate(nodes):                                  # steps 2 and 3
        wide = radius + (gap_depth_reference(known, r, c) if training_radius == "gap" else 0)
        cand, dist = _bp_candidates(observed, training, known, r, c, k, wide, proximity,
                                    range_weight, missing_range,
                                    max(H, W) + 2 * max(pad, math.ceil(wide)), channels)
        cands[i] = cand
        unary[i] = [-d / (2.0 * sigma_i * sigma_i) for d in dist]
        if range_copy == "offset":
            shifts[i] = [offset_shift(observed, (r, c), q, source=frame, tolerance=agreement)
                         for q in cand]
        patches = [frame.patch(a, b)[1] for a, b in cand]
        for dr, dc, direction, node_first in ((0, 1, "h", True), (0, -1, "h", False),
                                              (1, 0, "v", True), (-1, 0, "v", False)):
            a, b = r + dr, c + dc
            if not (frame.inside(a, b) and known[a, b]) or on_edge[a, b] or (deaf and
                                                                           on_edge[r, c]):
                continue   # no fixed node there, or the edge rule stops its term
            fixed = frame.patch(a, b)[1]
            for label, patch in enumerate(patches):                     # step 4, fixed
                moved = (int(shifts[i, label]), 0) if node_first else (0, int(shifts[i, label]))
                ms = overlap_mean_square(*((patch, fixed) if node_first else (fixed, patch)),
                                         direction, moved)
                unary[i, label] = unary[i, label] + (-ms / (2.0 * sigma_s * sigma_s))
    pairs = [(node_of[(r, c)], node_of[(r, c + 1)], "h") for r in range(H) for c in range(W - 1)
             if (r, c) in node_of and (r, c + 1) in node_of]
    pairs += [(node_of[(r, c)], node_of[(r + 1, c)], "v") for r in range(H - 1)
              for c in range(W) if (r, c) in node_of and (r + 1, c) in node_of]
    E = len(pairs)
    log_psi = np.zeros((E, k, k))
    for e, (a, b, direction) in enumerate(pairs):                       # step 4
        pa = [frame.patch(*cands[a, label])[1] for label in range(k)]
        pb = [frame.patch(*cands[b, label])[1] for label in range(k)]
        for la in range(k):
            for lb in range(k):
                ms = overlap_mean_square(pa[la], pb[lb], direction,
                                         (shifts[a, la], shifts[b, lb]))
                log_psi[e, la, lb] = -ms / (2.0 * sigma_s * sigma_s)
    incoming = [[] for _ in range(N)]     # message rows into each node: left, up, right, down
    for e, pair in enumerate(pairs):
        incoming[pair[1]].append(e)
    for e, pair in enumerate(pairs):
        incoming[pair[0]].append(E + e)
    silent = [bool(on_edge[r, c]) for r, c in nodes]

    def beliefs(messages):
        out = np.zeros((N, k))
        for i in range(N):
            total = np.zeros(k)
            for row in incoming[i]:
                total = total + messages[row]
            out[i] = unary[i] + total
        return out

    messages = np.zeros((2 * E, k))
    sweeps = [] if trace else None
    done = 0
    while done < iterations:                                            # step 5
        done += 1
        belief = beliefs(messages)
        new = np.zeros((2 * E, k))
        for e, (a, b, _) in enumerate(pairs):
            if not silent[a] and not (deaf and silent[b]):
                new[e] = _send(log_psi[e] + (belief[a] - messages[E + e])[:, None], 0, product)
            if not silent[b] and not (deaf and silent[a]):
                new[E + e] = _send(log_psi[e] + (belief[b] - messages[e])[None, :], 1, product)
        if damping:
            new = new * (1.0 - damping) + damping * messages
        change = float(np.max(np.abs(new - messages), initial=0.0))
        messages = new
        if trace:
            sweeps.append((messages.copy(), change))
        if change <= tolerance:
            break
    belief = beliefs(messages)                                          # step 6
    values = np.where(known, range_values, 0.0)[cands[..., 0], cands[..., 1]]
    qvalues = frame.qr[cands[..., 0] + frame.h, cands[..., 1] + frame.h]   # integers
    low, high = float(np.nanmin(range_values)), float(np.nanmax(range_values))
    for i in range(N):                     # the offset copy's centres (NP's arithmetic)
        for label in range(k):
            q = int(qvalues[i, label])
            moved = min(max(q + int(shifts[i, label]), 0), 2**RANGE_BITS)
            if moved != q:
                qvalues[i, label] = moved
                values[i, label] = min(max(float(values[i, label] + (moved - q) * (
                    frame.span * 2.0**-RANGE_BITS)), low), high)
    labels = np.zeros(N, np.int64)
    out, confidence = range_values.copy(), known.astype(np.float64)
    for i, (r, c) in enumerate(nodes):
        labels[i] = int(np.argmax(belief[i]))
        out[r, c] = values[i, labels[i]]
        weights = portable_exp(belief[i] - belief[i].max())
        z = 0.0
        for w in weights:
            z += w
        pooled = 0.0
        for label in range(k):
            # on the range's integer grid: exact, and unchanged by a scale of the range
            if abs(int(qvalues[i, label]) - int(qvalues[i, labels[i]])) <= (
                    VALUE_TOLERANCE * 2.0**RANGE_BITS):
                pooled += weights[label] / z
        confidence[r, c] = min(pooled, 1.0)
    order = np.array(nodes, dtype=np.int64).reshape(-1, 2)
    out = _after_fill(out, range_values, edges, use_edges, gaps, median)
    return BPReference(out, confidence, order, labels, cands, values, unary,
                       np.array([p[:2] for p in pairs], np.int64).reshape(-1, 2), log_psi,
                       messages, belief, done, sweeps,
                       observed.qr[h : h + H, h : h + W].copy())
