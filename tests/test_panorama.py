"""Tests of the cylindrical panorama mosaic (Appendix A.1, Eqs. 14–18) in refsynth.registration."""

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy import ndimage as ndi

from refsynth.registration import (
    align_translation,
    blend,
    cylinder_coordinates,
    cylindrical_unwarp,
    cylindrical_warp,
    gauss_newton_step,
    hat_weight,
    hat_weights,
    mosaic,
    perspective_coordinates,
    project_to_cylinder,
)
from refsynth.scenes import render_views, rig_room, texture_views

EPS = np.finfo(np.float64).eps


def smooth_scene(height=80, width=160, phase=0.0):
    """A smooth, textured function sampled on a grid: ``scene(y, x)`` and the sampler."""

    def sample(y, x):
        return (
            np.sin(0.21 * x + phase) * np.cos(0.17 * y)
            + 0.5 * np.cos(0.09 * x - 0.13 * y + 1.0)
            + 0.3 * np.sin(0.05 * y + 0.3)
        )

    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    return sample(y, x), sample


def focal_lengths():
    """Focal lengths from wide to long (pixels)."""
    return st.floats(50.0, 2000.0)


# ----------------------------------------------------------------------------- Eq. 14


@settings(deadline=None)
@given(
    st.floats(-500, 500), st.floats(-500, 500), focal_lengths(),
)
@example(0.0, 0.0, 300.0)
def test_eq14_cylinder_coordinates_round_trip(x, y, focal):
    x_c, y_c = cylinder_coordinates(x, y, focal)
    back_x, back_y = perspective_coordinates(x_c, y_c, focal)
    scale = max(1.0, abs(x), abs(y), focal)
    assert abs(back_x - x) <= 64 * EPS * scale * (1 + (x / focal) ** 2)
    assert abs(back_y - y) <= 64 * EPS * scale * (1 + (x / focal) ** 2)


@settings(deadline=None)
@given(st.floats(-3.0, 3.0), st.floats(-2.0, 2.0), st.floats(0.5, 20.0), focal_lengths())
def test_eq14_projects_points_and_rays_alike(psi, height, distance, focal):
    """ψ and v depend on the ray only; a pixel (x, y, f) lands where cylinder_coordinates says."""
    point = np.array([distance * np.sin(psi), height, distance * np.cos(psi)])
    got_psi, got_v = project_to_cylinder(point, focal)
    assert np.isclose(got_psi, psi, atol=1e-12)
    assert np.isclose(got_v, focal * height / distance, rtol=1e-12)
    again = project_to_cylinder(3.7 * point, focal)
    assert np.allclose(again, (got_psi, got_v), rtol=1e-12, atol=1e-12)
    x, y = focal * np.tan(psi / 3), height * 40
    x_c, y_c = cylinder_coordinates(x, y, focal)
    psi_p, v_p = project_to_cylinder(np.array([x, y, focal]), focal)
    assert np.isclose(x_c, focal * psi_p, rtol=1e-12, atol=1e-9)
    assert np.isclose(y_c, v_p, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("order, tolerance", [(1, 0.03), (3, 2e-3)])
def test_eq14_warp_round_trips_with_its_inverse(order, tolerance):
    """Only interpolation error is left (bilinear smooths twice; a cubic spline barely)."""
    image, _ = smooth_scene(60, 90)
    back = cylindrical_unwarp(cylindrical_warp(image, 120.0, order=order), 120.0, order=order)
    assert np.isfinite(back).mean() > 0.85
    # the spline fills the pixels without data by their nearest neighbour: stay 3 px clear
    interior = ndi.binary_erosion(np.isfinite(back), iterations=3)
    assert np.max(np.abs(back - image)[interior]) < tolerance


def test_eq14_warp_is_the_identity_for_a_very_long_focal_length():
    image = np.random.default_rng(0).random((7, 9, 3))
    assert np.allclose(cylindrical_warp(image, 1e9), image, atol=1e-9)


def test_eq14_warp_samples_the_perspective_image_where_eq14_says():
    """A pixel of the cylindrical image holds the scene at its inverse Eq. 14 position."""
    height, width, focal = 40, 70, 60.0
    _, sample = smooth_scene()
    rows, cols = np.indices((height, width), dtype=np.float64)
    perspective = sample(rows, cols)
    cylinder = cylindrical_warp(perspective, focal, order=3)
    x, y = perspective_coordinates(cols - (width - 1) / 2, rows - (height - 1) / 2, focal)
    expected = sample(y + (height - 1) / 2, x + (width - 1) / 2)
    inside = np.isfinite(cylinder)
    inside &= (np.abs(x) < width / 2 - 3) & (np.abs(y) < height / 2 - 3)
    assert np.max(np.abs(cylinder - expected)[inside]) < 2e-3


def test_eq14_warp_keeps_the_input_and_marks_outside_as_nan():
    image = np.random.default_rng(1).random((20, 30))
    copy = image.copy()
    out = cylindrical_warp(image, 15.0)
    assert np.array_equal(image, copy)
    assert np.isnan(out[:, 0]).all() and np.isfinite(out[10, 15])


def test_eq14_warp_scales_integer_images():
    image = np.full((6, 6), 255, dtype=np.uint8)
    assert np.allclose(cylindrical_warp(image, 1e6), 1.0)


# ----------------------------------------------------------------------------- Eqs. 15–17


@settings(deadline=None)
@given(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3))
@example(0.0, 0.0)
@example(0.3, -0.3)
@example(0.03125, 0.0)
def test_eq17_step_recovers_a_small_subpixel_shift_to_first_order(t_x, t_y):
    """δt = t + O(|t|²), up to the central differences' 1 % underestimate of the gradient.

    Starting at a whole-pixel translation, ``I1(x'_i)`` needs no interpolation;
    what is left is the linearisation of Eq. 16 (second order in t) and the
    central-difference gradient (``sin(ωh)/(ωh)``, 0.7 % for the image's
    highest frequency, first order in t).
    """
    reference, sample = smooth_scene()
    y, x = np.mgrid[0:60, 0:120].astype(np.float64) + 10
    moving = sample(y + t_y, x + t_x)  # moving[y, x] = reference[y + t_y, x + t_x]
    delta = gauss_newton_step(reference, moving, (10.0, 10.0))
    size = np.hypot(t_x, t_y)
    assert np.hypot(*(delta - (t_x, t_y))) <= 0.01 * size + 0.1 * size**2 + 1e-9


@settings(deadline=None)
@given(st.floats(-6.0, 6.0), st.floats(-4.0, 4.0))
@example(6.0, -4.0)
def test_eq17_iteration_converges_on_larger_shifts(t_x, t_y):
    reference, sample = smooth_scene()
    y, x = np.mgrid[0:60, 0:100].astype(np.float64)
    moving = sample(y + 10 + t_y, x + 40 + t_x)
    found = align_translation(reference, moving, (40.0, 10.0), search=(0, 0), order=3)
    assert np.allclose(found, (40 + t_x, 10 + t_y), atol=1e-3)
    # bilinear interpolation of I1 biases the fixed point by a few thousandths of a pixel
    found = align_translation(reference, moving, (40.0, 10.0), search=(0, 0))
    assert np.allclose(found, (40 + t_x, 10 + t_y), atol=0.01)


def test_align_translation_matches_its_documented_convention():
    scene, _ = smooth_scene(70, 150)
    reference, moving = scene[:60, :100], scene[4:, 70:]
    found = align_translation(reference, moving, (68.0, 2.0))
    assert np.allclose(found, (70.0, 4.0), atol=1e-3)
    # swapping the images negates the translation
    back = align_translation(moving, reference, (-68.0, -2.0))
    assert np.allclose(back, (-70.0, -4.0), atol=1e-3)


def test_align_translation_with_10_percent_overlap_on_the_rig():
    views = render_views(rig_room(3), n_views=4, start_angle=-0.2, height=240, overlap=0.1,
                         supersample=2, seed=3)
    cylinders = [cylindrical_warp(view, views.focal) for view in views.images]
    errors = []
    for k in range(3):
        initial = (views.focal * (views.pan_angles[k + 1] - views.pan_angles[k]), 0.0)
        found = align_translation(cylinders[k], cylinders[k + 1], initial)
        errors.append(found - views.translations[k])
    assert np.sqrt(np.mean(np.square(errors))) < 0.15


def test_align_translation_on_real_texture_at_10_percent_overlap():
    data = pytest.importorskip("skimage.data")
    views = texture_views(data.camera(), overlap=0.1, n_views=4, seed=0, noise=0.005,
                          vignetting=1.0)
    cylinders = [cylindrical_warp(view, views.focal) for view in views.images]
    errors = []
    for k in range(3):
        initial = (views.focal * (views.pan_angles[k + 1] - views.pan_angles[k]), 0.0)
        errors.append(align_translation(cylinders[k], cylinders[k + 1], initial)
                      - views.translations[k])
    assert np.sqrt(np.mean(np.square(errors))) < 0.5


def test_photometric_terms_absorb_a_gain_ramp():
    """A linear gain across the overlap biases Eq. 17; the photometric unknowns remove it."""
    scene, _ = smooth_scene(70, 150)
    reference = scene[:60, :100] + 3.0
    moving = scene[3:63, 60:].copy() + 3.0
    moving *= np.linspace(0.9, 1.05, moving.shape[1])[None, :]
    plain = align_translation(reference, moving, (59.0, 2.0), photometric=False)
    compensated = align_translation(reference, moving, (59.0, 2.0))
    assert np.hypot(*(compensated - (60.0, 3.0))) < 0.02
    assert np.hypot(*(plain - (60.0, 3.0))) > np.hypot(*(compensated - (60.0, 3.0)))


def test_align_translation_does_not_modify_its_inputs():
    scene, _ = smooth_scene()
    reference, moving = scene[:50, :90].copy(), scene[2:, 50:].copy()
    before = reference.copy(), moving.copy()
    align_translation(reference, moving, (50.0, 2.0))
    assert np.array_equal(reference, before[0]) and np.array_equal(moving, before[1])


# ----------------------------------------------------------------------------- Eq. 18


@settings(deadline=None)
@given(st.floats(0.5, 500), st.floats(0.5, 500))
def test_eq18_is_one_at_the_centre_and_zero_on_the_border(width, height):
    assert hat_weight(width / 2, height / 2, width, height) == 1.0
    for x, y in [(0, height / 2), (width, height / 2), (width / 2, 0), (width / 2, height),
                 (0, 0), (width, height)]:
        assert hat_weight(x, y, width, height) == 0.0


@settings(deadline=None)
@given(st.floats(0, 1), st.floats(0, 1), st.floats(0.5, 500), st.floats(0.5, 500))
def test_eq18_is_separable_and_symmetric(fx, fy, width, height):
    x, y = fx * width, fy * height
    w = hat_weight(x, y, width, height)
    assert np.isclose(
        w, hat_weight(x, height / 2, width, height) * hat_weight(width / 2, y, width, height),
        rtol=1e-12, atol=1e-15,
    )
    assert np.isclose(w, hat_weight(width - x, y, width, height), rtol=1e-9, atol=1e-12)
    assert np.isclose(w, hat_weight(x, height - y, width, height), rtol=1e-9, atol=1e-12)
    assert 0.0 <= w <= 1.0


@settings(deadline=None)
@given(st.integers(1, 30), st.integers(1, 30))
def test_eq18_pixel_weights_are_positive_symmetric_and_peak_at_the_centre(height, width):
    w = hat_weights((height, width))
    assert (w > 0).all() and w.max() <= 1.0
    assert np.allclose(w, w[::-1, :]) and np.allclose(w, w[:, ::-1])
    centre = np.unravel_index(w.argmax(), w.shape)
    assert abs(centre[0] - (height - 1) / 2) <= 0.5 and abs(centre[1] - (width - 1) / 2) <= 0.5


@settings(deadline=None)
@given(st.integers(8, 30), st.integers(8, 30), st.integers(1, 7), st.integers(-3, 3),
       st.integers(0, 2**32 - 1))
def test_eq18_blending_identical_overlapping_images_returns_the_image(
    height, width, shift_x, shift_y, seed
):
    assume(shift_x < width - 1 and abs(shift_y) < height - 1)
    scene = np.random.default_rng(seed).random((height + 6, width + 10))
    top = 3
    first = scene[top : top + height - 3, 0 : width - shift_x]
    second = scene[top + shift_y : top + shift_y + height - 3, shift_x:width]
    out, weight = blend([first, second], [(0, top), (shift_x, top + shift_y)],
                        shape=scene.shape)
    covered = weight > 0
    assert np.allclose(out[covered], scene[covered], rtol=0, atol=1e-12)
    assert np.isnan(out[~covered]).all()


def test_blend_is_a_weighted_mean_with_eq18_weights():
    a, b = np.zeros((4, 6)), np.ones((4, 6))
    out, weight = blend([a, b], [(0, 0), (3, 0)])
    # column 4 is pixel 4 of `a` (x = 4.5: w = 1 − 1.5/3 = 0.5) and pixel 1 of `b` (w = 0.5)
    assert np.allclose(out[:, 4], 0.5) and np.allclose(out[:, :3], 0.0)
    assert np.allclose(weight[1, 4], hat_weights((4, 6))[1, 4] * 2)


# ----------------------------------------------------------------------------- mosaic


def test_mosaic_of_the_rig_recovers_the_translations_and_blends_seamlessly():
    views = render_views(rig_room(0), n_views=4, start_angle=-0.4, height=120, overlap=0.2,
                         supersample=2, seed=0)
    result = mosaic(views.images, views.focal, np.radians(18), start_angle=views.pan_angles[0])
    assert result.translations.shape == (3, 2)
    assert np.sqrt(np.mean((result.translations - views.translations) ** 2)) < 0.1
    assert np.allclose(np.diff(result.offsets, axis=0), result.translations)
    assert result.offsets.min() == 0.0
    assert result.image.shape == result.weight.shape
    covered = result.weight > 0
    assert np.isfinite(result.image[covered]).all() and np.isnan(result.image[~covered]).all()
    # the horizon row and the column of pan angle of view 0's centre
    assert result.horizon_row == pytest.approx(result.offsets[0, 1] + 59.5)
    assert result.column_of(views.pan_angles[0]) == pytest.approx(
        result.offsets[0, 0] + (views.images.shape[2] - 1) / 2)


def test_mosaic_is_deterministic_and_accepts_colour():
    views = render_views(rig_room(1), n_views=3, start_angle=0.0, height=60, supersample=1,
                         seed=1)
    colour = np.stack([views.images, views.images * 0.9, views.images * 0.8], axis=-1)
    first = mosaic(list(colour), views.focal, np.radians(18))
    second = mosaic(list(colour), views.focal, np.radians(18))
    assert first.image.shape[2] == 3
    assert np.array_equal(first.image, second.image, equal_nan=True)


def test_full_circle_mosaic_closes_the_loop():
    y, x = np.mgrid[0:70, 0:600].astype(np.float64)
    texture = np.sin(2 * np.pi * x / 600 * 7) * np.cos(0.15 * y) + 0.4 * np.cos(
        2 * np.pi * x / 600 * 23 + 0.1 * y)
    focal = 600 / (2 * np.pi)
    rng = np.random.default_rng(0)
    pans = np.arange(12) * 2 * np.pi / 12 + rng.uniform(-0.01, 0.01, 12)
    width = 64
    rows, cols = np.indices((60, width), dtype=np.float64)
    x_c, y_c = cylinder_coordinates(cols - (width - 1) / 2, rows - 29.5, focal)
    views = [
        ndi.map_coordinates(texture, [y_c + 34.5, (focal * pan + x_c) % 600], order=3,
                            mode="grid-wrap")
        for pan in pans
    ]
    result = mosaic(views, focal, 2 * np.pi / 12, full_circle=True)
    assert result.period == pytest.approx(600.0)
    assert np.allclose(result.translations.sum(axis=0), (600.0, 0.0), atol=1e-9)
    truth = focal * np.diff(np.append(pans, pans[0] + 2 * np.pi))
    assert np.max(np.abs(result.translations[:, 0] - truth)) < 0.2
    assert result.image.shape[1] == 600 and np.isfinite(result.image[30]).all()


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "focal, error, match",
    [(0.0, ValueError, "focal"), (-3.0, ValueError, "focal"), (np.inf, ValueError, "focal"),
     (True, TypeError, "focal"), ("300", TypeError, "focal")],
)
def test_focal_is_validated(focal, error, match):
    with pytest.raises(error, match=match):
        cylindrical_warp(np.zeros((4, 4)), focal)


@pytest.mark.parametrize(
    "image, error, match",
    [
        ([[0.0, 1.0], [1.0, 0.0]], TypeError, "numpy array"),
        (np.zeros((4, 4), dtype=bool), TypeError, "real numeric"),
        (np.zeros((4, 4), dtype=complex), TypeError, "real numeric"),
        (np.zeros(4), ValueError, "shape"),
        (np.zeros((1, 4)), ValueError, "shape"),
        (np.full((4, 4), np.inf), ValueError, "finite"),
    ],
)
def test_images_are_validated(image, error, match):
    with pytest.raises(error, match=match):
        cylindrical_warp(image, 100.0)


def test_other_warp_parameters_are_validated():
    with pytest.raises(ValueError, match="order"):
        cylindrical_warp(np.zeros((4, 4)), 100.0, order=2)
    with pytest.raises(ValueError, match="output_shape"):
        cylindrical_unwarp(np.zeros((4, 4)), 100.0, output_shape=(4, 0))
    with pytest.raises(ValueError, match="points"):
        project_to_cylinder(np.zeros((3, 2)), 100.0)
    with pytest.raises(ValueError, match="axis"):
        project_to_cylinder(np.array([0.0, 1.0, 0.0]), 100.0)


def test_alignment_parameters_are_validated():
    scene, _ = smooth_scene()
    a, b = scene[:40, :60], scene[:40, 30:90]
    with pytest.raises(ValueError, match="initial"):
        align_translation(a, b, (1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="levels"):
        align_translation(a, b, (30.0, 0.0), levels=5)
    with pytest.raises(ValueError, match="levels"):
        align_translation(a, b, (30.0, 0.0), levels=0)
    with pytest.raises(ValueError, match="order"):
        align_translation(a, b, (30.0, 0.0), order=0)
    with pytest.raises(ValueError, match="search"):
        align_translation(a, b, (30.0, 0.0), search=(-1, 0))
    with pytest.raises(ValueError, match="tol"):
        align_translation(a, b, (30.0, 0.0), tol=0.0)
    with pytest.raises(TypeError, match="max_iter"):
        align_translation(a, b, (30.0, 0.0), max_iter=1.5)
    with pytest.raises(ValueError, match="overlap"):
        align_translation(a, b, (200.0, 0.0), search=(0, 0))
    with pytest.raises(ValueError, match="overlap"):
        gauss_newton_step(a, b, (70.0, 0.0))
    with pytest.raises(ValueError, match="texture"):
        gauss_newton_step(np.ones((20, 20)), np.ones((20, 20)))
    with pytest.raises(ValueError, match="shape"):
        gauss_newton_step(np.zeros((4, 4, 3)), np.zeros((4, 4)))


def test_mosaic_and_blend_parameters_are_validated():
    view = np.random.default_rng(0).random((20, 30))
    with pytest.raises(ValueError, match="at least 2"):
        mosaic([view], 100.0, 0.2)
    with pytest.raises(ValueError, match="one shape"):
        mosaic([view, view[:, :20]], 100.0, 0.2)
    with pytest.raises(ValueError, match="pan_step"):
        mosaic([view, view, view], 100.0, [0.2, 0.2, 0.2])
    with pytest.raises(ValueError, match="pan_step"):
        mosaic([view, view], 100.0, "wide")
    with pytest.raises(TypeError, match="full_circle"):
        mosaic([view, view], 100.0, 0.2, full_circle=1)
    with pytest.raises(TypeError, match="images"):
        mosaic("views", 100.0, 0.2)
    with pytest.raises(ValueError, match="finite"):
        mosaic([view, np.full_like(view, np.nan)], 100.0, 0.2)
    with pytest.raises(ValueError, match="offsets"):
        blend([view, view], [(0, 0)])
    with pytest.raises(ValueError, match="images"):
        blend([], [])
    with pytest.raises(ValueError, match="channels"):
        blend([view, np.zeros((20, 30, 3))], [(0, 0), (1, 0)])
    with pytest.raises(ValueError, match="width"):
        hat_weight(0.0, 0.0, 0.0, 1.0)
