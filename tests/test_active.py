"""next_slices (§5, active sensing): where to measure next, on hand-built scenes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from refsynth.acquisition import next_slices
from refsynth.acquisition.active import _greedy, expected_gain, measured_columns


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


def test_greedy_spreads_over_a_uniform_gap():
    """One long gap of uniform error: the first pick near its middle, then one each side."""
    measured = np.zeros(33, bool)
    measured[[0, 32]] = True
    error = np.where(measured, 0.0, 1.0)
    picks = _greedy(error, measured, 3)
    assert 12 <= picks[0] <= 20
    assert min(picks[1:]) < picks[0] < max(picks[1:])
    assert np.min(np.diff(np.sort(picks))) >= 6


def test_greedy_bunches_nowhere():
    """Error only on one stretch: consecutive picks keep apart within it."""
    measured = np.zeros(61, bool)
    measured[::20] = True
    error = np.zeros(61)
    error[21:40] = 1.0
    picks = np.sort(_greedy(error, measured, 4))
    assert np.all((picks > 20) & (picks < 40))
    assert np.min(np.diff(picks)) >= 3


@given(hnp.arrays(np.float64, 12, elements=st.floats(0.0, 10.0, width=64)),
       hnp.arrays(np.bool_, 12))
def test_gain_equals_the_error_removed(error, measured):
    """g(c) = Σ U(c') (1 − d_new(c') / d_old(c')), computed by measuring c and comparing."""
    measured[0] = True
    error = np.where(measured, 0.0, error)
    gain = expected_gain(error, measured)
    columns = np.arange(12)
    for c in np.flatnonzero(~measured):
        old = np.array([np.min(np.abs(i - columns[measured])) for i in columns], float)
        now = measured.copy()
        now[c] = True
        new = np.array([np.min(np.abs(i - columns[now])) for i in columns], float)
        removed = np.sum(np.where(old > 0, error * (1.0 - new / np.maximum(old, 1)), 0.0))
        assert gain[c] == pytest.approx(removed, rel=1e-12, abs=1e-12)
    assert np.all(np.isneginf(gain[measured]))


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
