"""``python -m refsynth oracle export DIR`` and ``oracle check MODULE:FUNCTION``.

- ``export DIR [--large] [--cases PATTERN ...]``: write the golden cases
  (:mod:`refsynth.oracle.export`: ``manifest.json``, ``schema.json``, ``cases/*.json`` and
  ``cases/*.npz``).
- ``check MODULE:FUNCTION [--dir DIR] [--case NAME] [--tolerance exact|float64|float32]
  [--timeout SECONDS]``: call ``FUNCTION(inputs, options)`` on every case
  (:mod:`refsynth.oracle.check`), in a worker process with a time limit per case (default
  120 s), and print one ``FAIL case …: KEY step S pixel (r, c): expected X, got Y`` line per
  failing case (its first mismatch, or what went wrong: the function raised, exited, returned
  no arrays, ran out of time), then the summary line ``PASS …``/``FAIL …: N passed, M
  failed``. Exit status 0 when every checked case passed, 1 when any failed (or none was
  handled). The module is imported from the current folder too, so a port's ``my_port.py``
  beside the cases works as ``my_port:check``.

:func:`add_oracle_parser` adds the subcommand to the main parser of :mod:`refsynth.cli.main`.
User errors (a bad ``MODULE:FUNCTION``, a module that does not import, a missing folder, an
unknown case, a case folder that does not match its checksums or is malformed, an export
into a folder that holds something else) are raised as ValueError / OSError with a one-line
message naming the module or file; the main entry point prints it and exits 2.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

from refsynth.cli.arguments import add_subcommand, check_folder
from refsynth.oracle.cases import build_cases, select_cases
from refsynth.oracle.check import DEFAULT_TIMEOUT, TOLERANCE_NAMES, check_function
from refsynth.oracle.export import export_cases
from refsynth.oracle.files import check_export_target
from refsynth.oracle.worker import MAX_TIMEOUT

__all__ = ["add_oracle_parser"]

DEFAULT_DIR = "oracle-cases"


def _seconds(text: str) -> float:
    """``--timeout``: a number of seconds in (0, a week]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, got {text!r}") from None
    if not (math.isfinite(value) and 0 < value <= MAX_TIMEOUT):
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0 and <= "
                                         f"{MAX_TIMEOUT:g}, got {text!r}")
    return value


def _cmd_export(args) -> int:
    out = check_export_target(check_folder(args.dir, "DIR"))
    start = time.perf_counter()
    cases = select_cases(build_cases(large=args.large), args.cases)
    names = export_cases(out, cases)
    print(f"wrote {len(names)} cases to {out} ({time.perf_counter() - start:.0f} s)")
    return 0


def _cmd_check(args) -> int:
    if os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.insert(0, os.getcwd())   # as `python -c` would: a port beside the cases
    report = check_function(args.function, args.dir, case=args.case, tolerance=args.tolerance,
                            timeout=args.timeout)
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
        description="The correctness oracle: golden cases with step traces, from refsynth's "
        "literal reference, for checking a port of NP, BP and the equations.",
    )
    sub = parser.add_subparsers(dest="oracle_command", required=True, metavar="ACTION")
    export = add_subcommand(
        sub, "export", help="write the golden cases (NPZ + JSON) to DIR",
        description="Write the versioned golden cases: whole NP and BP runs (8x8 to 64x64) "
        "with their step traces, and per-equation batches (Eqs. 2, 5, 6, 7, 10-12, 13, "
        "Canny, 14-21), as DIR/manifest.json, DIR/schema.json and DIR/cases/*.{json,npz}. "
        "DIR must be new, empty, or an earlier export.",
        func=_cmd_export,
    )
    export.add_argument("dir", metavar="DIR",
                        help="output folder (created if missing; a folder that holds anything "
                        "but an earlier export is refused)")
    export.add_argument("--large", action="store_true",
                        help="also a 48x64 NP run with the priority order (about a minute)")
    export.add_argument("--cases", nargs="+", metavar="PATTERN",
                        help="only the cases whose name matches a shell pattern "
                        "(e.g. 'np-*' 'eq5*'; default: all)")
    check = add_subcommand(
        sub, "check", help="run MODULE:FUNCTION on the cases and report the first mismatch",
        description="Verify the case files' checksums, then call FUNCTION(inputs, options) on "
        "every case, in a worker process with a time limit per case, and compare its arrays "
        "with the golden ones. Prints one line per failing case, 'FAIL case NAME: KEY step S "
        "pixel (r, c): expected X, got Y' (or what went wrong: the function raised, exited, "
        "returned no arrays, ran out of time), then a summary line 'N passed, M failed'. "
        "Exit status 0 if every checked case passed, 1 otherwise, 2 for a user error. "
        "FUNCTION returns a dict of arrays, or None for a kind of case it does not handle.",
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
    check.add_argument("--timeout", type=_seconds, default=DEFAULT_TIMEOUT, metavar="SECONDS",
                       help="time limit of each case's call (and of importing the module); a case "
                       "that overruns it fails "
                       f"(default: {DEFAULT_TIMEOUT:g})")
    return parser
