"""``python -m refsynth evaluate``: the paper's experiments and the baselines, side by side (§3.3).

:func:`add_evaluate_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`. It runs a grid of cases
(:mod:`refsynth.evaluation.cases`) with :func:`refsynth.evaluation.runner.run_cases`,
here or on a Dask cluster, aggregates the seeds, and prints the Markdown
tables of :mod:`refsynth.evaluation.reports`; ``--json`` / ``--csv`` write the
rows, ``--load`` prints a saved ``--json`` file again. Progress goes to stderr,
one line per finished case. User errors are raised as ValueError / TypeError /
OSError / ImportError with a one-line message (the main entry point prints
``refsynth evaluate: error: ...`` and exits with status 2).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from refsynth.evaluation import (
    DEFAULT_GRID,
    DEFAULT_SAMPLINGS,
    QUICK_GRID,
    Case,
    ProgressCallback,
    aggregate,
    case_cost,
    findings,
    format_findings,
    format_paper_comparison,
    format_pivot,
    format_results,
    format_runtimes,
    format_winners,
    grid_cases,
    method_names,
    parse_list,
    parse_method,
    parse_scene,
    read_json,
    run_cases,
    without_timing,
    write_csv,
    write_json,
)

__all__ = ["add_evaluate_parser"]


def _progress_printer(cases: Sequence[Case]) -> ProgressCallback:
    """A progress callback printing one line per finished case on stderr.

    The time left is estimated from the share of the grid's
    :func:`~refsynth.evaluation.runner.case_cost` done so far (the longest
    cases start first, so a count would mislead).
    """
    total_cost = sum(case_cost(c) for c in cases)
    done_cost = 0.0

    def report(done: int, total: int, case: Case, result: dict, elapsed: float) -> None:
        nonlocal done_cost
        done_cost += case_cost(case)
        minutes, seconds = divmod(int(elapsed), 60)
        eta = ""
        if done < total:
            left = int(elapsed * (total_cost - done_cost) / done_cost)
            eta = f", ~{left // 60}:{left % 60:02d} left"
        print(f"[{done:>{len(str(total))}}/{total} {minutes}:{seconds:02d}{eta}] {case.label}: "
              f"MAR {result['mar']:.4f} ({result['seconds']:.1f} s)", file=sys.stderr,
              flush=True)

    return report


def _cases_from_args(args) -> list[Case]:
    if args.seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {args.seeds}")
    methods = None if args.methods is None else ",".join(
        parse_list(args.methods, parse_method, "method"))
    if args.scene is None and args.size is None and args.sampling is None:
        blocks = QUICK_GRID if args.grid == "quick" else DEFAULT_GRID
        return grid_cases(blocks, args.seeds, methods)
    scenes = parse_list(args.scene or "synthetic,motorcycle", parse_scene, "scene")
    samplings = args.sampling or ",".join(DEFAULT_SAMPLINGS)
    cases: list[Case] = []
    for scene in scenes:
        sizes = args.size or ("native" if ":" in scene else "128")
        cases += grid_cases([(scene, sizes, samplings, methods)], args.seeds)  # None: all
    return list(dict.fromkeys(cases))


def _cmd_evaluate(args) -> int:
    if args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    wall = None
    if args.load:
        if args.scene or args.size or args.sampling or args.methods or args.scheduler:
            raise ValueError("--load prints saved rows: it takes no --scene, --size, "
                             "--sampling, --methods or --scheduler")
        rows = read_json(args.load)
        where = args.load
        cases: list[Case] = []
    else:
        cases = _cases_from_args(args)
        where = (f"Dask scheduler {args.scheduler}" if args.scheduler else
                 f"{args.jobs} local process{'es' if args.jobs > 1 else ''}")
        if not args.quiet:
            print(f"refsynth evaluate: {len(cases)} cases on {where}", file=sys.stderr,
                  flush=True)
        start = time.perf_counter()
        runs = run_cases(cases, jobs=args.jobs, scheduler=args.scheduler,
                         progress=None if args.quiet else _progress_printer(cases))
        wall = time.perf_counter() - start
        rows = aggregate(runs)
    timing = not args.no_timing and all("seconds" in r for r in rows)
    kept = rows if timing else without_timing(rows)
    print(format_results(rows, timing=timing))
    print("\n### MAR by method\n")
    print(format_pivot(rows))
    if timing:
        print("\n### Mean wall time of one fill\n")
        print(format_runtimes(rows))
    if not args.no_findings:
        print("\n### The paper's relative findings on these cases\n")
        print(format_findings(findings(rows)))
        winners = format_winners(rows)
        if winners:
            print("\n### Where refsynth wins and where it loses (mean MAR)\n")
            print(winners)
        comparison = format_paper_comparison(rows)
        if comparison:
            print("\n### The paper's numbers beside ours\n")
            print(comparison)
    if args.json:
        write_json(args.json, kept)
    if args.csv:
        write_csv(args.csv, kept)
    if not args.quiet and wall is not None:
        minutes, seconds = divmod(wall, 60)
        print(f"refsynth evaluate: {len(cases)} cases in {int(minutes)} min {seconds:.0f} s "
              f"on {where}", file=sys.stderr)
    return 0


def add_evaluate_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``evaluate`` subcommand to an argparse subparsers object.

    The handler (``args.func``) returns 0; user errors raise ``ValueError``,
    ``TypeError``, ``OSError`` (or ``ImportError`` for ``--scheduler``
    without dask) with a one-line message.
    """
    parser = subparsers.add_parser(
        "evaluate",
        help="the paper's experiments and the baselines, side by side",
        description="Run scenes × samplings × methods and print MAR (Eq. 13), RMSE, bad>1, "
        "bad>3 and seconds. Without --scene/--size/--sampling: the default grid (synthetic "
        "room and Motorcycle at 128x128, every sampling and method; rooms 1-3 at g5_25; "
        "Motorcycle 450x375 on x-stripes).",
    )
    parser.add_argument("--scene", help="comma-separated: synthetic, synthetic-N, motorcycle, "
                        "IMAGE:DISPARITY (default: synthetic,motorcycle)")
    parser.add_argument("--size", help="comma-separated: N (square), WxH (e.g. 450x375) or "
                        "native (default: 128; native for IMAGE:DISPARITY)")
    parser.add_argument("--sampling", help="comma-separated: gRW_XW, xNN, distance, distanceNN "
                        f"(default: {','.join(DEFAULT_SAMPLINGS)})")
    parser.add_argument("--methods",
                        help=f"comma-separated (default: all): {','.join(method_names())}")
    parser.add_argument("--seeds", type=int, default=3,
                        help="seeds per NP case, reported as mean ± sd (default 3)")
    parser.add_argument("--grid", choices=["default", "quick"], default="default",
                        help="the grid when no --scene/--size/--sampling is given")
    parser.add_argument("--jobs", type=int, default=1, help="local worker processes (default 1)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on this Dask scheduler (needs dask.distributed)")
    parser.add_argument("--json", metavar="FILE", help="write the rows as JSON")
    parser.add_argument("--csv", metavar="FILE", help="write the rows as CSV")
    parser.add_argument("--load", metavar="FILE",
                        help="print the tables of a previous --json file instead of running")
    parser.add_argument("--no-timing", action="store_true",
                        help="leave wall times out of the table and files (for identical output)")
    parser.add_argument("--no-findings", action="store_true",
                        help="print only the results tables")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    parser.set_defaults(func=_cmd_evaluate)
    return parser
