r"""PLY files of a :class:`~refsynth.model.build.Model`, written and read with numpy (stage 3).

The Polygon File Format (Turk, 1994) is a header of text lines followed by
the data, ASCII or binary. refsynth writes::

    ply
    format binary_little_endian 1.0        (or: format ascii 1.0)
    comment refsynth stage 3 model (Torres-Mendez & Dudek 2008)
    comment frame: x right, y up, z forward (refsynth, Eq. 14)
    element vertex N
    property double x                      (or float: coordinates="float32")
    property double y
    property double z
    property uchar red
    property uchar green
    property uchar blue
    property float confidence
    property float uncertainty             (when the model carries one)
    property uchar synthesized
    element face M
    property list uchar int vertex_indices
    end_header

- Coordinates are ``double`` (float64) by default so that a model read back
  is exactly the model written; ``coordinates="float32"`` halves them.
- ``confidence`` is a ``float`` (float32): it lies in [0, 1] and seven
  digits are plenty; read back, it is the float32 rounding of the model's.
- ``uncertainty`` is a ``float`` (float32): each vertex's expected absolute range error in
  the range's unit (:attr:`refsynth.SynthesisResult.uncertainty`, 0 where measured),
  written when the model carries one (``Model.uncertainty``).
- ``synthesized`` is 0 (measured) or 1 (synthesized).
- Faces are triangles, as ``uchar`` count 3 and three ``int`` (int32) indices.
- ASCII writes doubles with 17 significant digits and floats with 9, which
  read back to the same binary values.

refsynth's frame is left-handed (x right, y up, z forward, as Eq. 14), the
frame a PLY viewer does not assume: viewers show the model mirrored left to
right (negate x to see it the right way round). Faces are wound so that
their normals face the scanner.

:func:`read_ply` reads these files back (and other PLYs with a vertex
element of scalar properties and triangular faces), for round trips; the
tests check the files with the independent readers ``plyfile`` and
``trimesh``.

References
----------
G. Turk, "The PLY Polygon File Format" (1994).

L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §1 (stage 3), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from refsynth._checks import check_choice
from refsynth._files import write_atomic
from refsynth.model.build import Model

__all__ = ["write_ply", "read_ply", "PLY_TYPES"]

#: PLY scalar types and their numpy types (little-endian; the byte order is set per file).
PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}


def _vertex_dtype(coordinates: str, uncertainty: bool = False) -> np.dtype:
    kind = "<f8" if coordinates == "float64" else "<f4"
    extra = [("uncertainty", "<f4")] if uncertainty else []
    return np.dtype([("x", kind), ("y", kind), ("z", kind), ("red", "u1"), ("green", "u1"),
                     ("blue", "u1"), ("confidence", "<f4"), *extra, ("synthesized", "u1")])


def _header(model: Model, ascii: bool, coordinates: str, comments) -> bytes:
    kind = "double" if coordinates == "float64" else "float"
    lines = ["ply", f"format {'ascii' if ascii else 'binary_little_endian'} 1.0",
             "comment refsynth stage 3 model (Torres-Mendez & Dudek 2008)",
             "comment frame: x right, y up, z forward (refsynth, Eq. 14)"]
    for comment in comments:
        text = str(comment)
        if "\n" in text or "\r" in text:
            raise ValueError(f"The parameter `comments` must hold one-line strings, got {text!r}")
        lines.append(f"comment {text}")
    lines += [f"element vertex {model.n_vertices}",
              *(f"property {kind} {axis}" for axis in "xyz"),
              "property uchar red", "property uchar green", "property uchar blue",
              "property float confidence",
              *(["property float uncertainty"] if model.uncertainty is not None else []),
              "property uchar synthesized",
              f"element face {model.n_faces}", "property list uchar int vertex_indices",
              "end_header"]
    return ("\n".join(lines) + "\n").encode("ascii")


def write_ply(path, model: Model, *, ascii: bool = False, coordinates: str = "float64",
              comments=()) -> Path:
    """Write ``model`` as a PLY file (binary little-endian, or ASCII).

    Parameters
    ----------
    path : str or Path
        The file to write (its folder must exist); an existing file is
        replaced only once the new one is complete
        (:func:`refsynth._files.write_atomic`).
    model : Model
        The model to write (vertices, colours, confidence, synthesized, faces).
    ascii : bool, default False
        Write ``format ascii 1.0`` instead of ``binary_little_endian``.
    coordinates : {"float64", "float32"}, default "float64"
        The type of x, y, z (``double`` or ``float``).
    comments : iterable of str, default ()
        Extra ``comment`` lines for the header (one line each).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OSError
        Naming ``path``, if it cannot be written (the previous file is then
        intact, and no temporary file is left behind).

    Examples
    --------
    >>> import tempfile
    >>> from refsynth.model import PinholeCamera, build_model
    >>> model = build_model(np.full((2, 2), 3.0), PinholeCamera(100.0, 0.5, 0.5))
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     back = read_ply(write_ply(Path(folder) / "m.ply", model))
    >>> bool(np.array_equal(back.vertices, model.vertices)), back.n_faces
    (True, 2)
    """
    if not isinstance(model, Model):
        raise TypeError(f"The parameter `model` must be a Model, got {type(model).__name__}")
    coordinates = check_choice("coordinates", coordinates, ("float64", "float32"))
    if not isinstance(path, (str, Path)):
        raise TypeError(f"The parameter `path` must be a str or a Path, got {type(path).__name__}")
    if model.n_vertices and not np.all(np.isfinite(model.vertices)):
        raise ValueError("The model's `vertices` must be finite to be written")
    if model.n_faces and model.n_vertices > np.iinfo(np.int32).max:
        raise ValueError("The model has too many vertices for int32 face indices")
    path = Path(path)
    if model.uncertainty is not None and not (np.all(np.isfinite(model.uncertainty))
                                              and np.all(model.uncertainty >= 0)):
        raise ValueError("The model's `uncertainty` must be finite and >= 0 to be written")
    vertices = np.empty(model.n_vertices,
                        dtype=_vertex_dtype(coordinates, model.uncertainty is not None))
    for axis, name in enumerate("xyz"):
        vertices[name] = model.vertices[:, axis]
    for channel, name in enumerate(("red", "green", "blue")):
        vertices[name] = model.colours[:, channel]
    vertices["confidence"] = model.confidence
    if model.uncertainty is not None:
        vertices["uncertainty"] = model.uncertainty
    vertices["synthesized"] = model.synthesized
    faces = np.empty(model.n_faces, dtype=[("n", "u1"), ("v", "<i4", (3,))])
    faces["n"] = 3
    faces["v"] = model.faces
    header = _header(model, ascii, coordinates, comments)

    def write(stream) -> None:
        stream.write(header)
        if ascii:
            _write_ascii(stream, vertices, faces, coordinates)
        else:
            stream.write(vertices.tobytes())
            stream.write(faces.tobytes())

    return write_atomic(path, write)


def _write_ascii(stream, vertices: np.ndarray, faces: np.ndarray, coordinates: str) -> None:
    real = "%.17g" if coordinates == "float64" else "%.9g"
    names = vertices.dtype.names
    table = np.column_stack([vertices[name].astype(np.float64) for name in names])
    floats = ["%.9g"] * (len(names) - 7)  # confidence (and uncertainty)
    _write_rows(stream, table, " ".join([real] * 3 + ["%d"] * 3 + floats + ["%d"]))
    _write_rows(stream, np.column_stack([faces["n"], faces["v"]]).astype(np.int64),
                "%d %d %d %d")


def _write_rows(stream, table: np.ndarray, row: str, chunk: int = 65536) -> None:
    """``table``'s rows formatted by ``row``, one line each (a chunk per ``%`` call)."""
    for start in range(0, len(table), chunk):
        block = table[start:start + chunk]
        stream.write((((row + "\n") * len(block)) % tuple(block.ravel().tolist()))
                     .encode("ascii"))


# ----------------------------------------------------------------------------- reading


def _parse_header(data: bytes, path: Path):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError(f"Cannot read '{path}' as PLY: no 'ply' ... 'end_header' header")
    stop = data.find(b"\n", end)
    if stop < 0:
        raise ValueError(f"Cannot read '{path}' as PLY: the header does not end with a newline")
    lines = data[:end].decode("ascii", errors="replace").splitlines()
    fmt, elements = None, []
    for line in lines[1:]:
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) == 3 and words[1] in _FORMATS:
            fmt = words[1]
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) in (3, 5):
            if len(words) == 5 and words[1] == "list":
                prop = (words[4], "list", words[2], words[3])
            elif len(words) == 3:
                prop = (words[2], words[1])
            else:
                prop = None
            types = prop[1:] if prop and prop[1] != "list" else (prop[2:] if prop else ("?",))
            if prop is None or any(t not in PLY_TYPES for t in types):
                raise ValueError(f"Cannot read '{path}' as PLY: bad property line {line!r}")
            if any(p[0] == prop[0] for p in elements[-1][2]):
                raise ValueError(f"Cannot read '{path}' as PLY: the {elements[-1][0]} element "
                                 f"declares the property {prop[0]!r} twice")
            elements[-1][2].append(prop)
        else:
            raise ValueError(f"Cannot read '{path}' as PLY: unexpected header line {line!r}")
    if fmt is None:
        raise ValueError(f"Cannot read '{path}' as PLY: no valid 'format' line")
    return fmt, elements, stop + 1


def _scalar_dtype(props, order: str, path: Path, element: str) -> np.dtype:
    if any(p[1] == "list" for p in props):
        raise ValueError(f"Cannot read '{path}': the {element} element has list properties")
    return np.dtype([(p[0], order + PLY_TYPES[p[1]]) for p in props])


def _read_binary(data: bytes, offset: int, fmt: str, elements, path: Path):
    order = _FORMATS[fmt]
    out = {}
    for name, count, props in elements:
        if name == "face":
            if len(props) != 1 or props[0][1] != "list":
                raise ValueError(f"Cannot read '{path}': the face element must be one list")
            _, _, count_type, index_type = props[0]
            dtype = np.dtype([("n", order + PLY_TYPES[count_type]),
                              ("v", order + PLY_TYPES[index_type], (3,))])
        else:
            dtype = _scalar_dtype(props, order, path, name)
        size = dtype.itemsize * count
        if offset + size > len(data):
            raise ValueError(f"Cannot read '{path}': the {name} data is truncated")
        array = np.frombuffer(data, dtype=dtype, count=count, offset=offset)
        if name == "face" and count and np.any(array["n"] != 3):
            raise ValueError(f"Cannot read '{path}': only triangular faces are supported")
        out[name] = array
        offset += size
    if offset != len(data):
        raise ValueError(f"Cannot read '{path}': {len(data) - offset} bytes after the data")
    return out


def _read_ascii(data: bytes, offset: int, elements, path: Path):
    lines = data[offset:].decode("ascii", errors="replace").splitlines()
    lines = [line for line in lines if line.strip()]
    out, start = {}, 0
    for name, count, props in elements:
        block = lines[start:start + count]
        if len(block) != count:
            raise ValueError(f"Cannot read '{path}': the {name} data is truncated")
        if name == "face":
            array = np.empty(count, dtype=[("n", "u1"), ("v", "i8", (3,))])
            if count:
                table = _ascii_faces(block, start, path)
                array["n"], array["v"] = table[:, 0], table[:, 1:]
        else:
            dtype = _scalar_dtype(props, "<", path, name)
            array = np.empty(count, dtype=dtype)
            if count:
                table = _ascii_table(block, len(props), np.float64, start, path, name)
                for column, prop in enumerate(props):
                    with np.errstate(over="ignore"):  # too large for float: inf, refused below
                        array[prop[0]] = _fit(table[:, column], PLY_TYPES[prop[1]], path, name,
                                              prop[0])
        start += count
        out[name] = array
    if start != len(lines):
        raise ValueError(f"Cannot read '{path}': {len(lines) - start} lines after the data")
    return out


def _ascii_table(block: list[str], columns: int, dtype, first: int, path: Path,
                 name: str) -> np.ndarray:
    """``block``'s lines as a (len, columns) table, or a ValueError naming the first bad line.

    ``first`` is the 0-based index of the block's first line among the data
    lines, for the message.
    """
    try:
        table = np.loadtxt(io.StringIO("\n".join(block)), dtype=dtype, ndmin=2)
    except ValueError:
        table = None
    if table is not None and table.shape == (len(block), columns):
        return table
    parse = float if np.dtype(dtype).kind == "f" else int
    for k, line in enumerate(block):
        words = line.split()
        where = f"Cannot read '{path}': {name} {k} (data line {first + k + 1})"
        if len(words) != columns:
            raise ValueError(f"{where} has {len(words)} values, expected {columns}: {line!r}")
        for word in words:
            try:
                parse(word)
            except ValueError:
                kind = "a number" if parse is float else "an integer"
                raise ValueError(f"{where}: {word[:20]!r} is not {kind}") from None
    raise ValueError(f"Cannot read '{path}': the {name} lines are not {columns} numbers each")


def _ascii_faces(block: list[str], first: int, path: Path) -> np.ndarray:
    """The face lines as an (M, 4) int64 table: the count 3 and three vertex indices."""
    for k, line in enumerate(block):
        words = line.split()
        if words and words[0] != "3":
            where = f"Cannot read '{path}': face {k} (data line {first + k + 1})"
            if not words[0].isdigit():
                raise ValueError(f"{where}: {words[0][:20]!r} is not a vertex count")
            raise ValueError(f"{where} has {words[0]} vertices: only triangular faces are "
                             "supported")
    return _ascii_table(block, 4, np.int64, first, path, "face")


def _fit(values: np.ndarray, kind: str, path: Path, element: str, name: str) -> np.ndarray:
    """``values`` (float64, from text) checked to fit the property's type ``kind``."""
    dtype = np.dtype(kind)
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        bad = ~np.isfinite(values) | (values != np.round(values)) | (values < info.min) | (
            values > info.max)
        if bad.any():
            raise ValueError(
                f"Cannot read '{path}': the {element} property {name!r} ({dtype.name}) holds "
                f"{float(values[bad][0]):g}, not an integer in {info.min}..{info.max}"
            )
    return values


def read_ply(path) -> Model:
    """Read a PLY file into a :class:`~refsynth.model.build.Model` (stage 3's output format).

    Reads ASCII and binary (either byte order) files with a ``vertex``
    element of scalar properties, at least ``x``, ``y``, ``z``, and
    optionally ``red``, ``green``, ``blue`` (else grey 128), ``confidence``
    (else 1), ``uncertainty`` (else none) and ``synthesized`` (else 0), and an optional
    ``face`` element of
    triangles. Other properties and elements are refused or ignored as
    stated in the messages.

    Parameters
    ----------
    path : str or Path
        The PLY file to read.

    Returns
    -------
    Model
        float64 vertices and confidences, uint8 colours, int64 faces.

    Examples
    --------
    >>> import tempfile
    >>> text = ("ply\\nformat ascii 1.0\\nelement vertex 3\\nproperty float x\\n"
    ...         "property float y\\nproperty float z\\nend_header\\n0 0 1\\n1 0 1\\n0 1 1\\n")
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "points.ply"
    ...     _ = path.write_text(text)
    ...     model = read_ply(path)
    >>> model.vertices.shape, model.colours[0].tolist(), model.n_faces
    ((3, 3), [128, 128, 128], 0)
    """
    if not isinstance(path, (str, Path)):
        raise TypeError(f"The parameter `path` must be a str or a Path, got {type(path).__name__}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"No such file: '{path}'")
    data = path.read_bytes()
    fmt, elements, offset = _parse_header(data, path)
    if fmt == "ascii":
        arrays = _read_ascii(data, offset, elements, path)
    else:
        arrays = _read_binary(data, offset, fmt, elements, path)
    if "vertex" not in arrays:
        raise ValueError(f"Cannot read '{path}': it has no vertex element")
    vertex = arrays["vertex"]
    names = vertex.dtype.names
    if not {"x", "y", "z"} <= set(names):
        raise ValueError(f"Cannot read '{path}': the vertices lack x, y or z")
    n = len(vertex)
    with np.errstate(invalid="ignore", over="ignore"):
        coordinates = np.column_stack([vertex[a].astype(np.float64) for a in "xyz"]).reshape(n, 3)
    finite = np.isfinite(coordinates).all(axis=1)
    if not finite.all():
        raise ValueError(f"Cannot read '{path}': vertex {int(np.argmin(finite))} has a "
                         f"non-finite coordinate {coordinates[np.argmin(finite)].tolist()} "
                         f"({int(n - finite.sum())} such vertices; x, y, z must be finite)")
    confidence = (vertex["confidence"].astype(np.float64) if "confidence" in names
                  else np.ones(n))
    if not (np.isfinite(confidence).all() and (confidence >= 0).all()
            and (confidence <= 1).all()):
        raise ValueError(f"Cannot read '{path}': the vertices' confidence must lie in [0, 1]")
    uncertainty = None
    if "uncertainty" in names:
        uncertainty = vertex["uncertainty"].astype(np.float64)
        if not (np.isfinite(uncertainty).all() and (uncertainty >= 0).all()):
            raise ValueError(f"Cannot read '{path}': the vertices' uncertainty must be finite "
                             "and >= 0")
    colours = np.full((n, 3), 128, dtype=np.uint8)
    for channel, name in enumerate(("red", "green", "blue")):
        if name in names:
            colours[:, channel] = vertex[name]
    faces = arrays.get("face")
    faces = np.zeros((0, 3), np.int64) if faces is None else faces["v"].astype(np.int64)
    if faces.size and (faces.min() < 0 or faces.max() >= n):
        raise ValueError(f"Cannot read '{path}': a face indexes a vertex that is not there")
    return Model(
        vertices=coordinates,
        colours=colours,
        confidence=confidence,
        synthesized=(vertex["synthesized"] != 0 if "synthesized" in names
                     else np.zeros(n, dtype=bool)),
        faces=faces.reshape(-1, 3),
        uncertainty=uncertainty,
    )
