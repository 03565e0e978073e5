"""next_slices (§5, active sensing): where to measure next, on hand-built scenes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy import integrate

from refsynth import synthesize
from refsynth.acquisition import next_slices
from refsynth.acquisition.active import (
    _greedy,
    _grey_level,
    bending,
    expected_gain,
    line_error,
    measured_columns,
    returning_pixels,
)


def wall_and_object(height: int = 16, width: int = 40, step: int = 6):
    """A flat wall on the left half; on the right half a box before the wall (its own grey)."""
    intensity = np.tile(np.linspace(0.2, 0.4, width), (height, 1))
    truth = np.full((height, width), 4.0)
    rows, cols = slice(height // 4, 3 * height // 4), slice(width // 2 + 3, width - 4)
    intensity[rows, cols] = 0.9
    truth[rows, cols] = 1.5
    partial = np.full((height, width), np.nan)
    partial[:, ::step] = truth[:, ::step]
    return intensity, partial


@pytest.mark.parametrize("method", ["np", "bp"])
def test_picks_go_to_the_object_not_the_wall(method):
    intensity, partial = wall_and_object()
    picks = next_slices(intensity, partial, 4, method=method, iterations=5
                        if method == "bp" else None)
    assert np.all(picks >= 20), picks  # every pick on the object's half


def test_no_measured_column_no_repeat_and_spread():
    intensity, partial = wall_and_object()
    picks = next_slices(intensity, partial, 10, method="np")
    assert picks.shape == (10,) and picks.dtype == np.int64
    assert not measured_columns(partial)[picks].any()
    assert len(set(picks.tolist())) == 10


def test_deterministic():
    intensity, partial = wall_and_object()
    first = next_slices(intensity, partial, 5, method="bp", iterations=5)
    again = next_slices(intensity.copy(), partial.copy(), 5, method="bp", iterations=5)
    assert np.array_equal(first, again)


def test_inputs_are_not_modified():
    intensity, partial = wall_and_object()
    before = (intensity.copy(), partial.copy())
    next_slices(intensity, partial, 2, method="np")
    assert np.array_equal(intensity, before[0]) and np.array_equal(partial, before[1],
                                                                    equal_nan=True)


def naive_bend(estimate, measured):
    """``B`` per pixel by loops: the mean |second divided difference| at the measured
    columns bounding the pixel's gap that have a measured column on each side (beyond the
    outermost columns, the nearest one); NaN on measured columns or with < 3 columns."""
    known = np.flatnonzero(measured).tolist()
    bend = np.full(estimate.shape, np.nan)
    if len(known) < 3:
        return bend
    for row in range(estimate.shape[0]):
        f = estimate[row]
        second = {}
        for k0, k1, k2 in zip(known, known[1:], known[2:]):
            second[k1] = abs(((f[k2] - f[k1]) / (k2 - k1) - (f[k1] - f[k0]) / (k1 - k0))
                             / (k2 - k0))
        for c in np.flatnonzero(~measured):
            left = [k for k in known if k < c]
            right = [k for k in known if k > c]
            if not left:
                ends = [second[known[1]]]
            elif not right:
                ends = [second[known[-2]]]
            else:
                ends = [second[k] for k in (left[-1], right[0]) if k in second]
            bend[row, c] = sum(ends) / len(ends)
    return bend


def interp_fill_error(estimate, uncertainty, measured, distance0, counts, bend0):
    """Σ over unmeasured pixels of E|line − truth|, the line from ``np.interp`` per row
    (constant beyond the outermost measured column), the uncertainty scaled by the
    distance to the nearest measured column over ``distance0`` and combined with the bend
    term (``bend0`` times (c − a)(b − c) between measured columns a and b, d² beyond them)
    by their geometric mean: an independent reading of the module's model."""
    columns = np.arange(measured.size)
    known = np.flatnonzero(measured)
    distance = np.min(np.abs(columns[:, None] - known[None, :]), axis=1).astype(float)
    total = 0.0
    for row, scale_row, count_row, bend_row in zip(estimate, uncertainty, counts, bend0):
        line = np.interp(columns, known, row[known])
        for c in np.flatnonzero(~measured & count_row):
            scale = scale_row[c] * distance[c] / distance0[c]
            left, right = known[known < c], known[known > c]
            span = ((c - left[-1]) * (right[0] - c) if left.size and right.size
                    else distance[c] ** 2)
            if not np.isnan(bend_row[c]):
                scale = np.sqrt(scale * bend_row[c] * span)
            size = abs(line[c] - row[c])
            total += size + (scale * np.exp(-size / scale) if scale > 0 else 0.0)
    return total


def distances(measured):
    columns = np.arange(measured.size)
    known = np.flatnonzero(measured)
    return np.min(np.abs(columns[:, None] - known[None, :]), axis=1).astype(float)


@settings(max_examples=60)
@given(st.integers(0, 2**32 - 1), st.integers(1, 3), st.integers(2, 14), st.booleans(),
       st.booleans())
def test_gain_equals_the_error_removed(seed, height, width, sure, every):
    """g(c) = the expected error of the per-row lines before measuring c less after, over
    the pixels that count, computed with np.interp (edges: the outermost measured column's
    value) and the bend of the measured columns before c."""
    rng = np.random.default_rng(seed)
    estimate = rng.normal(size=(height, width)).cumsum(axis=1)
    measured = rng.random(width) < 0.3
    measured[rng.integers(width)] = True
    uncertainty = np.where(measured, 0.0, rng.random((height, width)) * (not sure))
    counts = np.ones((height, width), bool) if every else rng.random((height, width)) < 0.6
    gain = expected_gain(estimate, uncertainty, measured, None if every else counts)
    before, bend = distances(measured), naive_bend(estimate, measured)
    for c in np.flatnonzero(~measured):
        now = measured.copy()
        now[c] = True
        removed = (interp_fill_error(estimate, uncertainty, measured, before, counts, bend)
                   - interp_fill_error(estimate, uncertainty, now, before, counts, bend))
        assert gain[c] == pytest.approx(removed, rel=1e-9, abs=1e-9)
    assert np.all(np.isneginf(gain[measured]))


@settings(max_examples=60)
@given(st.integers(0, 2**32 - 1), st.integers(1, 3), st.integers(3, 16))
def test_bending_matches_a_loop_over_the_divided_differences(seed, height, width):
    rng = np.random.default_rng(seed)
    estimate = rng.normal(size=(height, width)).cumsum(axis=1)
    measured = rng.random(width) < 0.4
    np.testing.assert_allclose(bending(estimate, measured), naive_bend(estimate, measured),
                               rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("arguments, match", [
    ((np.zeros(5), np.ones(5, bool)), "`estimate`"),
    ((np.zeros((2, 5)), np.ones(4, bool)), "`measured`"),
    ((np.zeros((2, 5)), np.ones(5)), "`measured`"),
])
def test_bending_refuses_bad_input_by_name(arguments, match):
    with pytest.raises(ValueError, match=match):
        bending(*arguments)


@settings(max_examples=60)
@given(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0),
       hnp.arrays(np.bool_, st.integers(3, 20)))
def test_bending_of_a_quadratic_row_is_its_half_second_derivative(alpha, beta, gamma, measured):
    """Eq. f[k0, k1, k2] = f''/2 on any three columns of α x² + β x + γ: B = |α| on every
    unmeasured column (NaN on measured ones), for any spacing of at least three columns."""
    x = np.arange(measured.size, dtype=float)
    estimate = np.tile(alpha * x ** 2 + beta * x + gamma, (2, 1))
    bend = bending(estimate, measured)
    if np.count_nonzero(measured) < 3:
        assert np.all(np.isnan(bend))
    else:
        assert np.all(np.isnan(bend[:, measured]))
        np.testing.assert_allclose(bend[:, ~measured], abs(alpha), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("arguments, match", [
    ((np.zeros(5), np.zeros(5), np.ones(5, bool)), "`estimate`"),
    ((np.zeros((2, 5)), np.zeros((2, 4)), np.ones(5, bool)), "`uncertainty`"),
    ((np.zeros((2, 5)), -np.ones((2, 5)), np.ones(5, bool)), "`uncertainty`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.ones(4, bool)), "`measured`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.zeros(5, bool)), "`measured`"),
    ((np.full((2, 5), np.nan), np.zeros((2, 5)), np.ones(5, bool)), "`estimate`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.ones(5, bool), np.ones(5, bool)), "`counts`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.ones(5, bool), None, np.zeros(5)), "`bend`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.ones(5, bool), None, -np.ones((2, 5))), "`bend`"),
])
def test_expected_gain_refuses_bad_input_by_name(arguments, match):
    with pytest.raises(ValueError, match=match):
        expected_gain(*arguments)


@settings(max_examples=40)
@given(st.floats(-20.0, 20.0), st.floats(0.05, 5.0))
def test_line_error_is_the_laplace_expectation(deviation, scale):
    """e = E|δ − ε| for ε Laplace of mean absolute value U, by quadrature; U = 0 gives |δ|."""
    def integrand(x):
        return abs(deviation - x) * np.exp(-abs(x) / scale) / (2.0 * scale)

    expected = sum(integrate.quad(integrand, a, b, limit=200)[0]
                   for a, b in ((-np.inf, min(0.0, deviation)),
                                (min(0.0, deviation), max(0.0, deviation)),
                                (max(0.0, deviation), np.inf)))
    assert float(line_error(np.array(deviation), np.array(scale))) == pytest.approx(
        expected, rel=1e-7, abs=1e-9)
    assert float(line_error(np.array(deviation), np.array(0.0))) == abs(deviation)


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6))
def test_greedy_is_each_pick_taken_as_measured(seed, n):
    """_greedy (which recomputes only the two gaps a pick leaves) equals recomputing every
    gain after each pick, the uncertainty scaled by the new distance over the first, the
    bend that of the first measured columns."""
    rng = np.random.default_rng(seed)
    estimate = rng.normal(size=(4, 25)).cumsum(axis=1)
    measured = rng.random(25) < 0.2
    measured[rng.integers(25)] = True
    uncertainty = np.where(measured, 0.0, rng.random((4, 25)))
    counts = rng.random((4, 25)) < 0.7
    n = min(n, int(np.count_nonzero(~measured)))
    first, now, naive = distances(measured), measured.copy(), []
    bend = bending(estimate, measured)       # fixed for the call, as the uncertainty
    for _ in range(n):
        scaled = np.where(first > 0, uncertainty * distances(now) / np.maximum(first, 1), 0.0)
        pick = int(np.argmax(expected_gain(estimate, scaled, now, counts, bend)))
        naive.append(pick)
        now[pick] = True
    assert _greedy(estimate, uncertainty, measured, n, counts).tolist() == naive


def test_greedy_halves_a_bend_then_its_halves():
    """A parabola between two measured columns: the first pick at its middle (the split
    that leaves the least line error), then one in each half."""
    columns = np.arange(33)
    estimate = np.tile(columns * (32 - columns) / 32.0, (3, 1))
    measured = np.isin(columns, [0, 32])
    every = np.ones((3, 33), bool)
    picks = _greedy(estimate, np.zeros((3, 33)), measured, 3, every)
    assert picks[0] == 16 and sorted(picks[1:].tolist()) == [8, 24]
    spread = _greedy(estimate, np.where(measured, 0.0, np.full((3, 33), 0.5)), measured, 3,
                     every)
    assert spread[0] == 16 and min(spread[1:]) < 16 < max(spread[1:])


def test_the_bend_sends_the_picks_where_the_measured_columns_curve():
    """The fill is the line in every gap (as the gap gate leaves a smooth one), with the same
    uncertainty everywhere: without the bend every gap offers the same gain. The measured
    columns lie on a plane on the left, on a parabola on the right: the picks go right."""
    columns = np.arange(41)
    truth = np.where(columns < 20, 2 + 0.01 * columns,
                     2.2 + 0.01 * (columns - 20) + 0.02 * (columns - 20.0) ** 2)
    measured = columns % 4 == 0
    known = np.flatnonzero(measured)
    estimate = np.tile(np.interp(columns, known, truth[known]), (3, 1))
    uncertainty = np.where(measured, 0.0, 0.1) * np.ones((3, 1))
    flat = expected_gain(estimate, uncertainty, measured, bend=np.full((3, 41), np.nan))
    assert np.allclose(flat[1:4], flat[37:40]) and flat[1] > 0     # U alone: a tie
    gain = expected_gain(estimate, uncertainty, measured)
    plane, curve = ~measured & (columns < 16), ~measured & (columns > 20)
    assert np.allclose(gain[plane], 0.0) and np.all(gain[curve] > 0.1)
    picks = _greedy(estimate, uncertainty, measured, 4, np.ones((3, 41), bool))
    assert np.all(picks > 20), picks


def test_greedy_goes_where_the_range_leaves_the_line():
    """A flat wall with a box before it on columns 25-34: every pick near the box, apart."""
    estimate = np.full((5, 61), 4.0)
    estimate[1:4, 25:35] = 1.5
    measured = np.zeros(61, bool)
    measured[::10] = True
    picks = np.sort(_greedy(estimate, np.zeros((5, 61)), measured, 4, np.ones((5, 61), bool)))
    assert np.all((picks > 20) & (picks < 40)), picks
    assert len(set(picks.tolist())) == 4


@settings(max_examples=60)
@given(hnp.arrays(np.bool_, st.tuples(st.integers(1, 4), st.integers(2, 12))), st.booleans(),
       st.integers(0, 2**32 - 1))
def test_returning_pixels_look_at_the_nearest_measured_column_each_side(returned, grey, seed):
    """A pixel of an unmeasured column counts when its row returned in the nearest measured
    columns on both sides, not when in neither; on one side only, when (with an intensity)
    its grey level is at least as near the returning bound's as the other's, or (without)
    always. One side at the borders. A loop per pixel."""
    returned[0, returned.shape[1] // 2] = True          # at least one measured column
    partial = np.where(returned, 1.0, np.nan)
    measured = returned.any(axis=0)
    intensity = (np.random.default_rng(seed).integers(0, 4, returned.shape + (3,)) / 3.0
                 if grey else None)
    level = None if intensity is None else intensity.mean(axis=2)
    expected = np.zeros(returned.shape, bool)
    for r, c in np.ndindex(*returned.shape):
        if measured[c]:
            continue
        left = [k for k in range(c) if measured[k]]
        right = [k for k in range(c + 1, returned.shape[1]) if measured[k]]
        a = left[-1] if left else right[0]
        b = right[0] if right else left[-1]
        if returned[r, a] and returned[r, b]:
            expected[r, c] = True
        elif returned[r, a] or returned[r, b]:
            yes, no = (a, b) if returned[r, a] else (b, a)
            expected[r, c] = (level is None or abs(level[r, c] - level[r, yes])
                              <= abs(level[r, c] - level[r, no]))
    assert np.array_equal(returning_pixels(partial, intensity), expected)


def test_returning_pixels_leave_out_a_dark_pole_beside_a_returning_wall():
    """Columns 0, 4 and 8 measured; a dark pole on columns 3-5 returned nothing in column 4
    of row 0, the wall returned everywhere else. In row 0 the wall's pixels count, the
    pole's do not; without the intensity all do; row 1 returned on both sides: all count."""
    intensity = np.full((2, 9), 0.8)
    intensity[:, 3:6] = 0.05
    partial = np.full((2, 9), np.nan)
    partial[:, [0, 8]] = 3.0
    partial[1, 4] = 1.0
    counted = returning_pixels(partial, intensity)
    assert counted[1, [1, 2, 3, 5, 6, 7]].all()
    assert counted[0, [1, 2, 6, 7]].all() and not counted[0, [3, 5]].any()
    assert returning_pixels(partial)[0, [1, 2, 3, 5, 6, 7]].all()


@pytest.mark.parametrize("partial", [np.full((3, 4), np.nan), np.ones(4)])
def test_returning_pixels_refuses_bad_input_by_name(partial):
    with pytest.raises(ValueError, match="`partial_range`"):
        returning_pixels(partial)


@settings(max_examples=40)
@given(st.integers(0, 2**32 - 1), st.sampled_from([(), (1,), (3,), (4,)]))
def test_the_grey_level_is_the_channel_mean_summed_left_to_right(seed, channels):
    """As synthesize reads the intensity (8-bit scaled by 255), then ((c0 + c1) + c2) / C:
    the same bits on every machine."""
    image = np.random.default_rng(seed).integers(0, 256, (3, 4) + channels).astype(np.uint8)
    values = image / 255.0
    if values.ndim == 2:
        expected = values
    else:
        expected = values[:, :, 0]
        for c in range(1, values.shape[2]):
            expected = expected + values[:, :, c]
        expected = expected / values.shape[2]
    assert np.array_equal(_grey_level(image, (3, 4)), expected)


@pytest.mark.parametrize("intensity", [np.zeros((3, 5)), np.zeros((2, 5, 3)), np.zeros(4),
                                       np.full((2, 4), np.nan)])
def test_returning_pixels_refuse_a_bad_intensity_by_name(intensity):
    partial = np.full((2, 4), np.nan)
    partial[:, 0] = 1.0
    with pytest.raises(ValueError, match="`intensity`"):
        returning_pixels(partial, intensity)
    with pytest.raises(TypeError, match="`intensity`"):
        returning_pixels(partial, intensity.tolist())


def test_next_slices_counts_only_the_pixels_a_measurement_reaches():
    """next_slices is _greedy on the synthesis, its uncertainty and returning_pixels: rows
    that returned nothing in the measured columns of the right half do not count there."""
    intensity, partial = wall_and_object()
    partial += 0.01 * (np.arange(40) - 20.0) ** 2         # the wall bends (seen from inside)
    partial[4:12, 20:] = np.nan                           # the object's rows: no return
    result = synthesize(intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    counted = returning_pixels(partial, intensity)
    assert not counted[4:12, 25:].any() and counted[:, :18][:, ~measured[:18]].all()
    # between column 18 (wall, returned) and 24 (box, no return): the wall's pixels count
    assert counted[4:12, 19:23].all() and not counted[4:12, 23].any()
    picks = next_slices(intensity, partial, 4, method="np")
    assert np.array_equal(picks, _greedy(result.range, result.uncertainty, measured, 4,
                                         counted))
    every = _greedy(result.range, result.uncertainty, measured, 4, np.ones(partial.shape, bool))
    assert not np.array_equal(picks, every)               # the counting changes the choice


@given(st.integers(1, 6), st.integers(0, 3))
def test_any_n_gives_distinct_unmeasured_columns(n, offset):
    intensity = np.tile(np.linspace(0, 1, 14), (8, 1))
    partial = np.full((8, 14), np.nan)
    partial[:, offset::4] = 2.0 + np.arange(8)[:, None] / 8
    picks = next_slices(intensity, partial, n, method="np")
    assert len(set(picks.tolist())) == n
    assert np.all(np.isnan(partial[:, picks]))


@pytest.mark.parametrize("args, kwargs, error, match", [
    ((0,), {}, ValueError, "`n`"),
    ((35,), {}, ValueError, "`n`"),
    ((2.0,), {}, TypeError, "`n`"),
    ((2,), {"method": "lin"}, ValueError, "`method`"),
])
def test_errors_name_the_argument(args, kwargs, error, match):
    intensity, partial = wall_and_object()  # 40 columns, 7 measured: 33 unmeasured
    with pytest.raises(error, match=match):
        next_slices(intensity, partial, *args, **kwargs)


def test_errors_on_shapes_and_a_fully_measured_range():
    intensity, partial = wall_and_object()
    with pytest.raises(ValueError, match="partial_range|shape"):
        next_slices(intensity, partial[:, :-1], 1)
    full = np.where(np.isnan(partial), 1.0, partial)
    full[0, 0] = np.nan  # one unknown pixel, but in a measured column
    with pytest.raises(ValueError, match="`partial_range`"):
        next_slices(intensity, full, 1)
