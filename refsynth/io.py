"""Reading and writing the arrays refsynth works on: PFM, NPY and images.

- :func:`read_pfm` / :func:`write_pfm`: the Portable Float Map of the
  Middlebury stereo benchmark (ground-truth disparities, ``inf`` = unknown).
- :func:`read_image`: PNG, JPEG, TIFF, PGM/PPM … through Pillow (which
  matplotlib depends on), as float64 in [0, 1] or as the stored integers.
- :func:`read_array`: any of the above, chosen by the file's suffix.
- :func:`read_range`: a range image, the one way every command reads range
  (stored values or stored integers / an explicit scale; NaN = unknown; lossy
  formats and values <= 0 refused).
- :func:`write_array`: ``.npy``, ``.pfm`` or a 16-bit ``.png``, chosen by the
  suffix (:data:`WRITE_SUFFIXES`); anything else is refused before writing.
  :func:`write_unit_png16` writes values in [0, 1] (a confidence map).

Every writer goes through :func:`refsynth._files.write_atomic`: the file is
written beside its target and renamed over it once complete, so a failed
write (a full disk, a file-size limit) leaves the previous file intact and
raises an ``OSError`` naming the file.

Every reader rejects what it cannot read exactly — a truncated or padded
file, a malformed header, an image too large to decode safely — with a
``ValueError`` whose message names the file.

The PFM format: a text header of three whitespace-separated tokens, ``PF``
(3 channels) or ``Pf`` (1 channel), then ``W H``, then a scale whose sign
gives the byte order (negative: little-endian, positive: big-endian),
followed by a single whitespace character and ``W·H·C`` float32 values,
rows stored from the *bottom* of the image to the top.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
from PIL import Image

from refsynth._files import write_atomic
from refsynth._pfm import read_pfm, write_pfm

__all__ = [
    "read_pfm",
    "write_pfm",
    "read_image",
    "read_array",
    "read_npy",
    "read_range",
    "npy_bytes",
    "write_png16",
    "write_unit_png16",
    "write_array",
    "check_write_suffix",
    "IMAGE_SUFFIXES",
    "WRITE_SUFFIXES",
    "MAX_IMAGE_PIXELS",
    "LOSSY_SUFFIXES",
]

#: The largest image (in pixels) :func:`read_image` decodes: 2^28, a 16384×16384
#: picture. A file claiming more is refused before it is decompressed.
MAX_IMAGE_PIXELS = 2**28
#: The suffixes :func:`write_array` writes.
WRITE_SUFFIXES = (".npy", ".pfm", ".png")

#: Suffixes :func:`read_array` hands to :func:`read_image` (read by Pillow).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm", ".pbm")


def _check_path(path) -> Path:
    if not isinstance(path, (str, Path)):
        raise TypeError(f"The parameter `path` must be a str or a Path, got {type(path).__name__}")
    return Path(path)


# ----------------------------------------------------------------------------- images


def _decode(image: Image.Image) -> tuple[np.ndarray, str]:
    """Pillow's pixels as an array: grey modes as they are, alpha dropped, the rest RGB."""
    image.load()
    mode = image.mode
    if mode in ("LA", "La"):
        image = image.getchannel("L")
        mode = "L"
    elif mode not in ("1", "L", "I", "F") and not mode.startswith("I;16"):
        image = image.convert("RGB")
        mode = "RGB"
    return np.array(image), mode


def read_image(path: str | Path, *, raw: bool = False) -> np.ndarray:
    """Read a PNG, JPEG, TIFF, PGM … image through Pillow; drop any alpha channel.

    Parameters
    ----------
    path : str or Path
        Any file Pillow reads.
    raw : bool, default False
        False: return float64 in [0, 1], the stored integers divided by their
        type's full scale (255 for 8-bit, 65535 for 16-bit; Pillow's 32-bit
        integer mode, which it uses for some 16-bit files, is also divided by
        65535); float images (TIFF mode ``F``) are returned as they are.
        True: return the stored values unchanged (uint8, uint16, int32 or
        float32) — what a disparity PNG needs (see
        :func:`refsynth.scenes.load_middlebury`).

    Returns
    -------
    ndarray of shape (H, W) or (H, W, 3)
        Grey images (Pillow modes ``1``, ``L``, ``LA``, ``I``, ``I;16``,
        ``F``) come back 2-D; everything else is converted to RGB.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        If Pillow cannot read it (the message names the path).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from PIL import Image
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "grey.png"
    >>> Image.fromarray(np.array([[0, 255]], dtype=np.uint8)).save(path)
    >>> read_image(path).tolist(), read_image(path, raw=True).dtype
    ([[0.0, 1.0]], dtype('uint8'))
    """
    path = _check_path(path)
    if not path.is_file():
        raise FileNotFoundError(f"No such file: '{path}'")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            image_file = Image.open(path)
        with image_file as image:
            width, height = image.size
            if width * height <= MAX_IMAGE_PIXELS:
                array, mode = _decode(image)
    except Exception as error:  # Pillow raises OSError, ValueError,
        # SyntaxError, EOFError, struct.error, zlib.error ... on a damaged file
        reason = " ".join(str(error).split()) or type(error).__name__
        raise ValueError(f"Cannot read '{path}' as an image: {reason}") from error
    if width * height > MAX_IMAGE_PIXELS:
        raise ValueError(
            f"Cannot read '{path}' as an image: {width}x{height} pixels is more than "
            f"refsynth decodes ({MAX_IMAGE_PIXELS})"
        )
    if mode.startswith("I;16"):
        array = array.astype(np.uint16)
    if raw:
        return array
    if array.dtype == bool:
        return array.astype(np.float64)
    if array.dtype == np.uint8:
        return array / 255.0
    if np.issubdtype(array.dtype, np.integer):
        return array / 65535.0
    return array.astype(np.float64)


def read_array(path: str | Path, *, raw: bool = False) -> np.ndarray:
    """Read an array from ``.npy``, ``.pfm`` or an image file, by suffix.

    Parameters
    ----------
    path : str or Path
        ``.npy`` (read with ``allow_pickle=False``), ``.pfm``
        (:func:`read_pfm`) or one of :data:`IMAGE_SUFFIXES`
        (:func:`read_image`); the suffix is matched case-insensitively.
    raw : bool, default False
        For image files only, passed to :func:`read_image`: False gives
        float64 in [0, 1], True the stored integers.

    Returns
    -------
    ndarray

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        If the suffix is not one of those above, or the file cannot be read
        (the message names the path).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "range.npy"
    >>> np.save(path, np.array([[1.5, np.nan]]))
    >>> read_array(path).tolist()
    [[1.5, nan]]
    """
    path = _check_path(path)
    suffix = path.suffix.lower()
    if suffix == ".pfm":
        return read_pfm(path)
    if suffix in IMAGE_SUFFIXES:
        return read_image(path, raw=raw)
    if suffix == ".npy":
        return read_npy(path)
    raise ValueError(
        f"Cannot read '{path}': the suffix must be .npy, .pfm or one of "
        f"{', '.join(IMAGE_SUFFIXES)}, got {path.suffix or 'none'!r}"
    )


# ----------------------------------------------------------------------------- NPY


def read_npy(path: str | Path) -> np.ndarray:
    """Read a ``.npy`` file exactly: a numeric array, its header and data sizes consistent.

    Parameters
    ----------
    path : str or Path
        The ``.npy`` file to read (any suffix is accepted).

    Returns
    -------
    ndarray
        Of a bool, integer, floating or complex dtype (never objects: no pickles).

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        If the file is not a ``.npy`` file, its header is malformed, its data
        is shorter or longer than the header says, or its dtype holds objects
        or structured fields (the message names the path).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "mask.npy"
    >>> np.save(path, np.eye(2, dtype=bool))
    >>> read_npy(path).tolist()
    [[True, False], [False, True]]
    """
    path = _check_path(path)
    if not path.is_file():
        raise FileNotFoundError(f"No such file: '{path}'")
    try:
        with path.open("rb") as stream:
            version = np.lib.format.read_magic(stream)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(stream)
            elif version in ((2, 0), (3, 0)):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(stream)
            else:  # pragma: no cover - read_magic rejects other versions
                raise ValueError(f"unsupported version {version}")
            offset = stream.tell()
    except Exception as error:  # numpy raises ValueError, SyntaxError, TokenError, ...
        raise ValueError(f"Cannot read '{path}' as .npy: {error}") from None
    if dtype.hasobject or dtype.fields is not None or dtype.kind not in "biufc":
        raise ValueError(f"Cannot read '{path}' as .npy: unsupported dtype {dtype}")
    expected = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    size = path.stat().st_size - offset
    if size != expected:
        raise ValueError(
            f"Cannot read '{path}' as .npy: the header {tuple(shape)} {dtype} needs "
            f"{expected} bytes of data, the file has {size}"
        )
    return np.load(path, allow_pickle=False)


# ----------------------------------------------------------------------------- range

#: Image suffixes refused for range: lossy compression invents values (a JPEG's
#: ringing puts small nonzero values into the unknown pixels).
LOSSY_SUFFIXES = (".jpg", ".jpeg")
_JPEG_MAGIC = b"\xff\xd8\xff"


def read_range(
    path: str | Path,
    *,
    scale: float | None = None,
    allow_nonpositive: bool = False,
) -> np.ndarray:
    """Read a range image the one way every refsynth command reads range.

    ``synth``, ``model`` and ``evaluate`` all read range through this
    function, the inverse of :func:`write_array`:

    - ``.npy`` and ``.pfm``: the values as stored; non-finite values (NaN,
      ``±inf``) are unknown.
    - a lossless image (PNG, TIFF, PGM …, :data:`IMAGE_SUFFIXES`): the
      *stored integers*, never rescaled to [0, 1]; 0 is unknown; each value
      is divided by ``scale`` (what ``write_array(…, png_scale=scale)``
      multiplied by), so a 16-bit PNG that ``synth --out x.png --png-scale
      1000`` wrote comes back in the original unit.
    - JPEG (:data:`LOSSY_SUFFIXES`, or a file whose bytes are JPEG's
      whatever its suffix) is refused: its compression invents values.

    Parameters
    ----------
    path : str or Path
        The range file.
    scale : float, optional
        For an image file only: the stored integer per unit of range
        (default 1: the stored integers are the range).
    allow_nonpositive : bool, default False
        Accept known values <= 0. Range is a distance, so by default a known
        value <= 0 is refused (a signed map, e.g. heights about a plane,
        needs this).

    Returns
    -------
    ndarray of shape (H, W), float64
        NaN where the range is unknown (a new array).

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        Naming the file: if it cannot be read, is lossy, does not hold one
        channel of real numbers, holds a known value <= 0 (without
        ``allow_nonpositive``), or ``scale`` is given for a ``.npy`` /
        ``.pfm`` file or is not a finite number > 0.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> png = write_array(folder / "range.png", np.array([[1.25, np.nan]]), png_scale=1000)
    >>> read_range(png, scale=1000).tolist()
    [[1.25, nan]]
    >>> npy = write_array(folder / "range.npy", np.array([[2.0, np.inf]]))
    >>> read_range(npy).tolist()
    [[2.0, nan]]
    """
    path = _check_path(path)
    suffix = path.suffix.lower()
    image = suffix in IMAGE_SUFFIXES
    if scale is not None:
        if isinstance(scale, bool) or not isinstance(scale, (int, float, np.number)):
            raise TypeError(f"The parameter `scale` must be a number, got {scale!r}")
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"The parameter `scale` must be finite and > 0, got {scale}")
        if not image:
            raise ValueError(
                f"Cannot read '{path}' as range with a scale: the scale applies to an image "
                f"range (PNG, TIFF, PGM ...), a {suffix or 'suffix-less'} file holds the "
                "range itself"
            )
    if not path.is_file():
        raise FileNotFoundError(f"No such file: '{path}'")
    lossy = "JPEG" if suffix in LOSSY_SUFFIXES else (_lossy_format(path) if image else None)
    if lossy is not None:
        raise ValueError(
            f"Cannot read '{path}' as range: {lossy} is lossy (its compression invents range "
            "values); store range as .npy, .pfm or a 16-bit .png"
        )
    stored = read_array(path, raw=True)
    if stored.ndim == 3 and stored.shape[2] == 1:
        stored = stored[..., 0]
    if stored.ndim != 2:
        raise ValueError(
            f"Cannot read '{path}' as range: it must be a single-channel (H, W) map, got "
            f"shape {stored.shape}"
        )
    if stored.dtype == bool or stored.dtype.kind not in "iuf":
        raise ValueError(
            f"Cannot read '{path}' as range: it must hold real numbers, got dtype {stored.dtype}"
        )
    values = stored.astype(np.float64)
    if image:
        values[values == 0] = np.nan  # an image has no NaN: 0 marks the unknown pixels
        if scale is not None:
            values /= scale
    values[~np.isfinite(values)] = np.nan
    if not allow_nonpositive:
        with np.errstate(invalid="ignore"):
            bad = values <= 0
        if bad.any():
            raise ValueError(
                f"Cannot read '{path}' as range: {int(bad.sum())} known values are <= 0 "
                f"(the smallest {values[bad].min():g}); range is a distance > 0 (mark unknown "
                "pixels NaN, or 0 in an image), or allow them explicitly "
                "(allow_nonpositive; on the command line --allow-nonpositive)"
            )
    return values


def _lossy_format(path: Path) -> str | None:
    """"JPEG" or "WebP" if the file's first bytes say so (whatever its suffix), else None.

    A lossless WebP (``VP8L``) is not refused.
    """
    with path.open("rb") as stream:
        head = stream.read(16)
    if head.startswith(_JPEG_MAGIC):
        return "JPEG"
    if head[:4] == b"RIFF" and head[8:12] == b"WEBP" and head[12:16] != b"VP8L":
        return "WebP"
    return None


# ----------------------------------------------------------------------------- writing


def write_png16(path: str | Path, array: np.ndarray, scale: float = 1.0) -> None:
    """Write a range image as a 16-bit grey PNG: ``round(value · scale)``, 0 = unknown.

    Parameters
    ----------
    path : str or Path
        The file to write; an existing file is replaced only once the new
        one is complete (:func:`refsynth._files.write_atomic`).
    array : ndarray of shape (H, W), real
        NaN (and non-finite values) mark unknown pixels and are stored as 0.
    scale : float, default 1
        Stored integer per unit of range; read back with
        ``read_range(path, scale=scale)`` (0 = unknown, read as NaN).

    Raises
    ------
    ValueError
        If a finite value, scaled and rounded, falls outside 1…65535 (0 is
        reserved for "unknown"), or the shape is not (H, W).
    OSError
        Naming ``path``, if it cannot be written (the previous file is then
        intact).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "range.png"
    >>> write_png16(path, np.array([[1.25, np.nan]]), scale=100)
    >>> read_array(path, raw=True).tolist()
    [[125, 0]]
    """
    path = _check_path(path)
    if not isinstance(array, np.ndarray) or array.ndim != 2 or 0 in array.shape:
        shape = getattr(array, "shape", type(array).__name__)
        raise ValueError(f"The parameter `array` must be a non-empty 2-D array, got {shape}")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"The parameter `scale` must be finite and > 0, got {scale}")
    values = np.asarray(array, dtype=np.float64)
    known = np.isfinite(values)
    stored = np.zeros(values.shape, dtype=np.uint16)
    scaled = np.rint(values[known] * scale)
    if scaled.size and (scaled.min() < 1 or scaled.max() > 65535):
        raise ValueError(
            f"Cannot write '{path}' as a 16-bit PNG: value x {scale} spans "
            f"{scaled.min():g}..{scaled.max():g}, outside 1..65535 (0 = unknown); "
            "choose another --png-scale"
        )
    stored[known] = scaled.astype(np.uint16)
    write_atomic(path, _png_bytes(stored))


def write_array(path: str | Path, array: np.ndarray, *, png_scale: float = 1.0) -> Path:
    """Write ``array`` in the format its suffix names: ``.npy``, ``.pfm`` or 16-bit ``.png``.

    Parameters
    ----------
    path : str or Path
        Its suffix (case-insensitive) must be one of :data:`WRITE_SUFFIXES`.
    array : ndarray
        Any numeric array for ``.npy``; of shape (H, W) or (H, W, 3) for
        ``.pfm``; of shape (H, W) for ``.png``.
    png_scale : float, default 1
        For ``.png`` only (see :func:`write_png16`).

    Returns
    -------
    Path
        The path written (exactly ``path``: no suffix is added).

    Raises
    ------
    ValueError
        If :func:`check_write_suffix` refuses ``path``.
    OSError
        Naming ``path``, if it cannot be written (the previous file is then
        intact).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "range.npy"
    >>> write_array(path, np.ones((2, 2))) == path
    True
    """
    path = _check_path(path)
    suffix = check_write_suffix(path)
    if suffix == ".npy":
        write_atomic(path, npy_bytes(array))
    elif suffix == ".pfm":
        write_pfm(path, array)
    else:
        write_png16(path, array, png_scale)
    return path


def check_write_suffix(path: str | Path, name: str = "path") -> str:
    """The lower-case suffix of ``path`` if :func:`write_array` writes it, or ``ValueError``.

    Parameters
    ----------
    path : str or Path
        The file name to check (it need not exist).
    name : str, default "path"
        The argument name the error message gives.

    Returns
    -------
    str
        One of :data:`WRITE_SUFFIXES`, lower-case.

    Raises
    ------
    ValueError
        If the suffix is not one of :data:`WRITE_SUFFIXES`.

    Examples
    --------
    >>> check_write_suffix("out/range.PFM")
    '.pfm'
    """
    path = _check_path(path)
    suffix = path.suffix.lower()
    if not path.name or suffix not in WRITE_SUFFIXES:
        raise ValueError(
            f"The parameter `{name}` must end in one of {', '.join(WRITE_SUFFIXES)}, "
            f"got {str(path)!r}"
        )
    return suffix


def write_unit_png16(path: str | Path, array: np.ndarray) -> Path:
    """Write values in [0, 1] (a confidence map) as a 16-bit grey PNG: ``round(value · 65535)``.

    Read back with ``read_image(path)``, which divides by 65535. Unlike
    :func:`write_png16`, 0 is a value here, not "unknown".

    Parameters
    ----------
    path : str or Path
        The file to write; an existing file is replaced only once the new
        one is complete (:func:`refsynth._files.write_atomic`).
    array : ndarray of shape (H, W), real
        Finite values in [0, 1].

    Returns
    -------
    Path
        The path written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "confidence.png"
    >>> _ = write_unit_png16(path, np.array([[0.0, 0.5], [1.0, 0.25]]))
    >>> read_image(path).round(4).tolist()
    [[0.0, 0.5], [1.0, 0.25]]

    Raises
    ------
    ValueError
        If the shape is not (H, W) or a value is not finite or outside [0, 1].
    OSError
        Naming ``path``, if it cannot be written (the previous file is then
        intact).
    """
    path = _check_path(path)
    if not isinstance(array, np.ndarray) or array.ndim != 2 or 0 in array.shape:
        shape = getattr(array, "shape", type(array).__name__)
        raise ValueError(f"The parameter `array` must be a non-empty 2-D array, got {shape}")
    values = np.asarray(array, dtype=np.float64)
    if not (np.all(np.isfinite(values)) and values.min() >= 0 and values.max() <= 1):
        raise ValueError(f"Cannot write '{path}' as a [0, 1] PNG: values must lie in [0, 1]")
    write_atomic(path, _png_bytes(np.rint(values * 65535).astype(np.uint16)))
    return path


def _png_bytes(stored: np.ndarray) -> bytes:
    """``stored`` (uint8 or uint16, (H, W)) encoded as a grey PNG, in memory."""
    buffer = io.BytesIO()
    Image.fromarray(stored).save(buffer, format="PNG")
    return buffer.getvalue()


def npy_bytes(array: np.ndarray) -> bytes:
    """``array`` encoded as a ``.npy`` file, in memory (no pickles).

    :func:`write_array` hands these bytes to :func:`refsynth._files.write_atomic`:
    ``numpy.save`` to a real file writes through ``ndarray.tofile``, whose
    error at close can be lost; in memory nothing can fail silently.

    Parameters
    ----------
    array : ndarray
        A numeric array (bool, integer, floating or complex).

    Returns
    -------
    bytes
        What ``numpy.save(file, array, allow_pickle=False)`` writes.

    Raises
    ------
    TypeError
        If ``array`` is not a numpy array of a bool, integer, floating or
        complex dtype.

    Examples
    --------
    >>> data = npy_bytes(np.arange(3))
    >>> data[:6], np.load(io.BytesIO(data)).tolist()
    (b'\\x93NUMPY', [0, 1, 2])
    """
    if not isinstance(array, np.ndarray) or array.dtype.kind not in "biufc" \
            or array.dtype.fields is not None:
        what = getattr(array, "dtype", type(array).__name__)
        raise TypeError(f"The parameter `array` must be a numeric numpy array, got {what}")
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()
