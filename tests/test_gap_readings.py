"""synthesis.gap_readings: row gaps, the row interpolation, the gate, the residual reading."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis.gap_readings import (
    gap_gate,
    gated_synthesis,
    residual_synthesis,
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


# ----------------------------------------------------------------------------- gap_gate


def test_gap_gate_hand_built():
    partial = np.array([[1.0, nan, 1.1, nan, nan, 3.0, nan]])
    estimate = np.array([[9.0, 7.0, 9.0, 0.0, 2.5, 9.0, 8.0]])
    out = gap_gate(estimate, partial, jump=0.2, open_gaps="estimate")
    # 1 -> 1.1 is smooth (interpolated); 1.1 -> 3 holds an edge (clipped); the open gap kept
    np.testing.assert_allclose(out, [[1.0, 1.05, 1.1, 1.1, 2.5, 3.0, 8.0]])
    out = gap_gate(estimate, partial, jump=0.2)  # the open gap takes its bound by default
    assert out[0, -1] == 3.0
    # jump = 0 only clips; jump = inf interpolates every bounded gap
    np.testing.assert_allclose(gap_gate(estimate, partial, jump=0.0)[0, :3], [1.0, 1.1, 1.1])
    np.testing.assert_allclose(gap_gate(estimate, partial, jump=np.inf)[0, 3:5],
                               [1.1 + 1.9 / 3, 1.1 + 3.8 / 3])


@given(st.integers(0, 2**32 - 1), st.floats(0.0, 1.0))
def test_gap_gate_stays_within_the_bounds(seed, jump):
    rng = np.random.default_rng(seed)
    partial = np.where(rng.random((6, 10)) < 0.4, rng.uniform(1, 5, (6, 10)), nan)
    if not np.isfinite(partial).any():
        partial[0, 0] = 1.0
    estimate = rng.uniform(-10, 10, partial.shape)
    out = gap_gate(estimate, partial, jump=jump, open_gaps="estimate")
    left, right, width = row_gaps(partial)
    rows = np.arange(6)[:, None]
    lv, rv = partial[rows, np.maximum(left, 0)], partial[rows, np.maximum(right, 0)]
    bounded = width > 0
    assert np.all(out[bounded] >= np.fmin(lv, rv)[bounded] - 1e-12)
    assert np.all(out[bounded] <= np.fmax(lv, rv)[bounded] + 1e-12)
    known = np.isfinite(partial)
    assert np.array_equal(out[known], partial[known])
    assert np.array_equal(out[width < 0], estimate[width < 0])


def test_gap_gate_refuses_bad_input():
    partial = np.array([[1.0, nan, 2.0]])
    with pytest.raises(ValueError, match="jump"):
        gap_gate(partial, partial, jump=-0.1)
    with pytest.raises(ValueError, match="jump"):
        gap_gate(partial, partial, jump=nan)
    with pytest.raises(TypeError, match="jump"):
        gap_gate(partial, partial, jump="0.1")
    with pytest.raises(ValueError, match="open_gaps"):
        gap_gate(partial, partial, open_gaps="nearest")
    with pytest.raises(ValueError, match="estimate"):
        gap_gate(np.ones((2, 3)), partial)


# ----------------------------------------------------------------------------- with synthesis


@pytest.mark.parametrize("method", ["np", "bp"])
def test_residual_synthesis_is_the_interpolation_on_a_plane(method):
    """The residual reading: a planar range comes back exactly, whatever the texture."""
    shape = (14, 17)
    truth = _plane(shape)
    known = _columns(shape, range(0, 17, 4))
    partial = np.where(known, truth, nan)
    out = residual_synthesis(_texture(shape), partial, method=method, seed=1)
    np.testing.assert_allclose(out, truth, rtol=0, atol=1e-12)
    assert np.array_equal(out[known], partial[known])


def test_residual_synthesis_equals_the_interpolation_on_any_scene():
    """Every source holds a residual of 0, so the texture cannot change the result."""
    rng = np.random.default_rng(5)
    shape = (16, 16)
    partial = np.where(_columns(shape, [0, 3, 7, 8, 12, 15]), rng.uniform(1, 3, shape), nan)
    out = residual_synthesis(_texture(shape, 7), partial, seed=2)
    assert np.array_equal(out, row_interpolation(partial))
    nearest = residual_synthesis(_texture(shape, 7), partial, interpolation="nearest", seed=2)
    assert np.array_equal(nearest[:, 1], partial[:, 0])


@pytest.mark.parametrize("method", ["np", "bp"])
def test_gated_synthesis_on_a_plane_is_exact_and_deterministic(method):
    shape = (14, 17)
    truth = _plane(shape, 2.0, 0.01, -0.02)  # 4 % at most across a gap: no edge at jump 0.1
    known = _columns(shape, range(0, 17, 4))
    partial = np.where(known, truth, nan)
    out = gated_synthesis(_texture(shape), partial, method=method, seed=4)
    np.testing.assert_allclose(out, truth, rtol=0, atol=1e-12)
    assert np.array_equal(out, gated_synthesis(_texture(shape), partial, method=method, seed=4))


def test_gated_synthesis_is_synthesize_then_the_gate():
    """A step scene: the gaps across the step keep the synthesized range (clipped)."""
    shape = (16, 20)
    truth = np.where(np.arange(20) < 9, 1.0, 2.0) * np.ones(shape)
    image = np.where(truth > 1.5, 0.9, 0.1)
    partial = np.where(_columns(shape, [0, 1, 5, 6, 12, 13, 18, 19]), truth, nan)
    synthesized = refsynth.synthesize(image, partial, seed=0).range
    out = gated_synthesis(image, partial, seed=0, jump=0.1)
    assert np.array_equal(out, gap_gate(synthesized, partial, jump=0.1))
    # the edge's gap (columns 7-11) holds the synthesized, not the interpolated, step
    np.testing.assert_array_equal(out[:, 7:12], np.clip(synthesized[:, 7:12], 1.0, 2.0))
    assert np.array_equal(out[:, 2:5], np.ones((16, 3)))


def test_gated_synthesis_checks_before_any_work():
    partial = np.array([[1.0, nan, 2.0]] * 3)
    with pytest.raises(ValueError, match="jump"):
        gated_synthesis(np.zeros((3, 3)), partial, jump=-1.0)
    with pytest.raises(ValueError, match="open_gaps"):
        gated_synthesis(np.zeros((3, 3)), partial, open_gaps="x")
    with pytest.raises(ValueError):
        gated_synthesis(np.zeros((3, 4)), partial)


def test_gap_gate_keeps_the_estimate_in_a_wide_smooth_gap_with_an_edge():
    partial = np.array([[1.0] + [nan] * 8 + [1.0]])
    estimate = np.array([[1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0]])
    edges = np.zeros(partial.shape, bool)
    assert np.array_equal(gap_gate(estimate, partial), np.ones((1, 10)))  # no edges given
    assert np.array_equal(gap_gate(estimate, partial, edges=edges), np.ones((1, 10)))
    edges[0, 0] = edges[0, 9] = True  # on the bounds only: not inside the gap
    assert np.array_equal(gap_gate(estimate, partial, edges=edges), np.ones((1, 10)))
    edges[0, 3] = True
    assert np.array_equal(gap_gate(estimate, partial, edges=edges, wide_gaps="estimate"),
                          estimate)
    mean = gap_gate(estimate, partial, edges=edges)
    np.testing.assert_allclose(mean, (estimate + 1.0) / 2)
    # a gap no wider than max_gap is interpolated whatever the edges say
    assert np.array_equal(gap_gate(estimate, partial, edges=edges, max_gap=8), np.ones((1, 10)))
    assert np.array_equal(gap_gate(estimate, partial, edges=edges, max_gap=None),
                          np.ones((1, 10)))
    with pytest.raises(ValueError, match="edges"):
        gap_gate(estimate, partial, edges=edges.astype(int))
    with pytest.raises(ValueError, match="max_gap"):
        gap_gate(estimate, partial, max_gap=-1)
    with pytest.raises(ValueError, match="wide_gaps"):
        gap_gate(estimate, partial, wide_gaps="line")


def test_gated_synthesis_gates_with_synthesizes_edges():
    """Wide gaps (9 px) over a textured plane: the gate sees the same Canny edges as NP."""
    shape = (12, 22)
    truth = _plane(shape, 2.0, 0.005, 0.0)
    partial = np.where(_columns(shape, [0, 1, 11, 12, 21]), truth, nan)
    image = _texture(shape, 11)
    edges = np.zeros(shape, bool)
    edges[:, 5] = True
    given_edges = gated_synthesis(image, partial, seed=0, edges=edges)
    synthesized = refsynth.synthesize(image, partial, seed=0, edges=edges).range
    assert np.array_equal(given_edges, gap_gate(synthesized, partial, edges=edges))
    np.testing.assert_allclose(given_edges[:, 12:21], truth[:, 12:21], atol=1e-12)
    np.testing.assert_allclose(given_edges[:, 2:11], (synthesized[:, 2:11] + truth[:, 2:11]) / 2,
                               atol=1e-12)
    own = gated_synthesis(image, partial, seed=0)
    canny_edges = refsynth.synthesis.canny(
        refsynth.numeric.quantise_grey(refsynth.numeric.quantise_intensity(image)) * 2.0**-16,
        sigma=0.8)
    synthesized = refsynth.synthesize(image, partial, seed=0).range
    assert np.array_equal(own, gap_gate(synthesized, partial, edges=canny_edges))
