"""The median reading (refsynth.synthesis.median_pass) and ``readings={"median": ...}`` in
:func:`refsynth.synthesize`."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis.gap_readings import gap_gate
from refsynth.synthesis.median_pass import median_pass

nan = np.nan


def _window_medians(base: np.ndarray, size: int) -> np.ndarray:
    """An independent median: each pixel's window of the border-repeated array, by np.median."""
    h = size // 2
    padded = np.pad(base, h, mode="edge")
    out = np.empty_like(base)
    for r in range(base.shape[0]):
        for c in range(base.shape[1]):
            out[r, c] = np.median(padded[r : r + size, c : c + size])
    return out


@st.composite
def _inputs(draw):
    rows, cols = draw(st.integers(1, 9)), draw(st.integers(1, 9))
    g = np.random.default_rng(draw(st.integers(0, 2**16)))
    levels = draw(st.sampled_from([None, 3]))   # few levels: ties in the median
    estimate = g.random((rows, cols)) if levels is None else g.integers(0, levels,
                                                                         (rows, cols)) * 1.0
    known = g.random((rows, cols)) < draw(st.floats(0.0, 0.8))
    partial = np.where(known, 10.0 + g.random((rows, cols)), nan)
    return estimate, partial, draw(st.sampled_from([3, 5]))


@given(_inputs())
def test_each_unknown_pixel_is_its_windows_median_and_measured_pixels_stay(case):
    estimate, partial, size = case
    out = median_pass(estimate, partial, size)
    known = np.isfinite(partial)
    assert np.array_equal(out[known], partial[known])
    base = np.where(known, partial, estimate)
    want = _window_medians(base, size)
    assert np.array_equal(out[~known], want[~known])
    # an odd window's median is one of its values: nothing new is made up
    assert set(out[~known]) <= set(base.ravel())


@given(_inputs())
def test_size_zero_is_the_estimate_with_the_measurements(case):
    estimate, partial, _ = case
    known = np.isfinite(partial)
    assert np.array_equal(median_pass(estimate, partial, 0), np.where(known, partial, estimate))


def test_an_isolated_wrong_value_is_removed_and_a_straight_edge_kept():
    shape = (7, 8)
    truth = np.where(np.arange(8) >= 4, 3.0, 1.0) * np.ones(shape)
    partial = np.where(np.arange(8)[None, :] % 3 == 0, truth, nan)
    estimate = truth.copy()
    estimate[3, 2] = 3.0    # a copy from the other side of the edge
    out = median_pass(estimate, partial)
    assert np.array_equal(out, truth)


def test_the_border_repeats_its_pixels():
    partial = np.full((3, 3), nan)
    partial[2, 2] = 0.0
    estimate = np.array([[9.0, 9.0, 1.0], [0.0, 0.0, 1.0], [1.0, 1.0, 0.0]])
    # the corner's window: the corner four times, its two neighbours twice, the diagonal once
    # (9 9 9 9 9 9 0 0 0: 9), where a mirrored border would give 0 0 0 0 0 0 9 9 9 (0)
    assert median_pass(estimate, partial)[0, 0] == 9.0


@pytest.mark.parametrize(("size", "error", "match"), [
    (4, ValueError, "`median` must be 0 or an odd number from 3 to 15, got 4"),
    (1, ValueError, "got 1"),
    (17, ValueError, "got 17"),
    (-3, ValueError, "got -3"),
    (3.0, TypeError, "`median` must be an integer"),
    ("3", TypeError, "`median` must be an integer"),
])
def test_a_bad_size_is_refused_by_name(size, error, match):
    with pytest.raises(error, match=match):
        median_pass(np.zeros((3, 3)), np.full((3, 3), nan), size)


def test_bad_arrays_are_refused():
    with pytest.raises(ValueError, match="one shape"):
        median_pass(np.zeros((3, 4)), np.full((3, 3), nan))
    with pytest.raises(ValueError, match="one shape"):
        median_pass(np.zeros(3), np.full(3, nan))
    estimate = np.zeros((3, 3))
    estimate[1, 1] = nan
    with pytest.raises(ValueError, match="finite on every unknown pixel"):
        median_pass(estimate, np.full((3, 3), nan))


# ------------------------------------------------------------- the reading in synthesize


def _column_scan():
    g = np.random.default_rng(8)
    rows, cols = np.mgrid[:14, :20]
    box = (cols >= 7) & (cols < 13) & (rows >= 5)
    image = np.stack([np.where(box, 0.7, 0.3) + 0.1 * g.random((14, 20))] * 3, axis=-1)
    truth = np.where(box, 1.5, 3.0 + 0.02 * cols)
    return image, np.where(cols % 3 == 0, truth, nan)


@pytest.mark.parametrize("method", ["np", "bp"])
def test_the_default_is_the_fill_then_the_gate_then_the_median(method):
    image, partial = _column_scan()
    options = dict(method=method, seed=4, radius=3.0, candidates=3, iterations=5) \
        if method == "bp" else dict(method=method, seed=4, radius=3.0)
    fill = refsynth.synthesize(image, partial, **options,
                               readings={"gaps": "copy", "median": 0})
    default = refsynth.synthesize(image, partial, **options)
    gated = gap_gate(fill.range, partial, edges=fill.edges)
    assert np.array_equal(default.range, median_pass(gated, partial))
    assert not np.array_equal(default.range, gated)   # the median acts on this scene
    # the fill's own outputs are the same: the readings act on the range only
    assert np.array_equal(default.confidence, fill.confidence)
    assert np.array_equal(default.order, fill.order)
    assert default.params["median"] == 3 and fill.params["median"] == 0
    five = refsynth.synthesize(image, partial, **options, readings={"median": 5})
    assert np.array_equal(five.range, median_pass(gated, partial, 5))


def test_off_a_column_scan_the_median_acts_alone_and_the_paper_has_none():
    g = np.random.default_rng(2)
    image = g.random((12, 12))
    partial = np.where(g.random((12, 12)) < 0.4, 1.0 + g.random((12, 12)), nan)
    fill = refsynth.synthesize(image, partial, seed=1, radius=3.0, readings={"median": 0})
    default = refsynth.synthesize(image, partial, seed=1, radius=3.0)
    assert np.array_equal(default.range, median_pass(fill.range, partial))
    paper = refsynth.synthesize(image, partial, seed=1, radius=3.0, readings="paper")
    same = refsynth.synthesize(image, partial, seed=1, radius=3.0,
                               readings=refsynth.synthesis.readings.Readings.paper().replace(
                                   median=3))
    assert np.array_equal(same.range, median_pass(paper.range, partial))


def test_a_bad_median_reading_is_refused_before_any_work():
    with pytest.raises(ValueError, match="`median` must be 0 or an odd number"):
        refsynth.synthesize(np.zeros((3, 3)), np.where(np.eye(3) > 0, 1.0, nan),
                            readings={"median": 2})
