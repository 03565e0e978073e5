"""Eqs. 3–5 (§3.2.2) and NP synthesis as a whole, through ``refsynth.synthesize``."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from strategies import small_scene

import refsynth
from refsynth.synthesis.nonparametric import eq5_set
from refsynth.synthesis.priority import fill_front

distances = hnp.arrays(
    np.float64, st.integers(1, 30), elements=st.floats(0.0, 100.0, allow_subnormal=False)
)


@given(distances, st.floats(0.0, 2.0))
def test_eq5_set_always_holds_the_best_match(d, eps):
    members = eq5_set(d, eps)
    assert int(np.argmin(d)) in members.tolist()
    assert np.all(d[members] <= (1 + eps) * d.min())
    outside = np.setdiff1d(np.arange(d.size), members)
    assert np.all(d[outside] > (1 + eps) * d.min())


@given(distances, st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_eq5_set_grows_with_epsilon(d, e1, e2):
    lo, hi = sorted((e1, e2))
    assert set(eq5_set(d, lo).tolist()) <= set(eq5_set(d, hi).tolist())


def test_eq5_with_zero_epsilon_keeps_only_ties():
    d = np.array([3.0, 1.0, 2.0, 1.0])
    assert eq5_set(d, 0.0).tolist() == [1, 3]


@given(small_scene(), st.floats(0.5, 10.0), st.sampled_from(["priority", "onion"]))
def test_constant_range_scene_is_recovered_exactly(scene, level, ordering):
    image, _, known = scene
    partial = np.where(known, level, np.nan)
    result = refsynth.synthesize(image, partial, seed=1, ordering=ordering, neighbourhood=3)
    np.testing.assert_array_equal(result.range, level)


@given(small_scene(), st.integers(0, 1000))
def test_result_is_finite_keeps_measurements_and_copies_known_values(scene, seed):
    """Eq. 5's value copy: every synthesized value is one of the measured values."""
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    result = refsynth.synthesize(image, partial, seed=seed, neighbourhood=3, radius=3,
                                 readings={"range_copy": "value"})
    assert np.all(np.isfinite(result.range))
    np.testing.assert_array_equal(result.range[known], truth[known])
    assert np.isin(result.range[~known], truth[known]).all()
    assert np.all((result.confidence >= 0) & (result.confidence <= 1))
    np.testing.assert_array_equal(result.confidence[known], 1.0)
    assert result.order.shape == (int((~known).sum()), 2)


@given(small_scene(), st.integers(0, 1000))
def test_the_offset_copy_keeps_measurements_and_stays_in_the_measured_span(scene, seed):
    """The default shifted copy: finite, measured pixels unchanged, within [min, max]."""
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    result = refsynth.synthesize(image, partial, seed=seed, neighbourhood=3, radius=3)
    assert np.all(np.isfinite(result.range))
    np.testing.assert_array_equal(result.range[known], truth[known])
    assert truth[known].min() <= result.range.min() <= result.range.max() <= truth[known].max()
    assert np.all((result.confidence >= 0) & (result.confidence <= 1))
    np.testing.assert_array_equal(result.confidence[known], 1.0)
    assert result.order.shape == (int((~known).sum()), 2)


@given(small_scene(), st.integers(0, 1000), st.booleans())
def test_order_never_picks_a_pixel_off_the_fill_front(scene, seed, use_edges):
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    result = refsynth.synthesize(
        image, partial, seed=seed, neighbourhood=3, radius=2, use_edges=use_edges
    )
    filled = known.copy()
    edges = result.edges
    for r, c in result.order:
        front = fill_front(filled)
        assert front[r, c]
        if use_edges and edges[r, c]:
            # edge pixels come last: none of the front's non-edge pixels was left
            assert not np.any(front & ~edges)
        filled[r, c] = True
    assert filled.all()


@given(small_scene(), st.integers(0, 2**32 - 1), st.sampled_from(["priority", "onion"]))
def test_same_seed_gives_identical_output(scene, seed, ordering):
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    a = refsynth.synthesize(image, partial, seed=seed, ordering=ordering, neighbourhood=3)
    b = refsynth.synthesize(image, partial, seed=seed, ordering=ordering, neighbourhood=3)
    np.testing.assert_array_equal(a.range, b.range)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    np.testing.assert_array_equal(a.order, b.order)


def test_generator_seed_is_accepted_and_deterministic():
    image = np.random.default_rng(0).random((12, 12))
    partial = np.full((12, 12), np.nan)
    partial[:, ::4] = np.random.default_rng(1).random((12, 3))
    a = refsynth.synthesize(image, partial, seed=np.random.default_rng(7))
    b = refsynth.synthesize(image, partial, seed=np.random.default_rng(7))
    np.testing.assert_array_equal(a.range, b.range)


def _two_planes(h=40, w=40, step_col=19, seed=0):
    rng = np.random.default_rng(seed)
    cols = np.arange(w)[None, :].repeat(h, 0)
    truth = np.where(cols <= step_col, 2.0, 5.0)
    image = np.where(cols <= step_col, 0.25, 0.75) + 0.03 * rng.standard_normal((h, w))
    known = cols % 8 < 2  # x-stripes: 75 % unknown, the step falls in a gap
    return np.clip(image, 0, 1), truth, known


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("use_edges", [True, False])
def test_two_fronto_parallel_planes_keep_their_step_at_the_intensity_edge(seed, use_edges):
    image, truth, known = _two_planes(seed=seed)
    result = refsynth.synthesize(
        image, np.where(known, truth, np.nan), seed=seed, use_edges=use_edges
    )
    np.testing.assert_array_equal(result.range, truth)


def test_two_planes_with_colour_intensity():
    image, truth, known = _two_planes()
    colour = np.stack([image, 1 - image, 0.5 * image], axis=2)
    result = refsynth.synthesize(colour, np.where(known, truth, np.nan), seed=0)
    np.testing.assert_array_equal(result.range, truth)


def test_integer_and_scaled_images_give_the_same_fill():
    """Intensity is normalised by its span: uint8 and its [0, 1] float twin agree."""
    image, truth, known = _two_planes()
    img8 = np.round(image * 255).astype(np.uint8)
    partial = np.where(known, truth, np.nan)
    a = refsynth.synthesize(img8, partial, seed=3)
    b = refsynth.synthesize(img8 / 255.0, partial, seed=3)
    np.testing.assert_array_equal(a.range, b.range)


def test_range_unit_does_not_change_the_fill():
    """Range is normalised by its known span, so rescaling the unit rescales the fill.

    The factor is a power of two, so the normalised range is bit-identical and
    near-ties in Eq. 5 cannot flip through rounding.
    """
    image, truth, known = _two_planes()
    truth = truth + np.linspace(0, 0.5, truth.shape[0])[:, None]
    a = refsynth.synthesize(image, np.where(known, truth, np.nan), seed=4)
    b = refsynth.synthesize(image, np.where(known, truth * 1024.0, np.nan), seed=4)
    np.testing.assert_array_equal(b.range, a.range * 1024.0)


def test_a_gap_wider_than_r_is_filled():
    """Known range only in the first two columns; the rest lies far beyond r."""
    image = np.tile(np.linspace(0, 1, 60), (10, 1))
    partial = np.full((10, 60), np.nan)
    partial[:, :2] = 3.0
    result = refsynth.synthesize(image, partial, seed=0, radius=2)
    np.testing.assert_array_equal(result.range, 3.0)


@pytest.mark.parametrize("radius", [1.0, 1.2])
def test_radius_below_sqrt2_widens_the_search(radius):
    """A front pixel whose only filled neighbour is diagonal still gets candidates."""
    partial = np.full((5, 5), np.nan)
    partial[0, 0] = 1.5
    result = refsynth.synthesize(np.zeros((5, 5)), partial, seed=0, radius=radius)
    np.testing.assert_array_equal(result.range, 1.5)


def test_ablations_run_and_differ_in_order():
    image, truth, known = _two_planes()
    partial = np.where(known, truth, np.nan)
    orders = {
        name: refsynth.synthesize(image, partial, seed=0, **kw).order
        for name, kw in {
            "priority": {},
            "onion": {"ordering": "onion"},
            "no-edges": {"use_edges": False},
            "no-isophotes": {"use_isophotes": False},
        }.items()
    }
    assert not np.array_equal(orders["priority"], orders["onion"])
    assert not np.array_equal(orders["priority"], orders["no-edges"])
    assert refsynth.synthesize(image, partial, use_edges=False).edges.sum() == 0


def test_inputs_are_not_modified():
    image, truth, known = _two_planes()
    partial = np.where(known, truth, np.nan)
    image_copy, partial_copy = image.copy(), partial.copy()
    refsynth.synthesize(image, partial, seed=0)
    np.testing.assert_array_equal(image, image_copy)
    np.testing.assert_array_equal(partial, partial_copy)


def test_progress_is_reported():
    image, truth, known = _two_planes()
    calls = []
    refsynth.synthesize(
        image, np.where(known, truth, np.nan), progress=lambda d, t: calls.append((d, t))
    )
    total = int((~known).sum())
    assert calls[-1] == (total, total)
    assert all(a <= b for (a, _), (b, _) in zip(calls, calls[1:]))
