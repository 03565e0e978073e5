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


def interp_fill_error(estimate, uncertainty, measured, distance0, counts):
    """Σ over unmeasured pixels of E|line − truth|, the line from ``np.interp`` per row
    (constant beyond the outermost measured column), the uncertainty scaled by the
    distance to the nearest measured column over ``distance0``: an independent reading
    of the module's model."""
    columns = np.arange(measured.size)
    known = np.flatnonzero(measured)
    distance = np.min(np.abs(columns[:, None] - known[None, :]), axis=1).astype(float)
    total = 0.0
    for row, scale_row, count_row in zip(estimate, uncertainty, counts):
        line = np.interp(columns, known, row[known])
        for c in np.flatnonzero(~measured & count_row):
            scale = scale_row[c] * distance[c] / distance0[c]
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
    value)."""
    rng = np.random.default_rng(seed)
    estimate = rng.normal(size=(height, width)).cumsum(axis=1)
    measured = rng.random(width) < 0.3
    measured[rng.integers(width)] = True
    uncertainty = np.where(measured, 0.0, rng.random((height, width)) * (not sure))
    counts = np.ones((height, width), bool) if every else rng.random((height, width)) < 0.6
    gain = expected_gain(estimate, uncertainty, measured, None if every else counts)
    before = distances(measured)
    for c in np.flatnonzero(~measured):
        now = measured.copy()
        now[c] = True
        removed = (interp_fill_error(estimate, uncertainty, measured, before, counts)
                   - interp_fill_error(estimate, uncertainty, now, before, counts))
        assert gain[c] == pytest.approx(removed, rel=1e-9, abs=1e-9)
    assert np.all(np.isneginf(gain[measured]))


@pytest.mark.parametrize("arguments, match", [
    ((np.zeros(5), np.zeros(5), np.ones(5, bool)), "`estimate`"),
    ((np.zeros((2, 5)), np.zeros((2, 4)), np.ones(5, bool)), "`uncertainty`"),
    ((np.zeros((2, 5)), -np.ones((2, 5)), np.ones(5, bool)), "`uncertainty`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.ones(4, bool)), "`measured`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.zeros(5, bool)), "`measured`"),
    ((np.full((2, 5), np.nan), np.zeros((2, 5)), np.ones(5, bool)), "`estimate`"),
    ((np.zeros((2, 5)), np.zeros((2, 5)), np.ones(5, bool), np.ones(5, bool)), "`counts`"),
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
    gain after each pick, the uncertainty scaled by the new distance over the first."""
    rng = np.random.default_rng(seed)
    estimate = rng.normal(size=(4, 25)).cumsum(axis=1)
    measured = rng.random(25) < 0.2
    measured[rng.integers(25)] = True
    uncertainty = np.where(measured, 0.0, rng.random((4, 25)))
    counts = rng.random((4, 25)) < 0.7
    n = min(n, int(np.count_nonzero(~measured)))
    first, now, naive = distances(measured), measured.copy(), []
    for _ in range(n):
        scaled = np.where(first > 0, uncertainty * distances(now) / np.maximum(first, 1), 0.0)
        pick = int(np.argmax(expected_gain(estimate, scaled, now, counts)))
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
@given(hnp.arrays(np.bool_, st.tuples(st.integers(1, 4), st.integers(2, 12))))
def test_returning_pixels_look_at_the_nearest_measured_column_each_side(returned):
    """A pixel of an unmeasured column counts when its row returned in the nearest measured
    column to its left or to its right (one side at the borders): a loop per pixel."""
    returned[0, returned.shape[1] // 2] = True          # at least one measured column
    partial = np.where(returned, 1.0, np.nan)
    measured = returned.any(axis=0)
    expected = np.zeros(returned.shape, bool)
    for r, c in np.ndindex(*returned.shape):
        if measured[c]:
            continue
        left = [k for k in range(c) if measured[k]]
        right = [k for k in range(c + 1, returned.shape[1]) if measured[k]]
        expected[r, c] = bool((left and returned[r, left[-1]])
                              or (right and returned[r, right[0]]))
    assert np.array_equal(returning_pixels(partial), expected)


@pytest.mark.parametrize("partial", [np.full((3, 4), np.nan), np.ones(4)])
def test_returning_pixels_refuses_bad_input_by_name(partial):
    with pytest.raises(ValueError, match="`partial_range`"):
        returning_pixels(partial)


def test_next_slices_counts_only_the_pixels_a_measurement_reaches():
    """next_slices is _greedy on the synthesis, its uncertainty and returning_pixels: rows
    that returned nothing in the measured columns of the right half do not count there."""
    intensity, partial = wall_and_object()
    partial[4:12, 20:] = np.nan                           # the object's rows: no return
    result = synthesize(intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    counted = returning_pixels(partial)
    assert not counted[4:12, 25:].any() and counted[:, :24][:, ~measured[:24]].all()
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
