"""`evaluate` reads a PNG disparity with an explicit scale: ``IMAGE:DISPARITY@SCALE``."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from refsynth.evaluation.cases import load_scene, parse_scene


@pytest.fixture
def pair(tmp_path):
    """A 12×10 image, its disparity as float ``.npy`` and as a PNG stored ×2 (0 = unknown)."""
    g = np.random.default_rng(0)
    image = (g.random((10, 12, 3)) * 255).astype(np.uint8)
    disparity = np.round(4 + 20 * g.random((10, 12)) * 2) / 2  # halves: exact ×2 integers
    disparity[0, 0] = np.nan
    Image.fromarray(image).save(tmp_path / "im.png")
    np.save(tmp_path / "disp.npy", disparity)
    stored = np.where(np.isfinite(disparity), disparity * 2, 0).astype(np.uint16)
    Image.fromarray(stored).save(tmp_path / "disp.png")
    return tmp_path, disparity


def test_a_png_disparity_with_its_scale_reads_as_the_float_disparity(pair):
    folder, disparity = pair
    float_spec = parse_scene(f"{folder / 'im.png'}:{folder / 'disp.npy'}")
    png_spec = parse_scene(f"{folder / 'im.png'}:{folder / 'disp.png'}@2")
    assert png_spec.endswith("@2.0")
    expected = load_scene(float_spec, "native").range
    got = load_scene(png_spec, "native").range
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(disparity))


def test_without_a_scale_the_png_holds_the_stored_integers(pair):
    folder, disparity = pair
    spec = parse_scene(f"{folder / 'im.png'}:{folder / 'disp.png'}")
    assert "@" not in spec
    np.testing.assert_array_equal(load_scene(spec, "native").range, disparity * 2)


@pytest.mark.parametrize("scale", ["0", "-2", "inf", "nan"])
def test_a_scale_that_is_not_a_finite_positive_number_is_refused(pair, scale):
    folder, _ = pair
    with pytest.raises(ValueError, match="disparity scale"):
        parse_scene(f"{folder / 'im.png'}:{folder / 'disp.png'}@{scale}")


def test_a_file_name_holding_an_at_sign_is_read_as_it_is(pair):
    folder, _ = pair
    (folder / "disp@2").write_bytes((folder / "disp.npy").read_bytes())
    spec = parse_scene(f"{folder / 'im.png'}:{folder / 'disp@2'}")
    assert spec.endswith("disp@2")
