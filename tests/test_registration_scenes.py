"""Tests of refsynth.scenes (rig, rig_views): the synthetic rig and the real-texture views."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage as ndi

from refsynth.registration import cartesian_to_spherical, cylindrical_warp
from refsynth.scenes import cast_rig_rays as cast_rays
from refsynth.scenes import (
    laser_scan,
    render_views,
    rig_room,
    texture_views,
    view_width,
)


def test_the_rig_room_has_walls_5_to_8_m_away_and_furniture_nearer():
    for seed in range(5):
        room = rig_room(seed)
        assert np.all((room.upper[[0, 2]] >= 5) & (room.upper[[0, 2]] <= 8))
        assert np.all((-room.lower[[0, 2]] >= 5) & (-room.lower[[0, 2]] <= 8))
        distance = np.hypot(room.boxes[:, 0], room.boxes[:, 2])
        assert np.all((distance >= 1.5) & (distance <= 4.5))
        assert np.allclose(room.boxes[:, 1] - room.boxes[:, 4], room.lower[1])  # on the floor


def test_rays_hit_the_walls_at_the_right_distance():
    room = rig_room(0)
    # straight up and straight down: ceiling and floor
    distance, intensity = cast_rays(room, np.zeros(3), np.array([[0, 1.0, 0], [0, -1.0, 0]]))
    assert np.allclose(distance, [room.upper[1], -room.lower[1]])
    assert np.all((intensity >= 0) & (intensity <= 1))


def test_rendering_is_deterministic_and_seeded():
    room = rig_room(4)
    first = render_views(room, n_views=2, height=40, supersample=1, seed=7)
    second = render_views(room, n_views=2, height=40, supersample=1, seed=7)
    other = render_views(room, n_views=2, height=40, supersample=1, seed=8)
    assert np.array_equal(first.images, second.images)
    assert not np.array_equal(first.images, other.images)
    assert first.images.shape == (2, 40, view_width(300.0, math.radians(18), 0.2))


def test_true_translations_are_what_the_views_show():
    """Without noise or vignetting, shifting view 0 by the true t reproduces view 1."""
    room = rig_room(1)
    views = render_views(room, n_views=2, start_angle=0.3, height=100, noise=0.0,
                         vignetting=0.0, supersample=4, seed=1)
    first, second = (cylindrical_warp(view, views.focal, order=3) for view in views.images)
    t_x, t_y = views.translations[0]
    rows, cols = np.indices(second.shape, dtype=np.float64)
    shifted = ndi.map_coordinates(np.nan_to_num(first), [rows + t_y, cols + t_x], order=1,
                                  cval=np.nan)
    valid = ndi.binary_erosion(np.isfinite(second) & (cols + t_x < first.shape[1] - 12)
                               & (cols + t_x > 12), iterations=2)
    assert valid.sum() > 500
    assert np.median(np.abs(shifted - second)[valid]) < 0.02


def test_vignetting_darkens_the_corners():
    room = rig_room(2)
    plain = render_views(room, n_views=2, height=60, supersample=1, noise=0, vignetting=0,
                         seed=0)
    dark = render_views(room, n_views=2, height=60, supersample=1, noise=0, vignetting=1,
                        seed=0)
    ratio = dark.images[0] / np.maximum(plain.images[0], 1e-9)
    assert ratio[30, plain.images.shape[2] // 2] == pytest.approx(1.0, abs=0.01)
    assert ratio[0, 0] < 0.97


def test_the_laser_scan_is_partial_in_stripes_and_measures_distance():
    room = rig_room(0)
    scan = laser_scan(room, phi_range=(-0.3, 0.3), noise=0.0, stripes=(10, 15), seed=0)
    scanned = np.isfinite(scan.r).all(axis=1)
    assert scanned.sum() == np.count_nonzero(np.arange(scan.phi.size) % 25 < 10)
    assert np.isnan(scan.r[~scanned]).all()
    # the ranges are the distances from the laser centre, ΔY below the camera, to the points
    r, theta, phi = cartesian_to_spherical(scan.points - [0.0, -scan.delta_y, 0.0])
    assert np.allclose(r[scanned], scan.r[scanned])
    assert np.allclose(theta, scan.theta[None, :])
    assert np.allclose(phi, scan.phi[:, None] + scan.pan_offset)


@settings(deadline=None, max_examples=10)
@given(st.floats(0.05, 0.4), st.floats(0.1, 0.5))
def test_view_width_gives_the_requested_overlap(overlap, step):
    focal = 300.0
    width = view_width(focal, step, overlap)
    covered = 2 * focal * np.arctan(width / (2 * focal))
    assert abs((1 - focal * step / covered) - overlap) < 2.5 / covered


def test_texture_views_cut_a_photograph_with_known_translations():
    data = pytest.importorskip("skimage.data")
    views = texture_views(data.camera(), n_views=3, seed=0)
    assert views.images.shape[0] == 3
    assert np.allclose(views.translations[:, 0], views.focal * np.diff(views.true_pan))
    assert np.all(np.abs(views.translations[:, 1]) <= 3.0)


def test_scene_parameters_are_validated():
    with pytest.raises(ValueError, match="overlap"):
        view_width(300.0, 0.3, 1.0)
    with pytest.raises(ValueError, match="180"):
        view_width(300.0, 3.0, 0.5)
    with pytest.raises(ValueError, match="too small"):
        texture_views(np.zeros((50, 200)), n_views=5)
    with pytest.raises(ValueError, match="stripes"):
        laser_scan(rig_room(0), stripes=(0, 3))
    with pytest.raises(ValueError, match="n_views"):
        render_views(rig_room(0), n_views=1)
    with pytest.raises(ValueError, match="seed"):
        rig_room(-1)
