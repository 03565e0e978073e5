"""Stage 3 cameras: back-projection and projection (Eqs. 14, 19; the pinhole; disparity)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refsynth.model import CylindricalCamera, PinholeCamera, disparity_to_depth

# ----------------------------------------------------------------------------- strategies


@st.composite
def cylindrical_cameras(draw, width=None):
    """A cylindrical camera whose columns cover at most 360° for ``width`` columns."""
    focal = draw(st.floats(50.0, 600.0))
    phi_step = None
    if width is not None and draw(st.booleans()):
        phi_step = draw(st.floats(1e-3, 2 * math.pi / width))
    return CylindricalCamera(
        focal,
        cx=draw(st.floats(-20.0, 40.0)),
        cy=draw(st.floats(-20.0, 40.0)),
        phi_step=phi_step,
        h_step=draw(st.floats(0.25, 4.0)),
    )


@st.composite
def pinhole_cameras(draw):
    """A pinhole camera with its principal point near a small image."""
    return PinholeCamera(draw(st.floats(50.0, 2000.0)), cx=draw(st.floats(-5.0, 30.0)),
                         cy=draw(st.floats(-5.0, 30.0)))


@st.composite
def range_images(draw, low=0.3, high=30.0):
    """A small positive range image (H, W) in [low, high]."""
    height, width = draw(st.integers(1, 12)), draw(st.integers(1, 16))
    seed = draw(st.integers(0, 2**32 - 1))
    return np.random.default_rng(seed).uniform(low, high, (height, width))


# ----------------------------------------------------------------------------- round trips


@settings(deadline=None)
@given(data=st.data(), cylindrical=st.booleans())
def test_back_projection_then_projection_returns_row_col_range(data, cylindrical):
    r = data.draw(range_images())
    camera = data.draw(cylindrical_cameras(width=r.shape[1]) if cylindrical
                       else pinhole_cameras())
    row, col, distance = camera.project(camera.back_project(r), width=r.shape[1])
    rows, cols = np.indices(r.shape)
    np.testing.assert_allclose(row, rows, atol=1e-8)
    np.testing.assert_allclose(col, cols, atol=1e-8)
    np.testing.assert_allclose(distance, r, rtol=1e-13)  # distance, or depth for the pinhole


@settings(deadline=None)
@given(camera=cylindrical_cameras(), r=range_images())
def test_cylindrical_range_is_the_euclidean_distance(camera, r):
    points = camera.back_project(r)
    np.testing.assert_allclose(np.linalg.norm(points, axis=-1), r, rtol=1e-13)


@settings(deadline=None)
@given(data=st.data(), cylindrical=st.booleans())
def test_a_plane_stays_planar(data, cylindrical):
    height, width = data.draw(st.integers(2, 12)), data.draw(st.integers(2, 16))
    camera = data.draw(cylindrical_cameras() if cylindrical else pinhole_cameras())
    normal = np.array(data.draw(st.tuples(*[st.floats(-1, 1)] * 3)))
    if np.linalg.norm(normal) < 0.2:
        normal = np.array([0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal)
    offset = data.draw(st.floats(0.5, 10.0))  # the plane n·p = offset, the camera off it
    rays = camera.directions((height, width))
    facing = rays @ normal
    front = facing > 0.05 * np.linalg.norm(rays, axis=-1)
    t = np.divide(offset, facing, out=np.full(facing.shape, np.nan), where=front)
    points = camera.back_project(t)  # t: distance (unit rays) or depth (z = 1 rays)
    seen = np.isfinite(points[..., 0])
    scale = np.abs(points[seen]).max(initial=1.0)
    np.testing.assert_allclose(points[seen] @ normal, offset, atol=1e-12 * scale)


# ----------------------------------------------------------------------------- conventions


def test_cylindrical_camera_agrees_with_eq14_project_to_cylinder():
    from refsynth.registration import project_to_cylinder

    camera = CylindricalCamera(300.0, cx=10.3, cy=7.1, phi_step=0.01, h_step=1.5)
    r = np.random.default_rng(0).uniform(1, 8, (15, 20))
    psi, v = project_to_cylinder(camera.back_project(r), 300.0)
    np.testing.assert_allclose(psi, np.broadcast_to(camera.azimuth(np.arange(20)), r.shape),
                               atol=1e-14)
    np.testing.assert_allclose(v, np.broadcast_to(camera.height(np.arange(15))[:, None],
                                                  r.shape), atol=1e-12)


def test_from_cylinder_recovers_the_laser_points_of_eq19():
    from refsynth.registration import scan_to_cylinder, spherical_to_cartesian

    theta = np.arctan2(300.0, np.linspace(60.0, -60.0, 13))
    phi = np.linspace(-0.5, 0.5, 11)
    r = np.random.default_rng(1).uniform(2, 6, (11, 13))
    cylinder = scan_to_cylinder(r, theta, phi, 300.0, h_step=10.0)
    camera = CylindricalCamera.from_cylinder(cylinder)
    grid_theta, grid_phi = np.meshgrid(theta, phi)
    truth = spherical_to_cartesian(r, grid_theta, grid_phi).transpose(1, 0, 2)
    np.testing.assert_allclose(camera.back_project(cylinder.range), truth, atol=1e-12)


def test_from_warp_inverts_eq21():
    from refsynth.registration import Warp

    warp = Warp(a=301.0, b=-0.98, alpha=480.0, beta=114.0)
    camera = CylindricalCamera.from_warp(warp, 300.0, origin=(5, 20))
    phi, h = np.array([-0.4, 0.0, 0.7]), np.array([30.0, 0.0, -50.0])
    u, v = warp.apply(phi, h)
    np.testing.assert_allclose(camera.azimuth(u - 20), phi, atol=1e-12)
    np.testing.assert_allclose(camera.height(v - 5), h, atol=1e-12)
    with pytest.raises(ValueError, match="`warp`"):
        CylindricalCamera.from_warp(Warp(1.0, 1.0, 0.0, 0.0), 300.0)


def test_pan_angle_grows_from_z_towards_x_and_rows_go_down():
    camera = CylindricalCamera(100.0, cx=0.0, cy=1.0, phi_step=math.pi / 2)
    points = camera.back_project(np.ones((3, 2)))
    np.testing.assert_allclose(points[1, 1], [1.0, 0.0, 0.0], atol=1e-15)  # φ = 90°: +x
    assert points[0, 0, 1] > 0 > points[2, 0, 1]  # row 0 above the horizon
    pinhole = PinholeCamera(100.0, cx=0.0, cy=0.0)
    assert pinhole.back_project(np.ones((2, 2)))[1, 1].tolist() == [0.01, -0.01, 1.0]


def test_360_degree_panorama_covers_the_circle():
    camera = CylindricalCamera.panorama(100.0, (10, 628))
    assert camera.covers_360(628)
    assert not camera.covers_360(600)
    assert not CylindricalCamera.centred(300.0, (10, 600)).covers_360(600)
    assert not PinholeCamera(1.0, 0.0, 0.0).covers_360(10)


def test_pixels_without_range_have_no_point():
    r = np.array([[1.0, np.nan], [0.0, -2.0]])
    points = CylindricalCamera(10.0, 0.0, 0.0).back_project(r)
    assert np.isfinite(points[0, 0]).all() and np.isnan(points.reshape(-1, 3)[1:]).all()


def test_projection_of_points_on_the_axis_or_behind_is_nan():
    row, col, _ = CylindricalCamera(10.0, 0.0, 0.0).project([0.0, 1.0, 0.0])
    assert np.isnan(row) and np.isnan(col)
    row, col, depth = PinholeCamera(10.0, 0.0, 0.0).project([[0.0, 0.0, -1.0]])
    assert np.isnan(row).all() and np.isnan(depth).all()


# ----------------------------------------------------------------------------- disparity


def test_disparity_to_depth_is_f_b_over_d_plus_doffs():
    d = np.array([[10.0, 20.0], [np.inf, np.nan]])
    z = disparity_to_depth(d, focal=1000.0, baseline=0.2, doffs=10.0)
    np.testing.assert_allclose(z[0], [1000 * 0.2 / 20, 1000 * 0.2 / 30], rtol=1e-15)
    assert np.isnan(z[1]).all()
    assert np.isnan(disparity_to_depth(np.array([-10.0]), 1.0, 1.0, doffs=5.0)).all()


def test_middlebury_motorcycle_calibration_gives_metre_scale_depth():
    # Motorcycle (2014) calib.txt: f = 3979.911, doffs = 124.343, baseline = 193.001 mm;
    # the true disparities lie in about 30..260 px at full size.
    z = disparity_to_depth(np.array([30.0, 260.0]), 3979.911, 193.001, 124.343)
    assert 1900 < z[1] < 2100 and 4900 < z[0] < 5000


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize("kwargs, match", [
    (dict(focal=0.0, cx=0.0, cy=0.0), "`focal`"),
    (dict(focal=1.0, cx=np.nan, cy=0.0), "`cx`"),
    (dict(focal=1.0, cx=0.0, cy=0.0, phi_step=-1.0), "`phi_step`"),
    (dict(focal=1.0, cx=0.0, cy=0.0, h_step=0.0), "`h_step`"),
])
def test_cylindrical_camera_checks_its_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CylindricalCamera(**kwargs)


def test_cameras_check_their_inputs():
    camera = PinholeCamera(1.0, 0.0, 0.0)
    with pytest.raises(TypeError, match="`depth`"):
        camera.back_project([[1.0]])
    with pytest.raises(ValueError, match="`depth`"):
        camera.back_project(np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match="`points`"):
        camera.project(np.ones((3, 2)))
    with pytest.raises(ValueError, match="`shape`"):
        camera.directions((0, 2))
    with pytest.raises(ValueError, match="`baseline`"):
        disparity_to_depth(np.ones(2), 1.0, 0.0)


@pytest.mark.slow
def test_from_warp_puts_a_registered_scan_on_the_true_surface():
    """Appendix A's output, back-projected through the global warp, lies on the room."""
    from refsynth.model import Pose
    from refsynth.registration import register_scan
    from refsynth.scenes import cast_rays, laser_scan, render_views, rig_room

    room = rig_room(0)
    views = render_views(room, n_views=5, start_angle=-0.6, height=160, supersample=1)
    scan = laser_scan(room, phi_range=(-0.9, 0.9), stripes=None)
    _, partial, info = register_scan(views.images, views.pan_angles, 300.0,
                                     (scan.r, scan.theta, scan.phi))
    camera = CylindricalCamera.from_warp(info.warp, 300.0, origin=(info.crop[0], info.crop[2]))
    points = camera.back_project(partial)
    points = points[np.isfinite(points[..., 0])]  # the laser's frame
    laser = np.array([0.0, -scan.delta_y, 0.0])  # its centre and azimuth in the room
    rays = Pose(heading=scan.pan_offset).apply(points)
    r = np.linalg.norm(rays, axis=1)
    truth = cast_rays(room, rays / r[:, None], origin=laser).distance
    assert np.median(np.abs(r - truth) / truth) < 0.005
