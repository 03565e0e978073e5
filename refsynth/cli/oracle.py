"""``python -m refsynth oracle export DIR`` and ``oracle check MODULE:FUNCTION``.

- ``export DIR [--large] [--cases PATTERN ...]``: write the golden cases
  (:mod:`refsynth.oracle.export`: ``manifest.json``, ``schema.json``, ``cases/*.json`` and
  ``cases/*.npz``).
- ``check MODULE:FUNCTION [--dir DIR] [--case NAME] [--tolerance exact|float64|float32]``:
  call ``FUNCTION(inputs, options)`` on every case (:mod:`refsynth.oracle.check`) and print
  ``PASS …`` (exit 0) or the first mismatch, ``FAIL case …: KEY step S pixel (r, c): expected
  X, got Y`` (exit 1). The module is imported from the current folder too, so a port's
  ``my_port.py`` beside the cases works as ``my_port:check``.

:func:`add_oracle_parser` adds the subcommand to the main parser of :mod:`refsynth.cli.main`.
User errors (a bad ``MODULE:FUNCTION``, a missing folder, an unknown case) are raised as
ValueError / OSError with a one-line message; the main entry point prints it and exits 2.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from refsynth.cli.arguments import add_subcommand, check_folder
from refsynth.oracle.cases import build_cases, select_cases
from refsynth.oracle.check import TOLERANCE_NAMES, check_function, resolve_function
from refsynth.oracle.export import export_cases

__all__ = ["add_oracle_parser"]

DEFAULT_DIR = "oracle-cases"


def _cmd_export(args) -> int:
    out = check_folder(args.dir, "DIR")
    start = time.perf_counter()
    cases = select_cases(build_cases(large=args.large), args.cases)
    names = export_cases(out, cases)
    print(f"wrote {len(names)} cases to {out} ({time.perf_counter() - start:.0f} s)")
    return 0


def _cmd_check(args) -> int:
    if os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())   # as `python -c` would: a port beside the cases
    function = resolve_function(args.function)
    report = check_function(function, args.dir, case=args.case, tolerance=args.tolerance)
    print(report)
    return 0 if report.passed else 1


def add_oracle_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``oracle`` subcommand (``export``, ``check``) to an argparse subparsers object.

    The handlers (``args.func``) return 0, or 1 for a failed check; user errors raise
    ``ValueError`` or ``OSError`` with a one-line message.
    """
    parser = add_subcommand(
        subparsers, "oracle",
        help="golden cases for checking a port: export them, check a function",
        description="The correctness oracle (issue #11): golden cases with step traces, from "
        "refsynth's literal reference, for checking a port of NP, BP and the equations.",
    )
    sub = parser.add_subparsers(dest="oracle_command", required=True, metavar="ACTION")
    export = add_subcommand(
        sub, "export", help="write the golden cases (NPZ + JSON) to DIR",
        description="Write the versioned golden cases: whole NP and BP runs (8x8 to 64x64) "
        "with their step traces, and per-equation batches (Eqs. 2, 5, 6, 7, 10-12, 13, "
        "Canny, 14-21), as DIR/manifest.json, DIR/schema.json and DIR/cases/*.{json,npz}.",
        func=_cmd_export,
    )
    export.add_argument("dir", metavar="DIR", help="output folder (created if missing)")
    export.add_argument("--large", action="store_true",
                        help="also a 48x64 NP run with the priority order (about a minute)")
    export.add_argument("--cases", nargs="+", metavar="PATTERN",
                        help="only the cases whose name matches a shell pattern "
                        "(e.g. 'np-*' 'eq5*'; default: all)")
    check = add_subcommand(
        sub, "check", help="run MODULE:FUNCTION on the cases and report the first mismatch",
        description="Call FUNCTION(inputs, options) on every exported case and compare its "
        "arrays with the golden ones. Prints PASS (exit 0) or the first mismatch as "
        "'FAIL case NAME: KEY step S pixel (r, c): expected X, got Y' (exit 1). FUNCTION "
        "returns a dict of arrays, or None for a kind of case it does not handle.",
        func=_cmd_check,
    )
    check.add_argument("function", metavar="MODULE:FUNCTION",
                       help="the function under test, e.g. my_port:check or "
                       "refsynth.oracle:refsynth_fast")
    check.add_argument("--dir", default=DEFAULT_DIR, help="the exported cases")
    check.add_argument("--case", metavar="NAME", help="only this case (default: all)")
    check.add_argument("--tolerance", choices=TOLERANCE_NAMES, default="exact",
                       help="float comparison: exact; float64 (rtol 1e-9, atol 1e-12); "
                       "float32 (rtol 1e-4, atol 1e-6). Integer and index arrays are always "
                       "exact (default: exact)")
    return parser
