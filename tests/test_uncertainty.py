"""The uncertainty map (refsynth.synthesis.uncertainty) and SynthesisResult.uncertainty."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import refsynth
from refsynth.synthesis.gap_readings import row_interpolation
from refsynth.synthesis.uncertainty import (
    CALIBRATION,
    uncertainty_features,
    uncertainty_map,
)
from refsynth.synthesis.uncertainty import _row_line as row_line

NAN = np.nan


def stripes(shape=(12, 16), every=4, value=2.0) -> np.ndarray:
    partial = np.full(shape, NAN)
    partial[:, ::every] = value
    return partial


def scene(shape=(16, 20)):
    """A flat wall (left half) and a box with a textured face (right half), columns every 4."""
    rows, cols = np.mgrid[: shape[0], : shape[1]]
    truth = np.where(cols < shape[1] // 2, 3.0, 1.0 + 0.5 * ((rows // 2 + cols // 3) % 2))
    image = np.where(cols < shape[1] // 2, 0.3, 0.2 + 0.6 * ((rows // 2 + cols // 3) % 2))
    partial = np.where(cols % 4 == 0, truth, NAN)
    return image, partial, truth


@pytest.mark.parametrize("method", ["np", "bp"])
def test_synthesize_fills_the_map(method):
    image, partial, _ = scene()
    result = refsynth.synthesize(image, partial, method=method, radius=4.0)
    unc = result.uncertainty
    known = np.isfinite(partial)
    assert unc.shape == partial.shape and unc.dtype == np.float64
    assert np.all(unc[known] == 0.0)
    assert np.all(unc[~known] > 0.0) and np.isfinite(unc).all()
    raw = refsynth.synthesize(image, partial, method=method, radius=4.0,
                              readings={"gaps": "copy", "median": 0})
    again = uncertainty_map(partial, result.range, method=method, raw=raw.range,
                            candidate_values=result.candidate_values)
    assert np.array_equal(again, unc)
    # the fill as filled: the map of its own range
    assert np.array_equal(raw.uncertainty, uncertainty_map(
        partial, raw.range, method=method, candidate_values=raw.candidate_values))


def test_the_same_inputs_give_the_same_bits():
    image, partial, _ = scene()
    first = refsynth.synthesize(image, partial, method="bp", radius=4.0).uncertainty
    second = refsynth.synthesize(image, partial, method="bp", radius=4.0).uncertainty
    assert first.tobytes() == second.tobytes()


def test_the_textured_box_is_less_sure_than_the_wall():
    image, partial, _ = scene()
    result = refsynth.synthesize(image, partial, radius=4.0)
    unknown = ~np.isfinite(partial)
    wall = result.uncertainty[:, :10][unknown[:, :10]].mean()
    box = result.uncertainty[:, 10:][unknown[:, 10:]].mean()
    assert box > 2 * wall


def test_a_fill_that_leaves_the_line_is_less_sure_where_it_leaves_it():
    partial = stripes()
    agrees = np.full(partial.shape, 2.0)
    leaves = agrees.copy()
    leaves[:, 2] = 7.0  # one column far from the line between its bounds
    easy = uncertainty_map(partial, agrees)
    hard = uncertainty_map(partial, leaves)
    assert np.all(hard[:, 2] > easy[:, 2])
    # the far column (col 2) is the least sure in the rows' first gap
    assert np.all(hard[:, 2] > hard[:, 1]) and np.all(hard[:, 2] > hard[:, 3])


def test_bp_labels_that_disagree_raise_the_uncertainty():
    partial = stripes()
    estimate = np.full(partial.shape, 2.0)
    count = int(np.isnan(partial).sum())
    agree = np.full((count, 4), 2.0)
    disagree = agree.copy()
    disagree[:5] = [2.0, 6.0, -2.0, 9.0]
    calm = uncertainty_map(partial, estimate, method="bp", candidate_values=agree)
    doubt = uncertainty_map(partial, estimate, method="bp", candidate_values=disagree)
    unknown = np.isnan(partial)
    first = np.flatnonzero(unknown.ravel())[:5]
    assert np.all(doubt.ravel()[first] > calm.ravel()[first])
    rest = np.flatnonzero(unknown.ravel())[5:]
    assert np.array_equal(doubt.ravel()[rest], calm.ravel()[rest])


def test_a_depth_edge_between_columns_is_less_sure_than_a_flat_gap():
    partial = stripes((10, 13), every=4)
    partial[:, 8:] = np.where(np.isnan(partial[:, 8:]), NAN, 5.0)
    estimate = np.where(np.isnan(partial), 2.0, partial)  # columns 0, 4: 2; 8, 12: 5
    estimate[:, 9:] = 5.0  # the step put at column 8, in the gap 5–7 between 2 and 5
    unc = uncertainty_map(partial, estimate)
    assert unc[:, 5:8].min() > unc[:, 1:4].max()


def test_farther_from_the_measured_columns_is_less_sure():
    partial = np.full((8, 20), NAN)
    partial[:, 0] = partial[:, -1] = 1.0
    unc = uncertainty_map(partial, np.ones(partial.shape))
    assert np.all(np.diff(unc[:, 1:10], axis=1) > 0)


def test_a_post_processed_estimate_keeps_the_raw_fills_doubt():
    partial = stripes()
    line = row_interpolation(partial)
    raw = line.copy()
    raw[:, 1] = 5.0  # the method's fill disagreed with the line there
    with_raw = uncertainty_map(partial, line, raw=raw)
    without = uncertainty_map(partial, line)
    assert np.all(with_raw[:, 1] > without[:, 1])


def test_a_partial_range_of_zeros_still_gives_a_positive_map():
    partial = np.where(np.isnan(stripes()), NAN, 0.0)
    unc = uncertainty_map(partial, np.zeros(partial.shape))
    assert np.all(unc[np.isnan(partial)] > 0) and np.isfinite(unc).all()


@settings(deadline=None)
@given(known=arrays(bool, (6, 9)), seed=st.integers(0, 2**16))
def test_the_row_line_is_row_interpolation_bit_for_bit(known, seed):
    if not known.any():
        known[2, 3] = True
    values = np.random.default_rng(seed).normal(size=known.shape)
    partial = np.where(known, values, NAN)
    line, position = row_line(partial, known)
    assert np.array_equal(line, row_interpolation(partial))
    assert np.all((position >= 0) & (position <= 0.5))


@settings(deadline=None)
@given(seed=st.integers(0, 2**16), scale=st.floats(1e-3, 1e3), power=st.integers(-20, 20),
       method=st.sampled_from(["np", "bp"]))
def test_scaling_the_range_scales_the_map(seed, scale, power, method):
    rng = np.random.default_rng(seed)
    partial = np.where(rng.random((7, 11)) < 0.4, rng.uniform(1, 5, (7, 11)), NAN)
    partial[0, 0] = 3.0
    estimate = np.where(np.isnan(partial), rng.uniform(1, 5, partial.shape), partial)
    count = int(np.isnan(partial).sum())
    labels = rng.uniform(1, 5, (count, 3)) if method == "bp" else None

    def unc(k):
        return uncertainty_map(k * partial, k * estimate, method=method,
                               candidate_values=None if labels is None else k * labels)

    base = unc(1.0)
    assert np.array_equal(unc(2.0**power), 2.0**power * base)  # exact: a power of two
    np.testing.assert_allclose(unc(scale), scale * base, rtol=1e-12, atol=0)


def test_the_terms_are_zero_on_measured_pixels_and_the_floor_positive_elsewhere():
    partial = stripes()
    terms = uncertainty_features(partial, np.full(partial.shape, 2.0))
    known = np.isfinite(partial)
    assert set(terms) == {"spread", "labels", "variation", "floor"}
    for term in terms.values():
        assert np.all(term[known] == 0.0)
    assert np.all(terms["floor"][~known] > 0.0)
    assert set(CALIBRATION) == {"np", "bp"}


@pytest.mark.parametrize("call, error, words", [
    (lambda p, e: uncertainty_map(p.tolist(), e), TypeError, "partial_range"),
    (lambda p, e: uncertainty_map(p, e[:, :-1]), ValueError, "estimate"),
    (lambda p, e: uncertainty_map(p, np.where(np.isnan(p), NAN, e)), ValueError, "finite"),
    (lambda p, e: uncertainty_map(p, e.astype(bool)), TypeError, "estimate"),
    (lambda p, e: uncertainty_map(np.full(p.shape, NAN), e), ValueError, "measured"),
    (lambda p, e: uncertainty_map(np.where(np.isnan(p), NAN, np.inf), e), ValueError,
     "partial_range"),
    (lambda p, e: uncertainty_map(p, e, method="knn"), ValueError, "method"),
    (lambda p, e: uncertainty_map(p, e, method="bp"), ValueError, "candidate_values"),
    (lambda p, e: uncertainty_map(p, e, candidate_values=np.ones((3, 2))), ValueError,
     "candidate_values"),
    (lambda p, e: uncertainty_map(p, e, method="bp", candidate_values=np.ones((3, 2))),
     ValueError, "candidate_values"),
    (lambda p, e: uncertainty_map(p, e, raw=e[:2]), ValueError, "raw"),
])
def test_bad_input_is_refused_naming_the_argument(call, error, words):
    partial = stripes()
    with pytest.raises(error, match=words):
        call(partial, np.full(partial.shape, 2.0))


def test_the_benchmarks_ause_is_zero_for_the_true_errors_and_worst_reversed(benchmark_script):
    bench = benchmark_script("bench_uncertainty")
    errors = np.random.default_rng(0).exponential(size=500)
    assert bench.ause(errors, errors) == 0.0
    noise = np.random.default_rng(1).random(500)
    assert 0.2 < bench.ause(noise, errors) < bench.ause(-errors, errors)
    curve = bench.sparsification(np.argsort(-errors), errors)
    assert curve[0] == pytest.approx(errors.mean()) and np.all(np.diff(curve) <= 1e-12)


def test_the_held_out_scale_centres_the_other_scenes_ratios(benchmark_script):
    """``--held-out``: a scene's ratio under the scale whose other scenes' ratios (at scale 1)
    span [lo, hi] is its own ratio (at scale 1) over sqrt(lo · hi)."""
    bench = benchmark_script("bench_uncertainty")
    scale = bench.CALIBRATION["np"]["scale"]
    at_one = {"a": [2.0, 2.2], "b": [1.0], "c": [4.0]}   # ratios under scale 1
    cases = [(name, scale * r) for name, rs in at_one.items() for r in rs]
    rows = {name: (own, held) for name, own, held in bench.held_out(cases, "np")}
    assert rows["a"][0] == pytest.approx(2.1 * scale)
    assert rows["a"][1] == pytest.approx(2.1 / np.sqrt(1.0 * 4.0))
    assert rows["b"][1] == pytest.approx(1.0 / np.sqrt(2.0 * 4.0))
    assert rows["c"][1] == pytest.approx(4.0 / np.sqrt(1.0 * 2.2))
