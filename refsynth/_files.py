"""Writing files safely: the one way every refsynth writer puts bytes on disk.

- :func:`write_atomic`: a temporary file created exclusively (``O_CREAT |
  O_EXCL``, so never through a planted symlink) in the target's folder, with an
  unpredictable name; written, flushed and fsynced; renamed over the target.
  An error at any point removes the temporary file, leaves the previous target
  intact, and is raised as an ``OSError`` naming the target.
- :func:`write_new`: the same, but the target must not exist yet (and is never
  replaced, even by a writer racing this one): a scan's slices.
- :func:`check_output_path`: before any work, an output path whose folder
  exists and is writable, which is not a folder, and which is none of the
  inputs.

Every writer in the package (arrays, images, PLY, JSON, scan files, oracle
cases) goes through :func:`write_atomic` or :func:`write_new`.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import BinaryIO

__all__ = ["write_atomic", "write_new", "check_output_path", "same_file"]

Writer = Callable[[BinaryIO], object]


def _fsync_folder(folder: Path) -> None:
    """Make a rename in ``folder`` durable (where the platform allows it)."""
    with contextlib.suppress(OSError):
        descriptor = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(descriptor)
        finally:
            os.close(descriptor)


def _umask() -> int:
    """The process's umask, read without changing it where the platform says it."""
    with contextlib.suppress(OSError, ValueError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    mask = os.umask(0o022)  # elsewhere: set and restore at once
    os.umask(mask)
    return mask


def _mode_for(path: Path) -> int:
    """The permissions a new ``path`` gets: the replaced file's, else ``0o666`` less the umask."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        return 0o666 & ~_umask()


def _write_temporary(path: Path, data: bytes | Writer) -> Path:
    """Write ``data`` to a new, exclusively created temporary file beside ``path``."""
    folder = path.parent if str(path.parent) else Path(".")
    try:
        descriptor, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as error:
        raise OSError(error.errno, f"cannot write '{path}': {error.strerror}") from None
    temporary = Path(name)
    try:
        os.fchmod(descriptor, _mode_for(path))  # mkstemp's 0600 would hide the file
        with os.fdopen(descriptor, "wb") as stream:
            if isinstance(data, (bytes, bytearray, memoryview)):
                stream.write(data)
            else:
                data(stream)
            stream.flush()
            os.fsync(stream.fileno())
    except BaseException as error:
        with contextlib.suppress(OSError):
            temporary.unlink()
        if isinstance(error, OSError):
            reason = error.strerror or str(error)
            raise OSError(error.errno, f"cannot write '{path}': {reason}") from None
        raise
    return temporary


def write_atomic(path: str | os.PathLike, data: bytes | Writer) -> Path:
    """Write ``data`` to ``path`` all or nothing.

    Parameters
    ----------
    path : str or path-like
        The file to write; an existing file is replaced only once the new one
        is complete on disk.
    data : bytes or callable
        The bytes, or a function that writes them to the binary stream it is
        given (``lambda stream: numpy.save(stream, array)``).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OSError
        Naming ``path``, if the folder cannot take the file, the disk fills,
        or the write fails; the previous file at ``path`` is then intact and
        no temporary file is left behind. Anything ``data`` raises is raised
        as it is, after the temporary file is removed.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> write_atomic(path, b"one") == path
    True
    >>> _ = write_atomic(path, lambda stream: stream.write(b"two"))
    >>> path.read_bytes()
    b'two'
    """
    path = Path(path)
    temporary = _write_temporary(path, data)
    try:
        os.replace(temporary, path)
    except OSError as error:
        with contextlib.suppress(OSError):
            temporary.unlink()
        raise OSError(error.errno, f"cannot write '{path}': {error.strerror}") from None
    _fsync_folder(path.parent)
    return path


def write_new(path: str | os.PathLike, data: bytes | Writer) -> Path:
    """:func:`write_atomic` to a path that does not exist yet: nothing is ever replaced.

    The complete temporary file is hard-linked to ``path`` (which fails if
    anything, a symlink included, is there), so even two writers racing for one
    name cannot replace each other's file.

    Raises
    ------
    FileExistsError
        ``refusing to replace '<path>'`` if ``path`` exists (nothing written).
    OSError
        Naming ``path``, as :func:`write_atomic`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "slice"
    >>> _ = write_new(path, b"first")
    >>> write_new(path, b"second")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    FileExistsError: refusing to replace '...slice'
    """
    path = Path(path)
    if os.path.lexists(path):
        raise FileExistsError(f"refusing to replace '{path}'")
    temporary = _write_temporary(path, data)
    try:
        os.link(temporary, path, follow_symlinks=False)
    except FileExistsError:
        raise FileExistsError(f"refusing to replace '{path}'") from None
    except OSError as error:
        raise OSError(error.errno, f"cannot write '{path}': {error.strerror}") from None
    finally:
        with contextlib.suppress(OSError):
            temporary.unlink()
    _fsync_folder(path.parent)
    return path


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether ``a`` and ``b`` name one file (the same inode, or the same resolved path)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


def check_output_path(
    path: str | os.PathLike,
    *,
    name: str = "path",
    inputs: Iterable[str | os.PathLike] = (),
) -> Path:
    """Check, before any work, that ``path`` can be written and is not an input.

    Parameters
    ----------
    path : str or path-like
        The output file.
    name : str, default "path"
        The argument or option the messages name (``--out``).
    inputs : iterable of str or path-like
        Files the same run reads: ``path`` must be none of them.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        If ``path`` is a folder, its folder does not exist or is not writable,
        or it names one of ``inputs``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> source = folder / "in.npy"
    >>> source.write_bytes(b"")
    0
    >>> check_output_path(source, name="--out", inputs=[source])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ValueError: --out '...in.npy' is one of the inputs: refusing to write over it
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{name} '{path}' is a folder, not a file")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"{name} '{path}': the folder '{folder}' does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{name} '{path}': the folder '{folder}' is not writable")
    for source in inputs:
        if source is not None and os.path.lexists(path) and same_file(path, source):
            raise ValueError(f"{name} '{path}' is one of the inputs: refusing to write over it")
    return path
