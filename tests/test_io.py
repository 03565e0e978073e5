"""Tests of refsynth.io: PFM, NPY and image files."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from refsynth.io import read_array, read_image, read_pfm, write_pfm


@st.composite
def float_map(draw):
    """A tiny (H, W) or (H, W, 3) float32 array, with inf and NaN allowed."""
    height, width = draw(st.integers(1, 5)), draw(st.integers(1, 5))
    shape = draw(st.sampled_from([(height, width), (height, width, 3)]))
    return draw(arrays(np.float32, shape, elements=st.floats(width=32, allow_nan=True)))


@settings(deadline=None)
@given(float_map())
def test_pfm_round_trip(tmp_path_factory, array):
    path = tmp_path_factory.mktemp("pfm") / "map.pfm"
    original = array.copy()
    write_pfm(path, array)
    back = read_pfm(path)
    assert back.dtype == np.float32
    assert back.shape == array.shape
    np.testing.assert_array_equal(back, array)  # NaN == NaN here, and bit-exact otherwise
    np.testing.assert_array_equal(array, original)
    np.testing.assert_array_equal(read_array(path), array)


def _pfm_bytes(array: np.ndarray, *, big_endian: bool, header_spacing: str = "\n") -> bytes:
    """A PFM written by hand: rows bottom-to-top, byte order from the scale's sign."""
    kind = "PF" if array.ndim == 3 else "Pf"
    scale = "1.0" if big_endian else "-1.0"
    height, width = array.shape[:2]
    sep = header_spacing
    header = f"{kind}{sep}{width} {height}{sep}{scale}\n".encode()
    return header + np.flipud(array).astype(">f4" if big_endian else "<f4").tobytes()


@pytest.mark.parametrize("big_endian", [False, True])
@pytest.mark.parametrize("channels", [1, 3])
def test_read_pfm_byte_order_and_row_order(tmp_path, big_endian, channels):
    shape = (2, 3) if channels == 1 else (2, 3, 3)
    array = np.arange(np.prod(shape), dtype=np.float32).reshape(shape)
    array[0, 0] = np.inf
    path = tmp_path / "hand.pfm"
    path.write_bytes(_pfm_bytes(array, big_endian=big_endian))
    back = read_pfm(path)
    np.testing.assert_array_equal(back, array)
    # the first row of the result is the *last* row stored in the file
    assert back[0, 0].ravel()[0] == np.inf


def test_read_pfm_tolerates_header_whitespace(tmp_path):
    array = np.array([[1.5, -2.0]], dtype=np.float32)
    path = tmp_path / "spaces.pfm"
    path.write_bytes(_pfm_bytes(array, big_endian=False, header_spacing=" \n"))
    np.testing.assert_array_equal(read_pfm(path), array)


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (b"P6\n1 1\n255\n\x00\x00\x00", "must start with 'PF' or 'Pf'"),
        (b"Pf\n2", "header is truncated"),
        (b"Pf\nx 2\n-1\n" + bytes(8), "bad header"),
        (b"Pf\n0 2\n-1\n", "bad size"),
        (b"Pf\n2 2\n0\n" + bytes(16), "bad size"),
        (b"Pf\n2 2\n-1\n" + bytes(15), "expected 16 bytes"),
    ],
)
def test_read_pfm_rejects_bad_files(tmp_path, content, match):
    path = tmp_path / "bad.pfm"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=match) as info:
        read_pfm(path)
    assert str(path) in str(info.value)


def test_write_pfm_validation(tmp_path):
    with pytest.raises(TypeError, match="`array` must be a numpy array"):
        write_pfm(tmp_path / "a.pfm", [[1.0]])
    with pytest.raises(TypeError, match="`array` must be a real numeric array"):
        write_pfm(tmp_path / "a.pfm", np.ones((2, 2), bool))
    with pytest.raises(ValueError, match=r"`array` must have shape \(H, W\) or \(H, W, 3\)"):
        write_pfm(tmp_path / "a.pfm", np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match=r"got \(0, 2\)"):
        write_pfm(tmp_path / "a.pfm", np.ones((0, 2)))
    with pytest.raises(TypeError, match="`path` must be a str or a Path"):
        write_pfm(3, np.ones((2, 2)))


# ----------------------------------------------------------------------------- images


@pytest.mark.parametrize("suffix", [".png", ".tif", ".bmp", ".ppm"])
def test_read_image_rgb_round_trip(tmp_path, suffix):
    rgb = np.random.default_rng(0).integers(0, 256, (4, 5, 3), dtype=np.uint8)
    path = tmp_path / f"rgb{suffix}"
    Image.fromarray(rgb).save(path)
    image = read_image(path)
    assert image.dtype == np.float64
    assert image.shape == (4, 5, 3)
    np.testing.assert_allclose(image * 255, rgb, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(read_image(path, raw=True), rgb)
    np.testing.assert_array_equal(read_array(path), image)


def test_read_image_drops_alpha(tmp_path):
    rgba = np.random.default_rng(1).integers(0, 256, (3, 4, 4), dtype=np.uint8)
    path = tmp_path / "rgba.png"
    Image.fromarray(rgba).save(path)
    np.testing.assert_array_equal(read_image(path, raw=True), rgba[..., :3])
    grey_alpha = Image.fromarray(rgba[..., 0]).convert("LA")
    grey_alpha.save(tmp_path / "la.png")
    np.testing.assert_array_equal(read_image(tmp_path / "la.png", raw=True), rgba[..., 0])


def test_read_image_grey_8_and_16_bit(tmp_path):
    grey = np.arange(12, dtype=np.uint8).reshape(3, 4) * 20
    Image.fromarray(grey).save(tmp_path / "grey.png")
    np.testing.assert_allclose(read_image(tmp_path / "grey.png"), grey / 255.0)
    deep = np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000
    Image.fromarray(deep).save(tmp_path / "deep.png")
    raw = read_image(tmp_path / "deep.png", raw=True)
    np.testing.assert_array_equal(raw, deep)
    np.testing.assert_allclose(read_image(tmp_path / "deep.png"), deep / 65535.0)


def test_read_image_jpeg(tmp_path):
    flat = np.full((8, 8, 3), 128, dtype=np.uint8)
    Image.fromarray(flat).save(tmp_path / "flat.jpg", quality=95)
    image = read_array(tmp_path / "flat.jpg")
    assert image.shape == (8, 8, 3)
    np.testing.assert_allclose(image, 128 / 255, atol=2 / 255)


def test_read_image_palette_is_converted_to_rgb(tmp_path):
    grey = np.arange(16, dtype=np.uint8).reshape(4, 4) * 16
    Image.fromarray(grey).convert("P").save(tmp_path / "palette.png")
    image = read_image(tmp_path / "palette.png", raw=True)
    assert image.shape == (4, 4, 3)
    np.testing.assert_array_equal(image[..., 0], grey)


def test_read_image_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.png"):
        read_image(tmp_path / "missing.png")
    broken = tmp_path / "broken.png"
    broken.write_bytes(b"not an image")
    with pytest.raises(ValueError, match="Cannot read .*broken.png.* as an image"):
        read_image(broken)
    with pytest.raises(TypeError, match="`path` must be a str or a Path"):
        read_image(None)


# ----------------------------------------------------------------------------- read_array


def test_read_array_npy_and_suffix_case(tmp_path):
    array = np.arange(6.0).reshape(2, 3)
    np.save(tmp_path / "a.npy", array)
    np.testing.assert_array_equal(read_array(tmp_path / "a.npy"), array)
    np.testing.assert_array_equal(read_array(str(tmp_path / "a.npy")), array)
    write_pfm(tmp_path / "B.PFM", array)
    np.testing.assert_array_equal(read_array(tmp_path / "B.PFM"), array)


def test_read_array_errors(tmp_path):
    with pytest.raises(ValueError, match=r"Cannot read .*data.csv.*suffix must be .npy, .pfm"):
        read_array(tmp_path / "data.csv")
    with pytest.raises(ValueError, match="got 'none'"):
        read_array(tmp_path / "no_suffix")
    bad = tmp_path / "bad.npy"
    bad.write_bytes(b"garbage")
    with pytest.raises(ValueError, match=r"Cannot read .*bad.npy.* as .npy"):
        read_array(bad)
    with pytest.raises(FileNotFoundError, match="missing.npy"):
        read_array(tmp_path / "missing.npy")
    with pytest.raises(FileNotFoundError, match="missing.pfm"):
        read_array(tmp_path / "missing.pfm")


# ----------------------------------------------------------------------------- strict readers


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (b"Pf\n1_0 1\n-1\n" + bytes(40), "bad header"),  # int("1_0") == 10 in Python
        (b"Pf\n1 1\n-1_0\n" + bytes(4), "bad header"),
        (b"Pf\n+1 1\n-1\n" + bytes(4), "bad header"),
        (b"Pf\n1 1\n-1\n" + bytes(4) + b"junk", "expected 4 bytes"),
    ],
)
def test_read_pfm_rejects_what_it_cannot_read_exactly(tmp_path, content, match):
    path = tmp_path / "bad.pfm"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=match) as info:
        read_pfm(path)
    assert str(path) in str(info.value)


def test_read_pfm_crlf_header(tmp_path):
    # a header written on Windows: every line ends in "\r\n", the data follows the last one
    array = np.array([[13.0, -2.5, 7.0]], dtype=np.float32)
    path = tmp_path / "crlf.pfm"
    path.write_bytes(b"Pf\r\n3 1\r\n-1.0\r\n" + array.astype("<f4").tobytes())
    np.testing.assert_array_equal(read_pfm(path), array)


@pytest.mark.parametrize(
    "content",
    [
        b"\x93NUMPY\x01\x00v\x00{'descr'",  # 15 bytes: numpy's parser raises TokenError
        b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f8'}",
        b"not a numpy file at all",
        b"",
    ],
)
def test_read_array_rejects_malformed_npy(tmp_path, content):
    path = tmp_path / "bad.npy"
    path.write_bytes(content)
    with pytest.raises(ValueError, match="bad.npy.* as .npy") as info:
        read_array(path)
    assert "\n" not in str(info.value)


def test_read_array_rejects_npy_with_wrong_data_length(tmp_path):
    path = tmp_path / "short.npy"
    np.save(path, np.arange(6.0))
    data = path.read_bytes()
    path.write_bytes(data[:-8])
    with pytest.raises(ValueError, match="needs 48 bytes of data, the file has 40"):
        read_array(path)
    path.write_bytes(data + b"\x00" * 8)
    with pytest.raises(ValueError, match="the file has 56"):
        read_array(path)


def test_read_array_rejects_object_and_structured_npy(tmp_path):
    path = tmp_path / "fields.npy"
    np.save(path, np.zeros(3, dtype=[("a", "<f8"), ("b", "<i4")]))
    with pytest.raises(ValueError, match="unsupported dtype"):
        read_array(path)


def test_read_image_refuses_a_decompression_bomb(tmp_path, monkeypatch):
    import refsynth.io as rio

    path = tmp_path / "big.png"
    Image.fromarray(np.zeros((64, 64), np.uint8)).save(path)
    monkeypatch.setattr(rio, "MAX_IMAGE_PIXELS", 1000)
    with pytest.raises(ValueError, match=r"big.png.*64x64 pixels is more than"):
        read_image(path)


def test_write_array_writes_the_format_its_suffix_names(tmp_path):
    from refsynth.io import write_array

    values = np.array([[1.25, np.nan], [3.0, 250.5]])
    assert write_array(tmp_path / "r.npy", values) == tmp_path / "r.npy"
    np.testing.assert_array_equal(read_array(tmp_path / "r.npy"), values)
    write_array(tmp_path / "r.pfm", values)
    np.testing.assert_array_equal(read_array(tmp_path / "r.pfm"), values.astype(np.float32))
    write_array(tmp_path / "r.PNG", values, png_scale=4.0)
    stored = read_array(tmp_path / "r.PNG", raw=True)
    assert stored.dtype == np.uint16
    np.testing.assert_array_equal(stored, [[5, 0], [12, 1002]])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.PNG", "r.npy", "r.pfm"]


@pytest.mark.parametrize("name", ["r.pfm.npy.txt", "r", "", "r.tif"])
def test_write_array_refuses_unknown_suffixes_before_writing(tmp_path, name):
    from refsynth.io import write_array

    with pytest.raises(ValueError, match="`path` must end in one of .npy, .pfm, .png"):
        write_array(tmp_path / name if name else "", np.ones((2, 2)))
    assert list(tmp_path.iterdir()) == []


def test_write_png16_refuses_values_it_cannot_store(tmp_path):
    from refsynth.io import write_png16

    with pytest.raises(ValueError, match="outside 1..65535"):
        write_png16(tmp_path / "r.png", np.array([[0.1, 2.0]]))
    with pytest.raises(ValueError, match="outside 1..65535"):
        write_png16(tmp_path / "r.png", np.array([[70000.0, 2.0]]))
    assert not (tmp_path / "r.png").exists()


# ----------------------------------------------------------------------------- fuzz


def _valid_bytes(suffix: str, array: np.ndarray, folder) -> bytes:
    """The bytes of a valid file of ``suffix`` holding ``array`` (grey, small)."""
    path = folder / f"valid{suffix}"
    if suffix == ".npy":
        np.save(path, array)
    elif suffix == ".pfm":
        write_pfm(path, array.astype(np.float32))
    else:
        Image.fromarray((array * 255).astype(np.uint8)).save(path)
    return path.read_bytes()


@st.composite
def damaged_file(draw):
    """A suffix and bytes: random junk, or a valid small file truncated, overwritten or padded."""
    suffix = draw(st.sampled_from([".npy", ".pfm", ".png"]))
    if draw(st.booleans()):
        return suffix, draw(st.binary(max_size=200)), None
    height, width = draw(st.integers(1, 4)), draw(st.integers(1, 4))
    array = draw(arrays(np.float64, (height, width), elements=st.floats(0, 1)))
    edits = draw(st.lists(st.tuples(st.sampled_from(["cut", "set", "insert", "append"]),
                                    st.integers(0, 10_000), st.binary(min_size=1, max_size=8)),
                          max_size=3))
    return suffix, array, edits


def _apply(data: bytes, edits) -> bytes:
    for kind, where, chunk in edits:
        at = where % (len(data) + 1)
        if kind == "cut":
            data = data[:at]
        elif kind == "set":
            data = data[:at] + chunk + data[at + len(chunk):]
        elif kind == "insert":
            data = data[:at] + chunk + data[at:]
        else:
            data = data + chunk
    return data


@settings(deadline=None, max_examples=300)
@given(damaged_file())
def test_readers_give_an_array_or_one_line_naming_the_file(tmp_path_factory, case):
    """Random or damaged .npy/.pfm/.png files: an array, or one ValueError line naming the file."""
    folder = tmp_path_factory.mktemp("fuzz")
    suffix, content, edits = case
    if edits is not None:
        content = _apply(_valid_bytes(suffix, content, folder), edits)
    path = folder / f"damaged{suffix}"
    path.write_bytes(content)
    for raw in (False, True):
        try:
            array = read_array(path, raw=raw)
        except ValueError as error:
            message = str(error)
            assert "\n" not in message and str(path) in message, message
        else:
            assert isinstance(array, np.ndarray)


def test_a_damaged_file_pillow_rejects_with_a_value_error_names_the_file(tmp_path):
    """Pillow raised a bare ValueError ("Reached EOF while reading header") for this one."""
    path = tmp_path / "range.png"
    path.write_bytes(b"P1")
    with pytest.raises(ValueError, match="Cannot read .*range.png' as an image") as info:
        read_array(path, raw=True)
    assert "\n" not in str(info.value)


def test_write_unit_png16_round_trips_a_confidence_map(tmp_path):
    from refsynth.io import write_unit_png16

    confidence = np.array([[0.0, 0.25], [0.5, 1.0]])
    write_unit_png16(tmp_path / "c.png", confidence)
    np.testing.assert_allclose(read_image(tmp_path / "c.png"), confidence, atol=1 / 65535)
    assert read_image(tmp_path / "c.png", raw=True).dtype == np.uint16
    for bad in (np.array([[0.5, 1.5]]), np.array([[np.nan, 0.5]]), np.zeros(3)):
        with pytest.raises(ValueError):
            write_unit_png16(tmp_path / "bad.png", bad)
    assert not (tmp_path / "bad.png").exists()


@settings(deadline=None)
@given(arrays(st.sampled_from([np.float64, np.float32, np.int16, np.uint8, np.bool_]),
              st.tuples(st.integers(0, 4), st.integers(1, 4))))
def test_write_array_npy_is_numpys_own_file_written_whole(tmp_path_factory, array):
    """The .npy written through memory is byte for byte what numpy.save writes, and no
    temporary file is left beside it."""
    import io as _io

    from refsynth.io import npy_bytes, write_array

    folder = tmp_path_factory.mktemp("npy")
    path = write_array(folder / "a.npy", array)
    expected = _io.BytesIO()
    np.save(expected, array)
    assert path.read_bytes() == expected.getvalue() == npy_bytes(array)
    assert [p.name for p in folder.iterdir()] == ["a.npy"]
    np.testing.assert_array_equal(np.load(path), array)
