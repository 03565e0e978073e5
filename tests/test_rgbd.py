"""refsynth.scenes.rgbd: real RGB-D / stereo data from disk, on small files the tests write."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from refsynth.io import write_pfm
from refsynth.scenes import (
    MOTORCYCLE_CROP,
    centre_crop,
    load_rgbd,
    load_rgbd_folder,
    read_scene_metadata,
)


def _rgb(path, height, width, value=(200, 100, 50)):
    image = np.zeros((height, width, 3), np.uint8)
    image[...] = value
    Image.fromarray(image).save(path)
    return path


def _png16(path, values):
    Image.fromarray(np.asarray(values, np.uint16)).save(path)
    return path


# ----------------------------------------------------------------------------- reading


def test_png_depth_scaled_with_invalid_values(tmp_path):
    stored = np.array([[0, 1000, 2500], [65535, 3000, 1]])
    scene = load_rgbd(_rgb(tmp_path / "i.png", 2, 3), _png16(tmp_path / "d.png", stored),
                      scale=1000, invalid=(0, 65535))
    expected = np.array([[np.nan, 1.0, 2.5], [np.nan, 3.0, 0.001]])
    np.testing.assert_array_equal(scene.range, expected)
    assert scene.range.dtype == np.float64 and scene.units == "m"
    np.testing.assert_allclose(scene.intensity[0, 0], [200 / 255, 100 / 255, 50 / 255])


def test_invalid_none_keeps_zero(tmp_path):
    scene = load_rgbd(_rgb(tmp_path / "i.png", 1, 2), _png16(tmp_path / "d.png", [[0, 4]]),
                      invalid=None)
    np.testing.assert_array_equal(scene.range, [[0.0, 4.0]])


def test_npy_nan_and_pfm_inf_are_invalid(tmp_path):
    np.save(tmp_path / "gt.npy", np.array([[1.5, np.nan], [np.inf, 0.0]], np.float32))
    scene = load_rgbd(_rgb(tmp_path / "i.png", 2, 2), tmp_path / "gt.npy")
    np.testing.assert_array_equal(np.isnan(scene.range), [[False, True], [True, True]])
    assert scene.range[0, 0] == 1.5
    write_pfm(tmp_path / "d.pfm", np.array([[8.0, np.inf]], np.float32))
    scene = load_rgbd(_rgb(tmp_path / "j.png", 1, 2), tmp_path / "d.pfm", scale=2,
                      kind="disparity")
    np.testing.assert_array_equal(scene.range, [[4.0, np.nan]])
    assert scene.units == "disparity (px)"


def test_grey_image_stays_two_dimensional(tmp_path):
    Image.fromarray(np.full((3, 4), 51, np.uint8)).save(tmp_path / "g.png")
    np.save(tmp_path / "gt.npy", np.ones((3, 4)))
    scene = load_rgbd(tmp_path / "g.png", tmp_path / "gt.npy")
    assert scene.intensity.shape == (3, 4)
    np.testing.assert_allclose(scene.intensity, 0.2)


def test_crop_is_applied_to_both(tmp_path):
    stored = np.arange(1, 1 + 6 * 8).reshape(6, 8)
    image = np.zeros((6, 8, 3), np.uint8)
    image[..., 0] = np.arange(8) * 10
    Image.fromarray(image).save(tmp_path / "i.png")
    scene = load_rgbd(tmp_path / "i.png", _png16(tmp_path / "d.png", stored),
                      crop=((1, 4), (2, 7)))
    np.testing.assert_array_equal(scene.range, stored[1:4, 2:7])
    np.testing.assert_allclose(scene.intensity[0, :, 0], np.arange(2, 7) * 10 / 255)


# ----------------------------------------------------------------------------- Table 4's protocol


def test_centre_crop_cases():
    assert centre_crop((500, 741)) == MOTORCYCLE_CROP
    assert centre_crop((426, 560)) == ((0, 426), (24, 535))          # NYU after 45:471, 41:601
    assert centre_crop((500, 500)) == ((41, 458), (0, 500))          # taller: rows cut
    assert centre_crop((375, 450)) == ((0, 375), (0, 450))           # already 6:5
    assert centre_crop((10, 20), (1, 1)) == ((0, 10), (5, 15))


@settings(deadline=None, max_examples=60)
@given(st.integers(1, 400), st.integers(1, 400), st.integers(1, 20), st.integers(1, 20))
def test_centre_crop_is_centred_inside_and_of_the_aspect(height, width, aw, ah):
    (r0, r1), (c0, c1) = centre_crop((height, width), (aw, ah))
    assert 0 <= r0 < r1 <= height and 0 <= c0 < c1 <= width
    assert (r0, r1) == (0, height) or (c0, c1) == (0, width)          # one axis kept whole
    assert abs(r0 - (height - r1)) <= 1 and abs(c0 - (width - c1)) <= 1
    # the cut side is the rounding of the exact one (at least one pixel)
    if (c0, c1) != (0, width):
        assert abs((c1 - c0) - height * aw / ah) <= 0.5 + 1e-9 or c1 - c0 == 1
    elif (r0, r1) != (0, height):
        assert abs((r1 - r0) - width * ah / aw) <= 0.5 + 1e-9 or r1 - r0 == 1


def test_size_crops_to_aspect_then_area_resizes(tmp_path):
    # 30 x 40: the centred 6:5 crop is 36 columns (2:38), resized by 1/3 to 12 x 10
    depth = np.full((30, 40), 3000)
    depth[:, 2:5] = 0                         # the crop's first three columns: none
    depth[:, 5:8] = 6000                      # the next cell: 6 m
    scene = load_rgbd(_rgb(tmp_path / "i.png", 30, 40), _png16(tmp_path / "d.png", depth),
                      scale=1000, size=(12, 10))
    assert scene.range.shape == (10, 12) and scene.intensity.shape == (10, 12, 3)
    assert np.isnan(scene.range[:, 0]).all()
    np.testing.assert_allclose(scene.range[:, 1], 6.0)
    np.testing.assert_allclose(scene.range[:, 2:], 3.0)


def test_disparity_follows_the_horizontal_scale_depth_does_not(tmp_path):
    np.save(tmp_path / "gt.npy", np.full((20, 24), 10.0))
    image = _rgb(tmp_path / "i.png", 20, 24)
    disparity = load_rgbd(image, tmp_path / "gt.npy", kind="disparity", size=(12, 10))
    depth = load_rgbd(image, tmp_path / "gt.npy", kind="depth", size=(12, 10))
    np.testing.assert_allclose(disparity.range, 5.0)
    np.testing.assert_allclose(depth.range, 10.0)


def test_resize_keeps_half_covered_cells(tmp_path):
    # 1 of 4 source pixels valid: NaN (coverage < 0.5); 2 of 4: their mean
    truth = np.full((2, 4), np.nan)
    truth[0, 0] = 1.0
    truth[:, 2] = 3.0
    np.save(tmp_path / "gt.npy", truth)
    scene = load_rgbd(_rgb(tmp_path / "i.png", 2, 4), tmp_path / "gt.npy", size=(2, 1))
    assert np.isnan(scene.range[0, 0]) and scene.range[0, 1] == 3.0


# ----------------------------------------------------------------------------- errors


def test_mismatched_sizes(tmp_path):
    np.save(tmp_path / "gt.npy", np.ones((3, 5)))
    with pytest.raises(ValueError, match=r"`truth` must match the image's size.*\(3, 4\).*"
                                         r"\(3, 5\)"):
        load_rgbd(_rgb(tmp_path / "i.png", 3, 4), tmp_path / "gt.npy")


@pytest.mark.parametrize("scale", [0, -1.0, float("nan"), float("inf")])
def test_bad_scale_value(tmp_path, scale):
    with pytest.raises(ValueError, match="`scale` must be a finite number > 0"):
        load_rgbd(tmp_path / "i.png", tmp_path / "gt.npy", scale=scale)


@pytest.mark.parametrize("scale", ["1000", True, None])
def test_bad_scale_type(tmp_path, scale):
    with pytest.raises(TypeError, match="`scale` must be a real number"):
        load_rgbd(tmp_path / "i.png", tmp_path / "gt.npy", scale=scale)


@pytest.mark.parametrize("crop", [((0, 4), (0, 9)), ((2, 2), (0, 3)), ((-1, 2), (0, 3)),
                                  ((3, 1), (0, 3))])
def test_bad_crop_value(tmp_path, crop):
    np.save(tmp_path / "gt.npy", np.ones((3, 4)))
    with pytest.raises(ValueError, match=r"`crop` must be .*3 rows and 4 columns"):
        load_rgbd(_rgb(tmp_path / "i.png", 3, 4), tmp_path / "gt.npy", crop=crop)


@pytest.mark.parametrize("crop", [(0, 3), ((0, 3),), ((0.0, 3), (0, 4)), "0:3,0:4"])
def test_bad_crop_type(tmp_path, crop):
    np.save(tmp_path / "gt.npy", np.ones((3, 4)))
    with pytest.raises(TypeError, match="`crop` must be"):
        load_rgbd(_rgb(tmp_path / "i.png", 3, 4), tmp_path / "gt.npy", crop=crop)


def test_other_errors(tmp_path):
    np.save(tmp_path / "gt.npy", np.ones((3, 4)))
    np.save(tmp_path / "rgb.npy", np.ones((3, 4, 3)))
    image = _rgb(tmp_path / "i.png", 3, 4)
    with pytest.raises(ValueError, match="`kind` must be one of"):
        load_rgbd(image, tmp_path / "gt.npy", kind="range")
    with pytest.raises(ValueError, match="single-channel"):
        load_rgbd(image, tmp_path / "rgb.npy")
    with pytest.raises(FileNotFoundError, match="`truth` names no file"):
        load_rgbd(image, tmp_path / "missing.npy")
    with pytest.raises(ValueError, match="`truth` must be a .npy, .pfm or image file"):
        (tmp_path / "gt.txt").write_text("1")
        load_rgbd(image, tmp_path / "gt.txt")
    with pytest.raises(TypeError, match="`invalid` must be"):
        load_rgbd(image, tmp_path / "gt.npy", invalid="0")
    with pytest.raises(TypeError, match="`image` must be a str or a Path"):
        load_rgbd(3, tmp_path / "gt.npy")
    with pytest.raises(ValueError, match="`size` must be"):
        load_rgbd(image, tmp_path / "gt.npy", size=(0, 4))
    with pytest.raises(ValueError, match="`shape` must be"):
        centre_crop((0, 4))


# ----------------------------------------------------------------------------- folders


def test_folder_metadata_and_overrides(tmp_path):
    folder = tmp_path / "room"
    folder.mkdir()
    _rgb(folder / "rgb.png", 6, 8)
    stored = np.full((6, 8), 2000)
    stored[0] = 0
    _png16(folder / "depth.png", stored)
    meta = {"image": "rgb.png", "truth": "depth.png", "scale": 1000, "invalid": [0],
            "kind": "depth", "units": "m", "crop": [[0, 4], [0, 8]]}
    (folder / "scene.json").write_text(json.dumps(meta))
    assert read_scene_metadata(folder)["crop"] == ((0, 4), (0, 8))
    scene = load_rgbd_folder(folder)
    assert scene.name == "room" and scene.range.shape == (4, 8)
    assert np.isnan(scene.range[0]).all() and (scene.range[1:] == 2.0).all()
    scene = load_rgbd_folder(folder, scale=500, crop=None, name="other")
    assert scene.name == "other" and scene.range.shape == (6, 8) and scene.range[1, 0] == 4.0


def test_folder_without_metadata(tmp_path):
    _rgb(tmp_path / "rgb.png", 4, 4)
    np.save(tmp_path / "gt.npy", np.ones((4, 4)))
    with pytest.raises(FileNotFoundError, match="No scene.json"):
        load_rgbd_folder(tmp_path)
    scene = load_rgbd_folder(tmp_path, image="rgb.png", truth="gt.npy", kind="disparity")
    assert scene.units == "disparity (px)"
    with pytest.raises(TypeError, match="unexpected keyword"):
        load_rgbd_folder(tmp_path, image="rgb.png", truth="gt.npy", colour=True)


@pytest.mark.parametrize("text, match", [
    ("[1, 2]", "JSON object"),
    ('{"image": "a.png"}', "`truth`"),
    ('{"image": "a.png", "truth": "b.npy", "scael": 2}', "unknown keys"),
    ("{not json", "as JSON"),
])
def test_bad_metadata(tmp_path, text, match):
    (tmp_path / "scene.json").write_text(text)
    with pytest.raises(ValueError, match=match):
        read_scene_metadata(tmp_path)
