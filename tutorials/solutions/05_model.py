"""Solutions to the exercises of tutorial 5 (from range image to 3-D model, stage 3).

Run as ``python tutorials/solutions/05_model.py``; the test suite runs it
too. Each exercise prints its numbers and asserts the claims its answer
makes, so a change in refsynth that breaks an answer fails a test.
"""

import math

import numpy as np

from refsynth.model import (
    CylindricalCamera,
    PinholeCamera,
    Pose,
    alignment_error,
    build_model,
    disparity_to_depth,
    grid_faces,
    refine_poses,
)
from refsynth.scenes import cast_rays, rig_room

ROOM = rig_room(0)
SHAPE, FOCAL = (100, 628), 100.0
CAMERA = CylindricalCamera.panorama(FOCAL, SHAPE)
TRUE_POSES = [Pose(), Pose(x=0.8, z=-0.6, heading=math.radians(25.0))]


def true_scan(pose: Pose, seed: int = 0):
    """The tutorial's 360° scan from ``pose``: true range + 5 mm noise, and the true range."""
    rays = CAMERA.directions(SHAPE) @ pose.matrix()[:3, :3].T
    truth = cast_rays(ROOM, rays, origin=pose.matrix()[:3, 3]).distance
    return truth + np.random.default_rng(seed).normal(0.0, 0.005, SHAPE), truth


def exercise_1() -> None:
    """Choosing τ: 0.05 is the largest of the values that bridges no true jump.

    The number of triangles grows with τ (more of the grazing floor stays);
    from τ = 0.1 on, triangles start to bridge true jumps of 10 % or more —
    as they must, since the rule then lets jumps of up to 10 % per pixel
    through. At τ = 0.05 the floor keeps over 90 % of its triangles.
    """
    r, truth = true_scan(TRUE_POSES[0])
    points = CAMERA.back_project(r).reshape(-1, 3)
    rows = {}
    for tau in (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, None):
        faces = grid_faces(r, max_jump=tau, wrap=True)
        ranges = truth.ravel()[faces]
        jumps = int(np.sum(ranges.max(axis=1) > 1.1 * ranges.min(axis=1)))
        floor = int(np.sum((points[faces][..., 1] < -1.0).all(axis=1)))
        rows[tau] = (len(faces), jumps, floor)
        print(f"1. tau = {tau}: {len(faces)} triangles, {jumps} across a true jump, "
              f"{floor} on the floor")
    counts = [rows[t][0] for t in rows]
    assert counts == sorted(counts)  # more triangles as τ grows
    assert all(rows[t][1] == 0 for t in (0.01, 0.02, 0.05))
    assert all(rows[t][1] > 0 for t in (0.1, 0.2, 0.5, None))
    assert rows[0.05][2] > 0.9 * rows[None][2]
    assert rows[0.01][2] < 0.5 * rows[None][2]  # a strict τ loses the grazing floor


def exercise_2() -> None:
    """ICP reaches 1 cm up to 10°/50 cm of odometry error here, and fails beyond.

    At 20°/1 m the nearest points it pairs are on the wrong surfaces: it
    settles in a wrong minimum metres away — and still reports ``converged``,
    which only means it stopped moving. Only a measurement against the truth
    (or a look) tells.
    """
    models = [build_model(true_scan(pose, seed=k)[0], CAMERA)
              for k, pose in enumerate(TRUE_POSES)]
    errors = {}
    for degrees, cm in ((2, 10), (5, 30), (10, 50), (20, 100), (30, 150)):
        step = cm / 100 / math.sqrt(2)
        odometry = Pose(x=0.8 + step, z=-0.6 - step, heading=math.radians(25.0 + degrees))
        refined, results = refine_poses(models, [TRUE_POSES[0], odometry])
        error = float(np.median(alignment_error(models[1].vertices, refined[1],
                                                TRUE_POSES[1].matrix())))
        errors[degrees] = (error, results[1].converged)
        print(f"2. odometry off by {degrees} deg / {cm} cm: median error after ICP "
              f"{100 * error:.2f} cm, converged {results[1].converged}")
    assert all(errors[d][0] <= 0.01 for d in (2, 5, 10))
    assert all(errors[d][0] > 0.1 for d in (20, 30))
    assert all(converged for _, converged in errors.values())  # converged is not "right"


def exercise_3() -> None:
    """Depth from rounded disparity: the error grows as z².

    ``z = f B / (d + doffs)`` gives ``dz/dd = −z² / (f B)``: an error δd in
    disparity is an error of ``z² |δd| / (f B)`` in depth, to first order —
    which the rounded disparities follow pixel by pixel to within 1 %. The
    same 1/8 px (the worst of rounding to 1/4 px) costs a few millimetres at
    the nearest box and (z_far / z_near)² times as much on the far wall.
    """
    focal, baseline, doffs = 3979.911 / 4, 193.001, 124.343 / 4
    camera = PinholeCamera(focal, cx=1244.772 / 4, cy=1019.507 / 4)
    rays = camera.directions((500, 741))
    unit = rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    depth = 1000.0 * cast_rays(ROOM, unit).distance * unit[..., 2]  # mm, along the axis
    disparity = focal * baseline / depth - doffs
    exact = disparity_to_depth(disparity, focal, baseline, doffs)
    assert np.allclose(exact, depth, rtol=1e-12)  # the round trip without rounding
    rounded = np.round(disparity * 4) / 4
    error = np.abs(disparity_to_depth(rounded, focal, baseline, doffs) - depth)
    predicted = depth**2 * np.abs(rounded - disparity) / (focal * baseline)
    moved = predicted > 0
    ratio = float(np.median(error[moved] / predicted[moved]))
    near, far = float(depth.min()), float(depth.max())
    worst = [z**2 / (focal * baseline) / 8 for z in (near, far)]
    print(f"3. depth error / (z^2 |dd| / (f B)): median {ratio:.4f}; 1/8 px costs "
          f"{worst[0]:.1f} mm at {near:.0f} mm and {worst[1]:.1f} mm at {far:.0f} mm")
    assert abs(ratio - 1) < 0.01
    assert worst[1] > 10 * worst[0]
    assert np.isfinite(camera.back_project(exact)).all()


if __name__ == "__main__":
    exercise_1()
    exercise_2()
    exercise_3()
