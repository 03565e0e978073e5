"""Stage 3 mesh and model: the depth-discontinuity rule, colours, confidence, flags, wrap."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from refsynth.model import (
    DEFAULT_MAX_JUMP,
    CylindricalCamera,
    PinholeCamera,
    build_model,
    depth_discontinuity,
    grid_faces,
    intensity_colours,
)


@st.composite
def grid_shapes(draw):
    """A small image shape (H, W), H, W >= 2."""
    return draw(st.integers(2, 10)), draw(st.integers(2, 12))


def _edges(faces: np.ndarray) -> np.ndarray:
    return np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])


# ----------------------------------------------------------------------------- properties


@settings(deadline=None)
@given(shape=grid_shapes(), r=st.floats(0.01, 1e4), wrap=st.booleans(),
       max_jump=st.floats(1e-6, 1.0))
def test_a_mesh_over_a_constant_range_image_drops_no_triangle(shape, r, wrap, max_jump):
    faces = grid_faces(np.full(shape, r), max_jump=max_jump, wrap=wrap)
    cells = (shape[0] - 1) * (shape[1] - (0 if wrap else 1))
    assert len(faces) == 2 * cells
    assert len(np.unique(np.sort(faces, axis=1), axis=0)) == len(faces)


@settings(deadline=None)
@given(shape=grid_shapes(), seed=st.integers(0, 2**32 - 1), near=st.floats(0.1, 100.0),
       max_jump=st.floats(1e-3, 0.5), excess=st.floats(1e-9, 10.0), wrap=st.booleans())
def test_a_step_above_the_threshold_is_never_bridged(shape, seed, near, max_jump, excess,
                                                      wrap):
    side = np.random.default_rng(seed).random(shape) < 0.5  # any two sets of pixels
    h = max_jump * near * (1 + excess)
    faces = grid_faces(np.where(side, near + h, near), max_jump=max_jump, wrap=wrap)
    labels = side.ravel()[faces]
    assert np.all(labels.all(axis=1) | ~labels.any(axis=1))


@settings(deadline=None)
@given(shape=grid_shapes(), seed=st.integers(0, 2**32 - 1), near=st.floats(0.1, 100.0),
       max_jump=st.floats(1e-3, 0.5), fraction=st.floats(0.0, 0.999))
def test_a_step_below_the_threshold_keeps_every_triangle(shape, seed, near, max_jump,
                                                         fraction):
    side = np.random.default_rng(seed).random(shape) < 0.5
    h = max_jump * near * fraction
    faces = grid_faces(np.where(side, near + h, near), max_jump=max_jump)
    assert len(faces) == 2 * (shape[0] - 1) * (shape[1] - 1)


@settings(deadline=None)
@given(shape=grid_shapes(), seed=st.integers(0, 2**32 - 1))
def test_no_face_uses_a_pixel_without_range(shape, seed):
    rng = np.random.default_rng(seed)
    r = np.where(rng.random(shape) < 0.3, np.nan, rng.uniform(1, 2, shape))
    faces = grid_faces(r, max_jump=None)
    assert np.isfinite(r.ravel()[faces]).all()
    # a cell with three or four vertices gives one or two triangles
    ok = np.isfinite(r)
    count = ok[:-1, :-1].astype(int) + ok[:-1, 1:] + ok[1:, :-1] + ok[1:, 1:]
    assert len(faces) == int(np.sum(count == 3) + 2 * np.sum(count == 4))


@settings(deadline=None)
@given(shape=grid_shapes(), r=st.floats(0.5, 50.0), cylindrical=st.booleans())
def test_faces_face_the_camera_and_tile_without_overlap(shape, r, cylindrical):
    camera = (CylindricalCamera.centred(200.0, shape) if cylindrical
              else PinholeCamera.centred(200.0, shape))
    model = build_model(np.full(shape, r), camera)
    v = model.vertices[model.faces]
    normal = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert np.all(np.einsum("ij,ij->i", normal, -v.mean(axis=1)) > 0)
    # every interior grid edge is shared by exactly two triangles (a manifold sheet)
    edges = np.sort(_edges(model.faces), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert counts.max() == 2


# ----------------------------------------------------------------------------- the rule


def test_depth_discontinuity_scales_with_the_nearer_range():
    assert not depth_discontinuity(10.0, 10.5, 0.05)
    assert depth_discontinuity(10.0, 10.51, 0.05)
    assert not depth_discontinuity(10.0, 10.7, 0.05, length=math.sqrt(2))
    assert depth_discontinuity(1.0, 1.06, 0.05)


def test_the_curtain_is_dropped_with_the_rule_and_kept_without():
    r = np.full((6, 8), 6.0)  # a wall at 6 m
    r[2:5, 2:5] = 3.0  # a table at 3 m in front of it
    with_rule = grid_faces(r)
    without = grid_faces(r, max_jump=None)
    assert len(without) == 2 * 5 * 7
    labels = (r.ravel() < 4)[with_rule]
    assert np.all(labels.all(axis=1) | ~labels.any(axis=1))
    assert (r.ravel()[with_rule] == 3.0).all(axis=1).sum() == 8  # the table's 2x2 cells
    assert len(with_rule) < len(without)


def test_four_vertex_cells_split_along_the_diagonal_with_the_smaller_jump():
    r = np.array([[1.0, 1.0], [1.0, 9.0]])  # corner 3 far: split 1-2, keep 0-1-2
    assert grid_faces(r).tolist() == [[0, 1, 2]]
    r = np.array([[1.0, 9.0], [1.0, 1.0]])  # corner 1 far: split 0-3, keep 0-3-2
    assert grid_faces(r).tolist() == [[0, 3, 2]]


def test_wrap_joins_the_last_column_to_the_first():
    faces = grid_faces(np.ones((2, 3)), wrap=True)
    assert len(faces) == 6 and {0, 2, 3, 5} <= set(faces[-2:].ravel())


def test_grid_faces_checks_its_inputs():
    with pytest.raises(ValueError, match="`range_image`"):
        grid_faces(np.ones(3))
    with pytest.raises(ValueError, match="`max_jump`"):
        grid_faces(np.ones((2, 2)), max_jump=-1.0)
    with pytest.raises(ValueError, match="`valid`"):
        grid_faces(np.ones((2, 2)), valid=np.ones((2, 2)))
    assert grid_faces(np.ones((1, 5))).shape == (0, 3)


# ----------------------------------------------------------------------------- build_model


def test_build_model_carries_colour_confidence_and_the_synthesized_flag():
    r = np.array([[2.0, 2.0, np.nan], [2.0, 2.0, 2.0]])
    grey = np.array([[0, 64, 128], [192, 255, 10]], dtype=np.uint8)
    confidence = np.array([[1.0, 0.5, 0.0], [1.0, 0.25, 1.0]])
    measured = np.array([[True, False, False], [True, False, True]])
    camera = PinholeCamera(100.0, 1.0, 0.5)
    model = build_model(r, camera, intensity=grey, confidence=confidence, measured=measured)
    assert model.n_vertices == 5
    assert model.pixels.tolist() == [[0, 0], [0, 1], [1, 0], [1, 1], [1, 2]]
    assert model.colours[:, 0].tolist() == [0, 64, 192, 255, 10]
    assert (model.colours == model.colours[:, :1]).all()
    assert model.confidence.tolist() == [1.0, 0.5, 1.0, 0.25, 1.0]
    assert model.synthesized.tolist() == [False, True, False, True, False]
    np.testing.assert_array_equal(model.vertices, camera.back_project(r)[np.isfinite(r)])
    # without `measured`, nothing claims to be measured: a confidence of 1 is not evidence
    assert build_model(r, camera, confidence=confidence).synthesized.all()
    assert build_model(r, camera).synthesized.all()


def test_low_confidence_vertices_are_dropped_with_their_triangles():
    r = np.full((3, 3), 2.0)
    confidence = np.ones((3, 3))
    confidence[1, 1] = 0.2
    model = build_model(r, PinholeCamera(100.0, 1.0, 1.0), confidence=confidence,
                        min_confidence=0.5)
    assert model.n_vertices == 8 and [1, 1] not in model.pixels.tolist()
    assert model.n_faces == 4  # each corner cell keeps the triangle without the centre


@pytest.mark.parametrize("image", [
    np.array([[0.0, 0.2], [0.6, 1.0]]),
    (np.array([[0.0, 0.2], [0.6, 1.0]]) * 65535).round().astype(np.uint16),
])
def test_intensity_colours_of_grey_float_and_integer_images(image):
    assert intensity_colours(image)[..., 1].tolist() == [[0, 51], [153, 255]]


def test_intensity_colours_of_rgb_images_keep_their_channels():
    rgb = np.random.default_rng(0).integers(0, 256, (4, 5, 3)).astype(np.uint8)
    np.testing.assert_array_equal(intensity_colours(rgb), rgb)
    np.testing.assert_array_equal(intensity_colours(rgb / 255.0), rgb)
    assert intensity_colours(np.full((2, 2), np.nan)).max() == 0


def test_a_360_degree_panorama_wraps_by_default():
    shape = (4, 63)
    camera = CylindricalCamera.panorama(10.0, shape)
    assert build_model(np.ones(shape), camera).n_faces == 2 * 3 * 63
    assert build_model(np.ones(shape), camera, wrap=False).n_faces == 2 * 3 * 62
    with pytest.raises(ValueError, match="`wrap`"):
        build_model(np.ones(shape), CylindricalCamera.centred(20.0, shape), wrap=True)


def test_build_model_checks_its_inputs():
    camera = PinholeCamera(1.0, 0.0, 0.0)
    r = np.ones((2, 2))
    with pytest.raises(ValueError, match="`intensity`"):
        build_model(r, camera, intensity=np.ones((3, 3)))
    with pytest.raises(ValueError, match="`confidence`"):
        build_model(r, camera, confidence=np.full((2, 2), 2.0))
    with pytest.raises(ValueError, match="`confidence`"):
        build_model(r, camera, confidence=np.ones((3, 2)))
    with pytest.raises(TypeError, match="`measured`"):
        build_model(r, camera, measured=np.ones((2, 2)))
    with pytest.raises(TypeError, match="`camera`"):
        build_model(r, "pinhole")
    with pytest.raises(ValueError, match="`min_confidence`"):
        build_model(r, camera, min_confidence=2.0)
    assert DEFAULT_MAX_JUMP == 0.05
