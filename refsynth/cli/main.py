"""The command line: ``python -m refsynth demo | synth | scan | register | evaluate | figures``.

:func:`build_parser` gathers each subcommand's parser from its module of
:mod:`refsynth.cli`; :func:`main` runs one. Errors print one line on stderr
and exit with status 2, without a traceback. Long runs report progress on
stderr.
"""

from __future__ import annotations

import argparse
import sys

from refsynth.cli.demo import add_demo_parser
from refsynth.cli.evaluate import add_evaluate_parser
from refsynth.cli.figures import add_figures_parser
from refsynth.cli.register import add_register_parser
from refsynth.cli.scan import add_scan_parser
from refsynth.cli.synth import add_synth_parser

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m refsynth`` parser, with every subcommand."""
    parser = argparse.ArgumentParser(
        prog="python -m refsynth",
        description="Range synthesis from intensity and partial range "
        "(Torres-Méndez & Dudek, IJCV 2008).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    add_demo_parser(sub)
    add_synth_parser(sub)
    add_scan_parser(sub)
    add_register_parser(sub)
    add_evaluate_parser(sub)
    add_figures_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, TypeError, OSError, ImportError) as exc:
        print(f"refsynth {args.command}: error: {exc}", file=sys.stderr)
        return 2
