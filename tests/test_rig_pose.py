"""The simulated rig scans from a pose: the room seen from there, consistently."""

import json
import math

import numpy as np
import pytest

from refsynth.acquisition import RigPose, RoomRig, load_scan
from refsynth.acquisition.geometry import directions, pan_angle, polar_angle
from refsynth.cli.main import main
from refsynth.model import Pose
from refsynth.plotting.story_truth import surface_distance
from refsynth.scenes import cast_rays

SHIFTED = RigPose(x=1.0, z=0.8, heading=math.radians(-20.0))
PANS = np.arange(0, 500, 25)
WINDOW = (379, 243)  # the scans' encoder window


def _slice_points(rig: RoomRig, pan: int, seq: int, count: int) -> np.ndarray:
    """A noise-free slice as points in the rig's own frame (NaN where nothing is hit)."""
    r = rig.truth(pan, seq, count)
    rays = directions(polar_angle(np.arange(seq, seq + count)), pan_angle(pan))
    return rays * np.where(np.isfinite(r), r, np.nan)[:, None]


def test_the_pose_is_refsynth_model_pose():
    pose = RigPose(x=0.3, z=-0.2, heading=math.radians(35.0))
    points = np.random.default_rng(0).normal(size=(20, 3))
    model = Pose(x=pose.x, z=pose.z, heading=pose.heading)
    np.testing.assert_allclose(pose.to_room(points), model.apply(points), atol=1e-12)
    assert RigPose.from_dict(pose.as_dict()).as_dict() == pose.as_dict()
    assert pose.as_dict() == {"x": 0.3, "z": -0.2, "heading": 35.0}
    assert RigPose().is_origin and not pose.is_origin


def test_the_default_pose_is_the_room_centre_exactly():
    plain, origin = RoomRig(seed=2), RoomRig(seed=2, pose=RigPose())
    for pan in (0, 250, 499):
        np.testing.assert_array_equal(plain.truth(pan, 0, 2000), origin.truth(pan, 0, 2000))
        for a, b in zip(plain.measure(pan, *WINDOW, 10), origin.measure(pan, *WINDOW, 10)):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(plain.picture(275), origin.picture(275))


def test_points_from_a_shifted_pose_land_on_the_room_s_surfaces():
    """Every point measured from the pose, put in the room's frame by refsynth.model.Pose,
    lies on a true surface; those the origin sees too are where the origin measures them."""
    shifted, centre = RoomRig(seed=0, pose=SHIFTED), RoomRig(seed=0)
    pose = Pose(x=SHIFTED.x, z=SHIFTED.z, heading=SHIFTED.heading)
    points = np.concatenate([_slice_points(shifted, int(p), *WINDOW) for p in PANS])
    points = points[np.isfinite(points).all(axis=1)]
    world = pose.apply(points)
    assert len(world) > 0.9 * len(PANS) * WINDOW[1]
    assert np.max(surface_distance(centre.room, world)) < 1e-9
    # seen from the origin: no point floats in front of a surface, most are hit exactly
    reach = np.linalg.norm(world, axis=1)
    hits = cast_rays(centre.room, world / reach[:, None]).distance
    assert np.all(hits <= reach + 1e-9)
    assert np.mean(np.abs(hits - reach) < 1e-9) > 0.6
    # and not by chance: the opposite heading puts most points off every surface
    wrong = Pose(x=SHIFTED.x, z=SHIFTED.z, heading=-SHIFTED.heading).apply(points)
    assert np.mean(surface_distance(centre.room, wrong) > 0.01) > 0.5


def test_the_heading_turns_the_pan_angle():
    """Heading k pan steps to the right: pan index i sees what the origin sees at i + k."""
    turned = RoomRig(seed=1, pose=RigPose(heading=math.radians(50 * 0.36)))
    centre = RoomRig(seed=1)
    for pan in (0, 120, 400):
        np.testing.assert_allclose(turned.truth(pan, *WINDOW), centre.truth(pan + 50, *WINDOW),
                                   rtol=1e-9)


def test_the_pictures_follow_the_pose():
    moved = RoomRig(seed=0, pose=RigPose(z=1.5))
    assert not np.array_equal(moved.picture(275), RoomRig(seed=0).picture(275))


@pytest.mark.parametrize("pose, message", [
    (RigPose(x=9.0), "not inside the room"),
    (RigPose(z=50.0), "not inside the room"),
    (RigPose(x=-1.0, z=4.4), "inside a piece of furniture"),
])
def test_a_pose_outside_the_room_or_in_furniture_is_refused(pose, message):
    with pytest.raises(ValueError, match=message):
        RoomRig(seed=0, pose=pose)


def test_scan_pose_is_recorded_and_the_scan_lands_on_the_surfaces(tmp_path, capsys):
    pytest.importorskip("pty")
    out = tmp_path / "scan"
    argv = ["scan", "--simulate", "--out", str(out), "--strategy", "every", "--step", "25",
            "--no-camera", "--quiet", "--pose", "1,0.8,-20"]
    assert main(argv) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["source"]["pose"] == {"x": 1.0, "z": 0.8, "heading": -20.0}
    scan = load_scan(out)
    sphere = np.stack([np.sin(scan.theta) * np.sin(scan.phi), np.cos(scan.theta),
                       np.sin(scan.theta) * np.cos(scan.phi)], axis=-1) * scan.r[..., None]
    points = sphere.reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1)]
    world = Pose(x=1.0, z=0.8, heading=math.radians(-20.0)).apply(points)
    distance = surface_distance(RoomRig(seed=0).room, world)
    assert np.median(distance) < 0.005 and np.mean(distance < 0.03) > 0.99
    capsys.readouterr()
    # resuming keeps the pose; another pose is refused in one line
    assert main(argv[:-2] + ["--resume"]) == 0
    assert main(argv[:-1] + ["1,0.9,-20", "--resume"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--pose differs" in err[0]


@pytest.mark.parametrize("value", ["1,2", "a,b,c", "1,1,nan", "0,0,400"])
def test_a_bad_pose_is_an_argparse_error(tmp_path, capsys, value):
    assert main(["scan", "--simulate", "--out", str(tmp_path / "s"), f"--pose={value}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--pose" in err[0]
    assert not (tmp_path / "s").exists()
