"""Tests of laser–camera registration (Appendix A.2, Eqs. 19–21) in refsynth.registration."""

import argparse
import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from refsynth.cli.register import add_register_parser
from refsynth.registration import (
    CylindricalRange,
    Warp,
    align_global,
    cartesian_to_spherical,
    eq20_warp,
    fit_warp,
    fit_warp_eq20,
    intensity_edges,
    match_edges,
    match_segments,
    range_edges,
    refine_local,
    register,
    register_scan,
    resample_range,
    scan_to_cylinder,
    spherical_to_cartesian,
    spherical_to_cylindrical,
)
from refsynth.registration import warp_forward as _forward
from refsynth.registration.scoring import registration_errors
from refsynth.scenes import laser_scan, render_views, rig_room

EPS = np.finfo(np.float64).eps


@st.composite
def warps(draw):
    """Eq. 21 parameters near the rig's: a ≈ f, b ≈ ±1, offsets of a few hundred px."""
    return Warp(
        draw(st.floats(50.0, 2000.0)) * draw(st.sampled_from([1.0, -1.0])),
        draw(st.floats(0.3, 3.0)) * draw(st.sampled_from([1.0, -1.0])),
        draw(st.floats(-1000.0, 1000.0)),
        draw(st.floats(-500.0, 500.0)),
    )


@st.composite
def laser_points(draw, minimum=2, maximum=12):
    """(φ, h) points with at least two distinct φ and two distinct h."""
    n = draw(st.integers(minimum, maximum))
    phi = draw(st.lists(st.floats(-1.6, 1.6), min_size=n, max_size=n))
    h = draw(st.lists(st.floats(-200.0, 200.0), min_size=n, max_size=n))
    phi[0], phi[1] = -0.5, 0.7
    h[0], h[1] = -40.0, 55.0
    return np.column_stack([phi, h])


# ----------------------------------------------------------------------------- Eq. 19


@settings(deadline=None)
@given(st.floats(-3.1, 3.1), st.floats(-1000.0, 1000.0), st.floats(50.0, 2000.0))
@example(0.0, 0.0, 300.0)
def test_eq19_maps_points_on_the_cylinder_to_themselves(phi, h, focal):
    point = np.array([focal * np.sin(phi), h, focal * np.cos(phi)])
    r, theta, azimuth = cartesian_to_spherical(point)
    r_out, phi_out, h_out = spherical_to_cylindrical(r, theta, azimuth, focal)
    assert np.isclose(phi_out, phi, rtol=0, atol=8 * EPS * 4)
    assert np.isclose(h_out, h, rtol=64 * EPS, atol=64 * EPS * focal)
    assert np.isclose(r_out, math.hypot(focal, h), rtol=8 * EPS)


@settings(deadline=None)
@given(st.floats(0.1, 50.0), st.floats(0.01, 3.13), st.floats(-3.1, 3.1))
def test_spherical_and_cartesian_round_trip(r, theta, phi):
    back = cartesian_to_spherical(spherical_to_cartesian(r, theta, phi))
    assert np.allclose(back, (r, theta, phi), rtol=1e-12, atol=1e-12)


@settings(deadline=None)
@given(st.floats(0.5, 20.0), st.floats(0.05, 3.09), st.floats(-3.0, 3.0), st.floats(50, 900))
def test_eq19_height_is_where_the_ray_meets_the_cylinder(r, theta, phi, focal):
    """h = f / tan θ: the ray through the sample crosses radius f at height h."""
    _, _, h = spherical_to_cylindrical(r, theta, phi, focal)
    x, y, z = spherical_to_cartesian(r, theta, phi)
    assert np.isclose(h, focal * y / math.hypot(x, z), rtol=1e-9, atol=1e-9)


def test_scan_to_cylinder_puts_each_slice_in_its_column_and_nan_where_not_scanned():
    focal = 100.0
    heights = np.arange(20.0, -21.0, -1.0)
    theta = np.arctan2(focal, heights)
    phi = np.arange(6) * 0.02
    r = np.add.outer(np.arange(6.0) + 1, np.zeros(theta.size))
    r[2] = np.nan  # slice 2 not scanned
    keep = [0, 1, 2, 4, 5]  # slice 3 missing from the file altogether
    image = scan_to_cylinder(r[keep], theta, phi[keep], focal)
    assert image.range.shape == (41, 6)
    assert np.allclose(image.h, heights) and np.allclose(image.phi, phi)
    assert np.allclose(image.range[:, [0, 1, 4, 5]], [1.0, 2.0, 5.0, 6.0])
    assert np.isnan(image.range[:, [2, 3]]).all()
    assert image.phi_step == pytest.approx(0.02) and image.h_step == pytest.approx(1.0)


def test_scan_to_cylinder_accepts_flat_samples():
    theta = np.radians(np.linspace(70, 110, 15))
    phi = np.radians(np.arange(8) * 0.36)
    rng = np.random.default_rng(0)
    r = rng.uniform(2, 8, (8, 15))
    grid_phi, grid_theta = np.meshgrid(phi, theta, indexing="ij")
    order = rng.permutation(r.size)
    flat = scan_to_cylinder(r.ravel()[order], grid_theta.ravel()[order],
                            grid_phi.ravel()[order], 300.0)
    structured = scan_to_cylinder(r, theta, phi, 300.0)
    assert np.array_equal(flat.range, structured.range, equal_nan=True)
    # per-sample angles of r's shape, as refsynth.acquisition writes scan.npz
    gridded = scan_to_cylinder(r, grid_theta, grid_phi, 300.0)
    assert np.array_equal(gridded.range, structured.range, equal_nan=True)


def test_scan_to_cylinder_leaves_rows_beyond_the_scan_empty():
    theta = np.radians([85.0, 90.0, 95.0])
    image = scan_to_cylinder(np.full((2, 3), 4.0), theta, [0.0, 0.01], 300.0,
                             h_range=(-60.0, 60.0))
    beyond = np.abs(image.h) > 300 * np.tan(np.radians(7.5))  # half a mirror step past 85°, 95°
    assert np.isnan(image.range[beyond]).all() and np.isfinite(image.range[~beyond]).all()


# ----------------------------------------------------------------------------- Eqs. 20–21


@settings(deadline=None)
@given(warps(), laser_points())
def test_eq21_fit_is_exact_on_noise_free_correspondences(warp, laser):
    camera = np.column_stack(warp.apply(laser[:, 0], laser[:, 1]))
    fitted = fit_warp(laser, camera)
    assert np.allclose(fitted, warp, rtol=1e-9, atol=1e-7 * (1 + abs(warp.alpha)))


@settings(deadline=None)
@given(warps(), laser_points(minimum=3), st.randoms(use_true_random=False))
def test_eq21_fit_does_not_depend_on_the_order_of_correspondences(warp, laser, random):
    rng = np.random.default_rng(random.randint(0, 2**32 - 1))
    camera = np.column_stack(warp.apply(laser[:, 0], laser[:, 1]))
    camera = camera + rng.normal(0, 2.0, camera.shape)
    order = rng.permutation(len(laser))
    first, second = fit_warp(laser, camera), fit_warp(laser[order], camera[order])
    assert np.allclose(first, second, rtol=1e-9, atol=1e-9)


def test_eq21_fit_from_noisy_correspondences_is_within_the_targets():
    """20 correspondences over 180°, 0.5 px noise: a, b within 1 %, α, β within 0.5 px."""
    rng = np.random.default_rng(0)
    truth = Warp(300.0, -1.0, 480.0, 120.0)
    laser = np.column_stack([rng.uniform(-1.5, 1.5, 20), rng.uniform(-100, 100, 20)])
    camera = np.column_stack(truth.apply(laser[:, 0], laser[:, 1]))
    fitted = fit_warp(laser, camera + rng.normal(0, 0.5, camera.shape))
    assert abs(fitted.a / truth.a - 1) < 0.01 and abs(fitted.b / truth.b - 1) < 0.01
    assert abs(fitted.alpha - truth.alpha) < 0.5 and abs(fitted.beta - truth.beta) < 0.5


@settings(deadline=None)
@given(laser_points(minimum=4), st.floats(0.01, 0.3), st.floats(-200, 200))
def test_eq20_fit_recovers_the_offset_exactly(laser, delta_y, v0):
    r = np.linspace(1.5, 8.0, len(laser))
    camera = eq20_warp(laser, r, a=300.0, b=-1.0, alpha=30.0, v0=v0, focal=300.0,
                       delta_y=delta_y)
    warp, fitted = fit_warp_eq20(laser, r, camera, 300.0)
    assert fitted == pytest.approx(delta_y, rel=1e-6, abs=1e-9)
    assert warp.beta == pytest.approx(v0, abs=1e-6) and warp.b == pytest.approx(-1.0, abs=1e-9)


def test_eq21_is_eq20_with_the_parallax_taken_as_constant():
    laser = np.array([[0.1, 10.0], [0.4, -30.0]])
    r = np.array([6.0, 6.0])
    exact = eq20_warp(laser, r, a=300, b=-1, alpha=5, v0=100, focal=300, delta_y=0.05)
    rho = r * 300 / np.hypot(300, laser[:, 1])
    approximate = np.column_stack(Warp(300, -1, 5, 100 + 300 * 0.05 / rho[0]).apply(*laser.T))
    assert np.allclose(exact[0], approximate[0])
    assert np.allclose(exact[1], approximate[1], atol=0.05)


def test_warp_inverts():
    warp = Warp(300.0, -1.02, 12.0, 99.0)
    u, v = warp.apply([0.3, -0.2], [40.0, -7.0])
    assert np.allclose(warp.invert(u, v), ([0.3, -0.2], [40.0, -7.0]))


# ----------------------------------------------------------------------------- edges


def _box_scene():
    """A mosaic with two boxes and a range image whose box tops are 3 and 1.5 px too low."""
    rng = np.random.default_rng(0)
    image = 0.3 + 0.02 * rng.standard_normal((100, 200))
    image[50:, 40:90] = 0.8
    image[40:, 120:170] = 0.6
    focal = 200.0
    phi = np.arange(100) * 0.01  # 2 mosaic px per column
    h = 60.0 - np.arange(100)  # one mosaic row per row
    r = np.full((100, 100), 6.0)
    r[53:, 20:45] = 2.0  # mosaic rows 53+ (the box starts at 50), cols 40–89
    r[41:, 60:85] = 3.0  # mosaic rows 41+ (the box starts at 40), cols 120–169
    r[:, 90:] = np.nan  # not scanned
    warp = Warp(focal, -1.0, 0.0, 60.0)  # u = 200 φ, v = 60 − h
    return image, CylindricalRange(r, phi, h, focal), warp


def test_range_edges_find_depth_jumps_and_not_the_scan_border():
    _, cylinder, _ = _box_scene()
    found = range_edges(cylinder)
    horizontal = found.axis == 1
    assert set(np.round(60 - found.h[horizontal], 1)) == {52.5, 40.5}
    vertical_u = np.round(200 * found.phi[~horizontal], 1)
    assert set(vertical_u) == {39.0, 89.0, 119.0, 169.0}
    assert np.all(found.r[horizontal] < 4)
    # segments: pieces of at most 12 points of one edge
    assert np.bincount(found.segment).max() <= 12 and found.segment.size == found.h.size


def test_match_edges_finds_the_offset_of_the_intensity_edge():
    image, cylinder, warp = _box_scene()
    found = range_edges(cylinder)
    positions = np.column_stack(warp.apply(found.phi, found.h))
    edges = intensity_edges(image)
    offset = match_edges(positions, found.axis, *edges, 5)
    tops = found.axis == 1
    first = tops & (found.r == 2.0)
    assert np.median(offset[first]) == pytest.approx(-3.0, abs=0.1)
    assert np.mean(np.abs(offset[first] + 3.0) < 0.6) > 0.9  # the box's corner is off
    _, agreement = match_segments(positions, found, *edges, 5)
    assert np.all(agreement[first] > 0.5)


def test_local_refinement_stretches_the_range_onto_the_intensity_edges():
    image, cylinder, warp = _box_scene()
    before = resample_range(cylinder, warp, image.shape)
    assert before[51, 60] == 6.0  # the box top is 3 px too low
    displacement, history = refine_local(image, cylinder, warp)
    after = resample_range(cylinder, warp, image.shape, displacement)
    assert after[51, 60] == 2.0 and after[48, 60] == 6.0
    assert after[41, 140] == 3.0 and after[38, 140] == 6.0
    # the misalignment averages every matched segment, also the box's sides, which are
    # matched within 0.5 px and need no stretch: it falls, and ends below 0.6 px
    assert history[-1]["misalignment"] < history[0]["misalignment"]
    assert history[-1]["misalignment"] < 0.6
    assert np.isnan(after[:, 185:]).all()  # not scanned stays unknown
    found = range_edges(cylinder)
    moved = _forward(warp, displacement, found.phi, found.h)
    tops = found.axis == 1
    expected = np.where(found.r[tops] == 2.0, 49.5, 39.5)
    error = np.abs(moved[tops, 1] - expected)
    # the tops, the segments the stretch must move: their error falls by more than half
    unstretched = np.abs(_forward(warp, None, found.phi, found.h)[tops, 1] - expected)
    assert np.mean(unstretched) > 2 * np.mean(error)
    # a smooth stretch between control points: exact in the middle of the tops, less at corners
    assert np.median(error) < 0.3 and np.mean(error < 0.75) > 0.8


def test_global_alignment_finds_the_offsets():
    image, cylinder, warp = _box_scene()
    shifted = Warp(warp.a, warp.b, warp.alpha - 6.0, warp.beta + 5.0)
    found, info = align_global(image, cylinder, shifted, fit_scale=False)
    # vertical depth edges lie between slices 2 px apart: α is known to about a pixel
    assert abs(found.alpha - warp.alpha) <= 1.0 and abs(info["shift"][0] - 6) <= 1
    # β settles between the two box tops, which are 3 and 1 px too low
    assert warp.beta - 3.5 <= found.beta <= warp.beta


# ----------------------------------------------------------------------------- the rig


@pytest.fixture(scope="module")
def small_rig():
    room = rig_room(2)
    views = render_views(room, n_views=5, start_angle=-0.6, height=200, supersample=2, seed=2)
    scan = laser_scan(room, phi_range=(-0.9, 0.9), seed=2)
    return room, views, scan


def test_register_scan_gives_registered_images_for_synthesize(small_rig):
    _, views, scan = small_rig
    intensity, partial, info = register_scan(
        views.images, views.pan_angles, views.focal, (scan.r, scan.theta, scan.phi)
    )
    assert intensity.shape == partial.shape and np.isfinite(intensity).all()
    known = np.isfinite(partial)
    assert 0.2 < known.mean() < 0.6  # stripes of 10 of every 25 slices
    assert np.nanmin(partial) > 0.5 and np.nanmax(partial) < 12
    errors = registration_errors(info, scan, views)
    assert errors["nominal"]["mean"] > 3.0
    assert errors["local"]["mean"] < 1.0
    assert errors["global"]["mean"] < 1.0


def test_registered_images_feed_synthesize(small_rig):
    import refsynth

    _, views, scan = small_rig
    intensity, partial, _ = register_scan(
        views.images, views.pan_angles, views.focal, (scan.r, scan.theta, scan.phi),
        refine=False,
    )
    window = (slice(40, 72), slice(100, 132))
    result = refsynth.synthesize(intensity[window], partial[window], seed=0)
    assert np.isfinite(result.range).all()


def test_register_is_deterministic(small_rig):
    _, views, scan = small_rig
    scan_tuple = (scan.r, scan.theta, scan.phi)
    first = register(views.images[:3], views.pan_angles[:3], views.focal, scan_tuple)
    second = register(views.images[:3], views.pan_angles[:3], views.focal, scan_tuple)
    assert np.array_equal(first.partial_range, second.partial_range, equal_nan=True)
    assert first.warp == second.warp


# ----------------------------------------------------------------------------- command line


def test_register_command_writes_the_registered_pair(small_rig, tmp_path, capsys):
    _, views, scan = small_rig
    names = []
    for k, view in enumerate(views.images[:3]):
        names.append(str(tmp_path / f"view{k}.npy"))
        np.save(names[-1], view)
    np.savez(tmp_path / "scan.npz", r=scan.r, theta=scan.theta, phi=scan.phi)
    parser = argparse.ArgumentParser()
    add_register_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(
        ["register", *names, "--scan", str(tmp_path / "scan.npz"), "--focal", "300",
         "--pan-step", "18", "--start", str(math.degrees(views.pan_angles[0])),
         "--out", str(tmp_path / "out")]
    )
    assert args.func(args) == 0
    intensity = np.load(tmp_path / "out" / "intensity.npy")
    partial = np.load(tmp_path / "out" / "partial_range.npy")
    assert intensity.shape == partial.shape
    assert "edge misalignment" in capsys.readouterr().out


def test_register_command_reports_user_errors(tmp_path):
    parser = argparse.ArgumentParser()
    add_register_parser(parser.add_subparsers(dest="command"))
    np.save(tmp_path / "view.npy", np.zeros((10, 10)))
    args = parser.parse_args(["register", str(tmp_path / "view.npy"), "--scan",
                              str(tmp_path / "none.npz"), "--focal", "300"])
    with pytest.raises(OSError, match="scan file not found"):
        args.func(args)
    np.savez(tmp_path / "bad.npz", r=np.ones(3))
    args = parser.parse_args(["register", str(tmp_path / "view.npy"), "--scan",
                              str(tmp_path / "bad.npz"), "--focal", "300"])
    with pytest.raises(ValueError, match="lacks the arrays"):
        args.func(args)
    (tmp_path / "junk.npz").write_text("not a zip")
    args = parser.parse_args(["register", str(tmp_path / "view.npy"), "--scan",
                              str(tmp_path / "junk.npz"), "--focal", "300"])
    with pytest.raises(ValueError, match="cannot read scan file"):
        args.func(args)


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "r, theta, phi, error, match",
    [
        (np.ones((2, 3)), np.ones(2), np.ones(2), ValueError, "shape"),
        (np.full((2, 3), np.nan), np.full(3, 1.5), [0.0, 0.1], ValueError, "no finite"),
        (-np.ones((2, 3)), np.full(3, 1.5), [0.0, 0.1], ValueError, "> 0"),
        (np.ones((2, 3)), np.array([0.0, 1.0, 1.5]), [0.0, 0.1], ValueError, "theta"),
        (np.ones((2, 3)), np.full(3, 1.5), [0.0, np.nan], ValueError, "phi"),
        (np.ones((2, 3), dtype=bool), np.full(3, 1.5), [0.0, 0.1], TypeError, "`r`"),
        (np.ones((2, 3)), np.array(["a", "b", "c"]), [0.0, 0.1], TypeError, "theta"),
    ],
)
def test_scans_are_validated(r, theta, phi, error, match):
    with pytest.raises(error, match=match):
        scan_to_cylinder(r, theta, phi, 300.0)


def test_other_scan_parameters_are_validated():
    theta, phi, r = np.full(3, 1.5) + [0, 0.01, 0.02], [0.0, 0.1], np.ones((2, 3))
    with pytest.raises(ValueError, match="h_range"):
        scan_to_cylinder(r, theta, phi, 300.0, h_range=(5.0, -5.0))
    with pytest.raises(ValueError, match="h_step"):
        scan_to_cylinder(r, theta, phi, 300.0, h_step=0.0)
    with pytest.raises(ValueError, match="focal"):
        scan_to_cylinder(r, theta, phi, -1.0)
    with pytest.raises(ValueError, match="theta"):
        spherical_to_cylindrical(1.0, 0.0, 0.0, 300.0)
    with pytest.raises(ValueError, match="points"):
        cartesian_to_spherical(np.zeros(2))


def test_warp_fits_are_validated():
    laser = np.array([[0.0, 1.0], [1.0, 2.0], [2.0, 0.0]])
    with pytest.raises(ValueError, match="at least 2"):
        fit_warp(laser[:1], laser[:1])
    with pytest.raises(ValueError, match="same shape"):
        fit_warp(laser, laser[:2])
    with pytest.raises(ValueError, match="distinct φ"):
        fit_warp(np.array([[0.5, 1.0], [0.5, 2.0]]), laser[:2])
    with pytest.raises(ValueError, match="distinct h"):
        fit_warp(np.array([[0.1, 1.0], [0.5, 1.0]]), laser[:2])
    with pytest.raises(ValueError, match="finite"):
        fit_warp(np.array([[0.1, np.nan], [0.5, 1.0]]), laser[:2])
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        fit_warp(np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="vary in both h and range"):
        fit_warp_eq20(np.array([[0.0, 5.0], [1.0, 5.0], [2.0, 5.0]]), np.ones(3), laser, 300.0)
    with pytest.raises(ValueError, match="`r`"):
        fit_warp_eq20(laser, -np.ones(3), laser, 300.0)
    with pytest.raises(ValueError, match="match in N"):
        fit_warp_eq20(laser, np.ones(2), laser, 300.0)


def test_registration_parameters_are_validated(small_rig):
    image, cylinder, warp = _box_scene()
    with pytest.raises(ValueError, match="axes"):
        refine_local(image, cylinder, warp, axes="xy")
    _, views, scan = small_rig
    scan_tuple = (scan.r, scan.theta, scan.phi)
    with pytest.raises(ValueError, match="one angle per image"):
        register(views.images, views.pan_angles[:2], views.focal, scan_tuple)
    with pytest.raises(ValueError, match="pan_angles"):
        register(views.images, np.full(5, np.nan), views.focal, scan_tuple)
    with pytest.raises(TypeError, match="scan"):
        register(views.images, views.pan_angles, views.focal, scan.r)
    flat = CylindricalRange(np.full((5, 5), 3.0), np.arange(5) * 0.01, 2.0 - np.arange(5),
                            300.0)
    with pytest.raises(ValueError, match="depth edges"):
        align_global(image, flat, warp)
