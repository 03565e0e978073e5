r"""The porter's contract: every float sequence a port must reproduce to pass the cases.

The oracle's cases (:mod:`refsynth.oracle.cases`) hold the literal reference's results
(:mod:`refsynth.synthesis.reference`) bit for bit, and ``oracle check`` compares a port's
at ``exact`` by default. Decisions (an argmin, Eq. 5's set, the fill order, BP's argmax)
rest on exact numbers (C1–C10), so the order of a sum never changes them; the few
floating-point sequences that remain are fixed here, operation by operation, in the order
a run meets them. Each rule names the case that fails when it is broken
(``tests/test_oracle_contract.py`` writes such wrong ports and checks the report).

Notation: ``q`` values are int64 on a ``2**-16`` grid, ``NO_RANGE = −1`` where unknown;
``(a · b) · c`` is evaluated as written, left to right; "a sum left to right" starts at
``0.0`` and adds the terms in the order listed; ``round_half_even`` is Python's ``round``
(and numpy's ``rint``).

The numeric contract (C1–C10)
-----------------------------

- C1. Intensity and range are quantised to ``2**-16`` of their spans:
  ``q = rint((x − min) / span · 2**16)`` in float64 (intensity: ``min``/``max`` over all
  pixels and channels; range: over the measured pixels; a zero span counts as 1)
  (:func:`refsynth.numeric.quantise_intensity`, :func:`~refsynth.numeric.quantise_range`).
  Canny, and Eq. 2 with ``colour=False``, see the grey level ``(w0 R + w1 G) + w2 B``
  (BT.709) of the quantised colour, quantised again (:func:`~refsynth.numeric.quantise_grey`).
- C2. Eq. 2's Gaussian window is the integer table ``G = rint(2**18 g)``
  (:func:`~refsynth.numeric.window_weights`). Eq. 2 is four sums of integer products,
  ``si = Σ_v G_v Σ_c ΔI²``, ``sr = Σ_{v∈S} G_v ΔR²``, ``ws = Σ_{v∈S} G_v``,
  ``wa = Σ_{v∈A} G_v`` (``S``: the offsets where both windows have range, ``A``: where
  the target's has), exact in any order.
- C3. The distance from the sums (:func:`~refsynth.numeric.combine_eq2`), ``u = 2**-50``,
  ``w = 2**-18``, ``ε = 10**-4``:
  ``d = (si · u) / C + λ (sr · u)`` (``missing_range="ignore"``) or
  ``d = (si · u) / C + (λ (sr · u) + λ ε) · ((wa · w) / (ws · w + ε))`` (``"mean"``).
  ``C`` is the channel divisor: 1 with ``channels="sum"`` (Eq. 2's sum over the
  channels, the default), the number of channels Eq. 2 sees with ``channels="mean"``
  (3 for colour, 1 with ``colour=False`` or a grey image). ``λ`` is ``range_weight``.
- C4. A synthesized pixel's confidence is rounded to ``2**-40``
  (``rint(x · 2**40) · 2**-40``, :func:`~refsynth.numeric.on_confidence_grid`), so
  Eq. 11's window sums are exact in any order.
- C5. Eq. 10 is ``P = C · max(D, 0) + 1 / (1 + E)`` (here ``C`` is Eq. 11's confidence
  term); ``‖m‖ = sqrt(m_row² + m_col²)`` (not ``hypot``); Eq. 12's arithmetic is below.
- C6. BP in float64, in logarithms; a node's incoming messages are summed left, up, right,
  down; the measured neighbours' terms are added right, left, below, above.
- C7. No libm or SIMD transcendental in a result: ``exp`` and ``log`` are
  :func:`~refsynth.numeric.portable_exp` and :func:`~refsynth.numeric.portable_log`
  (IEEE ``+ − × ÷`` and ``ldexp`` only); sums over labels run left to right.
- C8. Ties are broken by fixed rules: the first candidate in the disc's raster order (Eq. 4,
  BP's ranking), the seeded permutation ``tie`` (Eq. 10), the first maximum (Eq. 8).
- C9. No BLAS product and no library-ordered reduction on non-integer data.
- C10. Canny runs on the quantised grey level, with a portable Gaussian applied tap by tap.

Shared by NP and BP
-------------------

The intensity outside the image is **mirrored, the border pixel repeated**: a window
reaching ``k`` pixels beyond the border reads the ``k``-th pixel inside, counting the
border pixel as the first (``numpy.pad(mode="symmetric")``: ``I[−1] = I[0]``,
``I[−2] = I[1]``; not ``"reflect"``, ``I[−1] = I[1]``; not ``"edge"``, not zeros, not NaN).
Every intensity offset of a window is therefore present in Eq. 2's ``si``. The **range**
outside the image is unknown (``NO_RANGE``): it is in neither ``S`` nor ``A``.
Broken, it fails every case with a border window: NP's first ``cand_distance``, BP's
``candidates``.

Eq. 3's disc: the offsets ``(dr, dc) ≠ (0, 0)`` with ``dr² + dc² ≤ r²`` in raster order
(``dr``, then ``dc``), ``|dr|, |dc| ≤ floor(r)``.

NP, step by step
----------------

Random numbers, in the order they are drawn from ``numpy.random.default_rng(seed)``:
``tie = permutation((H + 2 pad) (W + 2 pad))`` reshaped, its inner ``H × W`` part the tie
key (``pad = max(ceil(r), n // 2 + 1)``); ``draws = random(N)`` (N unknown pixels); with
``ordering="onion"``, ``onion_tie = permutation(N)``. The cases carry all three.

1. **The pixel.** The front: unfilled pixels with a filled 8-neighbour. The next pixel has
   the smallest key ``(tier, −P, tie)``, tier 1 for an edge pixel when ``use_edges`` and
   ``edges_last``, else 0. The onion order (Fig. 7) instead sorts the unknown pixels
   (raster order) by ``(chessboard distance to the measured pixels, onion_tie)``; no
   priority is computed, and the trace's ``step_C``, ``step_D``, ``step_E`` and ``step_P``
   are all NaN.
2. **Eq. 11**, ``C(p) = S / |N_p|``: ``S`` the sum of the confidences in the n×n window
   (exact, C4), ``|N_p|`` the number of the window's pixels inside the image, one
   division. Measured pixels have confidence 1, unfilled 0.
3. **Eq. 12**, ``D``, with α = 1. Over the window's in-image pixels, the vertical pairs
   ``(i, j), (i + 1, j)`` with both filled give ``sum_row = Σ (q_r(i+1, j) − q_r(i, j))``
   and their count ``count_row`` (integers); the horizontal pairs likewise ``sum_col``,
   ``count_col``. ``g_row = (sum_row · 2**-16) / max(count_row, 1)``, ``g_col`` alike.
   The front normal ``m`` is the Sobel gradient of the filled mask over the 3 × 3 pixels
   around ``p`` inside the image, **un-normalised integers**: ``m_row = Σ S[a][b]``,
   ``m_col = Σ S[b][a]`` over the filled ``(p_r + a − 1, p_c + b − 1)``,
   ``S = ((−1, −2, −1), (0, 0, 0), (1, 2, 1))``. ``norm = sqrt(m_row² + m_col²)``
   (1.0 if 0). Then, in this order and no other::

       D = 1.0 − abs(g_row · m_col − g_col · m_row) / norm

   the cross product of the un-normalised vector, **divided by its norm once**. Dividing
   ``m`` first (``g_row · (m_col / norm) − …``), dividing each product separately, or
   multiplying by ``1 / norm`` differs by an ulp: the ``eq10_12-arithmetic`` case
   fails on ``D``. With ``use_isophotes=False``, ``D = 1``.
4. **Eq. 10**: ``E`` is the number of edge pixels in the in-image n×n window (with
   ``use_edges``; else the term is 1); ``P = C · max(D, 0.0) + 1.0 / (1.0 + E)``.
5. **Eqs. 3–4**: the candidates are ``p + v`` over the disc, inside the image and filled
   (measured or synthesized), in the disc's order; none: every filled pixel in image raster
   order whose distance ``sqrt(dr² + dc²)`` (of the integer sum) is at most
   ``min distance + r``. Each distance is C3 between ``p``'s and the candidate's windows
   (the range as filled so far); ``best`` is the first minimum.
6. **Eq. 5**: ``threshold = (1.0 + ε) · d_best`` (once); the members are the candidates
   with ``d ≤ threshold``, in candidate order; the step's draw ``u`` picks member
   ``floor(u · |Γ'|)``, the source.
7. **The value.** ``range_copy="value"`` (Eq. 5 as printed): the source's range, bit for
   bit, and ``q_r(p) = q_r(source)``. ``range_copy="offset"``: the shift ``Δ`` between
   ``p``'s and the source's windows of the range as filled so far (below);
   ``q_r(p) = min(max(q_r(source) + Δ, 0), 2**16)`` (**clipped to the grid**) and, when
   that differs from ``q_r(source)``, the value in the caller's unit is
   ``min(max(R(source) + (q_r(p) − q_r(source)) · (span · 2**-16), low), high)``
   (``low``, ``high``: the measured range's minimum and maximum; **clipped to the
   measured range**); else ``R(source)`` bit for bit. Broken clips fail
   ``np-10x12-best-grey`` / ``np-10x12-channel-mean`` on ``step_value``.
8. **The confidence**: ``C(best)`` (the best match's Eq. 11, ``confidence_update="best"``)
   or ``C(p) · C(best)`` (``"product"``), then C4.

The shift ``Δ`` (NP and BP, :func:`refsynth.synthesis.reference.offset_shift`), integers
throughout: over the window offsets ``v`` where both windows have range, ``δ_v =
q_r(p + v) − q_r(q + v)``, ``A = Σ G_v``, ``B = Σ G_v δ_v``; ``Δ = 0`` if ``A = 0`` or some
``|A δ_v − B| > s A`` with ``s = tolerance · 2**16`` (NP: ``2**-7``, ``s = 512``); else
``Δ = round_half_even(B / A)`` of the exact fraction.

BP, step by step (Fig. 6)
-------------------------

Nodes are the unknown pixels in raster order; pairs the 4-neighbour pairs of nodes,
horizontal ones in raster order, then vertical ones; message row ``e`` goes
``pairs[e, 0] → pairs[e, 1]``, row ``E + e`` back.

1. **The observations** ``y_i``: the measured range (``observation="measured"``), or
   completed at the unknown pixels by ``max(round_half_even(f · 2**16), 0)`` (float64,
   in that order), ``f = (D − low) / span`` with ``D`` NP's result
   (``observation="np"``: NP at its defaults with BP's ``neighbourhood``, ``radius``,
   ``use_edges``, ``range_weight``, ``missing_range``, ``colour``, ``channels`` and the
   case's seed) or ``f`` the colorization fill
   (:func:`refsynth.synthesis.completion.portable_colorization`). The cases' prepared
   ``q_observation`` holds the result.
2. **The labels** of node ``i``: its training radius ``r_i = r`` (``training_radius=
   "fixed"``) or ``r + isqrt(min squared distance to a measured pixel)`` (``"gap"``).
   Each disc offset ``v`` is ranked by ``d_v``: ``+inf`` off the image or not measured,
   else C3 between ``y_i``'s window and the measured (``"colorization-completed"``: the
   completed) window at ``i + v``, and with the proximity prior ``μ``::

       d_v = d + (μ / (r_i · r_i)) · float(dr² + dc²)

   (``(dr² + dc²)`` an integer; ``r_i``, not the doubled radius below). Ranked by
   ``(d_v, offset index)``, a stable sort, the first ``k`` kept; the disc's radius doubles
   while fewer than ``k`` of them are finite, fewer finite ones than measured pixels, and
   ``ceil(radius) < max(Hp, Wp)``, where
   ``Hp = H + 2 pad_i`` and ``Wp = W + 2 pad_i`` are the padded frame's sides,
   ``pad_i = max(ceil(r), n // 2 + 1, ceil(r_i))``; still too few, the last one found
   repeats.
3. **Eq. 7**: ``log Φ = (−d_v) / ((2.0 · σ_i) · σ_i)``.
4. **The offset copy** (``range_copy="offset"``): each label ``l`` of node ``i`` carries
   ``Δ_il``, the shift between ``y_i``'s window (the observations) and the label's measured
   window, at the agreement ``offset_tolerance`` (None: ``2**-3`` with
   ``observation="np"``, else ``2**-7``). In Eq. 6 the label's patch is moved by ``Δ_il``;
   a pixel is present where the **measured** patch has range, so a moved value below 0 (or
   above ``2**16``) still counts, unclipped (the fast code lifts the moved values by
   ``SHIFT_LIFT = 2**18`` to keep "≥ 0" meaning "present"; a port that tests the moved
   value fails ``bp-16x16-fig6-gap`` on ``log_psi``).
5. **Eq. 6**: for a pair (``first`` left of or above ``second``), over the overlap
   (``first[:, 1:]`` and ``second[:, :-1]``, or rows) where both have range, the integer
   ``d = (a + Δ_a) − (b + Δ_b)``; ``ms = (Σ d² · 2**-32) / count`` (exact sum, one scaling,
   one division; ``0.0`` with ``count = 0``); ``log Ψ = (−ms) / ((2.0 · σ_s) · σ_s)``.
6. **The unary term**: ``log Φ``, then each measured neighbour's ``log Ψ`` (the label's
   moved patch against the neighbour's unmoved one) added one at a time, right, left,
   below, above; a neighbour on an edge adds nothing (with ``use_edges``), and with
   ``edge_rule="deaf"`` a node on an edge receives none.
7. **Eq. 9, synchronous sweeps.** The beliefs of the previous sweep's messages,
   ``b_i = unary_i + ((((0 + M_left) + M_up) + M_right) + M_down)`` (the absent ones left
   out). The message ``i → j`` is **the sender's belief less j's message**,
   ``h = b_i − M_ji``, then ``t = log Ψ + h`` (the sender's labels along its axis) and
   max-product ``m(x_j) = max_l t``, ``m − max m``; sum-product ``top = max_l t``,
   ``m = log(Σ_l exp(t − top)) + top``, then ``m − (log(Σ exp(m − max m)) + max m)``
   (C7, sums left to right). A node on an edge sends nothing (its rows stay 0); with
   ``edge_rule="deaf"`` it receives nothing either. ``change = max |new − old|`` (0 with
   no messages); the run stops after the sweep whose change is ``≤ tolerance``, or after
   ``iterations`` sweeps.
8. **Eq. 8 and the result.** The labels' centres: the measured value and ``q``; with the
   offset copy ``q' = min(max(q + Δ_il, 0), 2**16)`` (**clipped to the grid**) and, if
   ``q' ≠ q``, the value ``min(max(R + (q' − q) · (span · 2**-16), low), high)``
   (**clipped to the measured range**; broken: ``bp-16x16-fig6-gap``'s
   ``candidate_values``). The MAP label is the first maximum of the final beliefs; its
   value is the range.
9. **The confidence**, in this order: ``p = portable_exp(b − max b)``;
   ``z = Σ p`` left to right; the pooled sum, left to right over the labels, of
   ``p_l / z`` for the labels with ``|q'_l − q'_MAP| ≤ 0.01 · 2**16`` (on the integer
   grid, the moved centres); then ``min(pooled, 1.0)``. numpy's ``sum`` (pairwise, eight
   accumulators from eight terms on), pooling before dividing by ``z``, or no clip (a
   belief pooled over every label sums to ``1 + 2**-52``) each fail ``bp-10x12-k8`` or
   ``bp-14x18-planes`` on ``confidence``.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.4, Eqs. 2–12, Fig. 6, Fig. 7,
doi:10.1007/s11263-007-0108-2.

Examples
--------
The arithmetic of Eq. 12 on one window of the ``eq10_12-arithmetic`` case:

>>> from refsynth.oracle.equations import equation_outputs, _arithmetic_windows
>>> batch = _arithmetic_windows()
>>> out = equation_outputs("eq10_12", batch, dict(neighbourhood=5, use_isophotes=True))
>>> out["D"].shape
(4,)
"""

__all__: list[str] = []
