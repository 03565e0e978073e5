"""Stage 3 PLY files: exact round trips through our reader and the independent plyfile, trimesh."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refsynth.model import CylindricalCamera, Model, build_model, read_ply, write_ply

plyfile = pytest.importorskip("plyfile")
trimesh = pytest.importorskip("trimesh")


@st.composite
def models(draw, min_vertices=0):
    """A model with random float64 vertices, colours, confidences, flags and triangles."""
    n = draw(st.integers(min_vertices, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    m = draw(st.integers(0, 30)) if n >= 3 else 0
    scale = draw(st.sampled_from([1e-3, 1.0, 1e4]))
    return Model(
        vertices=rng.normal(0.0, scale, (n, 3)),
        colours=rng.integers(0, 256, (n, 3)).astype(np.uint8),
        confidence=rng.random(n),
        synthesized=rng.random(n) < 0.5,
        faces=np.array([rng.choice(n, 3, replace=False) for _ in range(m)],
                       dtype=np.int64).reshape(-1, 3),
    )


def _assert_same(back: Model, model: Model, coordinates="float64"):
    kind = np.float64 if coordinates == "float64" else np.float32
    np.testing.assert_array_equal(back.vertices, model.vertices.astype(kind))
    np.testing.assert_array_equal(back.colours, model.colours)
    np.testing.assert_array_equal(back.confidence, model.confidence.astype(np.float32))
    np.testing.assert_array_equal(back.synthesized, model.synthesized)
    np.testing.assert_array_equal(back.faces, model.faces)


def _room_model():
    rng = np.random.default_rng(3)
    r = np.full((20, 126), 5.0) + rng.normal(0, 0.01, (20, 126))
    r[5:12, 30:50] = 2.5
    r[0, 0] = np.nan
    rgb = rng.integers(0, 256, (20, 126, 3)).astype(np.uint8)
    confidence = np.where(rng.random(r.shape) < 0.5, 1.0, rng.random(r.shape))
    return build_model(r, CylindricalCamera.panorama(20.0, r.shape), intensity=rgb,
                       confidence=confidence)


# ----------------------------------------------------------------------------- our reader


@settings(deadline=None, max_examples=40)
@given(model=models(), ascii=st.booleans(), coordinates=st.sampled_from(["float64", "float32"]))
def test_ply_round_trip_is_exact(tmp_path_factory, model, ascii, coordinates):
    path = tmp_path_factory.mktemp("ply") / "model.ply"
    write_ply(path, model, ascii=ascii, coordinates=coordinates)
    _assert_same(read_ply(path), model, coordinates)


def test_ascii_and_binary_files_hold_the_same_model(tmp_path):
    model = _room_model()
    binary = read_ply(write_ply(tmp_path / "b.ply", model))
    ascii = read_ply(write_ply(tmp_path / "a.ply", model, ascii=True))
    _assert_same(binary, model)
    _assert_same(ascii, model)


def test_the_header_is_the_documented_one(tmp_path):
    model = _room_model()
    path = write_ply(tmp_path / "m.ply", model, comments=["pose 0 0 0"])
    data = path.read_bytes()
    header = data[: data.index(b"end_header")].decode().splitlines()
    assert header[:2] == ["ply", "format binary_little_endian 1.0"]
    assert "comment pose 0 0 0" in header
    assert f"element vertex {model.n_vertices}" in header
    assert header[-11:] == [
        f"element vertex {model.n_vertices}",
        "property double x", "property double y", "property double z",
        "property uchar red", "property uchar green", "property uchar blue",
        "property float confidence", "property uchar synthesized",
        f"element face {model.n_faces}", "property list uchar int vertex_indices",
    ]
    expected = len(data) - (data.index(b"end_header\n") + len(b"end_header\n"))
    assert expected == model.n_vertices * (3 * 8 + 3 + 4 + 1) + model.n_faces * (1 + 3 * 4)


# ----------------------------------------------------------------------------- plyfile


@pytest.mark.parametrize("ascii", [False, True])
@pytest.mark.parametrize("coordinates", ["float64", "float32"])
def test_plyfile_reads_our_files_exactly(tmp_path, ascii, coordinates):
    model = _room_model()
    path = write_ply(tmp_path / "m.ply", model, ascii=ascii, coordinates=coordinates)
    data = plyfile.PlyData.read(str(path))
    assert data.text == ascii
    vertex, face = data["vertex"], data["face"]
    assert vertex.count == model.n_vertices and face.count == model.n_faces
    kind = np.float64 if coordinates == "float64" else np.float32
    for axis, name in enumerate("xyz"):
        assert vertex[name].dtype == kind
        np.testing.assert_array_equal(vertex[name], model.vertices[:, axis].astype(kind))
    for channel, name in enumerate(("red", "green", "blue")):
        assert vertex[name].dtype == np.uint8
        np.testing.assert_array_equal(vertex[name], model.colours[:, channel])
    np.testing.assert_array_equal(vertex["confidence"], model.confidence.astype(np.float32))
    np.testing.assert_array_equal(vertex["synthesized"], model.synthesized.astype(np.uint8))
    np.testing.assert_array_equal(np.stack(face["vertex_indices"]), model.faces)


@settings(deadline=None, max_examples=20)
@given(model=models(min_vertices=1), ascii=st.booleans())
def test_plyfile_round_trip_of_random_models(tmp_path_factory, model, ascii):
    path = write_ply(tmp_path_factory.mktemp("ply") / "m.ply", model, ascii=ascii)
    data = plyfile.PlyData.read(str(path))
    np.testing.assert_array_equal(
        np.column_stack([data["vertex"][a] for a in "xyz"]), model.vertices)
    np.testing.assert_array_equal(data["vertex"]["confidence"],
                                  model.confidence.astype(np.float32))
    faces = data["face"]["vertex_indices"]
    assert len(faces) == model.n_faces
    if model.n_faces:
        np.testing.assert_array_equal(np.stack(faces), model.faces)


def test_our_reader_reads_what_plyfile_writes(tmp_path):
    model = _room_model()
    vertex = np.empty(model.n_vertices, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"),
                                               ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    for axis, name in enumerate("xyz"):
        vertex[name] = model.vertices[:, axis]
    for channel, name in enumerate(("red", "green", "blue")):
        vertex[name] = model.colours[:, channel]
    face = np.empty(model.n_faces, dtype=[("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = model.faces
    for text in (False, True):
        path = tmp_path / f"plyfile-{text}.ply"
        plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"),
                         plyfile.PlyElement.describe(face, "face")], text=text,
                        byte_order=">").write(str(path))
        back = read_ply(path)
        np.testing.assert_array_equal(back.vertices, model.vertices)
        np.testing.assert_array_equal(back.colours, model.colours)
        np.testing.assert_array_equal(back.faces, model.faces)
        assert (back.confidence == 1).all() and not back.synthesized.any()


# ----------------------------------------------------------------------------- trimesh


@pytest.mark.parametrize("ascii", [False, True])
def test_trimesh_reads_our_files_exactly(tmp_path, ascii):
    model = _room_model()
    path = write_ply(tmp_path / "m.ply", model, ascii=ascii)
    mesh = trimesh.load(str(path), process=False)
    assert isinstance(mesh, trimesh.Trimesh)
    assert len(mesh.vertices) == model.n_vertices and len(mesh.faces) == model.n_faces
    np.testing.assert_array_equal(np.asarray(mesh.vertices), model.vertices)
    np.testing.assert_array_equal(np.asarray(mesh.faces), model.faces)
    np.testing.assert_array_equal(np.asarray(mesh.visual.vertex_colors)[:, :3], model.colours)
    raw = mesh.metadata["_ply_raw"]["vertex"]["data"]
    np.testing.assert_array_equal(np.ravel(raw["confidence"]),
                                  model.confidence.astype(np.float32))
    np.testing.assert_array_equal(np.ravel(raw["synthesized"]),
                                  model.synthesized.astype(np.uint8))


def test_trimesh_reads_a_point_cloud(tmp_path):
    model = _room_model()
    cloud = Model(model.vertices, model.colours, model.confidence, model.synthesized,
                  np.zeros((0, 3), np.int64))
    path = write_ply(tmp_path / "cloud.ply", cloud)
    points = trimesh.load(str(path), process=False)
    np.testing.assert_array_equal(np.asarray(points.vertices), model.vertices)
    _assert_same(read_ply(path), cloud)


# ----------------------------------------------------------------------------- errors


def test_read_ply_refuses_what_it_cannot_read(tmp_path):
    path = tmp_path / "bad.ply"
    path.write_bytes(b"not a ply")
    with pytest.raises(ValueError, match="bad.ply"):
        read_ply(path)
    model = _room_model()
    good = write_ply(tmp_path / "good.ply", model).read_bytes()
    path.write_bytes(good[:-5])
    with pytest.raises(ValueError, match="truncated"):
        read_ply(path)
    path.write_bytes(good + b"\0")
    with pytest.raises(ValueError, match="after the data"):
        read_ply(path)
    quads = (b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
             b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
             b"end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    path.write_bytes(quads)
    with pytest.raises(ValueError, match="triangular"):
        read_ply(path)
    with pytest.raises(FileNotFoundError):
        read_ply(tmp_path / "missing.ply")


def test_write_ply_checks_its_inputs(tmp_path):
    model = _room_model()
    with pytest.raises(TypeError, match="`model`"):
        write_ply(tmp_path / "m.ply", "model")
    with pytest.raises(ValueError, match="`coordinates`"):
        write_ply(tmp_path / "m.ply", model, coordinates="half")
    with pytest.raises(ValueError, match="`comments`"):
        write_ply(tmp_path / "m.ply", model, comments=["two\nlines"])
