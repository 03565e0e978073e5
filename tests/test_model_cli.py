"""``python -m refsynth model``: build and merge PLY models; errors exit 2 with one line."""

import argparse
import json
import math
import sys

import numpy as np
import pytest

from refsynth.cli.model import add_model_parser, read_poses
from refsynth.model import CylindricalCamera, PinholeCamera, Pose, read_ply, write_ply


def _main(argv):
    """``refsynth.cli.main.main`` with only the model subcommand (the same error handling)."""
    parser = argparse.ArgumentParser(prog="python -m refsynth")
    sub = parser.add_subparsers(dest="command", required=True)
    add_model_parser(sub)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, TypeError, OSError, ImportError) as exc:
        print(f"refsynth {args.command}: error: {exc}", file=sys.stderr)
        return 2


@pytest.fixture
def room(tmp_path):
    """A 360° panorama: a wall at 5 m with a box at 2.5 m; grey intensity; confidence."""
    shape = (30, 188)  # 2π · 30 ≈ 188 columns: f = 30 px closes the circle
    r = np.full(shape, 5.0)
    r[10:20, 40:60] = 2.5
    rng = np.random.default_rng(0)
    intensity = rng.integers(0, 256, shape).astype(np.uint8)
    partial = np.where(np.arange(shape[1]) % 3 == 0, r, np.nan)
    confidence = np.where(np.isfinite(partial), 1.0, 0.6)
    for name, array in [("dense", r), ("intensity", intensity), ("partial", partial),
                        ("confidence", confidence)]:
        np.save(tmp_path / f"{name}.npy", array)
    return tmp_path, r, intensity, partial


def test_model_writes_a_cylindrical_ply(room, capsys):
    folder, r, intensity, partial = room
    out = folder / "out" / "room.ply"
    code = _main(["model", str(folder / "dense.npy"), "--intensity",
                  str(folder / "intensity.npy"), "--camera", "cylindrical", "--focal", "30",
                  "--confidence", str(folder / "confidence.npy"), "--partial",
                  str(folder / "partial.npy"), "--out", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert f"wrote {out}" in text and "dropped at depth jumps" in text
    model = read_ply(out)
    assert model.n_vertices == r.size
    camera = CylindricalCamera.centred(30.0, r.shape)
    np.testing.assert_array_equal(model.vertices, camera.back_project(r).reshape(-1, 3))
    np.testing.assert_array_equal(model.colours[:, 0], intensity.ravel())
    assert model.synthesized.tolist() == (~np.isfinite(partial)).ravel().tolist()
    np.testing.assert_array_equal(model.confidence, np.where(np.isfinite(partial), 1.0,
                                                             np.float32(0.6)).ravel())
    # the box's edges are not bridged; the panorama closes (f = 30 px, 188 columns)
    near = (r.ravel() < 3)[model.faces]
    assert np.all(near.all(axis=1) | ~near.any(axis=1))
    cols = model.faces % r.shape[1]
    assert np.any((cols.min(axis=1) == 0) & (cols.max(axis=1) == r.shape[1] - 1))


def test_max_jump_off_keeps_the_curtain_and_ascii_writes_text(room, capsys):
    folder, r, _, _ = room
    out = folder / "curtain.ply"
    assert _main(["model", str(folder / "dense.npy"), "--focal", "30", "--max-jump", "off",
                  "--ascii", "--out", str(out)]) == 0
    assert "(0 dropped" in capsys.readouterr().out
    assert out.read_bytes().startswith(b"ply\nformat ascii 1.0\n")
    assert read_ply(out).n_faces == 2 * 29 * 188


def test_model_from_a_disparity_with_the_pinhole(tmp_path):
    disparity = np.full((20, 30), 40.0)
    disparity[5:10, 5:10] = 80.0
    disparity[0, 0] = np.inf  # Middlebury's unknown
    np.save(tmp_path / "disp.npy", disparity.astype(np.float32))
    out = tmp_path / "pinhole.ply"
    assert _main(["model", str(tmp_path / "disp.npy"), "--camera", "pinhole", "--focal", "500",
                  "--cx", "14.5", "--cy", "9.5", "--disparity", "--baseline", "100",
                  "--doffs", "10", "--float32", "--out", str(out)]) == 0
    model = read_ply(out)
    depth = np.where(np.isfinite(disparity), 500 * 100 / (disparity + 10), np.nan)
    expected = PinholeCamera(500.0, 14.5, 9.5).back_project(depth)[np.isfinite(depth)]
    np.testing.assert_array_equal(model.vertices, expected.astype(np.float32))


def test_merge_two_plys_by_their_poses_and_refine(tmp_path, capsys):
    shape = (40, 126)
    camera = CylindricalCamera.panorama(20.0, shape)
    rng = np.random.default_rng(1)

    def scan(pose):  # inside a 10 x 4 x 12 m box room
        rays = camera.directions(shape) @ pose.matrix()[:3, :3].T
        origin = pose.matrix()[:3, 3]
        lower, upper = np.array([-5.0, -1.5, -6.0]), np.array([5.0, 2.5, 6.0])
        with np.errstate(divide="ignore"):
            t = np.where(rays > 0, (upper - origin) / rays,
                         np.where(rays < 0, (lower - origin) / rays, np.inf)).min(axis=-1)
        return t + rng.normal(0, 0.002, shape)

    from refsynth.model import build_model

    poses = [Pose(), Pose(x=0.5, z=0.3, heading=math.radians(10.0))]
    names = []
    for k, pose in enumerate(poses):
        names.append(str(write_ply(tmp_path / f"scan{k}.ply", build_model(scan(pose), camera))))
    (tmp_path / "poses.json").write_text(json.dumps(
        [{"x": 0, "z": 0, "heading": 0}, {"x": 0.55, "z": 0.25, "heading": 11.0}]))
    out = tmp_path / "world.ply"
    assert _main(["model", "--merge", *names, "--poses", str(tmp_path / "poses.json"),
                  "--refine", "--poses-out", str(tmp_path / "refined.json"),
                  "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "refined" in text and "fused away" in text
    refined = read_poses(tmp_path / "refined.json")
    assert abs(refined[1][0, 3] - 0.5) < 0.02 and abs(refined[1][2, 3] - 0.3) < 0.02
    merged = read_ply(out)
    assert 0 < merged.n_vertices < 2 * shape[0] * shape[1]


@pytest.mark.parametrize("argv, message", [
    (["model", "--out", "x.ply"], "give a dense range"),
    (["model", "{dense}", "--out", "x.ply"], "--focal is required"),
    (["model", "{dense}", "--focal", "30", "--out", "x.obj"], "--out must end in .ply"),
    (["model", "{dense}", "--focal", "30", "--disparity", "--out", "x.ply"], "pinhole"),
    (["model", "{dense}", "--camera", "pinhole", "--focal", "30", "--disparity",
      "--out", "x.ply"], "--baseline"),
    (["model", "{dense}", "--focal", "30", "--baseline", "1", "--out", "x.ply"],
     "are for --disparity"),
    (["model", "{missing}", "--focal", "30", "--out", "x.ply"], "range file not found"),
    (["model", "{dense}", "--focal", "30", "--intensity", "{small}", "--out", "x.ply"],
     "intensity shape"),
    (["model", "{dense}", "--focal", "30", "--poses", "p.json", "--out", "x.ply"],
     "are for --merge"),
    (["model", "--merge", "a.ply", "--out", "x.ply"], "needs --poses"),
    (["model", "--merge", "{ply}", "--poses", "{poses}", "--out", "x.ply"], "holds 2 poses"),
    (["model", "{dense}", "--focal", "30", "--min-confidence", "2", "--out", "x.ply"],
     "`min_confidence`"),
])
def test_errors_print_one_line_and_exit_2(room, capsys, argv, message):
    folder = room[0]
    np.save(folder / "small.npy", np.zeros((3, 3)))
    (folder / "poses.json").write_text(json.dumps([{"x": 0}, {"x": 1}]))
    ply = write_ply(folder / "one.ply", read_ply_model())
    names = dict(dense=folder / "dense.npy", missing=folder / "nope.npy",
                 small=folder / "small.npy", ply=ply, poses=folder / "poses.json")
    argv = [a.format(**names) if "{" in a else a for a in argv]
    argv = [str(folder / a) if a == "x.ply" or a == "x.obj" else a for a in argv]
    assert _main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("refsynth model: error:") and message in err[0]


def read_ply_model():
    from refsynth.model import build_model

    return build_model(np.full((3, 4), 2.0), PinholeCamera(10.0, 1.5, 1.0))


def test_bad_max_jump_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        _main(["model", "d.npy", "--max-jump", "-1", "--out", "x.ply"])
    assert exit_.value.code == 2


def test_read_poses_accepts_poses_and_matrices(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps([{"x": 1, "z": 2, "heading": 90, "y": 0.5},
                                {"matrix": np.eye(4).tolist()}]))
    first, second = read_poses(path)
    np.testing.assert_allclose(first, Pose(1.0, 2.0, math.pi / 2, 0.5).matrix())
    np.testing.assert_array_equal(second, np.eye(4))
    path.write_text(json.dumps([{"heading_deg": 3}]))
    with pytest.raises(ValueError, match="unknown keys"):
        read_poses(path)
    path.write_text("{")
    with pytest.raises(ValueError, match="JSON"):
        read_poses(path)


def _wired() -> bool:
    import refsynth.cli.main

    return "add_model_parser" in vars(refsynth.cli.main)


@pytest.mark.skipif(not _wired(), reason="refsynth.cli.main does not add `model` yet")
def test_python_m_refsynth_model_is_wired(room):
    from refsynth.cli.main import main

    folder = room[0]
    assert main(["model", str(folder / "dense.npy"), "--focal", "30",
                 "--out", str(folder / "m.ply")]) == 0
    assert main(["model", str(folder / "dense.npy"), "--out", str(folder / "m.ply")]) == 2
