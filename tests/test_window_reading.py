"""The window reading (refsynth.synthesis.window_reading) and ``synthesize``'s neighbourhood."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis import reference as ref
from refsynth.synthesis.api import normalise_intensity
from refsynth.synthesis.gap_readings import is_column_scan
from refsynth.synthesis.nonparametric.reference import np_reference as literal_np
from refsynth.synthesis.window_reading import (
    DEFAULT_NEIGHBOURHOOD,
    NARROW_GAP,
    NARROW_NEIGHBOURHOOD,
    choose_neighbourhood,
    typical_gap,
)

nan = np.nan


def _widths_by_hand(partial: np.ndarray) -> list[int]:
    """Independently: per row, the runs of columns with no measured pixel at all (the scanned
    columns' holes count as measured), bounded by a scanned column on both sides; each run's
    width once per pixel of it."""
    scanned = np.isfinite(partial).any(axis=0)
    widths = []
    for _ in range(partial.shape[0]):
        start = None
        for c, is_scanned in enumerate(scanned):
            if is_scanned:
                if start is not None and start > 0:
                    widths += [c - start] * (c - start)
                start = None
            elif start is None:
                start = c
    return sorted(widths)


@st.composite
def _column_scans(draw):
    rows, cols = draw(st.integers(1, 8)), draw(st.integers(2, 40))
    g = np.random.default_rng(draw(st.integers(0, 2**16)))
    scanned = g.random(cols) < draw(st.floats(0.05, 0.9))
    holes = g.random((rows, cols)) < draw(st.sampled_from([0.0, 0.3]))
    known = scanned[None, :] & ~holes
    return np.where(known, 1.0 + g.random((rows, cols)), nan)


@given(_column_scans())
def test_the_typical_gap_is_the_lower_median_of_the_pixels_gap_widths(partial):
    widths = _widths_by_hand(partial)
    assert typical_gap(partial) == (widths[(len(widths) - 1) // 2] if widths else 0)


@given(_column_scans(), st.sampled_from(["gaps", "fixed"]))
def test_the_side_follows_the_typical_gap_on_a_column_scan(partial, window):
    side = choose_neighbourhood(partial, window)
    narrow = (window == "gaps" and is_column_scan(partial)
              and 1 <= typical_gap(partial) <= NARROW_GAP)
    assert side == (NARROW_NEIGHBOURHOOD if narrow else DEFAULT_NEIGHBOURHOOD)


def _every(step: int, shape=(10, 31)) -> np.ndarray:
    partial = np.full(shape, nan)
    partial[:, ::step] = 1.0
    return partial


@pytest.mark.parametrize(("step", "gap", "side"), [(2, 1, 3), (3, 2, 3), (6, 5, 3), (7, 6, 5),
                                                   (12, 11, 5)])
def test_hand_built_gaps_give_their_side(step, gap, side):
    assert typical_gap(_every(step)) == gap
    assert choose_neighbourhood(_every(step)) == side
    assert choose_neighbourhood(_every(step), "fixed") == 5


def test_a_wide_gap_outweighs_narrow_ones_by_its_pixels():
    partial = np.full((4, 30), nan)
    partial[:, [0, 2, 4, 6, 29]] = 1.0          # three gaps of 1 pixel, one of 22
    assert typical_gap(partial) == 22 and choose_neighbourhood(partial) == 5


def test_not_a_column_scan_or_no_bounded_gap_gives_five():
    grid = np.full((12, 12), nan)
    grid[::3, :] = 1.0                            # rows measured: every column holds range
    assert choose_neighbourhood(grid) == 5
    edge = np.full((6, 8), nan)
    edge[:, 0] = 1.0                              # one scanned column: the gap is open
    assert typical_gap(edge) == 0 and choose_neighbourhood(edge) == 5


def test_a_bad_window_is_refused_by_name():
    with pytest.raises(ValueError, match="window"):
        choose_neighbourhood(_every(3), "narrow")
    with pytest.raises(ValueError, match="window"):
        refsynth.synthesize(np.zeros((10, 31)), _every(3), readings={"window": "narrow"})


# -- the assembly: synthesize, the references -------------------------------------------------


def _scene(step: int):
    g = np.random.default_rng(3)
    rows, cols = np.mgrid[:12, :19]
    image = np.where(cols > 9, 0.8, 0.2) + 0.1 * g.random((12, 19))
    truth = np.where(cols > 9, 1.5, 3.0 + 0.05 * cols)
    return image, np.where(cols % step == 0, truth, nan)


@pytest.mark.parametrize("method", ["np", "bp"])
def test_synthesize_takes_the_readings_side_unless_given_one(method):
    image, narrow = _scene(3)                     # gaps of 2: 3 × 3
    plain = refsynth.synthesize(image, narrow, method=method, radius=4.0)
    three = refsynth.synthesize(image, narrow, method=method, radius=4.0, neighbourhood=3)
    five = refsynth.synthesize(image, narrow, method=method, radius=4.0, neighbourhood=5)
    fixed = refsynth.synthesize(image, narrow, method=method, radius=4.0,
                                readings={"window": "fixed"})
    paper = refsynth.synthesize(image, narrow, method=method, radius=4.0, readings="paper")
    assert plain.params["neighbourhood"] == 3 and plain.params["window"] == "gaps"
    np.testing.assert_array_equal(plain.range, three.range)
    np.testing.assert_array_equal(fixed.range, five.range)
    assert fixed.params["neighbourhood"] == paper.params["neighbourhood"] == 5
    assert not np.array_equal(plain.range, five.range)   # the side reaches the fill
    _, wide = _scene(9)                           # gaps of 8: 5 × 5
    np.testing.assert_array_equal(
        refsynth.synthesize(image, wide, method=method, radius=4.0).range,
        refsynth.synthesize(image, wide, method=method, radius=4.0, neighbourhood=5).range)


def test_the_references_choose_the_same_side():
    image, narrow = _scene(3)
    fast = refsynth.synthesize(image, narrow, seed=2, radius=3.0)
    slow = ref.np_reference(normalise_intensity(image), narrow, fast.edges,
                            np.random.default_rng(2), radius=3.0)
    np.testing.assert_array_equal(fast.range, slow.range)
    fast_bp = refsynth.synthesize(image, narrow, method="bp", seed=2, radius=3.0, candidates=3,
                                  iterations=4)
    slow_bp = ref.bp_reference(normalise_intensity(image), narrow, fast_bp.edges, radius=3.0,
                               k=3, iterations=4, rng=np.random.default_rng(2))
    np.testing.assert_array_equal(fast_bp.range, slow_bp.range)
    # the literal NP reference takes the side as given, the paper's 5 x 5 by default
    paper = refsynth.synthesize(image, narrow, seed=2, radius=3.0, readings="paper")
    literal = literal_np(normalise_intensity(image), narrow, paper.edges,
                         np.random.default_rng(2), radius=3.0)
    np.testing.assert_array_equal(paper.range, literal.range)
