"""Tests of refsynth.acquisition.sampling: stripe masks (§3.3), Fig. 2 sampling (§3.1.1)."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from refsynth.acquisition.sampling import (
    column_range_profile,
    distance_driven,
    stripe_gap_for_fraction,
    stripes,
    unknown_fraction,
    x_stripes_for_fraction,
)

widths = st.integers(1, 6)
"""Stripe widths rw, xw: small, so that many periods fit in a tiny mask."""


def runs(line: np.ndarray) -> list[tuple[bool, int]]:
    """Run-length encoding of a 1-D boolean array: [(value, length), ...]."""
    change = np.flatnonzero(np.diff(line.astype(np.int8))) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [line.size]])
    return [(bool(line[s]), int(e - s)) for s, e in zip(starts, ends, strict=True)]


# ----------------------------------------------------------------------------- stripes


@settings(deadline=None)
@given(widths, widths, st.integers(1, 5), st.integers(0, 4))
def test_x_stripes_have_exactly_the_period_and_widths(rw, xw, periods, extra):
    width = periods * (rw + xw) + extra
    mask = stripes((3, width), rw, xw, axes="x")
    assert mask.shape == (3, width)
    assert (mask == mask[0]).all()  # whole columns
    line = mask[0]
    np.testing.assert_array_equal(line[rw + xw :], line[: width - rw - xw])  # the period
    inner = runs(line)
    # phase 0: a known stripe first; every complete run has its width
    assert inner[0] == (True, rw)
    for value, length in inner[:-1]:
        assert length == (rw if value else xw)
    assert inner[-1][1] <= (rw if inner[-1][0] else xw)


@settings(deadline=None)
@given(widths, widths, st.integers(1, 4), st.integers(-20, 20), st.sampled_from(["x", "y", "xy"]))
def test_phase_shifts_the_mask_like_np_roll(rw, xw, periods, phase, axes):
    side = periods * (rw + xw)  # a whole number of periods: rolling keeps the pattern
    base = stripes((side, side), rw, xw, axes=axes)
    shifted = stripes((side, side), rw, xw, axes=axes, phase=phase)
    np.testing.assert_array_equal(shifted, np.roll(base, (phase, phase), axis=(0, 1)))


@settings(deadline=None)
@given(widths, widths, st.integers(-10, 10), st.integers(-10, 10))
def test_phase_pair_is_row_then_column(rw, xw, row_phase, col_phase):
    side = 2 * (rw + xw)
    base = stripes((side, side), rw, xw)
    shifted = stripes((side, side), rw, xw, phase=(row_phase, col_phase))
    np.testing.assert_array_equal(shifted, np.roll(base, (row_phase, col_phase), axis=(0, 1)))


@settings(deadline=None)
@given(widths, widths, st.integers(1, 5), st.integers(1, 5), st.integers(-10, 10))
def test_unknown_fraction_of_whole_periods(rw, xw, row_periods, col_periods, phase):
    period = rw + xw
    shape = (row_periods * period, col_periods * period)
    x = stripes(shape, rw, xw, axes="x", phase=phase)
    y = stripes(shape, rw, xw, axes="y", phase=phase)
    xy = stripes(shape, rw, xw, axes="xy", phase=phase)
    assert unknown_fraction(x) == pytest.approx(xw / period, rel=1e-12)
    assert unknown_fraction(y) == pytest.approx(xw / period, rel=1e-12)
    assert unknown_fraction(xy) == pytest.approx((xw / period) ** 2, rel=1e-12)
    np.testing.assert_array_equal(xy, x | y)  # known if the column OR the row is known
    np.testing.assert_array_equal(y, stripes(shape[::-1], rw, xw, axes="x", phase=phase).T)


# Table 1 of the paper, 128 x 128: with phase 0 the first two settings give the
# paper's 39 %; the last two (paper: 61 %, 76.5 %) cannot be reached by any phase.
TABLE_1 = [
    (24, 80, 0.390625),
    (10, 20, 0.390625),
    (5, 25, 0.64752197265625),
    (3, 28, 0.77935791015625),
]


@pytest.mark.parametrize(("rw", "xw", "fraction"), TABLE_1)
def test_table1_settings_at_128(rw, xw, fraction):
    mask = stripes((128, 128), rw, xw, axes="xy", phase=0)
    assert unknown_fraction(mask) == fraction
    # phase 0 gives the smallest unknown fraction of all phases
    others = [unknown_fraction(stripes((128, 128), rw, xw, phase=p)) for p in range(rw + xw)]
    assert min(others) == fraction


def test_stripes_examples():
    np.testing.assert_array_equal(
        stripes((2, 7), 2, 3, axes="x", phase=1).astype(int),
        [[0, 1, 1, 0, 0, 0, 1]] * 2,
    )
    np.testing.assert_array_equal(
        stripes((5, 1), 1, 2, axes="y").ravel(), [True, False, False, True, False]
    )


# ----------------------------------------------------------------------------- fraction targets


@settings(deadline=None)
@given(
    st.integers(16, 200),
    st.floats(0.3, 0.95),
    st.integers(1, 4),
    st.integers(0, 10),
)
def test_x_stripes_for_fraction_is_the_best_xw(width, target, rw, phase):
    mask = x_stripes_for_fraction((4, width), target, rw=rw, phase=phase)
    achieved = unknown_fraction(mask)
    candidates = [
        unknown_fraction(stripes((1, width), rw, xw, axes="x", phase=phase))
        for xw in range(1, width + 1)
    ]
    assert abs(achieved - target) <= min(abs(c - target) for c in candidates) + 1e-12
    xw = stripe_gap_for_fraction(width, target, rw=rw, phase=phase)
    np.testing.assert_array_equal(mask, stripes((4, width), rw, xw, axes="x", phase=phase))


@settings(deadline=None)
@given(st.integers(128, 741), st.floats(0.6, 0.9))
def test_x_stripes_for_fraction_within_tolerance(width, target):
    """With the default rw = 3 the Table 4 range (62-85 %) is hit within 3 %.

    The achievable fractions xw / (rw + xw) lie about (1 - f)² / rw apart
    near f, so half of that (2.7 % at 60 %), plus a partial period's worth.
    """
    achieved = unknown_fraction(x_stripes_for_fraction((8, width), target))
    assert abs(achieved - target) <= 0.5 * (1 - target) ** 2 / 3 + 3 / width


def test_x_stripes_for_the_papers_middlebury_fractions():
    for target in (0.62, 0.78, 0.85):
        mask = x_stripes_for_fraction((375, 450), target)
        assert abs(unknown_fraction(mask) - target) < 0.01
        assert (mask == mask[0]).all()


# ----------------------------------------------------------------------------- Fig. 2


@settings(deadline=None)
@given(
    st.integers(30, 300),
    st.floats(1.0, 3.0),
    st.floats(1.5, 4.0),
    st.floats(0.2, 0.6),
    st.booleans(),
)
def test_distance_driven_is_denser_where_farther(width, near, ratio, fraction, far_right):
    profile = np.linspace(near, near * ratio, width)
    if not far_right:
        profile = profile[::-1]
    mask = distance_driven(profile, fraction, height=2)
    columns = np.flatnonzero(mask[0])
    gaps = np.diff(columns)
    if not far_right:
        gaps = gaps[::-1]  # read from near to far
    assume(gaps.size >= 2)
    # from the near end to the far end the spacing shrinks, up to one column of rounding
    later_max = np.maximum.accumulate(gaps[::-1])[::-1]  # max of gaps[i:]
    assert (later_max[1:] <= gaps[:-1] + 1).all()
    # and strictly on average when the range changes a lot
    if ratio >= 2 and gaps.size >= 8:
        half = gaps.size // 2
        assert gaps[:half].mean() > gaps[half:].mean()


@settings(deadline=None)
@given(
    st.integers(20, 400),
    st.floats(0.1, 0.9),
    st.integers(0, 2**32 - 1),
)
def test_distance_driven_hits_the_known_fraction(width, fraction, seed):
    rng = np.random.default_rng(seed)
    profile = rng.uniform(1.0, 9.0, width)
    mask = distance_driven(profile, fraction, height=3)
    known_columns = np.count_nonzero(mask[0])
    assert abs(known_columns - fraction * width) <= 1.0 + 1e-9
    assert (mask == mask[0]).all()


@settings(deadline=None)
@given(st.integers(20, 100), st.floats(0.2, 0.6), st.data())
def test_distance_driven_scans_the_phase_column_and_is_deterministic(width, fraction, data):
    phase = data.draw(st.integers(0, width - 1))
    profile = np.linspace(2.0, 6.0, width)
    mask = distance_driven(profile, fraction, height=1, phase=phase)
    assert mask[0, phase]
    np.testing.assert_array_equal(mask, distance_driven(profile, fraction, height=1, phase=phase))


def test_distance_driven_uniform_range_gives_even_spacing():
    mask = distance_driven(np.full(100, 5.0), 0.25, height=4)
    np.testing.assert_array_equal(np.flatnonzero(mask[0]), np.arange(0, 100, 4))


def test_distance_driven_respects_step_bounds():
    profile = np.concatenate([np.full(50, 1.0), np.full(50, 20.0)])
    mask = distance_driven(profile, 0.3, height=1, min_step=2, max_step=6)
    gaps = np.diff(np.flatnonzero(mask[0]))
    assert gaps.min() >= 2
    assert gaps.max() <= 6


def test_distance_driven_from_a_range_image_with_holes():
    rows, width = 20, 60
    image = np.tile(np.linspace(2.0, 8.0, width), (rows, 1))
    image[::2, :] = np.nan  # half of every column unknown: the median ignores it
    image[:, 10] = np.nan  # a column with no range at all: interpolated
    image[0, 30] = np.inf
    image_input = image.copy()
    mask = distance_driven(image, 0.4)
    assert mask.shape == (rows, width)
    np.testing.assert_array_equal(image, image_input)  # input not modified
    expected = distance_driven(np.linspace(2.0, 8.0, width), 0.4, height=rows)
    np.testing.assert_array_equal(mask, expected)


def test_column_range_profile():
    image = np.array([[1.0, np.nan, 9.0, np.nan], [3.0, np.nan, np.inf, np.nan], [2.0, 0, 7, 5]])
    image[2, 1] = np.nan
    np.testing.assert_allclose(column_range_profile(image), [2.0, 5.0, 8.0, 5.0])
    np.testing.assert_allclose(column_range_profile(np.array([4.0, np.nan, 8.0])), [4, 6, 8])


@pytest.mark.parametrize(
    ("arguments", "keywords", "error", "match"),
    [
        (([1.0, 2.0],), {"height": 2}, TypeError, "`coarse_range` must be a numpy array"),
        ((np.array(["a"]),), {"height": 2}, TypeError, "`coarse_range` must be a real array"),
        ((np.ones((2, 2, 2)),), {}, ValueError, r"`coarse_range` must be a non-empty 1-D"),
        ((np.ones(0),), {"height": 2}, ValueError, r"`coarse_range` must be a non-empty 1-D"),
        ((np.full(5, np.nan),), {"height": 2}, ValueError, "at least one finite value"),
        ((np.array([1.0, -1.0]),), {"height": 2}, ValueError, r"distances > 0"),
        ((np.ones(10),), {}, ValueError, "`height` is required"),
        ((np.ones((3, 10)),), {"height": 3}, ValueError, "`height` must be None"),
        ((np.ones(10),), {"height": 0}, ValueError, "`height` must be an integer >= 1, got 0"),
        ((np.ones(10),), {"height": 2.0}, TypeError, "`height` must be an integer"),
        ((np.ones(10), 0.0), {"height": 2}, ValueError, "`known_fraction` must be strictly"),
        ((np.ones(10), 1.0), {"height": 2}, ValueError, "`known_fraction` must be strictly"),
        ((np.ones(10), "0.5"), {"height": 2}, TypeError, "`known_fraction` must be a real"),
        ((np.ones(10),), {"height": 2, "min_step": 0.5}, ValueError, "`min_step` must be"),
        ((np.ones(10),), {"height": 2, "max_step": np.inf}, ValueError, "`max_step` must be"),
        ((np.ones(10),), {"height": 2, "max_step": "3"}, TypeError, "`max_step` must be a real"),
        (
            (np.ones(10),),
            {"height": 2, "min_step": 3, "max_step": 2},
            ValueError,
            "`max_step` must be >= `min_step`",
        ),
        ((np.ones(100), 0.9), {"height": 2, "min_step": 2}, ValueError, "to be reachable"),
        ((np.ones(100), 0.05), {"height": 2, "max_step": 4}, ValueError, "to be reachable"),
        ((np.ones(10),), {"height": 2, "phase": 10}, ValueError, "`phase` must be a column"),
        ((np.ones(10),), {"height": 2, "phase": -1}, ValueError, "`phase` must be an integer"),
    ],
)
def test_distance_driven_validation(arguments, keywords, error, match):
    with pytest.raises(error, match=match):
        distance_driven(*arguments, **keywords)


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("arguments", "keywords", "error", "match"),
    [
        (
            ((0, 5), 1, 1),
            {},
            ValueError,
            r"`shape` must be a pair of positive integers, got \(0, 5\)",
        ),
        (((4,), 1, 1), {}, ValueError, "`shape` must be a pair"),
        (((4.0, 4), 1, 1), {}, ValueError, "`shape` must be a pair"),
        (((4, 4), 0, 1), {}, ValueError, "`rw` must be an integer >= 1, got 0"),
        (((4, 4), 1, 0), {}, ValueError, "`xw` must be an integer >= 1, got 0"),
        (((4, 4), 1.5, 1), {}, TypeError, "`rw` must be an integer"),
        (((4, 4), True, 1), {}, TypeError, "`rw` must be an integer"),
        (((4, 4), 1, 1), {"axes": "z"}, ValueError, "`axes` must be one of"),
        (((4, 4), 1, 1), {"phase": 0.5}, ValueError, "`phase` must be an integer or a pair"),
        (((4, 4), 1, 1), {"phase": (1, 2, 3)}, ValueError, "`phase` must be an integer or a pair"),
    ],
)
def test_stripes_validation(arguments, keywords, error, match):
    with pytest.raises(error, match=match):
        stripes(*arguments, **keywords)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: x_stripes_for_fraction((4, 10), 0.0), ValueError, "`unknown_fraction` must be"),
        (lambda: x_stripes_for_fraction((4, 10), 1.5), ValueError, "`unknown_fraction` must be"),
        (lambda: x_stripes_for_fraction((4, 10), None), TypeError, "`unknown_fraction` must be"),
        (lambda: x_stripes_for_fraction((4, 10), 0.5, rw=0), ValueError, "`rw` must be"),
        (lambda: x_stripes_for_fraction((4, -1), 0.5), ValueError, "`shape` must be"),
        (lambda: x_stripes_for_fraction((4, 10), 0.5, phase=1.0), TypeError, "`phase` must be"),
        (lambda: stripe_gap_for_fraction(0, 0.5), ValueError, "`width` must be an integer >= 1"),
        (lambda: unknown_fraction([[True]]), TypeError, "`mask` must be a numpy array"),
        (lambda: unknown_fraction(np.ones(3)), TypeError, "`mask` must be a boolean array"),
        (lambda: unknown_fraction(np.ones(0, bool)), ValueError, "`mask` must not be empty"),
    ],
)
def test_fraction_validation(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_unknown_fraction():
    assert unknown_fraction(np.array([[True, False, False, False]])) == 0.75
    assert unknown_fraction(np.ones((3, 3), bool)) == 0.0
    assert unknown_fraction(np.zeros((3, 3), bool)) == 1.0
