"""Tests of refsynth.evaluation.metrics: MAR (Eq. 13), RMSE and bad-pixel rates."""

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from refsynth.evaluation.metrics import bad_pixel_rate, evaluate, evaluated_pixels, mar, rmse

EPS = np.finfo(np.float64).eps


@st.composite
def evaluation_case(draw, max_side: int = 6):
    """(estimate, truth, known) on a tiny grid, with at least one evaluated pixel.

    Values are moderate floats so that differences are exact enough to
    compare with a few ulps; ``truth`` has NaN holes (no ground truth).
    """
    shape = draw(st.tuples(st.integers(1, max_side), st.integers(1, max_side)))
    values = st.floats(-100, 100, allow_nan=False, allow_infinity=False, width=64,
                       allow_subnormal=False)
    estimate = draw(arrays(np.float64, shape, elements=values))
    truth = draw(arrays(np.float64, shape, elements=values))
    known = draw(arrays(np.bool_, shape))
    no_truth = draw(arrays(np.bool_, shape))
    truth = np.where(no_truth, np.nan, truth)
    assume(np.any(~known & ~no_truth))
    return estimate, truth, known


@settings(deadline=None)
@given(evaluation_case())
def test_eq13_zero_for_perfect_fill(case):
    _, truth, known = case
    estimate = np.where(np.isfinite(truth), truth, 0.0)
    assert mar(estimate, truth, known) == 0.0
    assert rmse(estimate, truth, known) == 0.0
    assert bad_pixel_rate(estimate, truth, known, 0.0) == 0.0


@settings(deadline=None)
@given(evaluation_case(), st.floats(-50, 50, allow_nan=False))
def test_eq13_equals_constant_offset(case, offset):
    _, truth, known = case
    estimate = np.where(np.isfinite(truth), truth, 0.0) + offset
    # (t + c) - t is c to within one ulp of the larger magnitude involved
    tolerance = 4 * EPS * (150 + abs(offset))
    assert mar(estimate, truth, known) == pytest.approx(abs(offset), abs=tolerance)
    assert rmse(estimate, truth, known) == pytest.approx(abs(offset), abs=tolerance)


@settings(deadline=None)
@given(evaluation_case(), st.floats(-1e3, 1e3, allow_nan=False))
def test_eq13_ignores_known_pixels_and_pixels_without_truth(case, junk):
    estimate, truth, known = case
    ignored = known | ~np.isfinite(truth)
    changed = np.where(ignored, junk, estimate)
    assert mar(changed, truth, known) == mar(estimate, truth, known)
    # NaN in the estimate where there is nothing to evaluate is fine too
    assert mar(np.where(ignored, np.nan, estimate), truth, known) == mar(estimate, truth, known)


@settings(deadline=None)
@given(evaluation_case())
def test_eq13_is_symmetric(case):
    estimate, truth, known = case
    truth = np.where(np.isfinite(truth), truth, 0.0)  # both finite: the pixel set is the same
    assert mar(estimate, truth, known) == mar(truth, estimate, known)
    assert rmse(estimate, truth, known) == rmse(truth, estimate, known)


@settings(deadline=None)
@given(evaluation_case(), st.sampled_from([2.0, 4.0, 8.0]))
def test_eq13_scales_linearly(case, scale):
    estimate, truth, known = case
    # multiplying by a power of two is exact (no overflow or underflow here)
    assert mar(scale * estimate, scale * truth, known) == scale * mar(estimate, truth, known)
    assert rmse(scale * estimate, scale * truth, known) == pytest.approx(
        scale * rmse(estimate, truth, known), rel=4 * EPS
    )


@settings(deadline=None)
@given(evaluation_case())
@example((np.zeros((1, 1)), np.full((1, 1), 1.1e-271), np.zeros((1, 1), bool)))  # underflow
def test_rmse_at_least_mar(case):
    estimate, truth, known = case
    assert rmse(estimate, truth, known) >= mar(estimate, truth, known) * (1 - 4 * EPS)


@settings(deadline=None)
@given(evaluation_case(), st.floats(0, 100), st.floats(0, 100))
def test_bad_pixel_rate_is_monotone_in_threshold(case, a, b):
    estimate, truth, known = case
    low, high = min(a, b), max(a, b)
    rate_low = bad_pixel_rate(estimate, truth, known, low)
    rate_high = bad_pixel_rate(estimate, truth, known, high)
    assert 0.0 <= rate_high <= rate_low <= 1.0


@settings(deadline=None)
@given(evaluation_case())
def test_evaluate_agrees_with_the_single_measures(case):
    estimate, truth, known = case
    result = evaluate(estimate, truth, known)
    assert list(result) == ["mar", "rmse", "bad1", "bad3", "n"]
    assert result["mar"] == pytest.approx(mar(estimate, truth, known), rel=1e-12)
    assert result["rmse"] == pytest.approx(rmse(estimate, truth, known), rel=1e-12)
    assert result["bad1"] == bad_pixel_rate(estimate, truth, known, 1.0)
    assert result["bad3"] == bad_pixel_rate(estimate, truth, known, 3.0)
    assert result["n"] == np.count_nonzero(~known & np.isfinite(truth))
    assert isinstance(result["n"], int)


def test_hand_computed_example():
    truth = np.array([[1.0, 2.0, 3.0], [4.0, np.nan, 6.0]])
    known = np.array([[True, False, False], [False, False, True]])
    estimate = np.array([[100.0, 2.5, 1.0], [8.0, 7.0, -50.0]])
    # evaluated: (0,1) |0.5|, (0,2) |2|, (1,0) |4|
    assert mar(estimate, truth, known) == pytest.approx(6.5 / 3, rel=1e-15)
    assert rmse(estimate, truth, known) == pytest.approx(np.sqrt((0.25 + 4 + 16) / 3), rel=1e-15)
    assert bad_pixel_rate(estimate, truth, known, 1.0) == pytest.approx(2 / 3)
    assert bad_pixel_rate(estimate, truth, known, 3.0) == pytest.approx(1 / 3)
    assert evaluate(estimate, truth, known)["n"] == 3


def test_integer_inputs_are_accepted_and_not_modified():
    truth = np.array([[1, 2], [3, 4]])
    estimate = np.array([[1, 3], [3, 2]])
    known = np.array([[True, False], [False, False]])
    copies = truth.copy(), estimate.copy(), known.copy()
    assert mar(estimate, truth, known) == 1.0
    for original, copy in zip((truth, estimate, known), copies, strict=True):
        np.testing.assert_array_equal(original, copy)


# ----------------------------------------------------------------------------- validation

GOOD = np.zeros((2, 2)), np.ones((2, 2)), np.array([[True, False], [False, False]])


@pytest.mark.parametrize(
    ("arguments", "error", "match"),
    [
        (([[0.0]], GOOD[1], GOOD[2]), TypeError, "`estimate` must be a numpy array"),
        ((GOOD[0], "truth", GOOD[2]), TypeError, "`truth` must be a numpy array"),
        ((GOOD[0], GOOD[1], [[True]]), TypeError, "`known` must be a numpy array"),
        ((GOOD[0].astype(bool), GOOD[1], GOOD[2]), TypeError, "`estimate` must be a real"),
        ((GOOD[0] + 0j, GOOD[1], GOOD[2]), TypeError, "`estimate` must be a real"),
        ((GOOD[0], GOOD[1].astype(str), GOOD[2]), TypeError, "`truth` must be a real"),
        ((GOOD[0], GOOD[1], GOOD[2].astype(int)), TypeError, "`known` must be a boolean"),
        ((GOOD[0], np.ones((2, 3)), GOOD[2]), ValueError, r"`truth` must have the shape"),
        ((GOOD[0], GOOD[1], np.ones(4, bool)), ValueError, r"`known` must have the shape"),
        ((GOOD[0], GOOD[1], np.ones((2, 2), bool)), ValueError, "No pixel to evaluate"),
        ((GOOD[0], np.full((2, 2), np.nan), GOOD[2]), ValueError, "No pixel to evaluate"),
        (
            (np.array([[0.0, np.nan], [0.0, 0.0]]), GOOD[1], GOOD[2]),
            ValueError,
            "`estimate` must be finite on the evaluated pixels",
        ),
    ],
)
@pytest.mark.parametrize("measure", [mar, rmse, evaluate, evaluated_pixels])
def test_validation(measure, arguments, error, match):
    with pytest.raises(error, match=match):
        measure(*arguments)


@pytest.mark.parametrize(
    ("threshold", "error", "match"),
    [
        (-1.0, ValueError, "`threshold` must be a finite number >= 0, got -1.0"),
        (np.inf, ValueError, "`threshold` must be a finite number >= 0"),
        (np.nan, ValueError, "`threshold` must be a finite number >= 0"),
        ("1", TypeError, "`threshold` must be a real number"),
        (True, TypeError, "`threshold` must be a real number"),
    ],
)
def test_threshold_validation(threshold, error, match):
    with pytest.raises(error, match=match):
        bad_pixel_rate(*GOOD, threshold)
