"""The comparison fills."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from strategies import small_scene

from refsynth.evaluation.baselines import (
    BASELINES,
    colorization_fill,
    harmonic_fill,
    joint_bilateral_fill,
    nearest_fill,
)


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


# ----------------------------------------------------------------------------- colorization


def _toolbox_colorization(grey, depth, known, alpha=1.0):
    """``fill_depth_colorization.m`` of the NYU Depth V2 toolbox, transcribed loop for loop.

    The gold for :func:`colorization_fill`: per pixel, the 3×3 window's
    variance, the toolbox's two lower bounds on ``csig``, the normalised
    weights, the unit diagonal, then ``(A + G) \\ (alpha K d)``, dense.
    """
    H, W = grey.shape
    n = H * W
    A = np.zeros((n, n))
    for i in range(H):
        for j in range(W):
            me = i * W + j
            nbrs, gvals = [], []
            for ii in range(max(0, i - 1), min(i + 2, H)):
                for jj in range(max(0, j - 1), min(j + 2, W)):
                    if (ii, jj) != (i, j):
                        nbrs.append(ii * W + jj)
                        gvals.append(grey[ii, jj])
            cur = grey[i, j]
            window = np.array([*gvals, cur])
            c_var = np.mean((window - np.mean(window)) ** 2)
            csig = c_var * 0.6
            mgv = np.min((np.array(gvals) - cur) ** 2)
            if csig < -mgv / np.log(0.01):
                csig = -mgv / np.log(0.01)
            if csig < 0.000002:
                csig = 0.000002
            w = np.exp(-((np.array(gvals) - cur) ** 2) / csig)
            w = w / w.sum()
            A[me, nbrs] = -w
            A[me, me] = 1.0
    G = np.diag(alpha * known.ravel().astype(float))
    return np.linalg.solve(A + G, alpha * known.ravel() * np.where(known, depth, 0).ravel())


@pytest.mark.parametrize("alpha", [1.0, 0.25])
def test_colorization_matches_the_toolbox_loop(alpha):
    rng = np.random.default_rng(4)
    grey = rng.random((5, 6))
    grey[:, 3:] += 2.0  # a strong edge, and values beyond 1 for the variance rule
    grey /= grey.max()
    depth = 1.0 + rng.random((5, 6))
    known = rng.random((5, 6)) < 0.4
    known[0, 0] = True
    gold = _toolbox_colorization(grey, depth, known, alpha).reshape(5, 6)
    out = colorization_fill(grey, np.where(known, depth, np.nan), alpha=alpha)
    np.testing.assert_allclose(out[~known], gold[~known], rtol=1e-9)
    np.testing.assert_array_equal(out[known], depth[known])


def test_colorization_uses_matlab_rgb2gray_for_colour():
    rng = np.random.default_rng(5)
    colour = rng.random((6, 7, 3))
    partial = np.where(rng.random((6, 7)) < 0.4, rng.random((6, 7)), np.nan)
    partial[0, 0] = 0.5
    grey = colour @ np.array([0.2989, 0.5870, 0.1140])
    np.testing.assert_allclose(colorization_fill(colour, partial),
                               colorization_fill(grey, partial), rtol=1e-12)


def _edge_scene(width=12, height=6, edge=6):
    """Left half dark at range 2, right half bright at range 5; known columns at both ends."""
    image = np.where(np.arange(width) < edge, 0.2, 0.8)[None, :].repeat(height, 0)
    truth = np.where(np.arange(width) < edge, 2.0, 5.0)[None, :].repeat(height, 0)
    known = np.zeros((height, width), dtype=bool)
    known[:, [0, width - 1]] = True
    return image, truth, known


def test_colorization_respects_an_intensity_edge():
    """The range steps where the intensity does, instead of ramping as the harmonic fill does."""
    image, truth, known = _edge_scene()
    partial = np.where(known, truth, np.nan)
    out = colorization_fill(image, partial)
    step = 3.0
    assert np.max(np.abs(out - truth)) < 0.01 * step
    ramp = harmonic_fill(image, partial)
    assert np.max(np.abs(ramp - truth)) > 0.3 * step  # what ignoring the intensity costs


def test_colorization_validates_alpha():
    image, truth, known = _edge_scene()
    with pytest.raises(ValueError, match="`alpha`"):
        colorization_fill(image, np.where(known, truth, np.nan), alpha=0.0)
    with pytest.raises(TypeError, match="`alpha`"):
        colorization_fill(image, np.where(known, truth, np.nan), alpha="1")


# ----------------------------------------------------------------------------- joint bilateral


def test_joint_bilateral_with_a_tiny_intensity_sigma_never_blends_across_an_edge():
    image, truth, known = _edge_scene()
    out = joint_bilateral_fill(image, np.where(known, truth, np.nan), sigma_intensity=1e-6)
    np.testing.assert_array_equal(out, truth)


def test_joint_bilateral_blends_across_the_edge_when_intensity_is_ignored():
    image, truth, known = _edge_scene()
    out = joint_bilateral_fill(image, np.where(known, truth, np.nan), sigma_intensity=1e6,
                               radius=11)
    assert 2.0 < out[0, 5] < 5.0 and 2.0 < out[0, 6] < 5.0


def test_joint_bilateral_is_the_normalised_convolution_at_one_pixel():
    rng = np.random.default_rng(6)
    image = rng.random((7, 8, 3))
    truth = 1.0 + rng.random((7, 8))
    known = rng.random((7, 8)) < 0.5
    known[3, 4] = False
    s_s, s_i, radius = 1.7, 0.3, 2
    out = joint_bilateral_fill(image, np.where(known, truth, np.nan), sigma_spatial=s_s,
                               sigma_intensity=s_i, radius=radius)
    num = den = 0.0
    for r in range(1, 6):
        for c in range(2, 7):
            if known[r, c]:
                w = np.exp(-((r - 3) ** 2 + (c - 4) ** 2) / (2 * s_s**2)) * np.exp(
                    -np.mean((image[3, 4] - image[r, c]) ** 2) / (2 * s_i**2))
                num, den = num + w * truth[r, c], den + w
    assert out[3, 4] == pytest.approx(num / den, rel=1e-12)


def test_joint_bilateral_falls_back_to_nearest_where_no_weight_reaches():
    """A pixel unlike every known pixel in its window (σ_i → 0) takes the nearest value."""
    image = np.zeros((5, 9))
    image[2, 4] = 1.0
    truth = np.tile(np.arange(9.0), (5, 1))
    known = np.zeros((5, 9), dtype=bool)
    known[:, [0, 8]] = True
    partial = np.where(known, truth, np.nan)
    out = joint_bilateral_fill(image, partial, sigma_intensity=1e-6, radius=4)
    assert out[2, 4] == nearest_fill(image, partial)[2, 4]


def test_joint_bilateral_default_window_reaches_a_known_pixel_from_every_gap():
    known = np.zeros((4, 40), dtype=bool)
    known[:, 0] = True  # the widest gap: 39 columns
    partial = np.where(known, 3.0, np.nan)
    out = joint_bilateral_fill(np.zeros((4, 40)), partial, sigma_intensity=1e-6)
    np.testing.assert_array_equal(out, 3.0)


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"sigma_spatial": 0.0}, ValueError, "`sigma_spatial`"),
    ({"sigma_intensity": -1.0}, ValueError, "`sigma_intensity`"),
    ({"sigma_intensity": float("nan")}, ValueError, "`sigma_intensity`"),
    ({"radius": 0}, ValueError, "`radius`"),
    ({"radius": 2.5}, TypeError, "`radius`"),
])
def test_joint_bilateral_validates_its_parameters(kwargs, error, match):
    image, truth, known = _edge_scene()
    with pytest.raises(error, match=match):
        joint_bilateral_fill(image, np.where(known, truth, np.nan), **kwargs)
