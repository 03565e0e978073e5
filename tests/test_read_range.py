"""Range is read one way everywhere: ``refsynth.io.read_range`` and the commands that use it.

- A PNG range is its stored integers divided by an explicit scale (the
  inverse of ``write_array``'s ``png_scale``), never an intensity in [0, 1].
- JPEG is refused (by suffix and by content); so are known values <= 0
  unless allowed; non-finite values are unknown.
- ``synth --out x.png --png-scale S`` round-trips through ``model --png-scale S``
  in the right unit; ``model`` never takes a confidence of 1 for "measured".
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from refsynth.cli.main import main
from refsynth.io import read_range, write_array, write_pfm, write_png16
from refsynth.model import read_ply


@settings(deadline=None)
@given(millimetres=st.lists(st.integers(1, 65535), min_size=1, max_size=12),
       scale=st.sampled_from([1.0, 10.0, 1000.0, 256.0]))
def test_a_png_range_reads_back_in_the_unit_it_was_written_in(tmp_path_factory, millimetres,
                                                               scale):
    folder = tmp_path_factory.mktemp("png")
    values = np.array([millimetres + [0]], dtype=np.float64) / scale
    values[0, -1] = np.nan  # unknown: stored as 0
    path = write_array(folder / "r.png", values, png_scale=scale)
    back = read_range(path, scale=scale)
    assert back.dtype == np.float64 and back.shape == values.shape
    np.testing.assert_array_equal(back, values)  # exact: integer / scale both ways


def test_a_png_range_is_not_an_intensity(tmp_path):
    path = tmp_path / "r.png"
    write_png16(path, np.array([[2500.0, 65535.0]]))
    assert read_range(path).tolist() == [[2500.0, 65535.0]]
    assert read_range(path, scale=1000).tolist() == [[2.5, 65.535]]


def test_an_8_bit_png_and_a_pfm_and_an_npy(tmp_path):
    Image.fromarray(np.array([[0, 7, 255]], dtype=np.uint8)).save(tmp_path / "r8.png")
    assert np.array_equal(read_range(tmp_path / "r8.png"), [[np.nan, 7.0, 255.0]],
                          equal_nan=True)
    write_pfm(tmp_path / "r.pfm", np.array([[1.5, np.inf, -np.inf]]))
    assert np.array_equal(read_range(tmp_path / "r.pfm"), [[1.5, np.nan, np.nan]],
                          equal_nan=True)
    np.save(tmp_path / "r.npy", np.array([[np.nan, 3], [np.inf, 4]]))
    assert np.array_equal(read_range(tmp_path / "r.npy"), [[np.nan, 3], [np.nan, 4]],
                          equal_nan=True)
    np.save(tmp_path / "one.npy", np.ones((2, 3, 1), dtype=np.int16))
    assert read_range(tmp_path / "one.npy").shape == (2, 3)


def _jpeg_bytes() -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(np.full((8, 8), 100, dtype=np.uint8)).save(buffer, format="JPEG")
    return buffer.getvalue()


@pytest.mark.parametrize("name", ["r.jpg", "r.JPEG", "disguised.png"])
def test_jpeg_is_refused_by_suffix_and_by_content(tmp_path, name):
    (tmp_path / name).write_bytes(_jpeg_bytes())
    with pytest.raises(ValueError, match=f"Cannot read '.*{name}' as range: JPEG is lossy"):
        read_range(tmp_path / name)


@pytest.mark.parametrize("value", [-1.0, 0.0, -1e-300])
def test_values_at_or_below_zero_are_refused_unless_allowed(tmp_path, value):
    np.save(tmp_path / "r.npy", np.array([[2.0, value, np.nan]]))
    with pytest.raises(ValueError, match=r"r.npy' as range: 1 known values are <= 0 .*"
                                         "--allow-nonpositive"):
        read_range(tmp_path / "r.npy")
    back = read_range(tmp_path / "r.npy", allow_nonpositive=True)
    assert back[0, 1] == value and np.isnan(back[0, 2])


@pytest.mark.parametrize(("make", "kwargs", "match"), [
    (lambda p: np.save(p / "r.npy", np.ones((2, 2))), {"scale": 1000},
     "the scale applies to an image range"),
    (lambda p: Image.fromarray(np.ones((2, 2, 3), np.uint8)).save(p / "r.png"), {},
     r"single-channel \(H, W\) map, got shape \(2, 2, 3\)"),
    (lambda p: np.save(p / "r.npy", np.ones((2, 2), bool)), {}, "must hold real numbers"),
    (lambda p: np.save(p / "r.npy", np.ones((2, 2), complex)), {}, "must hold real numbers"),
    (lambda p: np.save(p / "r.npy", np.ones(4)), {}, "single-channel"),
    (lambda p: (p / "r.png").write_bytes(b"\x89PNG broken"), {}, "Cannot read"),
    (lambda p: np.save(p / "r.npy", np.ones((2, 2))), {"scale": 0}, "`scale` must be finite"),
])
def test_bad_range_files_name_the_file(tmp_path, make, kwargs, match):
    make(tmp_path)
    path = next(tmp_path.iterdir())
    with pytest.raises(ValueError, match=match):
        read_range(path, **kwargs)


def test_a_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.png"):
        read_range(tmp_path / "nope.png")


# ----------------------------------------------------------------------------- the commands


@pytest.fixture
def scene(tmp_path):
    """A 20×24 image; a range in metres (2 m and 4 m halves), every 4th column measured."""
    rng = np.random.default_rng(0)
    np.save(tmp_path / "image.npy", rng.random((20, 24)))
    truth = np.where(np.arange(24) < 12, 2.0, 4.0)[None, :].repeat(20, 0)
    partial = np.where(np.arange(24) % 4 == 0, truth, np.nan)
    np.save(tmp_path / "partial.npy", partial)
    return tmp_path, partial


def _one_error(capsys, needle):
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], lines
    return lines[0]


def test_synth_png_output_round_trips_through_model_in_metres(scene, capsys):
    folder, partial = scene
    image, range_ = str(folder / "image.npy"), str(folder / "partial.npy")
    assert main(["synth", image, range_, "--out", str(folder / "dense.npy")]) == 0
    assert main(["synth", image, range_, "--out", str(folder / "dense_mm.png"),
                 "--png-scale", "1000"]) == 0
    dense = np.load(folder / "dense.npy")
    common = ["--camera", "pinhole", "--focal", "30", "--partial", range_]
    assert main(["model", str(folder / "dense.npy"), *common, "--out",
                 str(folder / "m.ply")]) == 0
    assert main(["model", str(folder / "dense_mm.png"), "--png-scale", "1000", *common,
                 "--out", str(folder / "mm.ply")]) == 0
    from_npy, from_png = read_ply(folder / "m.ply"), read_ply(folder / "mm.ply")
    assert from_png.n_vertices == from_npy.n_vertices == dense.size
    # the PNG stores whole millimetres: the model agrees to half a millimetre, in metres
    np.testing.assert_allclose(from_png.vertices, from_npy.vertices, atol=1e-3)
    assert 1.5 < np.median(np.linalg.norm(from_png.vertices, axis=1)) < 5.0
    assert np.array_equal(from_png.synthesized, ~np.isfinite(partial).ravel())


def test_synth_refuses_a_jpeg_range_and_negative_range(scene, capsys):
    folder, partial = scene
    (folder / "range.jpg").write_bytes(_jpeg_bytes())
    assert main(["synth", str(folder / "image.npy"), str(folder / "range.jpg"),
                 "--out", str(folder / "o.npy")]) == 2
    _one_error(capsys, "JPEG is lossy")
    np.save(folder / "neg.npy", -partial)
    assert main(["synth", str(folder / "image.npy"), str(folder / "neg.npy"),
                 "--out", str(folder / "o.npy")]) == 2
    _one_error(capsys, "known values are <= 0")
    assert not (folder / "o.npy").exists()
    assert main(["synth", str(folder / "image.npy"), str(folder / "neg.npy"),
                 "--allow-nonpositive", "--out", str(folder / "o.npy")]) == 0
    assert np.nanmax(np.load(folder / "o.npy")) < 0


def test_model_refuses_a_jpeg_range_and_a_png_scale_for_npy(scene, capsys):
    folder, _ = scene
    (folder / "dense.jpg").write_bytes(_jpeg_bytes())
    assert main(["model", str(folder / "dense.jpg"), "--focal", "30",
                 "--out", str(folder / "m.ply")]) == 2
    _one_error(capsys, "JPEG is lossy")
    assert main(["model", str(folder / "partial.npy"), "--focal", "30", "--png-scale", "1000",
                 "--out", str(folder / "m.ply")]) == 2
    _one_error(capsys, "--png-scale applies to an image DENSE or --partial")
    assert not (folder / "m.ply").exists()


def test_model_without_partial_claims_nothing_measured_and_says_so(scene, capsys):
    """BP's belief reaches 1 at synthesized pixels: a confidence of 1 is not "measured"."""
    folder, partial = scene
    dense = np.where(np.isfinite(partial), partial, 3.0)
    np.save(folder / "dense.npy", dense)
    np.save(folder / "confidence.npy", np.ones(dense.shape))  # saturated everywhere
    argv = ["model", str(folder / "dense.npy"), "--camera", "pinhole", "--focal", "30",
            "--confidence", str(folder / "confidence.npy"), "--out", str(folder / "m.ply")]
    assert main(argv) == 0
    captured = capsys.readouterr()
    note = captured.err.strip().splitlines()
    assert len(note) == 1 and "no --partial given: every point is marked synthesized" in note[0]
    assert f"({dense.size} synthesized)" in captured.out
    assert read_ply(folder / "m.ply").synthesized.all()
    assert main([*argv, "--partial", str(folder / "partial.npy")]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    unknown = int(np.count_nonzero(~np.isfinite(partial)))
    assert f"({unknown} synthesized)" in captured.out
    assert np.array_equal(read_ply(folder / "m.ply").synthesized, ~np.isfinite(partial).ravel())


def test_evaluate_reads_a_png_disparity_as_synth_does(tmp_path, capsys):
    """A JPEG disparity in an IMAGE:DISPARITY scene is refused, as synth refuses it."""
    Image.fromarray(np.full((20, 20), 128, np.uint8)).save(tmp_path / "im.png")
    (tmp_path / "disp.jpg").write_bytes(_jpeg_bytes())
    assert main(["evaluate", "--scene", f"{tmp_path / 'im.png'}:{tmp_path / 'disp.jpg'}",
                 "--methods", "nearest", "--sampling", "x50", "--quiet"]) == 2
    _one_error(capsys, "JPEG is lossy")


def test_a_lossy_webp_disguised_as_png_is_refused(tmp_path):
    from PIL import features

    if not features.check("webp"):
        pytest.skip("Pillow built without WebP")
    buffer = io.BytesIO()
    Image.fromarray(np.full((8, 8), 100, dtype=np.uint8)).save(buffer, format="WEBP")
    (tmp_path / "r.png").write_bytes(buffer.getvalue())
    with pytest.raises(ValueError, match="r.png' as range: WebP is lossy"):
        read_range(tmp_path / "r.png")
