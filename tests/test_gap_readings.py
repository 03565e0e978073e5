"""The gap reading (refsynth.synthesis.gap_readings): row gaps, the row line, the slices'
holes, the gate, and the reading ``gaps`` in :func:`refsynth.synthesize`."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis.gap_readings import (
    complete_slices,
    gap_gate,
    is_column_scan,
    row_gaps,
    row_interpolation,
)

nan = np.nan


def _plane(shape, a=2.0, b=0.05, c=-0.03):
    rows, cols = np.indices(shape)
    return a + b * cols + c * rows


def _columns(shape, known_cols):
    mask = np.zeros(shape, bool)
    mask[:, list(known_cols)] = True
    return mask


def _texture(shape, seed=3):
    return np.random.default_rng(seed).random((*shape, 3))


# ----------------------------------------------------------------------------- row_gaps


def test_row_gaps_hand_built():
    partial = np.array([[nan, 1.0, nan, nan, 4.0, nan],
                        [0.5, nan, 2.0, nan, nan, nan]])
    left, right, width = row_gaps(partial)
    assert left.tolist() == [[-1, 1, 1, 1, 4, 4], [0, 0, 2, 2, 2, 2]]
    assert right.tolist() == [[1, 1, 4, 4, 4, -1], [0, 2, 2, -1, -1, -1]]
    assert width.tolist() == [[-1, 0, 2, 2, 0, -1], [0, 1, 0, -1, -1, -1]]


@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.integers(2, 12))
def test_row_gaps_bounds_are_the_nearest_known(seed, height, width):
    rng = np.random.default_rng(seed)
    known = rng.random((height, width)) < 0.4
    partial = np.where(known, 1.0, nan)
    left, right, gap = row_gaps(partial)
    for i in range(height):
        for j in range(width):
            on_left = [c for c in range(j + 1) if known[i, c]]
            on_right = [c for c in range(j, width) if known[i, c]]
            assert left[i, j] == (on_left[-1] if on_left else -1)
            assert right[i, j] == (on_right[0] if on_right else -1)
            if known[i, j]:
                assert gap[i, j] == 0
            elif on_left and on_right:
                assert gap[i, j] == on_right[0] - on_left[-1] - 1
            else:
                assert gap[i, j] == -1


# ----------------------------------------------------------------------------- row_interpolation


@given(st.integers(0, 2**32 - 1))
def test_row_interpolation_is_exact_on_a_plane(seed):
    """Known first and last columns: every pixel of a plane is recovered (up to rounding)."""
    rng = np.random.default_rng(seed)
    shape = (7, 15)
    inner = [c for c in range(1, 14) if rng.random() < 0.3]
    known = _columns(shape, [0, 14, *inner])
    truth = _plane(shape, *rng.uniform(-2, 2, 3))
    out = row_interpolation(np.where(known, truth, nan))
    np.testing.assert_allclose(out, truth, rtol=0, atol=1e-12)
    assert np.array_equal(out[known], truth[known])  # measured pixels, bit for bit


def test_row_interpolation_hand_built_borders_and_empty_rows():
    partial = np.array([[nan, 1.0, nan, 3.0, nan],
                        [nan, nan, nan, nan, nan],
                        [nan, 5.0, nan, nan, nan]])
    out = row_interpolation(partial)
    assert out[0].tolist() == [1.0, 1.0, 2.0, 3.0, 3.0]
    assert out[2].tolist() == [5.0] * 5
    # the empty row, from the rows above and below along each column
    assert out[1].tolist() == [3.0, 3.0, 3.5, 4.0, 4.0]


def test_row_interpolation_refuses_bad_input():
    with pytest.raises(ValueError, match="partial_range"):
        row_interpolation(np.full((3, 3), nan))
    with pytest.raises(ValueError, match="partial_range"):
        row_interpolation(np.ones(4))


# ----------------------------------------------------------------------------- slices


def test_is_column_scan_on_stripes_slices_with_holes_and_grids():
    shape = (10, 12)
    stripes = np.where(_columns(shape, range(0, 12, 3)), 1.0, nan)
    assert is_column_scan(stripes)
    holed = stripes.copy()
    holed[2:8, 3] = nan            # a sensor's dropouts in a scanned column
    assert is_column_scan(holed)
    grid = stripes.copy()
    grid[::3, :] = 1.0             # measured rows too: the paper's grid (Table 1)
    assert not is_column_scan(grid)
    assert not is_column_scan(np.ones(shape))   # nothing unknown
    rng = np.random.default_rng(0)
    assert not is_column_scan(np.where(rng.random(shape) < 0.4, 1.0, nan))


def test_complete_slices_fills_each_scanned_column_along_itself():
    partial = np.array([[1.0, nan, nan],
                        [nan, nan, 5.0],
                        [nan, nan, nan],
                        [4.0, nan, 7.0]])
    out = complete_slices(partial)
    np.testing.assert_allclose(out[:, 0], [1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(out[:, 2], [5.0, 5.0, 6.0, 7.0])   # constant above the first
    assert np.isnan(out[:, 1]).all()                               # an unscanned column
    assert out[0, 0] == 1.0 and out[3, 2] == 7.0


# ----------------------------------------------------------------------------- gap_gate


def gate_by_loops(estimate, partial, edges, jump=0.1, max_gap=6):
    """The gate pixel by pixel, from its docstring: the independent check of the arrays."""
    height, width = partial.shape
    known = np.isfinite(partial)
    unknown = ~known
    empty = ~known.any(axis=0)
    if unknown.sum() == 0 or 2 * unknown[:, empty].sum() < unknown.sum():
        return np.where(known, partial, estimate)
    filled = partial.copy()
    for c in range(width):
        rows = [r for r in range(height) if known[r, c]]
        for r in range(height):
            if rows and not known[r, c]:
                above = [q for q in rows if q < r]
                below = [q for q in rows if q > r]
                if above and below:
                    a, b = above[-1], below[0]
                    step = (partial[b, c] - partial[a, c]) / (b - a)
                    filled[r, c] = partial[a, c] + (r - a) * step
                else:
                    filled[r, c] = partial[(above or below)[-1 if above else 0], c]
    out = filled.copy()
    for r in range(height):
        cols = [c for c in range(width) if np.isfinite(filled[r, c])]
        for c in range(width):
            if np.isfinite(filled[r, c]):
                continue
            left = [q for q in cols if q < c]
            right = [q for q in cols if q > c]
            if not left or not right:
                out[r, c] = filled[r, (left or right)[-1 if left else 0]]
                continue
            lo, hi = left[-1], right[0]
            lv, rv = filled[r, lo], filled[r, hi]
            line = lv + (c - lo) / (hi - lo) * (rv - lv)
            if abs(rv - lv) > jump * max(abs(lv), abs(rv)):
                out[r, c] = min(max(estimate[r, c], min(lv, rv)), max(lv, rv))
            elif hi - lo - 1 > max_gap and edges[r, lo + 1:hi].any():
                out[r, c] = 0.5 * (estimate[r, c] + line)
            else:
                out[r, c] = line
    return out


@given(st.integers(0, 2**32 - 1), st.integers(2, 9), st.integers(3, 14),
       st.floats(0.0, 0.5), st.integers(0, 4))
def test_gap_gate_equals_its_loops(seed, height, width, jump, max_gap):
    rng = np.random.default_rng(seed)
    known = _columns((height, width), [c for c in range(width) if rng.random() < 0.4])
    known &= rng.random((height, width)) < 0.85           # the sensor's holes
    if not known.any():
        known[0, 0] = True
    partial = np.where(known, rng.uniform(1, 5, (height, width)), nan)
    estimate = rng.uniform(-10, 10, partial.shape)
    edges = rng.random(partial.shape) < 0.2
    expected = gate_by_loops(estimate, partial, edges, jump, max_gap)
    got = gap_gate(estimate, partial, edges=edges, jump=jump, max_gap=max_gap)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert np.array_equal(got[known], partial[known])


def test_gap_gate_hand_built():
    partial = np.array([[1.0, nan, 1.1, nan, nan, 3.0, nan]] * 2)
    estimate = np.array([[9.0, 7.0, 9.0, 0.0, 2.5, 9.0, 8.0]] * 2)
    out = gap_gate(estimate, partial, jump=0.2, open_gaps="estimate")
    # 1 -> 1.1 is smooth (the line); 1.1 -> 3 holds an edge (clipped); the open gap kept
    np.testing.assert_allclose(out[0], [1.0, 1.05, 1.1, 1.1, 2.5, 3.0, 8.0])
    out = gap_gate(estimate, partial, jump=0.2)  # the open gap takes its bound by default
    assert out[0, -1] == 3.0
    # jump = 0 only clips; jump = inf takes the line in every bounded gap
    np.testing.assert_allclose(gap_gate(estimate, partial, jump=0.0)[0, :3], [1.0, 1.1, 1.1])
    np.testing.assert_allclose(gap_gate(estimate, partial, jump=np.inf)[0, 3:5],
                               [1.1 + 1.9 / 3, 1.1 + 3.8 / 3])


def test_gap_gate_bounds_a_row_by_its_neighbouring_slices_through_a_hole():
    """A hole in column 2 at row 1: the row's gap is bounded by column 2's completed value."""
    partial = np.tile([1.0, nan, 3.0, nan, 9.0], (3, 1))
    partial[1, 2] = nan
    estimate = np.full(partial.shape, 100.0)
    out = gap_gate(estimate, partial, jump=np.inf)
    assert out[1, 2] == 3.0                       # the hole: the line along its column
    np.testing.assert_allclose(out[1], [1.0, 2.0, 3.0, 6.0, 9.0])


def test_gap_gate_leaves_a_grid_to_the_synthesis():
    partial = np.where(_columns((9, 9), [0, 4, 8]), 1.0, nan)
    partial[::4, :] = 1.0
    estimate = np.full(partial.shape, 7.0)
    out = gap_gate(estimate, partial)
    known = np.isfinite(partial)
    assert np.array_equal(out[~known], estimate[~known])
    assert np.array_equal(out[known], partial[known])


def test_gap_gate_wide_smooth_gaps_with_an_edge():
    partial = np.array([[1.0] + [nan] * 8 + [1.0]])
    estimate = np.array([[1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0]])
    edges = np.zeros(partial.shape, bool)
    assert np.array_equal(gap_gate(estimate, partial), np.ones((1, 10)))  # no edges given
    edges[0, 0] = edges[0, 9] = True  # on the bounds only: not inside the gap
    assert np.array_equal(gap_gate(estimate, partial, edges=edges), np.ones((1, 10)))
    edges[0, 3] = True
    assert np.array_equal(gap_gate(estimate, partial, edges=edges, wide_gaps="estimate"),
                          estimate)
    np.testing.assert_allclose(gap_gate(estimate, partial, edges=edges), (estimate + 1.0) / 2)
    # a gap no wider than max_gap takes the line whatever the edges say
    assert np.array_equal(gap_gate(estimate, partial, edges=edges, max_gap=8), np.ones((1, 10)))
    assert np.array_equal(gap_gate(estimate, partial, edges=edges, max_gap=None),
                          np.ones((1, 10)))


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"jump": -0.1}, ValueError, "jump"),
    ({"jump": nan}, ValueError, "jump"),
    ({"jump": "0.1"}, TypeError, "jump"),
    ({"open_gaps": "nearest"}, ValueError, "open_gaps"),
    ({"wide_gaps": "line"}, ValueError, "wide_gaps"),
    ({"max_gap": -1}, ValueError, "max_gap"),
    ({"edges": np.zeros((1, 3), int)}, ValueError, "edges"),
])
def test_gap_gate_refuses_bad_input(kwargs, error, match):
    partial = np.array([[1.0, nan, 2.0]])
    with pytest.raises(error, match=match):
        gap_gate(partial, partial, **kwargs)
    with pytest.raises(ValueError, match="estimate"):
        gap_gate(np.ones((2, 3)), partial)


# ----------------------------------------------------------------------------- the reading


@pytest.mark.parametrize("method", ["np", "bp"])
def test_the_default_reading_gates_what_the_paper_copies(method):
    shape = (12, 22)
    truth = _plane(shape, 2.0, 0.005, 0.0)
    partial = np.where(_columns(shape, [0, 1, 11, 12, 21]), truth, nan)
    image = _texture(shape, 11)
    edges = np.zeros(shape, bool)
    edges[:, 5] = True
    copied = refsynth.synthesize(image, partial, method=method, seed=0, edges=edges,
                                 readings={"gaps": "copy", "median": 0})
    gated = refsynth.synthesize(image, partial, method=method, seed=0, edges=edges,
                                readings={"median": 0})
    assert gated.params["gaps"] == "gate" and copied.params["gaps"] == "copy"
    assert np.array_equal(gated.range, gap_gate(copied.range, partial, edges=edges))
    np.testing.assert_allclose(gated.range[:, 12:21], truth[:, 12:21], atol=1e-12)
    np.testing.assert_allclose(gated.range[:, 2:11], (copied.range[:, 2:11] + truth[:, 2:11]) / 2,
                               atol=1e-12)
    assert np.array_equal(gated.confidence, copied.confidence)
    paper = refsynth.synthesize(image, partial, method=method, seed=0, edges=edges,
                                readings="paper")
    assert paper.params["gaps"] == "copy"


def test_the_reading_uses_synthesizes_own_canny_edges():
    shape = (12, 22)
    partial = np.where(_columns(shape, [0, 10, 21]), _plane(shape, 2.0, 0.005, 0.0), nan)
    image = _texture(shape, 5)
    copied = refsynth.synthesize(image, partial, seed=0, readings={"gaps": "copy", "median": 0})
    gated = refsynth.synthesize(image, partial, seed=0, readings={"median": 0})
    assert np.array_equal(gated.range, gap_gate(copied.range, partial, edges=copied.edges))


def test_the_reading_is_refused_by_name():
    with pytest.raises(ValueError, match="`gaps` must be one of 'copy', 'gate'"):
        refsynth.synthesize(np.zeros((3, 3)), np.where(np.eye(3) > 0, 1.0, nan),
                            readings={"gaps": "line"})
