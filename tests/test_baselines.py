"""The comparison fills."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from strategies import small_scene

from refsynth.baselines import BASELINES, harmonic_fill, nearest_fill


@given(small_scene())
def test_nearest_fill_copies_from_a_nearest_known_pixel(scene):
    image, truth, known = scene
    out = nearest_fill(image, np.where(known, truth, np.nan))
    np.testing.assert_array_equal(out[known], truth[known])
    rows, cols = np.nonzero(known)
    for r, c in np.argwhere(~known)[:10]:
        d = np.hypot(rows - r, cols - c)
        nearest = truth[rows[d == d.min()], cols[d == d.min()]]
        assert out[r, c] in nearest


def test_nearest_fill_validates_like_synthesize():
    with pytest.raises(ValueError, match="no known range"):
        nearest_fill(np.zeros((4, 4)), np.full((4, 4), np.nan))


@given(small_scene(), st.floats(0.5, 10.0), st.sampled_from(sorted(BASELINES)))
def test_every_baseline_recovers_a_constant_range_and_keeps_measurements(scene, level, name):
    image, truth, known = scene
    out = BASELINES[name](image, np.where(known, level, np.nan))
    np.testing.assert_allclose(out, level, rtol=1e-9)
    out = BASELINES[name](image, np.where(known, truth, np.nan))
    np.testing.assert_array_equal(out[known], truth[known])
    assert np.all(np.isfinite(out))


@pytest.mark.parametrize("name", ["linear", "harmonic"])
def test_interpolating_baselines_are_exact_on_a_ramp(name):
    """Range linear in x, known columns at both ends and in between."""
    cols = np.arange(30, dtype=float)
    truth = np.tile(2.0 + 0.1 * cols, (12, 1))
    known = np.zeros((12, 30), dtype=bool)
    known[:, [0, 7, 18, 29]] = True
    out = BASELINES[name](np.zeros((12, 30)), np.where(known, truth, np.nan))
    np.testing.assert_allclose(out, truth, rtol=1e-9)


def test_harmonic_fill_is_the_mean_of_its_neighbours():
    rng = np.random.default_rng(0)
    truth = rng.random((10, 10))
    known = rng.random((10, 10)) < 0.3
    known[0, 0] = True
    out = harmonic_fill(np.zeros((10, 10)), np.where(known, truth, np.nan))
    padded = np.pad(out, 1, mode="edge")
    for r, c in np.argwhere(~known):
        nbrs = [(r, c + 1), (r + 2, c + 1), (r + 1, c), (r + 1, c + 2)]
        inside = [(a, b) for a, b in nbrs if 1 <= a <= 10 and 1 <= b <= 10]
        assert out[r, c] == pytest.approx(np.mean([padded[a, b] for a, b in inside]), abs=1e-9)
