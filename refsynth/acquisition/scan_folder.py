"""A scan's folder on disk: slice files, ``manifest.json``, ``scan.npz`` (§4).

Scans that lose nothing: each validated slice is written at once to
``slices/pan-<index>.slice`` with :func:`refsynth._files.write_new` (an
exclusive temporary file with an unpredictable name, fsynced, then linked
into place: never through a symbolic link, never over a file), and its
bytes depend only on the data (:func:`slice_bytes`); ``manifest.json`` is
rewritten with :func:`refsynth._files.write_atomic` after every slice and
picture, recording each slice's CRC. A session holds the folder's lock
(:func:`lock_folder`): a second scan into it is refused. When the plan is
complete the scan is assembled into ``scan.npz`` (:func:`write_npz`, whose
bytes depend only on the arrays; :func:`read_npz` reads one back, or says
why it cannot). A file a session cannot trust is never deleted:
:func:`set_aside` moves it into ``rejected/``.

Output folder::

    manifest.json        settings, plan, devices, slices, pictures, sessions
    slices/pan-0250.slice
    images/pan-0025.png  the camera's pictures (every 18°)
    scan.npz             r, theta, phi, amplitude, pan_index, encoder
    rejected/            files a session could not trust, set aside (never deleted)

What the manifest holds and how it is checked is
:mod:`refsynth.acquisition.manifest`; which files a resumed session trusts,
:mod:`refsynth.acquisition.resume`.

References
----------
Torres-Méndez & Dudek (2008), §4 (what a scan saves: 2-D slices, each an
average of 10 samples, and a picture every 18°), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import stat
import struct
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from refsynth._files import write_atomic, write_new
from refsynth.acquisition.errors import ProtocolError
from refsynth.acquisition.geometry import PAN_SLICES
from refsynth.acquisition.rangefinder_protocol import (
    LINE_WIDTH,
    crc16,
    decode_samples,
    encode_samples,
)

__all__ = [
    "SliceRecord",
    "slice_name",
    "slice_bytes",
    "slice_crc",
    "parse_slice",
    "read_slice",
    "slice_files",
    "odd_slice_entries",
    "png_is_complete",
    "write_atomic",
    "write_new",
    "write_json",
    "write_npz",
    "read_npz",
    "set_aside",
    "check_subfolder",
    "read_regular",
    "temporary_target",
    "lock_folder",
]

_SLICE_MAGIC = b"refsynth-slice 1\n"
_SLICE_NAME = re.compile(r"pan-(\d{4})\.slice")
_TEMPORARY = re.compile(r"\.(?P<name>[^/]+?)(?:\.[a-z0-9_]{8})?\.tmp")
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: What reading a damaged ``.npz`` can raise (zip, zlib and numpy's own errors).
_NPZ_ERRORS = (OSError, ValueError, EOFError, KeyError, RuntimeError, NotImplementedError,
               zipfile.BadZipFile, zlib.error, struct.error)


# ----------------------------------------------------------------------------- slice files


@dataclass(frozen=True, eq=False)
class SliceRecord:
    """One saved slice.

    Attributes
    ----------
    pan_index, seq, count, average : int
    range_mm : ndarray of shape (count,), uint16
        0 = no return.
    amplitude : ndarray of shape (count,), uint8
    """

    pan_index: int
    seq: int
    count: int
    average: int
    range_mm: np.ndarray
    amplitude: np.ndarray


def slice_name(pan_index: int) -> str:
    """``pan-0250.slice``."""
    return f"pan-{int(pan_index):04d}.slice"


def slice_bytes(record: SliceRecord) -> bytes:
    """The slice file's bytes: a header, the samples as on the wire, a CRC line.

    ::

        refsynth-slice 1
        pan 250
        seq 379
        count 243
        average 10

        <the GS data lines: 6 hex digits per sample, 64 characters a line>
        =<CRC-16 of the data lines, LF included>

    Nothing in it but the data: the same slice always gives the same bytes.
    """
    payload = encode_samples(record.range_mm, record.amplitude)
    lines = [payload[i : i + LINE_WIDTH] for i in range(0, len(payload), LINE_WIDTH)]
    block = b"".join(line + b"\n" for line in lines)
    header = (f"pan {record.pan_index}\nseq {record.seq}\ncount {record.count}\n"
              f"average {record.average}\n\n").encode("ascii")
    return _SLICE_MAGIC + header + block + f"={crc16(block):04X}\n".encode("ascii")


def slice_crc(data: bytes) -> str:
    """The CRC the manifest records for a slice file's bytes: CRC-16, 4 upper-case hex digits."""
    return f"{crc16(data):04X}"


def parse_slice(data: bytes, path: str | os.PathLike) -> SliceRecord:
    """Check the bytes of a slice file (header, CRC, sample count) and decode them.

    Raises
    ------
    ValueError
        If they are not a valid slice file (the message names ``path``).
    """
    try:
        if not data.startswith(_SLICE_MAGIC):
            raise ProtocolError("not a slice file")
        header, sep, rest = data[len(_SLICE_MAGIC):].partition(b"\n\n")
        if not sep:
            raise ProtocolError("no blank line after the header")
        values = {}
        for line in header.split(b"\n"):
            key, _, value = line.partition(b" ")
            if not value.isdigit() or len(value) > 6:
                raise ProtocolError(f"bad header line {line[:30]!r}")
            values[key.decode("ascii", "replace")] = int(value)
        if set(values) != {"pan", "seq", "count", "average"}:
            raise ProtocolError(f"header keys {sorted(values)}")
        block, _, crc_line = rest.rpartition(b"=")
        if not (crc_line.endswith(b"\n") and len(crc_line) == 5) or (
            int(crc_line[:4], 16) != crc16(block)
        ):
            raise ProtocolError("CRC mismatch")
        range_mm, amplitude = decode_samples(block.replace(b"\n", b""), values["count"])
    except (ProtocolError, ValueError) as error:
        raise ValueError(f"'{path}' is not a valid slice file: {error}") from None
    return SliceRecord(values["pan"], values["seq"], values["count"], values["average"],
                       range_mm, amplitude)


def read_slice(path: str | os.PathLike) -> SliceRecord:
    """Read and check a slice file (header, CRC, sample count): one vertical slice (§3.1.1).

    Parameters
    ----------
    path : str or Path
        A ``slices/pan-<i>.slice`` file written by
        :func:`refsynth.acquisition.run_scan`.

    Returns
    -------
    SliceRecord
        The slice's pan index, GS window and samples.

    Raises
    ------
    ValueError
        If the file is not a valid slice file (the message names it).
    FileNotFoundError
        If it does not exist.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> range_mm = np.array([1200, 0, 3400], dtype=np.uint16)
    >>> amplitude = np.array([90, 0, 255], dtype=np.uint8)
    >>> path = Path(tempfile.mkdtemp()) / slice_name(100)
    >>> _ = path.write_bytes(slice_bytes(SliceRecord(100, 7, 3, 10, range_mm, amplitude)))
    >>> record = read_slice(path)
    >>> record.pan_index, record.count, record.range_mm.tolist()
    (100, 3, [1200, 0, 3400])
    """
    return parse_slice(Path(path).read_bytes(), path)


def slice_files(folder: Path) -> dict[int, Path]:
    """The regular files ``slices/pan-<i>.slice`` of ``folder`` with ``i`` a pan index, by ``i``.

    Nothing is read: what they hold is for the caller to check. Entries of
    those names that are not regular files (a symbolic link, a folder) are
    :func:`odd_slice_entries`.
    """
    return {index: path for index, path in _slice_entries(folder).items()
            if path.is_file() and not path.is_symlink()}


def odd_slice_entries(folder: Path) -> list[Path]:
    """The entries ``slices/pan-<i>.slice`` of ``folder`` that are not regular files
    (symbolic links, folders, ...): never read, never written through."""
    return [path for path in _slice_entries(folder).values()
            if path.is_symlink() or not path.is_file()]


def _slice_entries(folder: Path) -> dict[int, Path]:
    found: dict[int, Path] = {}
    directory = folder / "slices"
    if directory.is_symlink() or not directory.is_dir():
        return found
    for path in sorted(directory.iterdir()):
        match = _SLICE_NAME.fullmatch(path.name)
        if match is not None and int(match.group(1)) < PAN_SLICES:
            found[int(match.group(1))] = path
    return found


def temporary_target(name: str) -> str | None:
    """The file a temporary file of refsynth's writers was for, or None if ``name`` is not one.

    :func:`refsynth._files.write_atomic` writes ``.<name>.<8 random
    characters>.tmp`` beside ``<name>``; earlier scans wrote ``.<name>.tmp``.

    Examples
    --------
    >>> temporary_target(".pan-0250.slice.k3j_x9ab.tmp"), temporary_target(".manifest.json.tmp")
    ('pan-0250.slice', 'manifest.json')
    >>> temporary_target("notes.txt") is None
    True
    """
    match = _TEMPORARY.fullmatch(name)
    return None if match is None else match.group("name")


def png_is_complete(path: Path) -> bool:
    """Whether ``path`` is a whole PNG file: the signature, then chunks whose CRC-32s
    hold, ending with ``IEND`` at the end of the file (a cut-short or damaged picture
    is not). The pixels are not decoded."""
    try:
        data = path.read_bytes()
    except OSError:
        return False
    if not data.startswith(_PNG_SIGNATURE):
        return False
    position = len(_PNG_SIGNATURE)
    while position + 12 <= len(data):
        length = int.from_bytes(data[position : position + 4], "big")
        end = position + 12 + length
        if end > len(data):
            return False
        if zlib.crc32(data[position + 4 : end - 4]) != int.from_bytes(data[end - 4 : end], "big"):
            return False
        kind, position = data[position + 4 : position + 8], end
        if kind == b"IEND":
            return position == len(data)
    return False


# ----------------------------------------------------------------------------- writing


def write_json(path: Path, value: dict) -> None:
    """:func:`~refsynth._files.write_atomic` of ``value`` as indented JSON with sorted keys."""
    write_atomic(path, (json.dumps(value, indent=1, sort_keys=True) + "\n").encode("utf-8"))


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """An ``.npz`` whose bytes depend only on the arrays (fixed zip timestamps)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as archive:
        for name, array in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(array), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.create_system = 3
            info.external_attr = 0o644 << 16
            archive.writestr(info, member.getvalue())
    write_atomic(path, buffer.getvalue())


def read_npz(path: Path, names, max_bytes: int) -> dict[str, np.ndarray]:
    """The arrays ``names`` of the ``.npz`` at ``path``, each member at most ``max_bytes``.

    Raises
    ------
    ValueError
        ``cannot read scan file '<path>' as .npz (...)`` if it is not a
        readable ``.npz`` without pickles; ``scan file '<path>' lacks the
        arrays [...]``; or a member is larger than ``max_bytes``.
    FileNotFoundError
        If it does not exist.
    """
    if not Path(path).is_file():
        raise FileNotFoundError(f"'{path}' not found")
    try:
        with zipfile.ZipFile(path) as archive:
            sizes = {info.filename: info.file_size for info in archive.infolist()}
    except _NPZ_ERRORS as error:
        raise ValueError(f"cannot read scan file '{path}' as .npz ({error})") from None
    missing = sorted(name for name in names if f"{name}.npy" not in sizes)
    if missing:
        raise ValueError(f"scan file '{path}' lacks the arrays {missing}")
    large = sorted(name for name in names if sizes[f"{name}.npy"] > max_bytes)
    if large:
        raise ValueError(f"scan file '{path}': the arrays {large} are larger than a scan can be "
                         f"({max_bytes} bytes)")
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: data[name] for name in names}
    except _NPZ_ERRORS as error:
        raise ValueError(f"cannot read scan file '{path}' as .npz ({error})") from None


def set_aside(folder: Path, path: Path) -> Path:
    """Move ``path`` into ``folder/rejected/`` (``name``, else ``name.1``, ``name.2``, …).

    How a session gets a file it cannot trust out of its way without losing
    it; a symbolic link is moved itself, never what it points to. Returns the
    new path.

    Raises
    ------
    ValueError
        If ``folder/rejected`` is not a folder of its own (a symbolic link, or
        a file): nothing is moved out of the scan folder.
    """
    rejected = folder / "rejected"
    if not os.path.lexists(rejected):
        rejected.mkdir()
    check_subfolder(folder, "rejected")
    target, number = rejected / path.name, 0
    while os.path.lexists(target):
        number += 1
        target = rejected / f"{path.name}.{number}"
    os.replace(path, target)
    return target


def check_subfolder(folder: Path, name: str) -> None:
    """Check that ``folder/name``, if it exists, is a real folder (not a symbolic link).

    Raises
    ------
    ValueError
        ``'<folder>/<name>' is a symbolic link ...`` or ``... is not a
        folder``: a scan writes only into folders of its own.
    """
    path = folder / name
    if path.is_symlink():
        raise ValueError(f"'{path}' is a symbolic link: a scan writes only into folders of its "
                         "own inside its folder; move the link away")
    if os.path.lexists(path) and not path.is_dir():
        raise ValueError(f"'{path}' is not a folder: a scan keeps its {name} there; move it away")


def read_regular(path: Path) -> bytes | None:
    """The bytes of ``path`` if it is a regular file (never through a symbolic link), else None."""
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        return None
    with os.fdopen(descriptor, "rb") as stream:
        if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            return None
        return stream.read()


# ----------------------------------------------------------------------------- the lock

#: The lock file, where a folder itself cannot be locked (some network file systems).
LOCK_NAME = ".refsynth-scan.lock"


@contextlib.contextmanager
def lock_folder(folder: Path):
    """Hold an exclusive lock on the scan folder ``folder`` for a session.

    The folder itself is locked (``flock`` on its descriptor; no file is
    written), or, where the file system cannot lock a folder, the file
    ``folder/.refsynth-scan.lock`` (created without following a symbolic
    link). The lock goes with the process: a killed scan leaves none behind.
    Where the platform has no ``fcntl`` (Windows), nothing is locked.

    Raises
    ------
    ValueError
        ``'<folder>' is in use by another scan ...`` if another process
        holds the lock.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    descriptors = []

    def take(descriptor: int) -> None:
        descriptors.append(descriptor)
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)

    try:
        try:
            take(os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | os.O_CLOEXEC))
        except BlockingIOError:
            raise
        except OSError:  # the folder cannot be locked here: a lock file then
            lock = folder / LOCK_NAME
            try:
                descriptor = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC
                                     | getattr(os, "O_NOFOLLOW", 0), 0o600)
            except OSError as error:
                raise ValueError(f"cannot lock the scan folder '{folder}': '{lock}': "
                                 f"{error.strerror}") from None
            if not stat.S_ISREG(os.fstat(descriptor).st_mode):
                os.close(descriptor)
                raise ValueError(f"cannot lock the scan folder '{folder}': '{lock}' is not a "
                                 "regular file") from None
            take(descriptor)
    except BlockingIOError:
        for descriptor in descriptors:
            os.close(descriptor)
        raise ValueError(f"'{folder}' is in use by another scan (its lock is held): wait for "
                         "that scan to end, or choose another folder") from None
    try:
        yield
    finally:
        for descriptor in descriptors:
            os.close(descriptor)
