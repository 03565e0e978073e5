"""What every subcommand's parser shares: its construction, strict number types, path checks.

- :func:`add_subcommand`: a subcommand's parser, built the same way for
  every one (its ``help``, ``description``, handler, and
  :class:`DefaultsFormatter`, which ends each option's help with its
  default).
- :func:`prefixed`: ``add_argument`` for options that only apply with
  another one, their help starting with that condition once.
- :func:`integer` and :func:`real`: argparse ``type=`` functions that accept
  ASCII digits only (Python's ``int`` reads ``"٣"`` as 3 and ``"1_0"`` as 10)
  and, for reals, finite values only.
- :func:`check_output`: an output file's suffix and folder, checked before
  any work starts (by creating and removing a file there, which no
  permission bit can fake), and that it is none of the run's inputs, so that
  a long run never ends in "cannot write" nor writes over what it read.
- :func:`check_distinct`: several outputs of one run name different files.
- :func:`check_files_in`: the files a command writes into its output folder
  are not folders there.
- :func:`make_parent`: create an output file's missing folders, once the work
  is done.
- :func:`check_folder`: an output folder, checked before any work.
- :func:`check_memory`: refuse work whose estimated memory exceeds the
  machine's, saying how much it would need.

User errors are raised as ``ValueError`` / ``OSError`` with a one-line
message naming the option (:mod:`refsynth.cli.main` prints it and exits 2).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from refsynth._checks import check_memory_need, format_bytes, physical_memory
from refsynth._files import check_output_path, same_file

__all__ = [
    "add_subcommand", "DefaultsFormatter", "prefixed",
    "integer", "real", "check_output", "check_distinct", "check_files_in", "make_parent",
    "check_folder",
    "check_memory",
    "physical_memory", "format_bytes",
]

_INTEGER = re.compile(r"[+-]?[0-9]+")
_REAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")
#: Digits accepted in an integer argument: more would only name an absurd value.
_MAX_DIGITS = 18


class DefaultsFormatter(argparse.HelpFormatter):
    """Help that ends each option's text with ``(default: X)`` unless it states its default.

    Options without a default (None) or flags (False) get nothing added.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if (not action.option_strings or default is None or default is False
                or default is argparse.SUPPRESS or "default" in text.lower()):
            return text
        return f"{text} (default: %(default)s)"


def add_subcommand(subparsers, name: str, *, help: str, description: str,
                   func: Callable[[argparse.Namespace], int] | None = None
                   ) -> argparse.ArgumentParser:
    """Add the subcommand ``name`` to ``subparsers`` and return its parser.

    Every ``python -m refsynth`` subcommand is built here, so that each one's
    ``--help`` follows the same conventions whatever parser it is added to
    (the main one, ``python -m refsynth.cli.scan``, a test's plain
    ``ArgumentParser``): every option's default is shown
    (:class:`DefaultsFormatter`).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``ArgumentParser.add_subparsers`` returned.
    name : str
        The subcommand, e.g. ``"synth"``.
    help : str
        Its one line in the parent's ``--help`` (lower case, no full stop);
        keyword-only, as are ``description`` and ``func``, so that the two
        texts cannot be swapped.
    description : str
        The paragraph at the top of its own ``--help``.
    func : callable, optional
        The handler, stored as ``args.func``: it takes the parsed arguments
        and returns the exit status. None for a parser whose own
        subcommands set it (``oracle export``, ``oracle check``).

    Returns
    -------
    argparse.ArgumentParser

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="refsynth")
    >>> sub = parser.add_subparsers(dest="command")
    >>> hello = add_subcommand(sub, "hello", help="say hello", description="Say hello.",
    ...                        func=lambda args: 0)
    >>> _ = hello.add_argument("--times", type=integer, default=1, help="how often")
    >>> "how often (default: 1)" in hello.format_help()
    True
    >>> parser.parse_args(["hello"]).func(None)
    0
    """
    parser = subparsers.add_parser(name, help=help, description=description,
                                   formatter_class=DefaultsFormatter)
    if func is not None:
        parser.set_defaults(func=func)
    return parser


def prefixed(group, prefix: str) -> Callable[..., argparse.Action]:
    """``group.add_argument``, each option's help starting with ``prefix``.

    For options that apply only with another option or a kind of input
    (``"with --merge: "``, ``"cylindrical: "``): the condition is written
    once, and every such option's help states it.

    >>> parser = argparse.ArgumentParser()
    >>> add = prefixed(parser, "with --merge: ")
    >>> add("--voxel", type=real, help="fusion voxel size").help
    'with --merge: fusion voxel size'
    """
    def add_argument(*names: str, help: str, **kwargs) -> argparse.Action:
        return group.add_argument(*names, help=prefix + help, **kwargs)

    return add_argument


def integer(text: str) -> int:
    """An argparse type: an integer written with ASCII digits (``-3``, ``42``).

    >>> integer("42"), integer("-3")
    (42, -3)
    """
    if not _INTEGER.fullmatch(text) or len(text.lstrip("+-")) > _MAX_DIGITS:
        raise argparse.ArgumentTypeError(
            f"invalid integer {text!r} (ASCII digits, at most {_MAX_DIGITS})"
        )
    return int(text)


def real(text: str) -> float:
    """An argparse type: a finite real number written with ASCII digits (``0.5``, ``1e-3``).

    >>> real("0.5"), real("1e-3")
    (0.5, 0.001)
    """
    value = float(text) if _REAL.fullmatch(text) else float("nan")
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"invalid number {text!r} (a finite decimal number)")
    return value


def check_output(path: str, option: str, suffixes: Iterable[str] | None = None, *,
                 inputs: Iterable[str | os.PathLike | None] = ()) -> Path:
    """Check, before any work, that ``path`` can be written as the file ``option`` names.

    Parameters
    ----------
    path : str
        The value given to ``option``.
    option : str
        The option's name, for the message (``"--out"``).
    suffixes : iterable of str, optional
        The suffixes allowed (lower case, with the dot), matched
        case-insensitively; default: any.
    inputs : iterable of path-like, optional
        The files the same run reads (None entries are skipped): ``path``
        must be none of them, not even through a link
        (:func:`refsynth._files.check_output_path`).

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        If the path is empty, its suffix is not allowed, or it names one of
        ``inputs``.
    OSError
        If it names a folder, or its nearest existing folder is not a folder
        or does not take a new file (a file is created there and removed:
        permission bits say nothing to root, nor about ``/proc``). Missing
        folders below it are created later by :func:`make_parent`.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> check_output(str(folder / "new" / "out.npy"), "--out", (".npy",)).name
    'out.npy'
    >>> check_output(str(folder / "out.txt"), "--out", (".npy",))
    Traceback (most recent call last):
    ValueError: --out must end in .npy, got '....txt'
    """
    target = Path(path)
    if not path or not target.name or path.endswith(("/", os.sep)):
        raise ValueError(f"{option} must name a file, got {path!r}")
    if suffixes is not None:
        allowed = tuple(suffixes)
        if target.suffix.lower() not in allowed:
            raise ValueError(
                f"{option} must end in {', '.join(allowed)}, got {path!r}"
            )
    if target.is_dir():
        raise IsADirectoryError(f"{option} names a folder, not a file: {path}")
    if target.exists() and not os.access(target, os.W_OK):
        raise PermissionError(f"{option}: cannot write {path} (permission denied)")
    _check_nearest_folder(target.parent, f"{option}: cannot write {path}")
    if target.parent.is_dir():
        check_output_path(target, name=option, inputs=[p for p in inputs if p is not None])
    return target


def check_distinct(outputs: Mapping[str, Path | None]) -> None:
    """Refuse two outputs of one run that name the same file (one would overwrite the other).

    Parameters
    ----------
    outputs : mapping of str to Path or None
        Option name to the path it gives (None: not given).

    Raises
    ------
    ValueError
        Naming the two options and the file.

    Examples
    --------
    >>> check_distinct({"--out": Path("a.npy"), "--confidence": Path("./a.npy")})
    Traceback (most recent call last):
    ValueError: --out and --confidence name the same file a.npy: give each its own
    """
    given = [(option, path) for option, path in outputs.items() if path is not None]
    for k, (option, path) in enumerate(given):
        for other, other_path in given[:k]:
            if path.resolve() == other_path.resolve() or (
                    path.exists() and other_path.exists() and same_file(path, other_path)):
                raise ValueError(f"{other} and {option} name the same file {path}: give each "
                                 "its own")


def _check_nearest_folder(folder: Path, prefix: str) -> None:
    """The nearest existing folder at or above ``folder`` must be a folder that takes files."""
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise NotADirectoryError(f"{prefix}: {folder} is not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PermissionError(f"{prefix}: the folder {folder} is read-only")
    try:  # the one test that cannot be fooled: make a file there
        descriptor, name = tempfile.mkstemp(prefix=".refsynth-check-", dir=folder)
    except OSError as error:
        raise OSError(f"{prefix}: the folder {folder} does not take new files "
                      f"({error.strerror or error})") from None
    os.close(descriptor)
    with contextlib.suppress(OSError):
        os.unlink(name)


def make_parent(path: Path) -> Path:
    """Create the missing folders above ``path`` (checked by :func:`check_output`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def check_folder(path: str, option: str) -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a writable folder.

    Raises
    ------
    ValueError
        If the path is empty.
    OSError
        If it names a file, or its nearest existing folder is read-only.
    """
    if not path:
        raise ValueError(f"{option} must name a folder, got {path!r}")
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(f"{option} must be a folder, got the file {path}")
    _check_nearest_folder(folder, f"{option}: cannot create {path}")
    return folder


def check_files_in(folder: Path, names: Iterable[str], option: str) -> None:
    """Check, before any work, that none of the files ``names`` in ``folder`` is a folder.

    For a command that writes fixed file names into the folder ``option``
    gives (``figures --out``, ``demo --out``), after :func:`check_folder`.

    Parameters
    ----------
    folder : Path
        The output folder (it need not exist yet).
    names : iterable of str
        The files the command writes there.
    option : str
        The option that names the folder, for the message.

    Raises
    ------
    IsADirectoryError
        Naming the first such file.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> (folder / "b.png").mkdir()
    >>> check_files_in(folder, ["a.png", "b.png"], "--out")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    IsADirectoryError: --out: cannot write .../b.png: it is a folder
    """
    for name in names:
        if (folder / name).is_dir():
            raise IsADirectoryError(f"{option}: cannot write {folder / name}: it is a folder")


def check_memory(need: int, what: str, hint: str = "") -> None:
    """Refuse ``what`` (one line, with the estimate) if it needs more than the machine has.

    :func:`refsynth._checks.check_memory_need` against this machine's
    physical memory as this module looks it up (:func:`physical_memory`, so
    that a test can stand in a smaller machine); 2^50, a pebibyte, where the
    OS does not say.

    Raises
    ------
    ValueError
        If ``need`` bytes exceed the machine's memory.
    """
    have = physical_memory()
    check_memory_need(need, what, hint, limit=have)
