"""``python -m refsynth evaluate``: the paper's experiments and the baselines, side by side (§3.3).

:func:`add_evaluate_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`. It runs a grid of cases
(:mod:`refsynth.evaluation.cases`) with :func:`refsynth.evaluation.runner.run_cases`,
here or on a Dask cluster, aggregates the seeds, and prints the Markdown
tables of :mod:`refsynth.evaluation.reports`; ``--json`` / ``--csv`` write the
rows, ``--load`` prints a saved ``--json`` file again. Progress goes to stderr,
one line per finished case.

Everything is checked before the first case runs: the specs, the output
files, scikit-image for the Motorcycle, and the memory the largest case
would need (:func:`refsynth.evaluation.cases.case_memory`). User errors are
raised as ValueError / TypeError / OSError / ImportError with a one-line
message (the main entry point prints ``refsynth evaluate: error: ...`` and
exits with status 2).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from refsynth.cli.arguments import (
    add_subcommand,
    check_distinct,
    check_memory,
    check_output,
    integer,
    make_parent,
)
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
from refsynth.evaluation.cases import case_memory
from refsynth.scenes.middlebury import require_scikit_image

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
    # an empty --scene "" is an empty list (refused), not "the default"
    scenes = parse_list("synthetic,motorcycle" if args.scene is None else args.scene,
                        parse_scene, "scene")
    samplings = ",".join(DEFAULT_SAMPLINGS) if args.sampling is None else args.sampling
    cases: list[Case] = []
    for scene in scenes:
        sizes = ("native" if ":" in scene else "128") if args.size is None else args.size
        cases += grid_cases([(scene, sizes, samplings, methods)], args.seeds)  # None: all
    return list(dict.fromkeys(cases))


def _check_before_work(args, cases: Sequence[Case]) -> None:
    """What would fail later, checked now: memory and scikit-image."""
    largest = max(cases, key=lambda c: case_memory(c) or 0)
    need = case_memory(largest)
    if need:
        at_once = 1 if args.scheduler else min(args.jobs, len(cases))
        what = (f"{at_once} cases at once (--jobs {args.jobs}) as large as {largest.label}"
                if at_once > 1 else f"the case {largest.label}")
        check_memory(need * at_once, what, "choose a smaller --size"
                     + (" or fewer --jobs" if at_once > 1 else ""))
    if any(case.scene.startswith("motorcycle") for case in cases):
        require_scikit_image("the Motorcycle scene (in --scene or the default grid)")


def _comparable(rows: Sequence[dict]) -> list[dict]:
    """The rows the paper's tables can stand beside: the synthetic rooms at 128x128 only.

    The Table 1 analogue is headed 128×128 (the paper's size); rooms run at
    another size are left out of it rather than mislabelled.
    """
    return [r for r in rows if not (r["scene"].startswith("synthetic-room-")
                                    and r["size"] != "128x128")]


def _input_files(args) -> list[str]:
    """Every file the run may read: ``--load`` and the pieces of ``IMAGE:DISPARITY`` scenes.

    A piece that is not a file is harmless here: an output is compared with
    the inputs only where both name the same file.
    """
    files = [] if args.load is None else [args.load]
    for spec in (args.scene or "").split(","):
        if ":" in spec:
            files += [piece.strip() for piece in spec.split(":") if piece.strip()]
            files += [piece.rpartition("@")[0] for piece in files[-1:] if "@" in piece]
    return files


def _cmd_evaluate(args) -> int:
    if args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    inputs = _input_files(args)
    json_path = None if args.json is None else check_output(args.json, "--json", (".json",),
                                                            inputs=inputs)
    csv_path = None if args.csv is None else check_output(args.csv, "--csv", (".csv",),
                                                          inputs=inputs)
    check_distinct({"--json": json_path, "--csv": csv_path})
    wall = None
    if args.load is not None:
        if any(value is not None for value in (args.scene, args.size, args.sampling,
                                                args.methods, args.scheduler)):
            raise ValueError("--load prints saved rows: it takes no --scene, --size, "
                             "--sampling, --methods or --scheduler")
        if not Path(args.load).is_file():
            raise FileNotFoundError(f"--load: file not found: {args.load}")
        rows = read_json(args.load)
        where = args.load
        cases: list[Case] = []
    else:
        cases = _cases_from_args(args)
        _check_before_work(args, cases)
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
        comparison = format_paper_comparison(_comparable(rows))
        if comparison:
            print("\n### The paper's numbers beside ours\n")
            print(comparison)
    if json_path is not None:
        write_json(make_parent(json_path), kept)
    if csv_path is not None:
        write_csv(make_parent(csv_path), kept)
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
    parser = add_subcommand(
        subparsers, "evaluate",
        help="the paper's experiments and the baselines, side by side",
        description="Run scenes × samplings × methods and print MAR (Eq. 13), RMSE, bad>1, "
        "bad>3 and seconds. Without --scene/--size/--sampling: the default grid (synthetic "
        "room and Motorcycle at 128x128, every sampling and method; rooms 1-3 at g5_25; "
        "Motorcycle 450x375 on x-stripes). The Motorcycle needs scikit-image "
        '(pip install "refsynth[data]").',
        func=_cmd_evaluate,
    )
    cases = parser.add_argument_group("cases (scenes × sizes × samplings × methods)")
    cases.add_argument("--scene", help="comma-separated: synthetic, synthetic-N, motorcycle "
                       "(needs scikit-image), IMAGE:DISPARITY[@SCALE] (SCALE: a PNG "
                       "disparity's stored integers per pixel of disparity; default 1) "
                       "(default: synthetic,motorcycle)")
    cases.add_argument("--size", help="comma-separated: N (square), WxH (e.g. 450x375) or "
                       "native (default: 128; native for IMAGE:DISPARITY)")
    cases.add_argument("--sampling", help="comma-separated: gRW_XW, xNN, distance, distanceNN "
                       f"(default: {','.join(DEFAULT_SAMPLINGS)})")
    cases.add_argument("--methods",
                       help=f"comma-separated (default: all): {','.join(method_names())}")
    cases.add_argument("--seeds", type=integer, default=3,
                       help="seeds per NP case, reported as mean ± sd (default 3)")
    cases.add_argument("--grid", choices=["default", "quick"], default="default",
                       help="the grid when no --scene/--size/--sampling is given "
                       "(default: default)")
    running = parser.add_argument_group("where the cases run")
    running.add_argument("--jobs", type=integer, default=1,
                         help="local worker processes (default 1)")
    running.add_argument("--scheduler", metavar="ADDRESS",
                         help="run on this Dask scheduler (needs dask.distributed; default: "
                         "local processes)")
    output = parser.add_argument_group("output (the tables go to stdout)")
    for option, form in (("--json", "JSON"), ("--csv", "CSV")):
        output.add_argument(option, metavar="FILE",
                            help=f"write the rows as {form} (a .{option[2:]} file; default none)")
    output.add_argument("--no-timing", action="store_true",
                        help="leave wall times out of the table and files (for identical output)")
    output.add_argument("--no-findings", action="store_true",
                        help="print only the results tables")
    output.add_argument("--quiet", action="store_true", help="no progress on stderr")
    output.add_argument("--load", metavar="FILE",
                        help="print the tables of a previous --json file instead of running "
                        "(default: run)")
    return parser
