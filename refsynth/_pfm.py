"""The Portable Float Map (PFM) of the Middlebury stereo benchmark, read and written exactly.

:func:`read_pfm` and :func:`write_pfm` are re-exported by :mod:`refsynth.io`
(see its docstring for the format), which is where callers find them.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from refsynth._files import write_atomic

__all__ = ["read_pfm", "write_pfm"]

_PFM_INT = re.compile(rb"[0-9]{1,9}")
_PFM_REAL = re.compile(rb"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


def _check_path(path) -> Path:
    if not isinstance(path, (str, Path)):
        raise TypeError(f"The parameter `path` must be a str or a Path, got {type(path).__name__}")
    return Path(path)


def _read_bytes(path: Path) -> bytes:
    if not path.is_file():
        raise FileNotFoundError(f"No such file: '{path}'")
    return path.read_bytes()


def _pfm_header(data: bytes, path: Path) -> tuple[list[bytes], int]:
    """The four header tokens (kind, W, H, scale) and the offset of the first data byte."""
    tokens: list[bytes] = []
    position = 0
    while len(tokens) < 4:
        while position < len(data) and data[position : position + 1].isspace():
            position += 1
        start = position
        while position < len(data) and not data[position : position + 1].isspace():
            position += 1
        if start == position:
            raise ValueError(f"Cannot read '{path}' as PFM: the header is truncated")
        tokens.append(data[start:position])
        if tokens[0] not in (b"PF", b"Pf"):
            raise ValueError(
                f"Cannot read '{path}' as PFM: it must start with 'PF' or 'Pf', "
                f"got {tokens[0][:10]!r}"
            )
    # one whitespace character separates the header from the data ("\r\n" counts as one)
    if data[position : position + 2] == b"\r\n":
        return tokens, position + 2
    return tokens, position + 1


def read_pfm(path: str | Path) -> np.ndarray:
    """Read a Portable Float Map.

    Parameters
    ----------
    path : str or Path
        A ``.pfm`` file: ``PF`` (colour) or ``Pf`` (grey), either byte order.

    Returns
    -------
    ndarray of shape (H, W) or (H, W, 3), float32
        In native byte order, rows from the top of the image down (the file
        stores them bottom-up). Values are returned as stored: for Middlebury
        disparities ``inf`` marks the pixels without ground truth.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        If the file is not a valid PFM (the message names the path).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "disparity.pfm"
    >>> write_pfm(path, np.array([[1.0, 2.0], [3.0, np.inf]]))
    >>> read_pfm(path).tolist()
    [[1.0, 2.0], [3.0, inf]]
    """
    path = _check_path(path)
    data = _read_bytes(path)
    (kind, width_token, height_token, scale_token), offset = _pfm_header(data, path)
    if not (
        _PFM_INT.fullmatch(width_token)
        and _PFM_INT.fullmatch(height_token)
        and _PFM_REAL.fullmatch(scale_token)
    ):
        raise ValueError(
            f"Cannot read '{path}' as PFM: bad header {width_token!r} {height_token!r} "
            f"{scale_token!r}"
        )
    width, height, scale = int(width_token), int(height_token), float(scale_token)
    if width <= 0 or height <= 0 or scale == 0 or not np.isfinite(scale):
        raise ValueError(f"Cannot read '{path}' as PFM: bad size {width}x{height} or scale {scale}")
    channels = 3 if kind == b"PF" else 1
    dtype = np.dtype("<f4" if scale < 0 else ">f4")
    count = width * height * channels
    if len(data) - offset != count * 4:
        raise ValueError(
            f"Cannot read '{path}' as PFM: expected {count * 4} bytes of data for "
            f"{width}x{height}x{channels}, got {len(data) - offset}"
        )
    values = np.frombuffer(data, dtype=dtype, count=count, offset=offset)
    image = values.reshape((height, width, channels) if channels == 3 else (height, width))
    return np.flipud(image).astype(np.float32)


def write_pfm(path: str | Path, array: np.ndarray) -> None:
    """Write a Portable Float Map (little-endian, scale -1).

    Parameters
    ----------
    path : str or Path
        The file to write; an existing file is replaced only once the new
        one is complete (:func:`refsynth._files.write_atomic`).
    array : ndarray of shape (H, W) or (H, W, 3)
        Real values, stored as float32 (``Pf`` for (H, W), ``PF`` for
        (H, W, 3)); non-finite values are written as they are.

    Raises
    ------
    TypeError
        If ``array`` is not a real numeric numpy array.
    ValueError
        If its shape is not (H, W) or (H, W, 3) with H, W >= 1.
    OSError
        Naming ``path``, if it cannot be written (the previous file is then
        intact).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "range.pfm"
    >>> write_pfm(path, np.zeros((2, 3, 3)))
    >>> read_pfm(path).shape, path.read_bytes()[:2]
    ((2, 3, 3), b'PF')
    """
    path = _check_path(path)
    if not isinstance(array, np.ndarray):
        raise TypeError(f"The parameter `array` must be a numpy array, got {type(array).__name__}")
    if (
        array.dtype == bool
        or not np.issubdtype(array.dtype, np.number)
        or np.issubdtype(array.dtype, np.complexfloating)
    ):
        raise TypeError(f"The parameter `array` must be a real numeric array, got {array.dtype}")
    if not (array.ndim == 2 or (array.ndim == 3 and array.shape[2] == 3)) or 0 in array.shape:
        raise ValueError(
            f"The parameter `array` must have shape (H, W) or (H, W, 3), got {array.shape}"
        )
    height, width = array.shape[:2]
    kind = "PF" if array.ndim == 3 else "Pf"
    header = f"{kind}\n{width} {height}\n-1.0\n".encode("ascii")
    body = np.ascontiguousarray(np.flipud(array), dtype="<f4").tobytes()
    write_atomic(path, header + body)
