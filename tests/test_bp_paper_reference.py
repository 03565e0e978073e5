"""BP as printed (refsynth.synthesis.belief.reference) against the fast code, and its equations.

The reference's defaults are Fig. 6 as printed; with :data:`PAPER`, ``refsynth.synthesize``
runs the same reading, and the two agree bit for bit: range, confidence, candidates, Φ and
the measured neighbours' terms, Ψ, messages, beliefs and MAP labels. Then each equation's
piece of the reference on its own: Eq. 7's Φ, Eq. 6's Ψ, Eq. 9's messages, Eq. 8's MAP and
the confidence.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import refsynth
from refsynth.numeric import NO_RANGE, portable_exp
from refsynth.synthesis.belief import reference as belief
from refsynth.synthesis.belief.reference import bp_reference
from refsynth.synthesis.readings import Readings, split_options

#: Fig. 6 as printed, in :func:`refsynth.synthesize`'s options: the observations hold the
#: measured range only, the training disc is ``r``, the labels give their centre values,
#: Eq. 2 is literal, a node on an edge sends nothing, and the 50 sweeps all run (a sweep that
#: moves nothing is a fixed point, so stopping there changes nothing).
PAPER = dict(method="bp", observation="measured", training_radius="fixed", range_copy="value",
             missing_range="ignore", edge_rule="silent", tolerance=0.0, compatibility="overlap",
             proposals=None, proximity=0.0, product="max", iterations=50, candidates=8,
             neighbourhood=5, radius=10.0, range_weight=1.0, colour=True, channels="sum",
             sigma_i=0.1, sigma_s=0.2, canny_sigma=0.8, use_edges=True)

def paper_synthesize(image, partial, **options):
    """``refsynth.synthesize`` under :data:`PAPER`, with ``options`` (flat) on top."""
    keywords, readings = split_options({**PAPER, **options})
    return refsynth.synthesize(image, partial, **keywords,
                               readings=Readings.paper().replace(**readings))


#: At most this many sweeps of Eq. 9 in the random cases (the paper's 50 in the hand-built).
MAX_ITERATIONS = 6

AGREE = settings(max_examples=30, deadline=None, phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
FEW = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def paper_scene(draw, max_side: int = 14):
    """A small scene: noise, a few grey levels (ties in Eq. 2) or a ramp; the range with
    0 to 2 decimals (ties in the pooled confidence); some pixels known, some unknown."""
    g = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    H, W = draw(st.integers(3, max_side)), draw(st.integers(3, max_side))
    C = draw(st.sampled_from([1, 3]))
    kind = draw(st.sampled_from(["noise", "levels", "ramp"]))
    if kind == "noise":
        image = g.random((H, W, C))
    elif kind == "levels":
        image = g.integers(0, 3, (H, W, C)).astype(np.float64)
    else:
        image = np.broadcast_to(np.linspace(0, 1, W)[None, :, None], (H, W, C)).copy()
    partial = np.round(1.0 + 3.0 * g.random((H, W)), draw(st.integers(0, 2)))
    partial[g.random((H, W)) < draw(st.floats(0.2, 0.85))] = np.nan
    unknown = int(g.integers(H * W))
    partial.flat[unknown] = np.nan
    partial.flat[(unknown + 1) % (H * W)] = 2.0
    return image, partial


@st.composite
def paper_options(draw):
    """The reference's own options (the paper's parameters and readings), a few sweeps."""
    return dict(iterations=draw(st.integers(0, MAX_ITERATIONS)),
                radius=draw(st.sampled_from([1.0, 1.5, 2.5, 10.0])),
                candidates=draw(st.integers(1, 8)), product=draw(st.sampled_from(["max", "sum"])),
                edge_rule=draw(st.sampled_from(["deaf", "silent"])), colour=draw(st.booleans()),
                use_edges=draw(st.booleans()), range_weight=draw(st.sampled_from([1.0, 0.25, 4.0])),
                sigma_i=draw(st.sampled_from([0.1, 0.03, 1.0])),
                sigma_s=draw(st.sampled_from([0.2, 0.05, 2.0])),
                neighbourhood=draw(st.sampled_from([3, 5])))


def fast_and_reference(image, partial, edges=None, **options):
    """``synthesize`` under :data:`PAPER` (with ``options``) and the reference."""
    fast = paper_synthesize(image, partial, **{**options, "edges": edges})
    ref = bp_reference(image, partial, edges=edges, tolerance=0.0, **options)
    return fast, ref


def assert_same_bits(fast, ref):
    bp = fast.bp
    np.testing.assert_array_equal(fast.edges, ref.edges)
    np.testing.assert_array_equal(bp.candidates, ref.candidates)
    np.testing.assert_array_equal(bp.unary, ref.unary)
    np.testing.assert_array_equal(bp.log_psi, ref.log_psi)
    np.testing.assert_array_equal(bp.messages, ref.messages)
    np.testing.assert_array_equal(bp.beliefs, ref.beliefs)
    np.testing.assert_array_equal(bp.labels, ref.labels)
    assert bp.iterations == ref.iterations
    # bit for bit (assert_array_equal would let 0.0 == -0.0 pass)
    assert fast.range.tobytes() == ref.range.tobytes()
    assert fast.confidence.tobytes() == ref.confidence.tobytes()


# -- the reference equals the fast code under the paper's options --------------------------


@AGREE
@given(paper_scene(), paper_options(), st.booleans(), st.integers(0, 2**32 - 1))
def test_reference_equals_fast_under_the_paper_options(scene, options, own_edges, seed):
    image, partial = scene
    edges = None
    if own_edges:  # on measured and unknown pixels alike
        edges = np.random.default_rng(seed).random(partial.shape) < 0.3
    assert_same_bits(*fast_and_reference(image, partial, edges, **options))


def test_the_defaults_are_the_paper_options():
    """``bp_reference(I, R)`` with no option is ``synthesize(I, R, method="bp",
    readings="paper")``, whose readings are :data:`PAPER`'s: 50 sweeps."""
    keywords, readings = split_options(PAPER)
    assert Readings.paper().replace(**readings) == Readings.paper()
    g = np.random.default_rng(7)
    image, partial = g.random((10, 12, 3)), 1.0 + g.random((10, 12))
    partial[:, 4:9] = np.nan
    partial[g.random((10, 12)) < 0.2] = np.nan
    ref = bp_reference(image, partial)
    fast = refsynth.synthesize(image, partial, method="bp", readings="paper")
    assert ref.iterations == 50 and fast.iterations <= 50
    assert fast.range.tobytes() == ref.range.tobytes()
    assert fast.confidence.tobytes() == ref.confidence.tobytes()
    np.testing.assert_array_equal(fast.bp.messages, ref.messages)


def test_synthesize_defaults_are_not_the_paper():
    """The paper options matter: refsynth's defaults (NP's fill first, the offset copy, the
    gap radius) give another result on a scene where the value copy cannot be right."""
    image = np.tile(np.linspace(0, 1, 12), (8, 1))
    partial = np.tile(np.linspace(1.0, 4.0, 12), (8, 1))
    partial[:, 3:9] = np.nan
    paper = paper_synthesize(image, partial)
    ref = bp_reference(image, partial)
    assert paper.range.tobytes() == ref.range.tobytes()
    # the paper copies measured values: every filled value is one of the measured ones
    assert set(np.unique(ref.range[:, 3:9])) <= set(np.unique(partial[:, [0, 1, 2, 9, 10, 11]]))
    assert not np.array_equal(refsynth.synthesize(image, partial, method="bp").range, ref.range)


@pytest.mark.parametrize("rule", ["deaf", "silent"])
@pytest.mark.parametrize("product", ["max", "sum"])
def test_hand_built_edges_agree(rule, product):
    """A vertical edge through a gap, measured pixels on it too: fast == reference."""
    image = np.zeros((9, 11))
    image[:, 6:] = 1.0
    partial = np.where(np.arange(11) % 4 == 0, 2.0, np.nan) + np.zeros((9, 1))
    partial[:, 8] = 5.0
    edges = np.zeros((9, 11), bool)
    edges[:, 5] = edges[:, 8] = True
    fast, ref = fast_and_reference(image, partial, edges, iterations=8, edge_rule=rule,
                                   product=product)
    assert_same_bits(fast, ref)


@pytest.mark.parametrize("radius", [1.0, 40.0])
def test_hand_built_radius_extremes_agree(radius):
    """A disc too small for ``k`` (the radius doubles) and one far beyond the image (the fast
    code runs it as the next power of two at or above the image's reach): fast == reference."""
    g = np.random.default_rng(11)
    image, partial = g.integers(0, 3, (6, 7, 3)).astype(np.float64), 1.0 + g.random((6, 7))
    partial[:, 1:5] = np.nan
    assert_same_bits(*fast_and_reference(image, partial, radius=radius, iterations=4))


# -- the paper's edge rule ----------------------------------------------------------------


def test_paper_edge_rule_leaves_edge_nodes_their_own_evidence():
    """``edge_rule="deaf"``: a node on an edge hears nothing, its belief is log Φ alone;
    ``"silent"``: it still hears its neighbours, but sends nothing."""
    g = np.random.default_rng(3)
    image, partial = g.random((8, 9)), 1.0 + g.random((8, 9))
    partial[:, 2:7] = np.nan
    edges = np.zeros((8, 9), bool)
    edges[:, 4] = edges[:, 1] = True
    paper = bp_reference(image, partial, edges=edges, iterations=5, edge_rule="deaf")
    silent = bp_reference(image, partial, edges=edges, iterations=5)
    on_edge = edges[paper.order[:, 0], paper.order[:, 1]]
    log_phi = -paper.distances / (2.0 * 0.1 * 0.1)
    np.testing.assert_array_equal(paper.beliefs[on_edge], log_phi[on_edge])
    assert not np.array_equal(silent.beliefs[on_edge], log_phi[on_edge])
    for out in (paper, silent):  # an edge node sends nothing under either rule
        senders = np.concatenate([out.pairs[:, 0], out.pairs[:, 1]])  # of rows e, E + e
        assert not np.any(out.messages[on_edge[senders]])


# -- each equation ------------------------------------------------------------------------


@FEW
@given(st.floats(0.0, 50.0), st.floats(0.01, 10.0))
def test_eq7_phi_is_in_zero_one(distance, sigma_i):
    phi = math.exp(belief.log_phi(distance, sigma_i))
    assert 0.0 < phi <= 1.0 or distance / (2 * sigma_i**2) > 700
    assert belief.log_phi(0.0, sigma_i) == 0.0
    assert belief.log_phi(distance + 1.0, sigma_i) < belief.log_phi(distance, sigma_i)


@st.composite
def range_patch(draw, n=5):
    """An n×n patch of quantised range, NO_RANGE where unknown."""
    values = draw(st.lists(st.integers(-1, 2**16), min_size=n * n, max_size=n * n))
    return np.array(values, dtype=np.int64).reshape(n, n).clip(NO_RANGE)


@settings(max_examples=60, deadline=None)
@given(range_patch(), range_patch(), st.sampled_from(["h", "v"]), st.floats(0.1, 5.0))
def test_eq6_psi_is_symmetric_under_swapping_the_pair(first, second, direction, sigma_s):
    """Ψ(x_k^l, x_j^m) = Ψ(x_j^m, x_k^l): the pair seen from the other node (mirrored, so that
    it comes first) gives the same number; Ψ is in (0, 1], 1 when the overlaps agree."""
    flip = np.fliplr if direction == "h" else np.flipud
    psi = belief.log_psi(first, second, direction, sigma_s)
    assert psi == belief.log_psi(flip(second), flip(first), direction, sigma_s)
    assert 0.0 < math.exp(psi) <= 1.0
    same = second.copy()
    if direction == "h":
        same[:, :-1] = first[:, 1:]
    else:
        same[:-1] = first[1:]
    assert belief.log_psi(first, same, direction, sigma_s) == 0.0


def test_eq6_mean_square_by_hand():
    """Two 3×3 horizontal neighbours: six shared pixels, one differing by 2**14 (a quarter
    of the span), one missing: (2**28 · 2**-32) / 5."""
    first = np.full((3, 3), 1000, dtype=np.int64)
    second = np.full((3, 3), 1000, dtype=np.int64)
    second[1, 0] = 1000 + 2**14
    second[2, 1] = NO_RANGE
    assert belief.overlap_mean_square(first, second, "h") == 2.0**-4 / 5
    assert belief.overlap_mean_square(first, np.full((3, 3), NO_RANGE), "v") == 0.0


def test_eq9_message_is_the_senders_belief_less_the_receivers_message():
    """M_ij = max over i's labels of log Ψ + (b_i − M_ji), normalised to a maximum of 0."""
    psi = np.log(np.array([[0.9, 0.1], [0.2, 0.8]]))
    belief_i, back = np.array([-0.5, -1.0]), np.array([0.0, -2.0])
    h = belief_i - back
    expected = np.array([max(psi[0, 0] + h[0], psi[1, 0] + h[1]),
                         max(psi[0, 1] + h[0], psi[1, 1] + h[1])])
    np.testing.assert_array_equal(belief.send(psi, h, 0), expected - expected.max())
    # the sender's labels on the other axis: the transposed table, the same message
    np.testing.assert_array_equal(belief.send(psi.T, h, 1), expected - expected.max())


@FEW
@given(paper_scene(max_side=9), paper_options())
def test_eq9_messages_are_normalised_and_eq8_map_is_the_argmax(scene, options):
    out = bp_reference(*scene, **{**options, "radius": min(options["radius"], 2.5)})
    sent = np.any(out.messages != 0.0, axis=1)
    if options["product"] == "max":
        assert np.all(out.messages[sent].max(axis=1) == 0.0)
    else:
        lse = np.log(np.exp(out.messages[sent]).sum(axis=1))
        np.testing.assert_allclose(lse, 0.0, atol=1e-12)
    assert np.all(out.messages <= 0.0)
    np.testing.assert_array_equal(out.labels, np.argmax(out.beliefs, axis=1))
    rows, cols = out.order[:, 0], out.order[:, 1]
    chosen = out.candidate_values[np.arange(out.labels.size), out.labels]
    np.testing.assert_array_equal(out.range[rows, cols], chosen)
    # the candidates are measured and ranked by Eq. 2
    assert np.all(np.isfinite(scene[1][out.candidates[..., 0], out.candidates[..., 1]]))
    assert np.all(np.diff(out.distances, axis=1) >= 0.0)
    # the confidence: 1 where measured, in (0, 1] where filled
    known = np.isfinite(scene[1])
    assert np.all(out.confidence[known] == 1.0)
    assert np.all((out.confidence[rows, cols] > 0.0) & (out.confidence[rows, cols] <= 1.0))


def test_confidence_rule_by_hand():
    """normalise (exp of b − max b, divided by its left-to-right sum), pool the labels within
    1 % of the span of the MAP's centre left to right, clip to 1."""
    b = np.array([-1.0, 0.0, -0.5, -3.0])
    q = np.array([2000, 500, 500 + 655, 500 + 656])   # 655 ≤ 0.01 · 2**16 < 656
    best, value, confidence = belief.map_and_confidence(b, np.array([1.0, 2.0, 3.0, 4.0]), q)
    assert (best, value) == (1, 2.0)
    p = portable_exp(b - b.max())
    p = p / (((p[0] + p[1]) + p[2]) + p[3])
    assert confidence == float((0.0 + p[1]) + p[2])
    # every label the same range: the pooled sum rounds to 1 + 2**-52 here, clipped to 1
    b = np.array([0.0, -0.68, -1.87, -0.25, -2.5, -2.36, -0.72])
    p = portable_exp(b - b.max())
    p = p / sum(p.tolist())
    assert sum(p.tolist()) == 1.0 + 2.0**-52
    best, _, confidence = belief.map_and_confidence(b, np.ones(7), np.full(7, 9))
    assert best == 0 and confidence == 1.0


def test_tolerance_zero_stops_only_at_a_fixed_point():
    g = np.random.default_rng(4)
    image, partial = g.random((7, 8)), 1.0 + g.random((7, 8))
    partial[:, 2:6] = np.nan
    full = bp_reference(image, partial, iterations=40, radius=3.0)
    early = bp_reference(image, partial, iterations=40, radius=3.0, tolerance=0.0)
    assert early.iterations <= full.iterations == 40
    assert full.range.tobytes() == early.range.tobytes()
    np.testing.assert_array_equal(full.messages, early.messages)


# -- what the reference is made of ----------------------------------------------------------


def test_reference_imports_no_fast_path_module():
    """The reference stands on Eq. 2's literal, the numeric contract and Canny alone."""
    tree = ast.parse(Path(belief.__file__).read_text(encoding="utf-8"))
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {a.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for a in node.names}
    allowed = {"__future__", "math", "dataclasses", "numpy", "refsynth._checks",
               "refsynth.numeric", "refsynth.synthesis.canny",
               "refsynth.synthesis.neighbourhood", "refsynth.synthesis.similarity"}
    assert imported <= allowed, imported - allowed
    assert len(Path(belief.__file__).read_text(encoding="utf-8").splitlines()) <= 400


@pytest.mark.parametrize("name, value", [("product", "min"), ("edge_rule", "none")])
def test_bad_choices_are_refused_naming_the_argument(name, value):
    image, partial = np.zeros((3, 3)), np.full((3, 3), np.nan)
    partial[0, 0] = 1.0
    with pytest.raises(ValueError, match=f"`{name}`"):
        bp_reference(image, partial, **{name: value})


def test_mismatched_shapes_are_refused():
    with pytest.raises(ValueError, match="`partial_range`"):
        bp_reference(np.zeros((3, 4)), np.full((4, 3), np.nan))
