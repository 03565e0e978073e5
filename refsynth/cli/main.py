"""The command line: ``python -m refsynth demo | synth | scan | register | evaluate | figures | model | notebooks``.

:func:`build_parser` gathers each subcommand's parser from its module of
:mod:`refsynth.cli`; :func:`main` runs one. Every error ends in one line on
stderr and exit status 2, without a traceback: a usage error as argparse
words it (``python -m refsynth SUB: error: ...``), a user error raised by
the command as ``refsynth SUB: error: ...``. ``--help`` shows every option's
meaning and default; ``--version`` prints the version. Long runs report
progress on stderr, with the time left.
"""  # noqa: E501

from __future__ import annotations

import argparse
import sys

from refsynth import __version__
from refsynth.cli.arguments import DefaultsFormatter
from refsynth.cli.demo import add_demo_parser
from refsynth.cli.evaluate import add_evaluate_parser
from refsynth.cli.figures import add_figures_parser
from refsynth.cli.model import add_model_parser
from refsynth.cli.notebooks import add_notebooks_parser
from refsynth.cli.oracle import add_oracle_parser
from refsynth.cli.register import add_register_parser
from refsynth.cli.scan import add_scan_parser
from refsynth.cli.synth import add_synth_parser

__all__ = ["OneLineParser", "DefaultsFormatter", "build_parser", "main"]

#: The errors a command raises for bad input; printed as one line, exit status 2.
USER_ERRORS = (ValueError, TypeError, OSError, ImportError, MemoryError)


def _one_line(text: str) -> str:
    return "; ".join(line.strip() for line in str(text).splitlines() if line.strip())


def _words(exc: BaseException) -> str:
    """An error's text without the ``[Errno N]`` an OSError carries (the file stays named)."""
    if isinstance(exc, OSError) and exc.strerror:
        where = "".join(f": '{name}'" for name in (exc.filename, exc.filename2) if name)
        return f"{exc.strerror}{where}"
    return str(exc)


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr and exit status 2.

    argparse prints the whole usage block before the error; here the line
    ``PROG: error: MESSAGE`` is all (``--help`` shows the usage). Its
    subcommand parsers are of this class too, and show every option's
    default (:class:`DefaultsFormatter`).
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", DefaultsFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {_one_line(message)} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m refsynth`` parser, with every subcommand."""
    parser = OneLineParser(
        prog="python -m refsynth",
        description="Range synthesis from intensity and partial range "
        "(Torres-Méndez & Dudek, IJCV 2008). Errors print one line on stderr and exit "
        "with status 2.",
    )
    parser.add_argument("--version", action="version", version=f"refsynth {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_demo_parser(sub)
    add_synth_parser(sub)
    add_scan_parser(sub)
    add_register_parser(sub)
    add_evaluate_parser(sub)
    add_figures_parser(sub)
    add_model_parser(sub)
    add_notebooks_parser(sub)
    add_oracle_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status (0, or 2 after one line on stderr)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # --help, --version (0) or a usage error (2)
        return stop.code if isinstance(stop.code, int) else 2
    try:
        return args.func(args)
    except USER_ERRORS as exc:
        message = _one_line(_words(exc)) or type(exc).__name__
        if isinstance(exc, MemoryError):
            message = f"not enough memory: {message}"
        print(f"refsynth {args.command}: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"refsynth {args.command}: interrupted", file=sys.stderr)
        return 130
