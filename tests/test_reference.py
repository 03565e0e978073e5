"""The literal reference (refsynth.synthesis.reference) against the fast code, and its contract.

The fast code gives *exactly* the reference's output: range, confidence, order,
BP's candidates, unary terms, compatibilities, messages and beliefs, on at least 200 random
small cases per method, with edges (on measured pixels too), fixed neighbours and every option.
Both follow the numeric contract of :mod:`refsynth.numeric`.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis import reference as ref
from refsynth.synthesis.api import normalise_intensity
from refsynth.synthesis.readings import split_options
from refsynth.synthesis.similarity import neighbourhood_distance

# the agreement tests: many cases, no shrinking needed to read a failure (the case is small)
MANY = settings(max_examples=200, deadline=None, phases=[Phase.explicit, Phase.generate],
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
FEW = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def synthesis_case(draw, method: str):
    """A small scene (8×8 to 16×16) with random mask, edges on or off, and method options.

    The intensity is uniform noise, a few grey levels (many exact ties in Eq. 2) or a ramp;
    the range has 0 to 2 decimals (ties in Eq. 5 and in BP's pooled confidence). Edges fall
    on unknown and on measured pixels alike.
    """
    seed = draw(st.integers(0, 2**32 - 1))
    g = np.random.default_rng(seed)
    H, W = draw(st.integers(8, 16)), draw(st.integers(8, 16))
    C = draw(st.sampled_from([1, 3]))
    kind = draw(st.sampled_from(["noise", "levels", "ramp"]))
    if kind == "noise":
        image = g.random((H, W, C))
    elif kind == "levels":
        image = g.integers(0, 4, (H, W, C)) / 3.0
    else:
        image = np.tile(np.linspace(0.0, 1.0, W)[None, :, None], (H, 1, C))
    if draw(st.booleans()):  # range with 0 to 2 decimals: ties in Eq. 5 and BP's pooling
        truth = np.round(1.0 + 4.0 * g.random((H, W)), draw(st.integers(0, 2)))
    else:  # slanted planes with a depth step: where range_copy="offset" shifts the copies
        rows, cols = np.mgrid[:H, :W]
        truth = 1.0 + g.random() * rows + g.random() * cols + np.where(
            cols > g.integers(W), 2.0 * g.random(), 0.0)
    known = g.random((H, W)) < draw(st.floats(0.2, 0.7))
    if draw(st.booleans()):  # a column scan with the sensor's holes: where the gap reading acts
        known = (g.random(W) < 0.4)[None, :] & (g.random((H, W)) < 0.9)
    known[g.integers(H), g.integers(W)] = True
    if known.all():
        known[0, 0] = False
    edges = g.random((H, W)) < 0.15
    use_edges = draw(st.booleans())
    options = dict(neighbourhood=draw(st.sampled_from([3, 5])),
                   radius=draw(st.sampled_from([1.5, 3.0, 4.5])),
                   range_weight=draw(st.sampled_from([0.0, 4.0, 16.0])),
                   missing_range=draw(st.sampled_from(["mean", "ignore"])), use_edges=use_edges,
                   colour=draw(st.booleans()), gaps=draw(st.sampled_from(["copy", "gate"])),
                   median=draw(st.sampled_from([0, 3])))
    if method == "np":
        options.update(epsilon=draw(st.sampled_from([0.0, 0.1, 0.5])),
                       use_isophotes=draw(st.booleans()),
                       ordering=draw(st.sampled_from(["priority", "priority", "onion"])),
                       confidence_update=draw(st.sampled_from(["product", "best"])),
                       edges_last=draw(st.booleans()),
                       range_copy=draw(st.sampled_from(["value", "offset"])))
    else:
        options.update(candidates=draw(st.integers(1, 4)), iterations=draw(st.integers(0, 6)),
                       proximity=draw(st.sampled_from([0.0, 1.0])),
                       sigma_i=draw(st.sampled_from([0.1, 0.5])),
                       product=draw(st.sampled_from(["max", "max", "sum"])),
                       edge_rule=draw(st.sampled_from(["silent", "deaf"])),
                       observation=draw(st.sampled_from(
                           ["colorization", "measured", "colorization-completed", "np"])),
                       training_radius=draw(st.sampled_from(["gap", "fixed"])),
                       range_copy=draw(st.sampled_from(["value", "offset"])))
    intensity = image[:, :, 0] if C == 1 else image
    return intensity, np.where(known, truth, np.nan), edges & use_edges, options, seed


def run_reference(intensity, partial, edges, options, seed, method):
    """The reference on the inputs :func:`refsynth.synthesize` hands its fill functions."""
    image = normalise_intensity(intensity)
    options = dict(options)
    if method == "np":
        return ref.np_reference(image, partial, edges, np.random.default_rng(seed), **options)
    options["k"] = options.pop("candidates")
    return ref.bp_reference(image, partial, edges, rng=np.random.default_rng(seed), **options)


def run_fast(intensity, partial, edges, options, seed, method):
    keywords, readings = split_options(options)
    return refsynth.synthesize(intensity, partial, method=method, seed=seed, edges=edges,
                               **keywords, readings=readings)


# -- fast = reference -----------------------------------------------------------------------


@MANY
@given(synthesis_case("np"))
def test_np_fast_equals_reference(case):
    fast, slow = run_fast(*case, "np"), run_reference(*case, "np")
    np.testing.assert_array_equal(fast.range, slow.range)
    np.testing.assert_array_equal(fast.order, slow.order)
    np.testing.assert_array_equal(fast.confidence, slow.confidence)


@MANY
@given(synthesis_case("bp"))
def test_bp_fast_equals_reference_with_its_messages_and_beliefs(case):
    """The result, and every intermediate of BP: candidates, terms, messages, beliefs.

    The same run also checks the reference's own invariants
    (:func:`bp_reference_messages_are_normalised_and_range_is_a_candidate_centre`), so each
    case runs the reference once.
    """
    fast, slow = run_fast(*case, "bp"), run_reference(*case, "bp")
    np.testing.assert_array_equal(fast.range, slow.range)
    np.testing.assert_array_equal(fast.order, slow.order)
    np.testing.assert_array_equal(fast.candidate_values, slow.candidate_values)
    np.testing.assert_array_equal(fast.confidence, slow.confidence)
    assert fast.iterations == slow.iterations
    for name in ("labels", "candidates", "candidate_values", "unary", "pairs", "log_psi",
                 "messages", "beliefs"):
        np.testing.assert_array_equal(getattr(fast.bp, name), getattr(slow, name), err_msg=name)
    bp_reference_messages_are_normalised_and_range_is_a_candidate_centre(slow, case)


# -- the reference itself ---------------------------------------------------------------------


@FEW
@given(synthesis_case("np"), st.sampled_from(["product", "best"]))
def test_np_reference_keeps_measurements_and_copies_known_values(case, rule):
    intensity, partial, edges, options, seed = case
    out = ref.np_reference(normalise_intensity(intensity), partial, edges,
                           np.random.default_rng(seed),
                           **dict(options, confidence_update=rule, range_copy="value",
                                  gaps="copy"))
    known = np.isfinite(partial)
    np.testing.assert_array_equal(out.range[known], partial[known])
    assert set(out.range[~known]) <= set(partial[known])
    assert sorted(map(tuple, out.order)) == sorted(zip(*np.nonzero(~known)))
    assert np.all((out.confidence >= 0) & (out.confidence <= 1))
    assert np.all(out.confidence[known] == 1.0)
    grid = out.confidence * 2.0**ref.CONFIDENCE_BITS
    np.testing.assert_array_equal(grid, np.rint(grid))


def bp_reference_messages_are_normalised_and_range_is_a_candidate_centre(out, case):
    """Max-product messages peak at 0; each pixel's range is its label's centre value, and
    its label the belief's argmax (checked on every case of the agreement test above)."""
    if out.messages.size and case[3]["product"] == "max":
        np.testing.assert_array_equal(out.messages.max(axis=1)[np.any(out.messages, axis=1)], 0)
    rows, cols = out.order[:, 0], out.order[:, 1]
    if case[3]["gaps"] == "copy" and not case[3]["median"]:  # the post-passes may not
        np.testing.assert_array_equal(out.range[rows, cols],
                                      out.candidate_values[np.arange(len(rows)), out.labels])
    np.testing.assert_array_equal(out.labels, np.argmax(out.beliefs, axis=1))


@FEW
@given(synthesis_case("np"), st.sampled_from([0.25, -3.0, 100.0]))
def test_an_intensity_offset_changes_nothing(case, offset):
    intensity, partial, edges, options, seed = case
    a = run_reference(intensity, partial, edges, options, seed, "np")
    b = run_reference(intensity + offset, partial, edges, options, seed, "np")
    np.testing.assert_array_equal(a.range, b.range)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    np.testing.assert_array_equal(a.order, b.order)


def test_an_integer_image_and_the_same_image_as_floats_give_the_same_quantisation():
    image = np.random.default_rng(0).integers(0, 256, (40, 40, 3)).astype(np.uint8)
    for offset in (0, 7):
        as_int = normalise_intensity(image // 2 + offset)
        as_float = normalise_intensity((image // 2 + offset) / 255.0)
        np.testing.assert_array_equal(ref.quantise_intensity(as_int),
                                      ref.quantise_intensity(normalise_intensity(image // 2)))
        np.testing.assert_array_equal(ref.quantise_intensity(as_int),
                                      ref.quantise_intensity(as_float))


@FEW
@given(st.integers(0, 10**6), st.sampled_from([3, 5]), st.sampled_from([1, 3]))
def test_eq2_reference_is_eq2_on_the_quantised_data(seed, n, channels):
    """The contract's Eq. 2 equals similarity.neighbourhood_distance on the same data: the
    floats on the grid, the window G = window_weights · 2**-18, bit for bit; and within
    G's rounding (2**-18) of the float window G / Σ G."""
    g = np.random.default_rng(seed)
    qi = g.integers(0, 2**16 + 1, (2, n, n, channels))
    qr = np.where(g.random((2, n, n)) < 0.6, g.integers(0, 2**16 + 1, (2, n, n)), ref.NO_RANGE)
    window = ref.window_weights(n)
    for rule in ("ignore", "mean"):
        exact = ref.eq2_distance(qi[0], qr[0], qi[1], qr[1], window, 4.0, rule)
        scale = 2.0**-16
        ra, rb = (np.where(q == ref.NO_RANGE, np.nan, q * scale) for q in qr)
        floats = dict(range_weight=4.0, missing_range=rule)
        assert exact == neighbourhood_distance(qi[0] * scale, ra, qi[1] * scale, rb,
                                               window=window * 2.0**-18, **floats)
        assert exact == neighbourhood_distance(qi[0] * scale, ra, qi[1] * scale, rb, **floats)
        near = neighbourhood_distance(qi[0] * scale, ra, qi[1] * scale, rb,
                                      window=window / window.sum(), **floats)
        assert exact == pytest.approx(near, rel=1e-4, abs=1e-12)


def test_eq2_integer_sums_stay_below_2_to_the_53():
    """The worst case of the expanded squares (colour, full range) is exact in float64."""
    for n in (3, 5, 7, 9, 11):
        total = int(ref.window_weights(n).sum())
        cross = 2 * total * 3 * (2**16) ** 2      # |−2 Σ G I_p I_q|, and s_p + s_q
        assert cross < 2**53


@pytest.mark.parametrize("x", [-745.0, -700.3, -20.5, -1e-9, 0.0, 0.5, 1.0, 3.7, 88.0, 700.0])
def test_portable_exp_and_log_are_within_a_few_ulp(x):
    assert abs(float(ref.portable_exp(x)) - np.exp(x)) <= 2 * np.spacing(np.exp(x))
    y = float(np.exp(x)) if x > -700 else 1e-300
    assert abs(float(ref.portable_log(y)) - np.log(y)) <= 4 * np.spacing(abs(np.log(y)) + 1e-300)


def test_the_window_is_the_rounded_gaussian_of_neighbourhood_py():
    from refsynth.synthesis.neighbourhood import gaussian_window

    for n in range(1, 32, 2):
        np.testing.assert_array_equal(ref.window_weights(n),
                                      np.rint(gaussian_window(n) * 2**ref.WINDOW_BITS))


# -- BP's default departures in the reference ---------------------------------------------


@FEW
@given(st.integers(0, 2**32 - 1), st.integers(2, 12), st.integers(2, 12),
       st.floats(0.05, 0.9))
def test_the_reference_gap_depth_is_the_floored_distance_transform(seed, H, W, fraction):
    from refsynth.synthesis.belief.gap_radius import gap_depth

    g = np.random.default_rng(seed)
    known = g.random((H, W)) < fraction
    known[g.integers(H), g.integers(W)] = True
    rq = np.where(known, 0, ref.NO_RANGE)
    rows, cols = np.nonzero(~known)
    want = gap_depth(rq, rows, cols)   # scipy's exact Euclidean distance transform
    got = [ref.gap_depth_reference(known, r, c) for r, c in zip(rows, cols)]
    assert got == want.tolist()


def test_the_reference_gap_depth_on_a_hand_built_row():
    known = np.array([[True, False, False, False, False, False, True]])
    depths = [ref.gap_depth_reference(known, 0, c) for c in range(7)]
    assert depths == [0, 1, 2, 3, 2, 1, 0]
    # (3, 4) from the corner: exactly 5; (1, 1): sqrt 2 floors to 1
    corner = np.zeros((5, 5), bool)
    corner[0, 0] = True
    assert ref.gap_depth_reference(corner, 3, 4) == 5
    assert ref.gap_depth_reference(corner, 1, 1) == 1


def test_the_reference_observations_are_the_fill_on_the_measured_grid():
    from refsynth.synthesis.completion import portable_colorization

    g = np.random.default_rng(5)
    image = g.random((9, 11, 1))
    partial = np.where(g.random((9, 11)) < 0.4, np.round(2.0 + g.random((9, 11)), 2), np.nan)
    partial[0, 0] = 2.0
    edges = np.zeros((9, 11), bool)
    measured = ref.bp_reference(image, partial, edges, neighbourhood=3, radius=2.0, k=2,
                                iterations=2, observation="measured")
    default = ref.bp_reference(image, partial, edges, neighbourhood=3, radius=2.0, k=2,
                               iterations=2, observation="colorization")
    q, low, span = ref.quantise_range(partial)
    np.testing.assert_array_equal(measured.observed, q)
    known = np.isfinite(partial)
    np.testing.assert_array_equal(default.observed[known], q[known])
    unit = np.where(q < 0, np.nan, q / 2.0**ref.RANGE_BITS)
    fill = portable_colorization(ref.quantise_intensity(image) / 2.0**16, unit)
    want = np.maximum(np.rint(fill * 2.0**ref.RANGE_BITS), 0)
    np.testing.assert_array_equal(default.observed[~known], want[~known])
    # the labels stay measured pixels; the ranking moved
    assert np.all(known[default.candidates[..., 0], default.candidates[..., 1]])
    assert not np.array_equal(measured.unary, default.unary)
    # the default: NP's fill (the reference's, drawing on the same generator) on
    # the measured grid; without a generator it is refused
    with pytest.raises(TypeError, match="rng"):
        ref.bp_reference(image, partial, edges, neighbourhood=3, radius=2.0, k=2, iterations=2)
    on_np = ref.bp_reference(image, partial, edges, neighbourhood=3, radius=2.0, k=2,
                             iterations=2, rng=np.random.default_rng(3))
    filled = ref.np_reference(image, partial, edges, np.random.default_rng(3),
                              neighbourhood=3, radius=2.0, gaps="copy", median=0).range
    np.testing.assert_array_equal(on_np.observed[known], q[known])
    want = np.maximum(np.rint((filled - low) / span * 2.0**ref.RANGE_BITS), 0)
    np.testing.assert_array_equal(on_np.observed[~known], want[~known])
    assert np.all(known[on_np.candidates[..., 0], on_np.candidates[..., 1]])
