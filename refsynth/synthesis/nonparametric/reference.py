r"""NP as the paper writes it: §3.2.2's sampling (Eqs. 2–5) in §3.2.4's order (Eqs. 10–12).

One voxel at a time, in plain Python loops, with **the paper's readings as the defaults**
(:meth:`refsynth.synthesis.readings.Readings.paper`: Eq. 2 as written, Eq. 5's value copy).
:func:`np_reference` with its defaults equals ``refsynth.synthesize(..., method="np",
readings="paper")`` bit for bit, and with refsynth's readings (``missing_range="mean"``,
``range_copy="offset"``) the default ``synthesize``; the fast fill
(:mod:`refsynth.synthesis.nonparametric.fill`) makes the same decisions. Use it on small
images (up to about 32 × 32).

The algorithm, step by step
---------------------------
While a voxel has unknown range:

1. **The order** (§3.2.4). Of the voxels on the front ``δΩ`` (unknown, with a filled
   8-neighbour), take the one of highest priority (Eq. 10)

   .. math:: P(V_p) = C(V_p)\,\max(D(V_p), 0) + \frac{1}{1 + E}                  \quad (10)

   .. math:: C(V_p) = \frac{\sum_{i \in N_p \cap \zeta} C(V_i)}{|N_p|}           \quad (11)

   .. math:: D(V_p) = 1 - \frac{|\nabla I^\perp_p \cdot n_p|}{\alpha}             \quad (12)

   ``E`` the Canny edge pixels in ``N_p``; voxels on an edge come after all others
   (``edges_last``: "to the very end", read on the front). Equal priorities go by a seeded
   permutation ``tie``. Or the onion-peel order (Fig. 7): layers of chessboard distance to
   the measured range, seeded within a layer.
2. **The training set** (Eq. 3): ``A_p``, the filled voxels within ``r`` of ``p``. Empty
   only for ``r < √2`` or in the onion order: then every filled voxel within ``d + r``,
   ``d`` the distance to the nearest filled one (the paper is silent).
3. **The distances** (Eq. 2, :func:`refsynth.synthesis.similarity.eq2_distance`) between
   ``N_p`` and each ``N_q``; **the best match** (Eq. 4), the first minimum; **the near-best
   set** (Eq. 5) ``Γ' = {q : ‖N_p − N_q‖ ≤ (1 + ε) ‖N_p − N_best‖}`` (``≤``, so that it
   holds ``N_best`` even at distance 0).
4. **The draw**: a uniform member of ``Γ'`` (the histogram of its centre values, each
   member counted once), whose centre range ``p`` takes (Eq. 5's copy).
5. **The confidence** (after Eq. 11): ``p`` takes ``C(N_best)``.

The numeric contract, as a port must reproduce it
-------------------------------------------------
- The intensity and the range are quantised: ``q = rint(2**16 (x − min) / span)``
  (:func:`~refsynth.numeric.quantise_intensity` over all pixels and channels,
  :func:`~refsynth.numeric.quantise_range` over the measured range). Beyond the image the
  intensity is **mirrored** (``numpy.pad(mode="symmetric")``); there is no range there.
- Eq. 2's window ``G`` is the integer table :func:`~refsynth.numeric.window_weights`; Eq. 2
  is four exact integer sums combined by :func:`~refsynth.numeric.combine_eq2`.
- Eq. 5's threshold is ``(1.0 + ε) * d_best`` (that product, then ``≤``); the draw ``u``
  picks member ``floor(u · |Γ'|)`` of ``Γ'`` in candidate order (Eq. 3's disc offsets in
  raster order, row then column).
- Eq. 11: ``|N_p|`` counts the window's voxels inside the image; the numerator is a sum of
  multiples of ``2**-40`` (exact in any order), divided once. A synthesized confidence is
  rounded to ``2**-40`` (:func:`~refsynth.numeric.on_confidence_grid`).
- Eq. 12 (α = 1 on the normalised range), in this order: ``g_row = (Σ ΔR_row · 2**-16) /
  max(n_row, 1)`` over the vertically adjacent pairs of filled voxels inside ``N_p`` (the
  integer sum scaled once, then divided), ``g_col`` likewise; ``m = (m_row, m_col)`` the
  **un-normalised** Sobel gradient of the filled mask (3 × 3, in the image), ``‖m‖ =
  sqrt(m_row² + m_col²)`` (1 if 0); ``D = 1 − |g_row · m_col − g_col · m_row| / ‖m‖`` —
  the isophote ``(−g_col, g_row)`` against the front normal ``m / ‖m‖``, divided by the
  norm once at the end. ``P = C · max(D, 0) + 1 / (1 + E)``.
- The order key is ``(tier, −P, tie)``, the smallest first; ``tie`` is
  ``rng.permutation`` of the frame padded by ``pad = max(ceil(r), n // 2 + 1)``, cut to the
  image. The generator is consumed in this order: that permutation, then one ``random()``
  per unknown voxel (the draws), then (onion order) the permutation of the unknown voxels.
- The offset copy (``range_copy="offset"``, a departure): over the offsets where both
  windows have range, ``A = Σ G``, ``B = Σ G δ`` (``δ = q_r(p + v) − q_r(q + v)``); the shift
  ``round(B / A)`` (half to even, exact) is taken when every ``|A δ − B| ≤ 2**9 A``; the
  quantised value is clipped to ``[0, 2**16]``, and the value in the caller's unit is ``R_q +
  (shifted − q_r(q)) · (span · 2**-16)``, clipped to the measured minimum and maximum.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, §3.2.4, Eqs. 2–5, 10–12, Fig. 7,
doi:10.1007/s11263-007-0108-2. A. A. Efros and T. K. Leung, "Texture synthesis by
non-parametric sampling", ICCV 1999.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from refsynth.numeric import (
    NO_RANGE,
    RANGE_BITS,
    on_confidence_grid,
    quantise_grey,
    quantise_intensity,
    quantise_range,
    window_weights,
)
from refsynth.synthesis.gap_readings import gap_gate
from refsynth.synthesis.median_pass import median_pass
from refsynth.synthesis.neighbourhood import disc_offsets
from refsynth.synthesis.similarity import eq2_distance

__all__ = ["NPResult", "np_reference", "confidence_term", "priority_terms", "priority",
           "offset_shift", "onion_schedule", "OFFSET_SLACK"]

#: The offset copy's agreement: every difference within ``2**-7`` of the span (on the grid).
OFFSET_SLACK = 2 ** (RANGE_BITS - 7)
_SOBEL = ((-1, -2, -1), (0, 0, 0), (1, 2, 1))   # d/d row; its transpose is d/d column


@dataclass(frozen=True)
class NPResult:
    """What :func:`np_reference` returns, as :func:`refsynth.synthesize` does.

    Attributes
    ----------
    range : ndarray of shape (H, W)
        The dense range; measured values unchanged.
    confidence : ndarray of shape (H, W)
        1 where measured; the confidence each voxel received (Eq. 11).
    order : ndarray of shape (N, 2), int64
        The synthesized voxels (row, col) in fill order.
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray


# -- Eqs. 10–12: the priority of a front voxel ------------------------------------------


def confidence_term(conf: np.ndarray, r: int, c: int, n: int) -> float:
    """Eq. 11: ``C(p) = Σ_{i ∈ N_p ∩ ζ} C(V_i) / |N_p|``, ``|N_p|`` the in-image voxels.

    >>> confidence_term(np.eye(3), 0, 0, 3)   # (1 + 1) over the 4 voxels in the image
    0.5
    """
    H, W = conf.shape
    h = n // 2
    rows = slice(max(r - h, 0), min(r + h, H - 1) + 1)
    cols = slice(max(c - h, 0), min(c + h, W - 1) + 1)
    count = (rows.stop - rows.start) * (cols.stop - cols.start)
    return float(conf[rows, cols].sum()) / count


def priority_terms(r: int, c: int, filled: np.ndarray, qr: np.ndarray, conf: np.ndarray,
                   edge_count: int | None, n: int, *,
                   use_isophotes: bool = True) -> tuple[float, float, float]:
    """The terms of Eq. 10 at a front voxel: ``(C, D, 1 / (1 + E))``.

    ``C`` is Eq. 11, ``D`` Eq. 12 in the contract's order (the module's docstring; 1 with
    ``use_isophotes=False``), ``edge_count`` is ``E`` (None without edges: the term is 1).
    ``qr`` holds the quantised range written so far, ``filled`` where it is known.
    """
    H, W = filled.shape
    h = n // 2
    e_term = 1.0 if edge_count is None else 1.0 / (1.0 + edge_count)
    C = confidence_term(conf, r, c, n)
    if not use_isophotes:
        return C, 1.0, e_term
    # the range gradient over the adjacent filled pairs inside N_p (both voxels)
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
    # the front normal: the Sobel gradient of the filled mask, un-normalised
    m_row = m_col = 0
    for a in range(3):
        for b in range(3):
            i, j = r + a - 1, c + b - 1
            if 0 <= i < H and 0 <= j < W and filled[i, j]:
                m_row, m_col = m_row + _SOBEL[a][b], m_col + _SOBEL[b][a]
    norm = math.sqrt(m_row * m_row + m_col * m_col) or 1.0
    D = 1.0 - abs(g_row * m_col - g_col * m_row) / norm
    return C, D, e_term


def priority(C: float, D: float, e_term: float) -> float:
    """Eq. 10 from its terms: ``P = C · max(D, 0) + 1 / (1 + E)`` (a negative D counts as 0).

    >>> priority(0.5, -0.4, 1.0), priority(0.5, 0.5, 0.25)
    (1.0, 0.5)
    """
    return C * max(D, 0.0) + e_term


def onion_schedule(known: np.ndarray, rng: np.random.Generator) -> list[tuple[int, int]]:
    """Fig. 7's onion peel: by chessboard distance to the measured range, seeded within.

    >>> onion_schedule(np.array([[True, False, False]]), np.random.default_rng(0))
    [(0, 1), (0, 2)]
    """
    H, W = known.shape
    unknown = [(r, c) for r in range(H) for c in range(W) if not known[r, c]]
    sources = [(r, c) for r in range(H) for c in range(W) if known[r, c]]
    layer = [min(max(abs(r - a), abs(c - b)) for a, b in sources) for r, c in unknown]
    tie = rng.permutation(len(unknown))
    return [unknown[i] for i in sorted(range(len(unknown)), key=lambda i: (layer[i], tie[i]))]


# -- Eq. 5's copy, shifted (a departure) ---------------------------------------------------


def offset_shift(q_pad: np.ndarray, window: np.ndarray, p: tuple[int, int],
                 q: tuple[int, int]) -> int:
    """The windows' consistent range difference ``Δ`` (0 when they disagree or share none).

    ``q_pad`` is the quantised range padded by ``n // 2`` (:data:`~refsynth.numeric.NO_RANGE`
    where unknown); ``p``, ``q`` are image coordinates, so ``q_pad[r : r + n, c : c + n]`` is
    the window centred on ``(r, c)``. Exact: Python integers and fractions.
    """
    n = window.shape[0]
    a = b = 0
    deltas = []
    for i in range(n):
        for j in range(n):
            at_p, at_q = int(q_pad[p[0] + i, p[1] + j]), int(q_pad[q[0] + i, q[1] + j])
            if at_p != NO_RANGE and at_q != NO_RANGE:
                g = int(window[i, j])
                a, b = a + g, b + g * (at_p - at_q)
                deltas.append(at_p - at_q)
    if a == 0 or any(abs(a * d - b) > OFFSET_SLACK * a for d in deltas):
        return 0
    return round(Fraction(b, a))


# -- NP --------------------------------------------------------------------------------------


def np_reference(image: np.ndarray, range_values: np.ndarray, edges: np.ndarray,
                 rng: np.random.Generator, *, neighbourhood: int = 5, radius: float = 10.0,
                 epsilon: float = 0.1, use_edges: bool = True, use_isophotes: bool = True,
                 ordering: str = "priority", range_weight: float = 1.0,
                 missing_range: str = "ignore", confidence_update: str = "best",
                 colour: bool = True, edges_last: bool = True, channels: str = "sum",
                 range_copy: str = "value", gaps: str = "copy", median: int = 0) -> NPResult:
    """NP range synthesis, one voxel at a time (§3.2.2, §3.2.4; the steps above).

    Parameters
    ----------
    image : ndarray of shape (H, W, C), float
        The intensity as :func:`refsynth.synthesize` hands it on
        (:func:`refsynth.synthesis.limits.normalise_intensity`).
    range_values : ndarray of shape (H, W)
        The measured range, NaN where unknown.
    edges : ndarray of shape (H, W), bool
        The Canny edge map (``synthesize(...).edges``).
    rng : numpy.random.Generator
        Consumed as the module's docstring says.
    neighbourhood, radius, epsilon, use_edges, use_isophotes, ordering
        As :func:`refsynth.synthesize`'s.
    range_weight, missing_range, confidence_update, colour, edges_last, channels, range_copy
        The readings (:class:`refsynth.synthesis.readings.Readings`); the defaults are the
        paper's.
    gaps : {"copy", "gate"}
        The reading after the fill: as filled (the paper's), or refsynth's
        :func:`~refsynth.synthesis.gap_readings.gap_gate` with ``edges`` (when ``use_edges``).
    median : int
        The reading after ``gaps``: 0, none (the paper's), or refsynth's
        :func:`~refsynth.synthesis.median_pass.median_pass` with that window.

    Returns
    -------
    NPResult

    Examples
    --------
    >>> import numpy as np, refsynth
    >>> image = np.tile(np.linspace(0, 1, 6), (6, 1))[:, :, None]
    >>> partial = np.where(np.arange(6) % 2 == 0, 1.0 + np.arange(6)[:, None], np.nan)
    >>> edges = np.zeros((6, 6), dtype=bool)
    >>> ours = np_reference(image, partial, edges, np.random.default_rng(1), neighbourhood=3)
    >>> fast = refsynth.synthesize(image[:, :, 0], partial, seed=1, neighbourhood=3,
    ...                            edges=edges, readings="paper")
    >>> bool(np.array_equal(ours.range, fast.range) and np.array_equal(ours.order, fast.order))
    True
    """
    H, W = range_values.shape
    n, h = neighbourhood, neighbourhood // 2
    # the contract's grids: intensity mirrored beyond the image, no range there
    qi = quantise_intensity(image)
    if not colour:
        qi = quantise_grey(qi)[:, :, None]
    qi_pad = np.pad(qi, ((h, h), (h, h), (0, 0)), mode="symmetric")
    q_range, _, span = quantise_range(range_values)
    qr_pad = np.pad(q_range, h, constant_values=NO_RANGE)
    qr = qr_pad[h : h + H, h : h + W]            # a view: what is written shows in qr_pad
    window = window_weights(n)
    known = np.isfinite(range_values)
    low, high = float(np.min(range_values[known])), float(np.max(range_values[known]))
    filled, conf, out = known.copy(), known.astype(np.float64), range_values.copy()

    # the random numbers, in the fast fill's order: ties, draws, the onion's ties
    pad = max(int(math.ceil(radius)), h + 1)
    tie = rng.permutation((H + 2 * pad) * (W + 2 * pad)).reshape(H + 2 * pad, W + 2 * pad)
    tie = tie[pad : pad + H, pad : pad + W]
    total = int((~known).sum())
    draws = rng.random(total)
    schedule = onion_schedule(known, rng) if ordering == "onion" else None

    def edge_count(r: int, c: int) -> int | None:                    # E of Eq. 10
        if not use_edges:
            return None
        return int(edges[max(r - h, 0) : r + h + 1, max(c - h, 0) : c + h + 1].sum())

    def patch(r: int, c: int) -> tuple[np.ndarray, np.ndarray]:      # N_r,c on the grids
        return qi_pad[r : r + n, c : c + n], qr_pad[r : r + n, c : c + n]

    offsets = list(zip(*(d.tolist() for d in disc_offsets(radius))))   # Eq. 3, raster order
    order = []
    for step in range(total):
        if schedule is not None:                                      # Fig. 7
            p = schedule[step]
        else:                                                         # Eqs. 10-12
            key = p = None
            for r in range(H):
                for c in range(W):
                    if filled[r, c] or not filled[max(r - 1, 0) : r + 2,
                                                  max(c - 1, 0) : c + 2].any():
                        continue                                      # not on the front
                    terms = priority_terms(r, c, filled, qr, conf, edge_count(r, c), n,
                                           use_isophotes=use_isophotes)    # (11), (12)
                    P = priority(*terms)                                              # (10)
                    tier = int(use_edges and edges_last and bool(edges[r, c]))
                    if key is None or (tier, -P, int(tie[r, c])) < key:
                        key, p = (tier, -P, int(tie[r, c])), (r, c)
        r, c = p
        candidates = [(r + dr, c + dc) for dr, dc in offsets                        # (3)
                      if 0 <= r + dr < H and 0 <= c + dc < W and filled[r + dr, c + dc]]
        if not candidates:              # a gap wider than r: every filled voxel within d + r
            near = [(a, b) for a in range(H) for b in range(W) if filled[a, b]]
            dist = [math.sqrt((a - r) ** 2 + (b - c) ** 2) for a, b in near]
            candidates = [q for q, d in zip(near, dist) if d <= min(dist) + radius]
        distances = [eq2_distance(*patch(r, c), *patch(a, b), window, range_weight,      # (2)
                                  missing_range, channels) for a, b in candidates]
        best = distances.index(min(distances))                                      # (4)
        threshold = (1.0 + epsilon) * distances[best]
        members = [i for i, d in enumerate(distances) if d <= threshold]            # (5)
        source = candidates[members[int(draws[step] * len(members))]]
        value, copied = int(qr[source]), float(out[source])          # Eq. 5's copy
        if range_copy == "offset":                                    # the departure
            shifted = min(max(value + offset_shift(qr_pad, window, p, source), 0),
                          2**RANGE_BITS)
            if shifted != value:
                copied = min(max(copied + (shifted - value) * (span * 2.0**-RANGE_BITS), low),
                             high)
                value = shifted
        c_best = confidence_term(conf, *candidates[best], n)                        # (11)
        new = c_best if confidence_update == "best" else confidence_term(conf, r, c, n) * c_best
        filled[r, c], qr[r, c], out[r, c] = True, value, copied
        conf[r, c] = on_confidence_grid(new)
        order.append(p)
    if gaps == "gate":  # a departure, after the fill: refsynth.synthesis.gap_readings
        out = gap_gate(out, range_values, edges=edges & use_edges)
    if median:  # a departure, after the gaps: refsynth.synthesis.median_pass
        out = median_pass(out, range_values, median)
    return NPResult(out, conf, np.array(order, dtype=np.int64).reshape(-1, 2))
