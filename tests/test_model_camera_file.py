"""``register`` writes camera.json; ``model --camera-file`` reads it."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_rig_scan_tampering import fake_scan  # noqa: E402

from refsynth.acquisition import ScanSettings  # noqa: E402
from refsynth.cli.main import main  # noqa: E402
from refsynth.cli.model import read_camera_file, write_camera_file  # noqa: E402
from refsynth.model import CylindricalCamera, PinholeCamera, read_ply  # noqa: E402
from refsynth.plotting.story_truth import surface_distance  # noqa: E402
from refsynth.scenes import room_geometry  # noqa: E402


@pytest.mark.parametrize("camera", [
    CylindricalCamera(300.0, cx=486.25241019837836, cy=115.88487829585588,
                      phi_step=1 / 300.0, h_step=1.0),
    CylindricalCamera(123.4, cx=-3.5, cy=7.25, phi_step=0.01, h_step=0.5),
    PinholeCamera(995.5, cx=12.25, cy=-4.0),
])
def test_the_camera_file_round_trips_exactly(tmp_path, camera):
    path = write_camera_file(tmp_path / "camera.json", camera, (20, 30))
    assert read_camera_file(path) == (camera, (20, 30))


@pytest.fixture(scope="module")
def registered(tmp_path_factory):
    """The README's scan (stripes, 40 %), registered by the command line."""
    base = tmp_path_factory.mktemp("camera-file")
    fake_scan(base / "scan", ScanSettings())
    assert main(["register", "--scan", str(base / "scan"), "--out", str(base / "reg")]) == 0
    partial = np.load(base / "reg" / "partial_range.npy")
    dense = np.where(np.isfinite(partial), partial, np.nanmedian(partial))
    np.save(base / "reg" / "dense.npy", dense)
    return base / "reg"


def test_register_writes_the_camera_of_its_warp(registered):
    record = json.loads((registered / "camera.json").read_text())
    intensity = np.load(registered / "intensity.npy")
    assert record["format"] == "refsynth-camera/1" and record["camera"] == "cylindrical"
    assert record["shape"] == list(intensity.shape[:2])
    row0, _, col0, _ = record["crop"]
    assert record["cx"] == record["warp"]["alpha"] - col0
    assert record["cy"] == record["warp"]["beta"] - row0
    assert record["phi_step_rad"] == 1.0 / record["warp"]["a"]


def _measured_surface_distance(ply: Path) -> float:
    model = read_ply(ply)
    return float(np.median(surface_distance(room_geometry(0),
                                            model.vertices[~model.synthesized])))


def test_model_with_the_camera_file_puts_the_measured_points_on_the_room(registered, capsys):
    """The simulated rig stands at the room's origin: its measured points lie on the true
    surfaces with the camera file (to a few mm), a centred camera is centimetres off."""
    dense, partial = str(registered / "dense.npy"), str(registered / "partial_range.npy")
    out = registered / "room.ply"
    assert main(["model", dense, "--camera-file", str(registered / "camera.json"),
                 "--partial", partial, "--out", str(out)]) == 0
    camera, _ = read_camera_file(registered / "camera.json")
    model = read_ply(out)
    # the dense range is finite everywhere: one vertex per pixel, in raster order
    np.testing.assert_array_equal(model.vertices,
                                  camera.back_project(np.load(dense)).reshape(-1, 3))
    centred = registered / "centred.ply"
    assert main(["model", dense, "--focal", "300", "--partial", partial,
                 "--out", str(centred)]) == 0
    assert _measured_surface_distance(out) < 0.005 < _measured_surface_distance(centred)


@pytest.mark.parametrize("extra, message", [
    (["--focal", "300"], "--camera-file gives the camera: drop --focal"),
    (["--camera", "pinhole", "--cx", "3"], "drop --camera, --cx"),
])
def test_camera_file_with_camera_options_is_an_error(registered, capsys, extra, message):
    argv = ["model", str(registered / "dense.npy"), "--camera-file",
            str(registered / "camera.json"), "--out", str(registered / "x.ply"), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


@pytest.mark.parametrize("content, message", [
    ("{", "cannot read"),
    ('{"format": "other"}', "is not a camera file"),
    ('{"format": "refsynth-camera/1", "camera": "fisheye"}', "must be 'cylindrical'"),
    ('{"format": "refsynth-camera/1", "camera": "pinhole", "focal": 1, "cx": "a", "cy": 0}',
     "must be finite numbers"),
    ('{"format": "refsynth-camera/1", "camera": "pinhole", "focal": 1, "cx": 0, "cy": 0, '
     '"shape": [3, 4]}', "is the camera of a 3x4 image"),
])
def test_a_bad_or_mismatched_camera_file_gives_one_line(registered, tmp_path, capsys,
                                                        content, message):
    path = tmp_path / "camera.json"
    path.write_text(content)
    argv = ["model", str(registered / "dense.npy"), "--camera-file", str(path),
            "--out", str(tmp_path / "x.ply")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
