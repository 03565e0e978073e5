"""Tests for refsynth.synthesis.canny: the Canny detector of §3.2 (σ = 0.8).

Three layers:

* oracle tests against ``skimage.feature.canny`` on real images (the camera
  and the Motorcycle left view, full size);
* hand-computed cases (a step, a ramp, hysteresis components);
* properties checked with hypothesis (invariances and symmetries).

A note on exact ties: the interpolated comparison of non-maximum suppression
uses ``<=``, so two neighbours with *exactly* equal magnitude (a step between
two columns, any mirror-symmetric image) both survive, and a last-bit rounding
difference decides which does when the arithmetic changes (adding a constant,
or the order in which the separable Gaussian visits the axes). The properties
that hold bit-for-bit (left-right flips; power-of-two scaling; transposition
without smoothing) are tested on arbitrary hypothesis arrays, ties included;
the others on images of continuous random values, where ties have probability
zero.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy import ndimage as ndi
from skimage import color, data, feature

from refsynth.synthesis.canny import (
    canny,
    hysteresis,
    non_maximum_suppression,
    sobel_gradients,
    to_grey,
)

SQUARE_3X3 = np.ones((3, 3), dtype=bool)


# --------------------------------------------------------------------------- helpers


def fraction_within_one_pixel(edges: np.ndarray, reference: np.ndarray) -> float:
    """Fraction of the pixels of ``edges`` within 1 px (chessboard) of ``reference``."""
    near = ndi.binary_dilation(reference, structure=SQUARE_3X3)
    return float((edges & near).sum() / max(int(edges.sum()), 1))


def exact_agreement(a: np.ndarray, b: np.ndarray) -> float:
    """|a ∧ b| / |a ∨ b|: the fraction of the edge pixels that both maps mark."""
    return float((a & b).sum() / max(int((a | b).sum()), 1))


# --------------------------------------------------------------------------- real images


@pytest.fixture(scope="module")
def camera() -> np.ndarray:
    """skimage's camera man, 512×512, scaled to float [0, 1]."""
    return data.camera() / 255.0


@pytest.fixture(scope="module")
def motorcycle() -> np.ndarray:
    """The left view of skimage's Middlebury Motorcycle pair, full size, grey in [0, 1]."""
    try:
        left = data.stereo_motorcycle()[0]
    except Exception as error:  # not bundled: fetched (once) by pooch
        pytest.skip(f"skimage.data.stereo_motorcycle() is not available: {error}")
    return to_grey(left)


@pytest.mark.parametrize("sigma", [0.8, 1.0, 2.0])
@pytest.mark.parametrize("name", ["camera", "motorcycle"])
def test_canny_matches_skimage_on_real_images(name, sigma, request):
    image = request.getfixturevalue(name)
    ours = canny(image, sigma=sigma)
    theirs = feature.canny(image, sigma=sigma)
    assert ours.sum() > 1000  # a real edge map, not a vacuous match
    assert fraction_within_one_pixel(ours, theirs) >= 0.95
    assert fraction_within_one_pixel(theirs, ours) >= 0.95
    # We mirror skimage's arithmetic: with scikit-image 0.26 the maps are identical.
    assert exact_agreement(ours, theirs) >= 0.99


@pytest.mark.parametrize(
    ("low", "high", "use_quantiles"),
    [(0.05, 0.15, False), (0.2, 0.5, False), (0.0, 0.0, False), (0.8, 0.95, True)],
)
def test_canny_matches_skimage_thresholds(camera, low, high, use_quantiles):
    kwargs = dict(low_threshold=low, high_threshold=high, use_quantiles=use_quantiles)
    ours = canny(camera, sigma=0.8, **kwargs)
    theirs = feature.canny(camera, sigma=0.8, **kwargs)
    assert fraction_within_one_pixel(ours, theirs) >= 0.95
    assert fraction_within_one_pixel(theirs, ours) >= 0.95
    assert exact_agreement(ours, theirs) >= 0.99


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_canny_matches_skimage_on_integer_images(dtype):
    image = (data.camera().astype(np.float64) / 255.0 * np.iinfo(dtype).max).astype(dtype)
    for thresholds in (
        {},
        {"low_threshold": 0.08 * np.iinfo(dtype).max, "high_threshold": 0.25 * np.iinfo(dtype).max},
    ):
        ours = canny(image, sigma=0.8, **thresholds)
        theirs = feature.canny(image, sigma=0.8, **thresholds)
        assert exact_agreement(ours, theirs) >= 0.99


def test_integer_thresholds_are_in_dtype_units(camera):
    """Integer images and their thresholds are both divided by the dtype's maximum."""
    image = data.camera()
    as_int = canny(image, low_threshold=25.5, high_threshold=51.0)
    as_float = canny(image / 255.0, low_threshold=0.1, high_threshold=0.2)
    np.testing.assert_array_equal(as_int, as_float)
    np.testing.assert_array_equal(canny(image), as_float)  # the defaults: 10 % and 20 %


def test_canny_matches_skimage_with_mask(camera):
    rng = np.random.default_rng(0)
    mask = ndi.binary_opening(rng.random(camera.shape) > 0.3, iterations=2)
    mask[100:300, 150:400] = False
    ours = canny(camera, sigma=0.8, mask=mask)
    theirs = feature.canny(camera, sigma=0.8, mask=mask)
    assert ours.sum() > 100
    assert exact_agreement(ours, theirs) >= 0.99
    # no edge within one pixel of the masked-out region
    assert not (ours & ndi.binary_dilation(~mask, structure=SQUARE_3X3)).any()


def test_masked_out_values_are_ignored(camera):
    mask = np.ones(camera.shape, dtype=bool)
    mask[200:260, 10:500] = False
    poisoned = camera.copy()
    poisoned[~mask] = np.nan
    np.testing.assert_array_equal(canny(poisoned, mask=mask), canny(camera, mask=mask))


def test_to_grey_matches_rgb2gray():
    rgb = data.astronaut()[::4, ::4]
    np.testing.assert_allclose(to_grey(rgb), color.rgb2gray(rgb), rtol=1e-12, atol=1e-15)
    as_float = rgb / 255.0
    np.testing.assert_allclose(to_grey(as_float), color.rgb2gray(as_float), rtol=1e-12)


# --------------------------------------------------------------------------- to_grey


def test_to_grey_grey_float_is_returned_unchanged_as_a_copy():
    image = np.array([[0.25, -1.0], [3.0, 0.5]], dtype=np.float32)
    grey = to_grey(image)
    assert grey.dtype == np.float64
    np.testing.assert_array_equal(grey, image)
    grey[0, 0] = 9.0
    assert image[0, 0] == np.float32(0.25)


def test_to_grey_squeezes_a_single_channel():
    image = np.arange(6, dtype=np.float64).reshape(2, 3, 1)
    np.testing.assert_array_equal(to_grey(image), image[:, :, 0])


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.int32])
def test_to_grey_scales_integers_by_dtype_max(dtype):
    top = np.iinfo(dtype).max
    image = np.array([[0, top], [top // 2, top]], dtype=dtype)
    np.testing.assert_allclose(to_grey(image), image / float(top), rtol=1e-15)
    colour = np.repeat(image[:, :, None], 3, axis=2)
    np.testing.assert_allclose(to_grey(colour), image / float(top), rtol=1e-12)


def test_to_grey_uses_rgb2gray_weights():
    pixels = np.eye(3).reshape(1, 3, 3)  # pure red, green, blue
    np.testing.assert_allclose(to_grey(pixels), [[0.2125, 0.7154, 0.0721]], rtol=1e-15)


def test_to_grey_does_not_modify_input():
    rgb = np.random.default_rng(1).random((4, 5, 3))
    before = rgb.copy()
    to_grey(rgb)
    np.testing.assert_array_equal(rgb, before)


# --------------------------------------------------------------------------- hand-computed


def step_image(rows: int, cols: int, column: int, height: float) -> np.ndarray:
    """0 left of ``column``, ``height / 2`` in it, ``height`` right of it."""
    image = np.zeros((rows, cols))
    image[:, column] = height / 2
    image[:, column + 1 :] = height
    return image


def test_vertical_step_gives_edges_in_the_step_column():
    # σ = 0: gx = 4·height at the step column, 2·height beside it, 0 elsewhere
    # (Sobel's [1, 2, 1] sums to 4 down a column), gy = 0; so NMS keeps exactly
    # the step column and 4 · 0.25 = 1 >= 0.2 passes the high threshold.
    expected = np.zeros((6, 9), dtype=bool)
    expected[1:-1, 4] = True
    for sigma in (0.0, 0.8, 2.0):
        np.testing.assert_array_equal(canny(step_image(6, 9, 4, 0.25), sigma=sigma), expected)


@given(
    rows=st.integers(3, 12),
    cols=st.integers(3, 12),
    data_=st.data(),
    height=st.floats(0.06, 10.0),
)
def test_vertical_step_edges_lie_in_the_step_column(rows, cols, data_, height):
    column = data_.draw(st.integers(1, cols - 2), label="column")
    image = step_image(rows, cols, column, height)
    expected = np.zeros((rows, cols), dtype=bool)
    expected[1:-1, column] = True
    np.testing.assert_array_equal(canny(image, sigma=0.0), expected)
    # and the same for a horizontal step, by transposition
    np.testing.assert_array_equal(canny(image.T, sigma=0.0), expected.T)


def test_sobel_gradients_of_a_ramp_hand_values():
    rows, cols = np.mgrid[0:5, 0:6].astype(np.float64)
    gy, gx = sobel_gradients(2.0 * rows - 0.5 * cols + 7.0)
    # unnormalised Sobel: 8 × the slope per pixel
    np.testing.assert_array_equal(gy[1:-1, 1:-1], 16.0)
    np.testing.assert_array_equal(gx[1:-1, 1:-1], -4.0)


@given(
    shape=st.tuples(st.integers(3, 10), st.integers(3, 10)),
    slope_row=st.floats(-100, 100),
    slope_col=st.floats(-100, 100),
    offset=st.floats(-100, 100),
)
def test_sobel_gradients_of_a_ramp_are_eight_times_its_slope(shape, slope_row, slope_col, offset):
    rows, cols = np.indices(shape, dtype=np.float64)
    gy, gx = sobel_gradients(slope_row * rows + slope_col * cols + offset)
    assert gy.shape == gx.shape == shape
    atol = 1e-12 * (abs(slope_row) + abs(slope_col) + abs(offset) + 1) * 100
    np.testing.assert_allclose(gy[1:-1, 1:-1], 8 * slope_row, rtol=1e-13, atol=atol)
    np.testing.assert_allclose(gx[1:-1, 1:-1], 8 * slope_col, rtol=1e-13, atol=atol)


def test_hysteresis_keeps_weak_components_touching_a_strong_pixel():
    magnitude = np.array(
        [
            [0.0, 0.5, 0.0, 0.0, 0.0, 0.3, 0.0],
            [0.0, 0.0, 0.3, 0.0, 0.0, 0.3, 0.0],  # (0,1)-(1,2)-(2,3): diagonal link
            [0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.2, 0.3, 0.05, 0.9, 0.0, 0.0, 0.0],  # 0.05 < low breaks the run
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.6],  # isolated strong pixel
        ]
    )
    expected = np.array(
        [
            [0, 1, 0, 0, 0, 0, 0],
            [0, 0, 1, 0, 0, 0, 0],
            [0, 0, 0, 1, 0, 0, 0],
            [0, 0, 0, 0, 0, 0, 0],
            [0, 0, 0, 1, 0, 0, 0],
            [0, 0, 0, 0, 0, 0, 1],
        ],
        dtype=bool,
    )
    result = hysteresis(magnitude, 0.1, 0.5)
    assert result.dtype == np.bool_
    np.testing.assert_array_equal(result, expected)
    # thresholds are inclusive: a component whose top is exactly `high` is kept
    np.testing.assert_array_equal(hysteresis(magnitude, 0.3, 0.3), magnitude >= 0.3)
    # zero is never an edge, even with low = 0
    np.testing.assert_array_equal(hysteresis(magnitude, 0.0, 0.0), magnitude > 0)


def small_magnitudes():
    """Small non-negative arrays, many zeros, a few distinct levels (readable shrinks)."""
    return hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, 8), st.integers(1, 8)),
        elements=st.sampled_from([0.0, 0.0, 0.1, 0.3, 0.6, 1.0]),
    )


@given(
    magnitude=small_magnitudes(),
    low=st.sampled_from([0.0, 0.1, 0.3]),
    extra=st.sampled_from([0.0, 0.3, 0.7]),
)
def test_hysteresis_is_the_union_of_components_with_a_strong_pixel(magnitude, low, extra):
    high = low + extra
    result = hysteresis(magnitude, low, high)
    weak = (magnitude > 0) & (magnitude >= low)
    labels, count = ndi.label(weak, structure=SQUARE_3X3)
    expected = np.zeros_like(weak)
    for label in range(1, count + 1):
        component = labels == label
        if (magnitude[component] >= high).any():
            expected |= component
    np.testing.assert_array_equal(result, expected)


def test_non_maximum_suppression_keeps_ridge_of_a_roof():
    # A roof along column 3: the magnitude falls off on both sides, the
    # gradient points across the columns. Only the ridge survives, and not on
    # the border rows.
    magnitude = np.tile(np.array([0.1, 0.2, 0.5, 1.0, 0.5, 0.2, 0.1]), (5, 1))
    gx = np.ones_like(magnitude)
    gy = np.zeros_like(magnitude)
    expected = np.zeros_like(magnitude)
    expected[1:-1, 3] = 1.0
    np.testing.assert_array_equal(non_maximum_suppression(magnitude, gy, gx), expected)
    # With the gradient along the ridge instead, every interior pixel is a
    # maximum along its (row) direction.
    np.testing.assert_array_equal(
        non_maximum_suppression(magnitude, gx, gy)[1:-1, 1:-1], magnitude[1:-1, 1:-1]
    )
    # A mask removes pixels.
    mask = np.ones(magnitude.shape, dtype=bool)
    mask[2, 3] = False
    expected[2, 3] = 0.0
    np.testing.assert_array_equal(non_maximum_suppression(magnitude, gy, gx, mask=mask), expected)


def test_non_maximum_suppression_interpolates_along_the_diagonal():
    # gradient at 45°: only the diagonal neighbours count (w = 1).
    magnitude = np.array([[0.0, 9.0, 0.0], [9.0, 1.0, 9.0], [0.0, 9.0, 0.0]])
    ones = np.ones_like(magnitude)
    assert non_maximum_suppression(magnitude, ones, ones)[1, 1] == 1.0
    assert non_maximum_suppression(magnitude, ones, -ones)[1, 1] == 1.0
    # gradient along the rows: the axial neighbours (9) beat it.
    assert non_maximum_suppression(magnitude, ones, 0 * ones)[1, 1] == 0.0


# --------------------------------------------------------------------------- properties


@st.composite
def small_images(draw, min_side: int = 1, max_side: int = 12):
    """Arbitrary small float images in [0, 1], ties and constant patches included."""
    shape = draw(st.tuples(st.integers(min_side, max_side), st.integers(min_side, max_side)))
    levels = st.sampled_from([0.0, 0.25, 0.5, 1.0]) | st.floats(0.0, 1.0)
    return draw(hnp.arrays(np.float64, shape, elements=levels))


@st.composite
def noisy_images(draw):
    """Continuous random images (no exact ties) with a step for structure."""
    rows = draw(st.integers(5, 24))
    cols = draw(st.integers(5, 24))
    seed = draw(st.integers(0, 2**32 - 1))
    noise = draw(st.sampled_from([0.1, 0.3, 1.0]))
    rng = np.random.default_rng(seed)
    image = noise * rng.random((rows, cols))
    image[:, cols // 2 :] += draw(st.floats(0.0, 1.0))
    return image


sigmas = st.sampled_from([0.0, 0.5, 0.8, 1.0, 2.0])


@given(
    shape=st.tuples(st.integers(1, 15), st.integers(1, 15)),
    value=st.floats(-1e6, 1e6),
    sigma=sigmas,
)
def test_constant_image_has_no_edges(shape, value, sigma):
    assert not canny(np.full(shape, value), sigma=sigma).any()


@given(image=small_images(), sigma=sigmas)
@example(image=np.ones((1, 1)), sigma=0.8)
@example(image=np.zeros((0, 4)), sigma=0.8)
def test_output_is_bool_same_shape_and_border_free(image, sigma):
    before = image.copy()
    edges = canny(image, sigma=sigma)
    assert edges.dtype == np.bool_
    assert edges.shape == image.shape
    if image.size:
        assert not edges[[0, -1], :].any()
        assert not edges[:, [0, -1]].any()
    np.testing.assert_array_equal(image, before)  # input untouched


@given(image=noisy_images(), shift=st.floats(-10.0, 10.0), sigma=sigmas)
def test_edges_invariant_to_adding_a_constant(image, shift, sigma):
    np.testing.assert_array_equal(canny(image + shift, sigma=sigma), canny(image, sigma=sigma))


@pytest.mark.parametrize("offset", [-3.7, 0.25, 1.0 / 3.0, 100.0])
def test_an_offset_leaves_a_real_images_edges_unchanged_bit_for_bit(camera, offset):
    """The numeric contract: Canny runs on its input brought to the 2**-24 grid of its span,
    so an offset changes nothing even where the map hinges on exact ties (a real image
    has many: equal magnitudes, flat patches)."""
    for sigma in (0.8, 2.0):
        np.testing.assert_array_equal(canny(camera + offset, sigma=sigma),
                                      canny(camera, sigma=sigma))


def test_the_same_image_in_any_integer_dtype_gives_the_same_edges():
    image = data.camera()
    expected = canny(image / 255.0)
    np.testing.assert_array_equal(canny(image), expected)
    np.testing.assert_array_equal(canny(image.astype(np.uint16) * 257), expected)
    np.testing.assert_array_equal(canny(image.astype(np.float32) / np.float32(255)), expected)


def test_the_gaussian_kernel_is_portable_and_scipys_at_the_papers_sigma():
    """From portable_exp and a left-to-right sum; at σ = 0.8 (and 0.5) bit for bit the
    kernel of scipy.ndimage.gaussian_filter, which the smoothing then reproduces too."""
    from scipy.ndimage._filters import _gaussian_kernel1d

    from refsynth.synthesis.canny import _gaussian_kernel, _smooth

    for sigma in (0.5, 0.8):
        radius = int(4.0 * sigma + 0.5)
        np.testing.assert_array_equal(_gaussian_kernel(sigma), _gaussian_kernel1d(sigma, 0, radius))
    image = np.random.default_rng(3).random((30, 41))
    np.testing.assert_array_equal(
        _smooth(image, 0.8), ndi.gaussian_filter(image, 0.8, mode="constant", truncate=4.0))
    for sigma in (1.0, 2.0, 3.3):
        np.testing.assert_allclose(
            _smooth(image, sigma),
            ndi.gaussian_filter(image, sigma, mode="constant", truncate=4.0), rtol=1e-14)


@given(image=small_images(min_side=3), power=st.integers(-10, 10), sigma=sigmas)
def test_edges_invariant_to_power_of_two_scaling_with_thresholds(image, power, sigma):
    # multiplying by 2**power is exact in floating point, ties included
    k = 2.0**power
    expected = canny(image, sigma=sigma, low_threshold=0.1, high_threshold=0.2)
    scaled = canny(k * image, sigma=sigma, low_threshold=0.1 * k, high_threshold=0.2 * k)
    np.testing.assert_array_equal(scaled, expected)


@given(image=noisy_images(), k=st.floats(0.01, 100.0), sigma=sigmas)
def test_edges_invariant_to_scaling_with_thresholds(image, k, sigma):
    expected = canny(image, sigma=sigma, low_threshold=0.1, high_threshold=0.2)
    scaled = canny(k * image, sigma=sigma, low_threshold=0.1 * k, high_threshold=0.2 * k)
    np.testing.assert_array_equal(scaled, expected)
    # quantile thresholds need no rescaling
    np.testing.assert_array_equal(
        canny(k * image, sigma=sigma, low_threshold=0.7, high_threshold=0.9, use_quantiles=True),
        canny(image, sigma=sigma, low_threshold=0.7, high_threshold=0.9, use_quantiles=True),
    )


@given(image=small_images(), sigma=sigmas)
def test_flipping_left_right_flips_the_edges(image, sigma):
    # Gaussian, Sobel and NMS are mirror-symmetric in floating point: exact, ties included.
    np.testing.assert_array_equal(
        canny(image[:, ::-1], sigma=sigma), canny(image, sigma=sigma)[:, ::-1]
    )
    np.testing.assert_array_equal(
        canny(image[::-1, :], sigma=sigma), canny(image, sigma=sigma)[::-1, :]
    )


@given(image=small_images())
def test_transposing_the_image_transposes_the_edges_without_smoothing(image):
    np.testing.assert_array_equal(canny(image.T, sigma=0.0), canny(image, sigma=0.0).T)


@given(image=noisy_images(), sigma=sigmas)
def test_transposing_the_image_transposes_the_edges(image, sigma):
    np.testing.assert_array_equal(canny(image.T, sigma=sigma), canny(image, sigma=sigma).T)


@settings(max_examples=20)
@given(image=noisy_images(), sigma=sigmas)
def test_canny_matches_skimage_on_noise(image, sigma):
    np.testing.assert_array_equal(canny(image, sigma=sigma), feature.canny(image, sigma=sigma))


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"image": np.zeros((4, 4, 3))}, ValueError, r"`image` must be a 2-D array.*\(4, 4, 3\)"),
        ({"image": np.zeros(5)}, ValueError, r"`image` must be a 2-D array"),
        ({"image": np.array([["a", "b"]])}, TypeError, r"`image` must be a real numeric"),
        ({"image": np.ones((3, 3), dtype=complex)}, TypeError, r"`image` must be a real numeric"),
        ({"image": np.full((3, 3), np.nan)}, ValueError, r"`image` must be finite"),
        ({"image": np.full((3, 3), np.inf)}, ValueError, r"`image` must be finite"),
        ({"sigma": -0.1}, ValueError, r"`sigma` must be >= 0"),
        ({"sigma": np.inf}, ValueError, r"`sigma` must be finite"),
        ({"sigma": np.nan}, ValueError, r"`sigma` must be finite"),
        ({"sigma": "0.8"}, TypeError, r"`sigma` must be a real number"),
        ({"sigma": True}, TypeError, r"`sigma` must be a real number"),
        ({"low_threshold": np.nan}, ValueError, r"`low_threshold` must be finite"),
        ({"high_threshold": np.inf}, ValueError, r"`high_threshold` must be finite"),
        ({"low_threshold": "low"}, TypeError, r"`low_threshold` must be a real number"),
        ({"high_threshold": [0.2]}, TypeError, r"`high_threshold` must be a real number"),
        (
            {"low_threshold": 0.3, "high_threshold": 0.2},
            ValueError,
            r"`low_threshold` \(0.3\) must not exceed `high_threshold` \(0.2\)",
        ),
        ({"low_threshold": 0.3}, ValueError, r"`low_threshold` .* must not exceed"),
        (
            {"low_threshold": -0.1, "use_quantiles": True},
            ValueError,
            r"`low_threshold` must be a quantile in \[0, 1\]",
        ),
        (
            {"high_threshold": 1.5, "use_quantiles": True},
            ValueError,
            r"`high_threshold` must be a quantile in \[0, 1\]",
        ),
        ({"use_quantiles": 1}, TypeError, r"`use_quantiles` must be a bool"),
        ({"mask": np.ones((4, 4))}, TypeError, r"`mask` must be a boolean array"),
        ({"mask": np.ones((4, 5), dtype=bool)}, ValueError, r"`mask` must have shape \(4, 4\)"),
    ],
)
def test_canny_validation(kwargs, error, match):
    kwargs = {"image": np.zeros((4, 4)), **kwargs}
    with pytest.raises(error, match=match):
        canny(**kwargs)


def test_canny_low_above_high_is_checked_after_dtype_scaling():
    with pytest.raises(ValueError, match=r"`low_threshold` .* must not exceed"):
        canny(np.zeros((4, 4), dtype=np.uint8), low_threshold=60, high_threshold=50)


def test_canny_options_are_keyword_only():
    with pytest.raises(TypeError):
        canny(np.zeros((4, 4)), 0.8)


@pytest.mark.parametrize(
    ("image", "error", "match"),
    [
        (np.zeros((4, 4, 4)), ValueError, r"`image` must have shape \(H, W\), \(H, W, 1\)"),
        (np.zeros((4, 4, 2)), ValueError, r"got shape \(4, 4, 2\)"),
        (np.zeros(4), ValueError, r"`image` must have shape"),
        (np.array([[object()]]), TypeError, r"`image` must be a real numeric array"),
    ],
)
def test_to_grey_validation(image, error, match):
    with pytest.raises(error, match=match):
        to_grey(image)


@pytest.mark.parametrize(
    ("image", "error", "match"),
    [
        (np.zeros((3, 3, 3)), ValueError, r"`image` must be a 2-D array"),
        (np.array([["x"]]), TypeError, r"`image` must be a real numeric array"),
    ],
)
def test_sobel_gradients_validation(image, error, match):
    with pytest.raises(error, match=match):
        sobel_gradients(image)


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        ((np.zeros(3), np.zeros(3), np.zeros(3)), {}, ValueError, r"`magnitude` must be a 2-D"),
        (
            (np.zeros((3, 3)), np.zeros((3, 3, 1)), np.zeros((3, 3))),
            {},
            ValueError,
            r"`gy` must be a 2-D",
        ),
        (
            (np.zeros((3, 3)), np.zeros((3, 3)), np.array([["x"]])),
            {},
            TypeError,
            r"`gx` must be a real numeric",
        ),
        (
            (np.zeros((3, 3)), np.zeros((3, 4)), np.zeros((3, 3))),
            {},
            ValueError,
            r"`gy` must have the shape of `magnitude` \(3, 3\)",
        ),
        (
            (np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((4, 3))),
            {},
            ValueError,
            r"`gx` must have the shape of `magnitude`",
        ),
        (
            (np.zeros((3, 3)),) * 3,
            {"mask": np.ones((3, 3), dtype=int)},
            TypeError,
            r"`mask` must be a boolean array",
        ),
        (
            (np.zeros((3, 3)),) * 3,
            {"mask": np.ones((2, 3), dtype=bool)},
            ValueError,
            r"`mask` must have shape \(3, 3\)",
        ),
    ],
)
def test_non_maximum_suppression_validation(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        non_maximum_suppression(*args, **kwargs)


@pytest.mark.parametrize(
    ("args", "error", "match"),
    [
        ((np.zeros(3), 0.1, 0.2), ValueError, r"`magnitude_nms` must be a 2-D"),
        ((np.array([["x"]]), 0.1, 0.2), TypeError, r"`magnitude_nms` must be a real numeric"),
        ((np.zeros((3, 3)), np.nan, 0.2), ValueError, r"`low` must be finite"),
        ((np.zeros((3, 3)), 0.1, np.inf), ValueError, r"`high` must be finite"),
        ((np.zeros((3, 3)), None, 0.2), TypeError, r"`low` must be a real number"),
        ((np.zeros((3, 3)), 0.1, "0.2"), TypeError, r"`high` must be a real number"),
        ((np.zeros((3, 3)), 0.3, 0.2), ValueError, r"`low` \(0.3\) must not exceed `high`"),
    ],
)
def test_hysteresis_validation(args, error, match):
    with pytest.raises(error, match=match):
        hysteresis(*args)


def test_inputs_are_not_modified(camera):
    image = camera[:64, :64].copy()
    mask = np.ones(image.shape, dtype=bool)
    mask[10:20, 10:20] = False
    image_before, mask_before = image.copy(), mask.copy()
    canny(image, mask=mask)
    gy, gx = sobel_gradients(image)
    magnitude = np.hypot(gy, gx)
    copies = [a.copy() for a in (magnitude, gy, gx)]
    thinned = non_maximum_suppression(magnitude, gy, gx, mask=mask)
    thinned_before = thinned.copy()
    hysteresis(thinned, 0.1, 0.2)
    np.testing.assert_array_equal(image, image_before)
    np.testing.assert_array_equal(mask, mask_before)
    for array, before in zip((magnitude, gy, gx), copies, strict=True):
        np.testing.assert_array_equal(array, before)
    np.testing.assert_array_equal(thinned, thinned_before)


@pytest.mark.parametrize("colour", [False, True])
def test_synthesis_edges_are_synthesizes_own(colour):
    """The edges synthesize detects: Canny on the quantised grey level, an offset and a
    scale of the intensity changing nothing."""
    import refsynth
    from refsynth.synthesis.api import synthesis_edges, validate_inputs

    g = np.random.default_rng(3)
    image = g.integers(0, 256, (20, 24, 3) if colour else (20, 24)).astype(np.uint8)
    partial = np.where(g.random((20, 24)) < 0.4, 1.0 + g.random((20, 24)), np.nan)
    partial[0, 0] = 2.0
    prepared = validate_inputs(image, partial)[0]
    edges = synthesis_edges(prepared, sigma=1.2)
    assert edges.any() and not edges.all()
    assert np.array_equal(edges, refsynth.synthesize(image, partial, canny_sigma=1.2).edges)
    assert np.array_equal(edges, synthesis_edges(prepared * 0.25 + 3.0, sigma=1.2))
    levels = refsynth.numeric.quantise_grey(refsynth.numeric.quantise_intensity(prepared))
    assert np.array_equal(edges, canny(levels * 2.0**-16, sigma=1.2))
