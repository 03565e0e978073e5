"""Stage 3 with several scan positions: poses, one world frame, fusion, ICP refinement."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refsynth.model import (
    CylindricalCamera,
    Pose,
    alignment_error,
    apply_transform,
    build_model,
    estimate_normals,
    icp,
    merge_models,
    pose_matrix,
    refine_poses,
    transform_model,
)

# ----------------------------------------------------------------------------- a box room

#: The room's inside (lower, upper corners) and two solid boxes (lower, upper corners), in m.
ROOM = (np.array([-4.0, -1.2, -5.0]), np.array([5.0, 1.8, 4.5]))
BOXES = [(np.array([1.0, -1.2, 1.5]), np.array([2.0, 0.0, 2.4])),
         (np.array([-3.0, -1.2, -2.5]), np.array([-2.2, 0.6, -1.0]))]


def _cast(origin: np.ndarray, rays: np.ndarray) -> np.ndarray:
    """Distance along unit ``rays`` from ``origin`` to the box room's first surface."""
    with np.errstate(divide="ignore", invalid="ignore"):
        exits = np.where(rays > 0, (ROOM[1] - origin) / rays,
                         np.where(rays < 0, (ROOM[0] - origin) / rays, np.inf))
        distance = exits.min(axis=-1)
        for lower, upper in BOXES:
            a, b = (lower - origin) / rays, (upper - origin) / rays
            near = np.nanmax(np.minimum(a, b), axis=-1)
            far = np.nanmin(np.maximum(a, b), axis=-1)
            hit = (near <= far) & (near > 0)
            distance = np.where(hit & (near < distance), near, distance)
    return distance


def _scan(pose: Pose, shape=(60, 314), focal=50.0, noise=0.0, seed=0):
    """A 360° cylindrical scan of the box room from ``pose``: (range, camera)."""
    camera = CylindricalCamera.panorama(focal, shape)
    rays = camera.directions(shape) @ pose.matrix()[:3, :3].T
    r = _cast(pose.matrix()[:3, 3], rays)
    if noise:
        r = r + np.random.default_rng(seed).normal(0.0, noise, r.shape)
    return r, camera


POSES = [Pose(), Pose(x=1.0, z=-0.8, heading=math.radians(35.0), y=0.1)]


# ----------------------------------------------------------------------------- poses


def test_heading_turns_pan_angles_in_their_own_sense():
    pose = Pose(heading=math.radians(30.0))
    phi = math.radians(20.0)
    world = pose.apply([math.sin(phi), 0.0, math.cos(phi)])
    assert math.isclose(math.atan2(world[0], world[2]), math.radians(50.0), abs_tol=1e-12)


@settings(deadline=None)
@given(x=st.floats(-10, 10), z=st.floats(-10, 10), y=st.floats(-2, 2),
       heading=st.floats(-3.1, 3.1))
def test_pose_matrix_is_rigid_and_round_trips(x, z, y, heading):
    pose = Pose(x=x, z=z, heading=heading, y=y)
    matrix = pose.matrix()
    np.testing.assert_allclose(matrix[:3, :3] @ matrix[:3, :3].T, np.eye(3), atol=1e-15)
    back = Pose.from_matrix(matrix)
    assert (back.x, back.y, back.z) == (x, y, z)
    assert math.isclose(back.heading, heading, abs_tol=1e-12)


def test_pose_matrix_refuses_what_is_not_rigid():
    with pytest.raises(ValueError, match="rigid"):
        pose_matrix(np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="4x4"):
        pose_matrix(np.eye(3))
    with pytest.raises(ValueError, match="`heading`"):
        Pose(heading=math.inf)


# ----------------------------------------------------------------------------- merging


def test_the_scans_of_a_room_land_on_the_same_surfaces():
    models = [build_model(*_scan(p)) for p in POSES]
    world = [transform_model(m, p) for m, p in zip(models, POSES)]
    for model in world:  # every point on a wall, the floor, the ceiling or a box face
        v = model.vertices
        on_room = np.min(np.abs(np.concatenate([v - ROOM[0], v - ROOM[1]], axis=1)), axis=1)
        on_box = np.min([np.min(np.abs(np.concatenate([v - lo, v - hi], axis=1)), axis=1)
                         for lo, hi in BOXES], axis=0)
        assert np.all(np.minimum(on_room, on_box) < 1e-9)


def test_one_scan_alone_is_never_thinned():
    model = build_model(*_scan(POSES[1]))
    merged = merge_models([model], [POSES[1]], voxel=0.5)
    assert merged.n_vertices == model.n_vertices and merged.n_faces == model.n_faces
    np.testing.assert_array_equal(merged.vertices, POSES[1].apply(model.vertices))


def test_a_scan_repeated_from_the_same_pose_adds_nothing():
    model = build_model(*_scan(POSES[0]))
    merged = merge_models([model, model], [POSES[0], POSES[0]])
    assert merged.n_vertices == model.n_vertices and (merged.source == 0).all()
    assert merged.n_faces == model.n_faces


def test_the_overlap_is_not_twice_as_dense():
    poses = [Pose(), Pose(x=0.3, z=0.2)]
    models = [build_model(*_scan(p)) for p in poses]
    merged = merge_models(models, poses)
    total = sum(m.n_vertices for m in models)
    assert merged.n_vertices < 0.65 * total
    assert set(np.unique(merged.source)) == {0, 1}
    assert merged.faces.max() < merged.n_vertices


def test_the_more_confident_scan_keeps_the_overlap():
    r, camera = _scan(POSES[0])
    confident = build_model(r, camera)
    doubtful = build_model(r, camera, confidence=np.full(r.shape, 0.4))
    merged = merge_models([doubtful, confident], [POSES[0], POSES[0]])
    assert (merged.source == 1).all() and (merged.confidence == 1).all()


def test_merge_models_checks_its_inputs():
    model = build_model(*_scan(POSES[0], shape=(8, 16)))
    with pytest.raises(ValueError, match="`models` and `poses`"):
        merge_models([model], [])
    with pytest.raises(TypeError, match="`models`"):
        merge_models(["model"], [Pose()])
    with pytest.raises(ValueError, match="`voxel`"):
        merge_models([model, model], [Pose(), Pose()], voxel=0.0)


# ----------------------------------------------------------------------------- ICP


def test_normals_of_a_plane_are_its_normal():
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.random(300), rng.random(300), np.full(300, 2.0)])
    normals = estimate_normals(points)
    np.testing.assert_allclose(np.abs(normals[:, 2]), 1.0, atol=1e-12)


@pytest.mark.parametrize("dof", [6, 4])
def test_icp_recovers_a_known_motion_of_the_room(dof):
    models = [build_model(*_scan(p)) for p in POSES]
    target = transform_model(models[0], POSES[0]).vertices
    true = POSES[1].matrix()
    odometry = Pose(x=1.0 + 0.07, z=-0.8 - 0.07, heading=math.radians(37.0), y=0.1).matrix()
    result = icp(models[1].vertices, target, odometry, dof=dof)
    assert result.converged
    error = alignment_error(models[1].vertices, result.transform, true)
    assert np.median(error) < 1e-4
    assert np.median(alignment_error(models[1].vertices, odometry, true)) > 0.05


def test_refine_poses_aligns_noisy_scans_to_a_centimetre():
    models = [build_model(*_scan(p, noise=0.005, seed=k)) for k, p in enumerate(POSES)]
    odometry = [POSES[0], Pose(x=1.0 - 0.0707, z=-0.8 + 0.0707, heading=math.radians(33.0),
                               y=0.1)]
    refined, results = refine_poses(models, odometry)
    assert results[0] is None and results[1].converged
    np.testing.assert_array_equal(refined[0], POSES[0].matrix())
    error = alignment_error(models[1].vertices, refined[1], POSES[1].matrix())
    assert np.median(error) <= 0.01


def test_apply_transform_and_icp_check_their_inputs():
    with pytest.raises(ValueError, match="`transform`"):
        apply_transform(np.eye(3), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="`source`"):
        icp(np.zeros((4, 2)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="`dof`"):
        icp(np.zeros((4, 3)), np.random.default_rng(0).random((10, 3)), dof=5)


# ----------------------------------------------------------------------------- the rig's room


def _rig():
    try:
        from refsynth.scenes import cast_rays, rig_room
    except ImportError:  # pragma: no cover - the scenes package is being reorganised
        pytest.skip("refsynth.scenes does not export rig_room and cast_rays")
    return rig_room, cast_rays


@pytest.mark.slow
def test_two_poses_in_the_rig_room_refined_to_a_centimetre():
    rig_room, cast_rays = _rig()
    room = rig_room(0)
    shape, focal = (100, 628), 100.0
    camera = CylindricalCamera.panorama(focal, shape)
    poses = [Pose(), Pose(x=0.8, z=-0.6, heading=math.radians(25.0))]
    rng = np.random.default_rng(0)
    models, truth = [], []
    for pose in poses:
        rays = camera.directions(shape) @ pose.matrix()[:3, :3].T
        hits = cast_rays(room, rays, origin=pose.matrix()[:3, 3])
        truth.append(pose.apply(camera.back_project(hits.distance)))  # world frame
        r = hits.distance + rng.normal(0.0, 0.005, shape)  # 5 mm range noise
        intensity = np.clip(hits.albedo * hits.shading, 0, 1)
        models.append(build_model(r, camera, intensity=intensity))
    odometry = Pose(x=0.8 + 0.0707, z=-0.6 - 0.0707, heading=math.radians(27.0))  # 2°, 10 cm
    before = alignment_error(models[1].vertices, odometry.matrix(), poses[1].matrix())
    refined, _ = refine_poses(models, [poses[0], odometry])
    after = alignment_error(models[1].vertices, refined[1], poses[1].matrix())
    assert np.median(before) > 0.1
    assert np.median(after) <= 0.01
    merged = merge_models(models, refined)
    assert merged.n_vertices < 0.8 * sum(m.n_vertices for m in models)
    # each merged point is near the true surface point of its scan's pixel
    true_points = np.stack(truth)[merged.source, merged.pixels[:, 0], merged.pixels[:, 1]]
    assert np.median(np.linalg.norm(merged.vertices - true_points, axis=1)) <= 0.01
