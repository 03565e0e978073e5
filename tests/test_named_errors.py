"""Errors a file or an argument can cause name it, in one line (no bare library text).

Malformed PLY files (ASCII and binary), malformed poses and camera files, and
ragged ``edges`` lists passed to ``synthesize``; through the command line, one
line on stderr and exit status 2.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

import refsynth
from refsynth.cli.main import main
from refsynth.cli.model import read_camera_file, read_poses
from refsynth.model import PinholeCamera, build_model, read_ply, write_ply

_HEAD = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\n{extra}element face 1\nproperty list uchar int vertex_indices\n"
         "end_header\n")
_GOOD = "0 0 1\n1 0 1\n0 1 1\n3 0 1 2\n"


@pytest.mark.parametrize(("extra", "body", "match"), [
    ("", "0 0 1\n1 abc 1\n0 1 1\n3 0 1 2\n", r"vertex 1 \(data line 2\): 'abc' is not a number"),
    ("", "0 0 1\n1 0\n0 1 1\n3 0 1 2\n", r"vertex 1 \(data line 2\) has 2 values, expected 3"),
    ("", "0 0 1\n1 0 1 7\n0 1 1\n3 0 1 2\n", r"vertex 1 \(data line 2\) has 4 values"),
    ("", "0 0 1\n1 0 1\n0 1 1\n4 0 1 2 0\n", "face 0 .* has 4 vertices: only triangular"),
    ("", "0 0 1\n1 0 1\n0 1 1\n3 0 1\n", r"face 0 \(data line 4\) has 3 values, expected 4"),
    ("", "0 0 1\n1 0 1\n0 1 1\n3 0 1 x\n", "'x' is not an integer"),
    ("", "0 0 1\n1 0 1\n0 1 1\nthree 0 1 2\n", "'three' is not a vertex count"),
    ("", "0 0 1\nnan 0 1\n0 1 1\n3 0 1 2\n", r"vertex 1 has a non-finite coordinate"),
    ("", "0 0 1\n1 0 1\n0 1e60 1\n3 0 1 2\n", r"vertex 2 has a non-finite coordinate"),
    ("", "0 0 1\n1 0 1\n0 1 1\n3 0 1 5\n", "a face indexes a vertex that is not there"),
    ("property float x\n", "0 0 1 0\n1 0 1 0\n0 1 1 0\n3 0 1 2\n",
     "the vertex element declares the property 'x' twice"),
    ("property uchar red\n", "0 0 1 3\n1 0 1 300\n0 1 1 0\n3 0 1 2\n",
     r"'red' \(uint8\) holds 300, not an integer in 0..255"),
    ("property float confidence\n", "0 0 1 1\n1 0 1 nan\n0 1 1 0\n3 0 1 2\n",
     r"confidence must lie in \[0, 1\]"),
])
def test_malformed_ascii_ply_names_the_file_and_the_line(tmp_path, extra, body, match):
    path = tmp_path / "bad.ply"
    path.write_text(_HEAD.format(extra=extra) + body)
    with pytest.raises(ValueError, match=f"Cannot read '{path}'.*{match}"):
        read_ply(path)


def test_the_well_formed_ascii_ply_reads(tmp_path):
    path = tmp_path / "good.ply"
    path.write_text(_HEAD.format(extra="") + _GOOD)
    model = read_ply(path)
    assert model.n_vertices == 3 and model.faces.tolist() == [[0, 1, 2]]


def _binary(vertices: list[tuple[float, float, float]], faces: list[list[int]]) -> bytes:
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(vertices)}\nproperty double x\nproperty double y\n"
              f"property double z\nelement face {len(faces)}\n"
              "property list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack("<3d", *v) for v in vertices)
    body += b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in faces)
    return header + body


@pytest.mark.parametrize(("vertices", "faces", "match"), [
    ([(0, 0, 1), (np.inf, 0, 1), (0, 1, 1)], [[0, 1, 2]], "vertex 1 has a non-finite"),
    ([(0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)], [[0, 1, 2, 3]], "only triangular faces"),
])
def test_malformed_binary_ply_names_the_file(tmp_path, vertices, faces, match):
    path = tmp_path / "bad.ply"
    path.write_bytes(_binary(vertices, faces))
    with pytest.raises(ValueError, match=f"Cannot read '{path}'.*{match}"):
        read_ply(path)


def test_model_merge_of_a_malformed_ply_is_one_line(tmp_path, capsys):
    good = write_ply(tmp_path / "good.ply",
                     build_model(np.full((3, 4), 2.0), PinholeCamera(10.0, 1.5, 1.0)))
    (tmp_path / "bad.ply").write_text(_HEAD.format(extra="") + "0 0 1\n1 abc 1\n0 1 1\n3 0 1 2\n")
    (tmp_path / "poses.json").write_text(json.dumps([{"x": 0}, {"x": 1}]))
    assert main(["model", "--merge", str(good), str(tmp_path / "bad.ply"), "--poses",
                 str(tmp_path / "poses.json"), "--out", str(tmp_path / "w.ply")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "bad.ply" in lines[0] and "'abc' is not a number" in lines[0]


# ----------------------------------------------------------------------------- poses


@pytest.mark.parametrize(("text", "match"), [
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('[{"x": 0, "heading": ' + str(10**400) + "}]", "pose 0 in .*: heading must be a finite"),
    ('[{"x": 1e999}]', "x must be a finite number"),
    ('[{"x": Infinity, "z": NaN}]', "x, z must be finite numbers"),
    ('[{"x": "1"}]', "x must be a finite number, got '1'"),
    (json.dumps([{"matrix": [["1", "0", "0", "0"]] * 4}]), "matrix must hold finite numbers"),
    (json.dumps([{"matrix": [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}]),
     r"matrix must be 4 rows of 4 numbers"),
    (json.dumps([{"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}]), "4 rows of 4 numbers"),
    (json.dumps([{"matrix": "eye"}]), "4 rows of 4 numbers"),
    (json.dumps([{"matrix": np.diag([2.0, 1, 1, 1]).tolist()}]), "must be rigid"),
    (json.dumps([{"matrix": np.eye(4).tolist(), "x": 1}]), "a matrix or x, z, heading, y"),
    ('[{"x": ' + "9" * 5000 + "}]", "cannot read .* as JSON"),
    ("\xff", "cannot read .* as JSON"),
    ('{"x": 1}', "must hold a JSON list of objects"),
])
def test_malformed_poses_name_the_file_and_the_pose(tmp_path, text, match):
    path = tmp_path / "poses.json"
    path.write_bytes(text.encode("utf-8", errors="surrogateescape") if text != "\xff"
                     else b"\xff")
    with pytest.raises(ValueError, match=match) as error:
        read_poses(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_poses_through_the_command_line_are_one_line(tmp_path, capsys):
    ply = write_ply(tmp_path / "a.ply",
                    build_model(np.full((3, 4), 2.0), PinholeCamera(10.0, 1.5, 1.0)))
    (tmp_path / "poses.json").write_text("[" * 100_000 + "]" * 100_000)
    assert main(["model", "--merge", str(ply), "--poses", str(tmp_path / "poses.json"),
                 "--out", str(tmp_path / "w.ply")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "poses.json" in lines[0] and "nested too deeply" in lines[0]


def test_a_camera_file_with_a_huge_integer_names_the_file(tmp_path):
    path = tmp_path / "camera.json"
    path.write_text('{"format": "refsynth-camera/1", "camera": "pinhole", "focal": '
                    + str(10**400) + ', "cx": 1, "cy": 1, "shape": [3, 3]}')
    with pytest.raises(ValueError, match="camera.json: focal, cx, cy must be finite numbers"):
        read_camera_file(path)


# ----------------------------------------------------------------------------- edges


def test_ragged_edges_lists_name_the_argument():
    partial = np.full((4, 4), np.nan)
    partial[0] = 1.0
    ragged = [[True] * 4, [True] * 3, [False] * 4, [False] * 4]
    with pytest.raises(ValueError, match=r"`edges` must be a boolean array of shape \(4, 4\), "
                                         "got ragged nested lists"):
        refsynth.synthesize(np.zeros((4, 4)), partial, edges=ragged)
