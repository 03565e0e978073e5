"""BP (§3.2.3, Eqs. 6–9, Fig. 6): compatibilities, messages, MAP, the whole fill."""

import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from strategies import small_scene

import refsynth
from refsynth.scenes import synthetic_room
from refsynth.synthesis import reference as ref
from refsynth.synthesis.belief.fill import (
    belief_propagation,
    fixed_neighbour_terms,
    grid_edges,
    pair_compatibilities,
    phi,
    psi,
)

UNIT = st.floats(0.0, 1.0, width=64)


@st.composite
def patch_pairs(draw, n=None, k=None):
    """Candidate range patches of two 4-neighbours, (1, K, n, n) each, NaN = missing."""
    n = draw(st.sampled_from([3, 5])) if n is None else n
    k = draw(st.integers(1, 4)) if k is None else k
    a = draw(hnp.arrays(np.float64, (1, k, n, n), elements=UNIT))
    b = draw(hnp.arrays(np.float64, (1, k, n, n), elements=UNIT))
    holes_a = draw(hnp.arrays(np.bool_, (1, k, n, n)))
    holes_b = draw(hnp.arrays(np.bool_, (1, k, n, n)))
    return np.where(holes_a, np.nan, a), np.where(holes_b, np.nan, b), draw(st.sampled_from("hv"))


def _shifted_views(field, n, direction):
    """Patches of one range field centred on two neighbouring pixels: they agree exactly."""
    h = n // 2
    centre = (field.shape[0] // 2, field.shape[1] // 2)
    nxt = (centre[0], centre[1] + 1) if direction == "h" else (centre[0] + 1, centre[1])
    take = [field[c[0] - h : c[0] + h + 1, c[1] - h : c[1] + h + 1] for c in (centre, nxt)]
    return take[0][None, None], take[1][None, None]


@given(hnp.arrays(np.float64, (9, 9), elements=UNIT), st.sampled_from([3, 5]),
       st.sampled_from("hv"), st.floats(0.01, 1.0))
def test_eq6_is_one_when_candidates_agree_on_their_overlap(field, n, direction, sigma_s):
    pj, pk = _shifted_views(field, n, direction)
    ms = pair_compatibilities(pj, pk, direction)
    assert ms.shape == (1, 1, 1)
    assert np.exp(psi(ms, sigma_s))[0, 0, 0] == pytest.approx(1.0, abs=1e-6)


@given(patch_pairs())
def test_eq6_is_symmetric_under_swapping_the_two_nodes(pair):
    """Mirroring the grid swaps which node is first: the k × k matrix transposes."""
    a, b, direction = pair
    flip = (lambda p: p[..., :, ::-1]) if direction == "h" else (lambda p: p[..., ::-1, :])
    forward = pair_compatibilities(a, b, direction)
    backward = pair_compatibilities(flip(b), flip(a), direction)
    np.testing.assert_allclose(forward[0], backward[0].T, rtol=1e-5, atol=1e-6)


@given(hnp.arrays(np.float64, (9, 9), elements=UNIT), st.sampled_from("hv"),
       st.floats(0.01, 0.3), st.floats(0.01, 0.3))
def test_eq6_falls_with_disagreement(field, direction, d1, d2):
    pj, pk = _shifted_views(field, 5, direction)
    lo, hi = sorted((d1, d2))
    near = pair_compatibilities(pj, pk + lo, direction)[0, 0, 0]
    far = pair_compatibilities(pj, pk + hi, direction)[0, 0, 0]
    assert near == pytest.approx(lo * lo, rel=1e-3, abs=2e-6)  # float32 expanded squares
    assert psi(far, 0.1) <= psi(near, 0.1)


def test_eq6_without_shared_range_is_uninformative():
    a = np.full((1, 1, 3, 3), np.nan)
    b = np.ones((1, 1, 3, 3))
    assert pair_compatibilities(a, b, "h")[0, 0, 0] == 0.0


@given(hnp.arrays(np.float64, (9, 9), elements=UNIT), st.sampled_from("hv"),
       st.sampled_from(["left", "right"]))
def test_fixed_neighbour_term_is_eq6_against_the_measured_patch(field, direction, side):
    """A measured neighbour's term is Eq. 6's mean square against its own patch.

    The range is on the numeric contract's 2**-16 grid (refsynth.numeric), so the shift
    is one that the grid holds exactly: 0.125 (a shift of 0.1 is 6553.6 grid steps and
    rounds to 6553 or 6554 per pixel)."""
    pj, pk = _shifted_views(field, 5, direction)
    cand, fixed = (pk, pj) if side == "left" else (pj, pk)
    term = fixed_neighbour_terms(np.concatenate([cand, cand + 0.125], axis=1), fixed, direction,
                                 side)
    np.testing.assert_allclose(term[0], [0.0, 0.125**2], atol=1e-6)
    # and exactly the literal reference's Eq. 6 on the quantised patches
    def q(patch):
        return np.rint(patch[0, 0] * 2**16).astype(np.int64)

    for label, patch in enumerate((cand, cand + 0.125)):
        first, second = (fixed, patch) if side == "left" else (patch, fixed)
        assert term[0, label] == ref.overlap_mean_square(q(first), q(second), direction)


@given(st.floats(0.0, 10.0), st.floats(0.0, 10.0), st.floats(0.01, 2.0))
def test_eq7_is_one_for_an_exact_match_and_falls_with_distance(d1, d2, sigma_i):
    assert phi(0.0, sigma_i) == 0.0  # log Φ = 0: Φ = 1
    lo, hi = sorted((d1, d2))
    assert phi(hi, sigma_i) <= phi(lo, sigma_i)


def _chain(n_nodes):
    return np.stack([np.arange(n_nodes - 1), np.arange(1, n_nodes)], axis=1)


def _brute_force(unary, pairs, log_psi):
    n, k = unary.shape
    best, best_labels = -np.inf, None
    scores = {}
    for labels in itertools.product(range(k), repeat=n):
        s = unary[np.arange(n), labels].sum()
        s += sum(log_psi[e, labels[a], labels[b]] for e, (a, b) in enumerate(pairs))
        scores[labels] = s
        if s > best:
            best, best_labels = s, labels
    return np.array(best_labels), scores


@st.composite
def chain_problem(draw):
    """A chain of 2–6 nodes with 1–3 labels and random log potentials."""
    n = draw(st.integers(2, 6))
    k = draw(st.integers(1, 3))
    pot = st.floats(-3.0, 0.0, width=32)
    unary = draw(hnp.arrays(np.float64, (n, k), elements=pot))
    log_psi = draw(hnp.arrays(np.float64, (n - 1, k, k), elements=pot))
    return unary, _chain(n), log_psi


@given(chain_problem())
def test_max_product_on_a_chain_equals_the_brute_force_map(problem):
    unary, pairs, log_psi = problem
    belief, _ = belief_propagation(unary, pairs, log_psi, iterations=20, tolerance=0.0)
    labels, scores = _brute_force(unary, pairs, log_psi)
    # on a tree, max-product beliefs are max-marginals: their maximum is the MAP score
    best_score = max(scores.values())
    # with a unique MAP, the per-node argmax of the beliefs is that MAP (Eq. 8)
    if sum(s > best_score - 1e-3 for s in scores.values()) == 1:
        assert tuple(np.argmax(belief, axis=1)) == tuple(labels)
    for node in range(unary.shape[0]):
        np.testing.assert_allclose(
            belief[node] - belief[node].max(),
            [max(s for lab, s in scores.items() if lab[node] == x) - best_score
             for x in range(unary.shape[1])],
            atol=1e-4,
        )
    assert labels.shape == (unary.shape[0],)


@given(chain_problem())
def test_sum_product_on_a_chain_gives_the_exact_marginals(problem):
    unary, pairs, log_psi = problem
    belief, _ = belief_propagation(unary, pairs, log_psi, iterations=20, tolerance=0.0,
                                   product="sum")
    _, scores = _brute_force(unary, pairs, log_psi)
    labels = np.array(list(scores))
    weights = np.exp(np.array(list(scores.values())))
    for node in range(unary.shape[0]):
        exact = np.array([weights[labels[:, node] == x].sum() for x in range(unary.shape[1])])
        got = np.exp(belief[node] - belief[node].max())
        np.testing.assert_allclose(got / got.sum(), exact / exact.sum(), atol=1e-4)


@given(chain_problem(), st.sampled_from(["max", "sum"]), st.floats(0.0, 0.7))
def test_messages_stay_finite_normalised_and_non_negative(problem, product, damping):
    unary, pairs, log_psi = problem
    _, _, messages = belief_propagation(unary, pairs, log_psi, iterations=5, product=product,
                                        damping=damping, return_messages=True)
    linear = np.exp(messages.astype(np.float64))
    assert np.all(np.isfinite(messages)) and np.all(linear >= 0)
    if product == "max" and damping == 0:
        np.testing.assert_allclose(linear.max(axis=1), 1.0, atol=1e-6)
    if product == "sum" and damping == 0:
        np.testing.assert_allclose(linear.sum(axis=1), 1.0, atol=1e-5)


def test_loopy_grid_messages_stay_finite():
    rng = np.random.default_rng(0)
    unknown = np.ones((6, 7), dtype=bool)
    edges = grid_edges(unknown)
    pairs = np.concatenate([edges["h"], edges["v"]])
    unary = rng.normal(size=(42, 4))
    log_psi = -rng.random((pairs.shape[0], 4, 4)) * 5
    belief, done, messages = belief_propagation(unary, pairs, log_psi, iterations=50,
                                                return_messages=True)
    assert np.all(np.isfinite(belief)) and np.all(np.isfinite(messages)) and done >= 1


def test_no_message_crosses_a_silent_edge_node():
    """Chain 0-1-2-3-4 with node 2 on an intensity edge: the two sides do not talk."""
    rng = np.random.default_rng(1)
    pairs = _chain(5)
    log_psi = -rng.random((4, 3, 3)) * 4
    silent = np.array([False, False, True, False, False])
    base = rng.normal(size=(5, 3))
    changed = base.copy()
    changed[3:] = rng.normal(size=(2, 3)) * 10  # the far side's evidence changes a lot
    b1, _, m1 = belief_propagation(base, pairs, log_psi, silent=silent, return_messages=True)
    b2, _ = belief_propagation(changed, pairs, log_psi, silent=silent)
    np.testing.assert_allclose(b1[:2], b2[:2], atol=1e-5)
    # the edge node's outgoing messages (2 -> 1 is row 4 + 1, 2 -> 3 is row 2) are zero
    np.testing.assert_array_equal(m1[[2, 5]], 0.0)


def test_grid_edges_classify_pairs():
    unknown = np.array([[True, True], [False, True]])
    edges = grid_edges(unknown)
    assert edges["h"].tolist() == [[0, 1]]
    assert edges["v"].tolist() == [[1, 3]]
    assert edges["h_fixed"].tolist() == [[2, 3]]
    assert edges["v_fixed"].tolist() == [[0, 2]]


@given(small_scene(), st.sampled_from(["max", "sum"]), st.sampled_from(["value", "offset"]))
def test_bp_fill_keeps_measurements_and_copies_candidate_centres(scene, product, copy):
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    result = refsynth.synthesize(image, partial, method="bp", neighbourhood=3, candidates=3,
                                 iterations=5, readings={"product": product, "range_copy": copy,
                                                         "gaps": "copy", "median": 0})
    np.testing.assert_array_equal(result.range[known], truth[known])
    assert np.all(np.isfinite(result.range))
    if copy == "value":  # Fig. 6's labels: a measured value
        assert np.isin(result.range[~known], truth[known]).all()
    else:  # moved labels: within the measured span
        low, high = truth[known].min(), truth[known].max()
        assert np.all((result.range >= low) & (result.range <= high))
    assert np.all((result.confidence > 0) & (result.confidence <= 1))
    np.testing.assert_array_equal(result.confidence[known], 1.0)
    # the chosen value is one of the pixel's candidates
    chosen = result.range[result.order[:, 0], result.order[:, 1]]
    assert np.all(np.any(result.candidate_values == chosen[:, None], axis=1))
    assert result.method == "bp" and 0 <= result.iterations <= 5


@given(small_scene(), st.floats(0.5, 10.0))
def test_bp_recovers_a_constant_range_exactly(scene, level):
    image, _, known = scene
    result = refsynth.synthesize(image, np.where(known, level, np.nan), method="bp",
                                 neighbourhood=3, candidates=4)
    np.testing.assert_array_equal(result.range, level)


def test_a_node_with_one_candidate_returns_it():
    rng = np.random.default_rng(2)
    image = rng.random((12, 12))
    truth = rng.random((12, 12)) + 1
    known = rng.random((12, 12)) < 0.4
    result = refsynth.synthesize(image, np.where(known, truth, np.nan), method="bp",
                                 candidates=1, readings={"median": 0})
    chosen = result.range[result.order[:, 0], result.order[:, 1]]
    np.testing.assert_array_equal(chosen, result.candidate_values[:, 0])
    np.testing.assert_array_equal(result.confidence[~known], 1.0)


def test_bp_is_deterministic_and_edge_rule_matters():
    rng = np.random.default_rng(3)
    scene = synthetic_room((32, 32), seed=5)
    known = rng.random((32, 32)) < 0.3
    partial = np.where(known, scene.range, np.nan)
    # on the colorization fill's observations BP makes no random choice
    a = refsynth.synthesize(scene.intensity, partial, method="bp", seed=0,
                            readings={"observation": "colorization"})
    b = refsynth.synthesize(scene.intensity, partial, method="bp", seed=99,
                            readings={"observation": "colorization"})
    np.testing.assert_array_equal(a.range, b.range)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    # on NP's fill (the default) it draws through NP: the seed reproduces it, and matters
    c = refsynth.synthesize(scene.intensity, partial, method="bp", seed=0)
    d = refsynth.synthesize(scene.intensity, partial, method="bp", seed=0)
    e = refsynth.synthesize(scene.intensity, partial, method="bp", seed=99)
    np.testing.assert_array_equal(c.range, d.range)
    np.testing.assert_array_equal(c.bp.beliefs, d.bp.beliefs)
    assert not np.array_equal(c.bp.unary, e.bp.unary)
    off = refsynth.synthesize(scene.intensity, partial, method="bp", use_edges=False,
                              readings={"sigma_s": 0.02, "sigma_i": 1.0})
    on = refsynth.synthesize(scene.intensity, partial, method="bp",
                             readings={"sigma_s": 0.02, "sigma_i": 1.0})
    assert not np.array_equal(off.confidence, on.confidence)


def test_a_gap_wider_than_r_gets_candidates():
    image = np.tile(np.linspace(0, 1, 40), (6, 1))
    partial = np.full((6, 40), np.nan)
    partial[:, :2] = 2.5
    result = refsynth.synthesize(image, partial, method="bp", radius=3, candidates=4)
    np.testing.assert_array_equal(result.range, 2.5)


# -- the edge-constraint rule -----------------------------------------------------------------


def _edge_scene(seed):
    g = np.random.default_rng(seed)
    H, W = 12, 13
    image = g.random((H, W))
    partial = np.where(g.random((H, W)) < 0.45, np.round(1.0 + 3.0 * g.random((H, W)), 2),
                       np.nan)
    partial[0, 0] = 2.0
    return image, partial


def _neighbours_of(mask, partial):
    """The unknown pixels with a 4-neighbour in ``mask``."""
    near = np.zeros(mask.shape, dtype=bool)
    near[1:, :] |= mask[:-1, :]
    near[:-1, :] |= mask[1:, :]
    near[:, 1:] |= mask[:, :-1]
    near[:, :-1] |= mask[:, 1:]
    return near & np.isnan(partial)


#: BP on the colorization fill's observations: NP's fill (the default) would take the edges
#: too, and the tests below are about what BP's own edge rule does with them.
BP_SMALL = dict(method="bp", candidates=3, neighbourhood=3, radius=4.0)
BP_SMALL_READINGS = {"sigma_s": 0.05, "observation": "colorization"}


@pytest.mark.parametrize("rule", ["silent", "deaf"])
@pytest.mark.parametrize("seed", range(3))
def test_a_measured_node_on_an_edge_constrains_no_neighbour(rule, seed):
    """Edges on measured pixels only: the terms those pixels put on their unknown
    neighbours disappear (before, the output was that of use_edges=False); nothing else
    changes."""
    image, partial = _edge_scene(seed)
    known = np.isfinite(partial)
    edges = known & (np.random.default_rng(seed + 50).random(known.shape) < 0.3)
    on = refsynth.synthesize(image, partial, edges=edges, **BP_SMALL,
                             readings={**BP_SMALL_READINGS, "edge_rule": rule})
    off = refsynth.synthesize(image, partial, use_edges=False, **BP_SMALL,
                              readings=BP_SMALL_READINGS)
    affected = _neighbours_of(edges, partial)[on.order[:, 0], on.order[:, 1]]
    differs = np.any(on.bp.unary != off.bp.unary, axis=1)
    assert differs.any() and not np.any(differs & ~affected)
    assert not np.array_equal(on.bp.beliefs, off.bp.beliefs)


@pytest.mark.parametrize("seed", range(3))
def test_the_deaf_edge_rule_isolates_edge_nodes(seed):
    """edge_rule="deaf": no message crosses an edge. An unknown node on an edge neither
    sends nor receives (its belief is its unary term, which holds no measured neighbour's
    term); the other nodes' unary terms are those of the default rule."""
    image, partial = _edge_scene(seed)
    unknown = np.isnan(partial)
    edges = np.random.default_rng(seed + 70).random(partial.shape) < 0.2
    deaf = refsynth.synthesize(image, partial, edges=edges, **BP_SMALL,
                               readings={**BP_SMALL_READINGS, "edge_rule": "deaf"})
    silent = refsynth.synthesize(image, partial, edges=edges, **BP_SMALL,
                                 readings={**BP_SMALL_READINGS, "edge_rule": "silent"})
    node_on_edge = edges[deaf.order[:, 0], deaf.order[:, 1]]
    assert node_on_edge.any() and (~node_on_edge).any()
    bp = deaf.bp
    np.testing.assert_array_equal(bp.beliefs[node_on_edge], bp.unary[node_on_edge])
    e = len(bp.pairs)
    touching = node_on_edge[bp.pairs[:, 0]] | node_on_edge[bp.pairs[:, 1]]
    np.testing.assert_array_equal(bp.messages[np.concatenate([touching, touching])], 0.0)
    np.testing.assert_array_equal(bp.unary[~node_on_edge], silent.bp.unary[~node_on_edge])
    with_fixed = node_on_edge & _neighbours_of(~unknown & ~edges, partial)[
        deaf.order[:, 0], deaf.order[:, 1]]
    assert np.any(bp.unary[with_fixed] != silent.bp.unary[with_fixed])
    # the default rule: an edge node still listens
    assert e and np.any(silent.bp.beliefs[node_on_edge] != silent.bp.unary[node_on_edge])


@given(small_scene(), st.sampled_from([1, 3, 7]))
def test_the_labels_shifts_do_not_depend_on_their_block_size(scene, block):
    """_label_shifts works in blocks of about bp._SHIFT_BLOCK labels (cache-sized
    temporaries): any block size gives the same shifts, so the same fill, bit for bit."""
    import refsynth.synthesis.belief.fill as bp

    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    kwargs = dict(method="bp", neighbourhood=3, candidates=3, iterations=3)
    saved = bp._SHIFT_BLOCK
    try:
        whole = refsynth.synthesize(image, partial, **kwargs)
        bp._SHIFT_BLOCK = block
        small = refsynth.synthesize(image, partial, **kwargs)
    finally:
        bp._SHIFT_BLOCK = saved
    np.testing.assert_array_equal(small.range, whole.range)
    np.testing.assert_array_equal(small.candidate_values, whole.candidate_values)
