"""``python -m refsynth demo``: the paper's story end to end, or (``--quick``) one table of fills.

:func:`add_demo_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`. The default is
:func:`refsynth.plotting.story.run_pipeline_demo`: the simulated rig scans
its room from two positions, registration (Appendix A), NP and BP, a table
of MAR against the simulator's ground truth, the targets of stage 3, the
merged 3-D model and its rendered view (about a minute on two cores);
``--pipeline`` names the same story. ``--quick`` (or ``--size``) is
:func:`refsynth.plotting.demo.run_demo`: the synthetic room, NP, its
ablations, BP and the baselines on two samplings (about 30 s on two cores).
``--active`` is :func:`refsynth.plotting.active_story.run_active_demo`: from
the story's first position, the rig scans with stripes, Fig. 2's
distance-driven slices and active scanning (§5) at the same number of
slices, and BP and two classical fills are scored on each. This
module prints their results, and the story's progress with the time left on
stderr. The output folder and the memory the largest fill needs are checked
before any work. User errors are raised as ValueError / OSError with a
one-line message.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from refsynth.cli.arguments import (
    add_subcommand,
    check_files_in,
    check_folder,
    check_memory,
    integer,
)
from refsynth.cli.synth import pixel_progress
from refsynth.evaluation.cases import Case, case_memory
from refsynth.plotting.active_story import ACTIVE_FILES, run_active_demo
from refsynth.plotting.demo import DEMO_FIGURES, run_demo, run_pipeline_demo
from refsynth.plotting.story import STORY_FILES

__all__ = ["add_demo_parser"]


def _format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """A plain-text table: ``columns`` are (row key, title, format spec or "")."""
    header = [title for _, title, _ in columns]
    body = [[format(row[key], fmt) if fmt else str(row[key]) for key, _, fmt in columns]
            for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in body)) for i, h in enumerate(header)]
    line = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths))  # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, body)])


def _clock(seconds: float) -> str:
    """``75.2`` → ``"1:15"``."""
    minutes, seconds = divmod(int(seconds), 60)
    return f"{minutes}:{seconds:02d}"


def story_progress(*, stream=None, interval: float | None = None, clock=time.monotonic):
    """The story's progress on stderr: stage, percent, time elapsed and left.

    A ``progress(stage, fraction)`` for
    :func:`refsynth.plotting.story.run_pipeline_demo`. On a terminal one line
    is updated in place (every 0.2 s); otherwise (a log, a pipe) a line is
    written as each stage starts and every 5 s within one, e.g. ``demo:  42 %
    position 2: BP, 0:31 elapsed, ~0:43 left``.
    """
    out = sys.stderr if stream is None else stream
    try:
        tty = bool(out.isatty())
    except (AttributeError, ValueError):
        tty = False
    every = (0.2 if tty else 5.0) if interval is None else interval
    start = clock()
    state = {"stage": None, "last": -math.inf, "width": 0}

    def report(stage: str, fraction: float) -> None:
        now = clock()
        if stage == state["stage"] and now - state["last"] < every:
            return
        state["stage"], state["last"] = stage, now
        elapsed = now - start
        line = f"demo: {100 * fraction:3.0f} % {stage}, {_clock(elapsed)} elapsed"
        if fraction > 0.02:
            line += f", ~{_clock(elapsed * (1 - fraction) / fraction)} left"
        if tty:
            padding = " " * max(0, state["width"] - len(line))
            state["width"] = len(line)
            print(f"\r{line}{padding}", end="", file=out, flush=True)
        else:
            print(line, file=out, flush=True)

    def finish() -> None:
        if tty and state["width"]:
            print(file=out, flush=True)

    report.finish = finish
    return report


def _print_targets(targets: dict) -> None:
    """Stage 3's targets against the room's truth as a table: one column per position."""
    per = targets["positions"]
    names = [f"position {k}" for k in range(1, len(per) + 1)]
    methods = [m for m in per[0]["points_percent"] if m != "measured"]
    rows = []

    def row(measure, cells, target=""):
        rows.append({"measure": measure, **dict(zip(names, cells)), "target": target})

    row("model points off the true surface (median % of range) [1]: measured",
        [f"{p['points_percent']['measured']:.2f} %" for p in per], "<= 1 %")
    for m in methods:
        row(f"  {m}-synthesized", [f"{p['points_percent'][m]:.2f} %" for p in per])
    tri = [p["triangles"] for p in per]
    row("triangles bridging a true depth discontinuity [2]: measured",
        [f"{t['measured']['bridging']} of {t['measured']['triangles']}" for t in tri], "0")
    for m in methods:
        row(f"  with a synthesized vertex, {m}",
            [f"{t[m]['bridging']} of {t[m]['triangles']}" for t in tri])
    row("silhouette triangles [3]: measured / " + " / ".join(methods),
        [" / ".join(str(t[k]["silhouette"]) for k in ("measured", *methods)) for t in tri])
    cells = ["-"] * len(per)
    for entry in targets["alignment"]:
        cells[entry["position"] - 1] = (f"{entry['odometry_cm']:.2f} -> "
                                        f"{entry['refined_cm']:.2f} cm")
    row(f"median alignment error of the merged model ({targets['merged']['method']}): "
        "odometry (2 deg, 10 cm) -> ICP", cells, "<= 1 cm")
    print("stage 3 against the room's truth (the model's targets):")
    print(_format_table(rows, [("measure", "measure", ""), *((n, n, "") for n in names),
                               ("target", "target", "")]))
    print("  [1] |r - r_true| / r_true along each point's ray (r_true: the simulator's ray caster "
          "from the true pose)")
    print("  [2] the true range jumps by > 10 % between its pixels and its centre lies > 2.5 % "
          "of its range off every true surface")
    print("  [3] the true range jumps by > 10 % between its pixels, but the triangle lies on one "
          "surface (a range registered a pixel beside a depth edge)")
    merged = targets["merged"]
    print(f"merged model: {merged['vertices']} vertices ({merged['fused_away']} fused away in "
          f"the overlap), {merged['triangles']} triangles")


def _print_story(summary: dict, args, seconds: float) -> None:
    """The story's results on stdout: positions, the MAR table, the targets, every file."""
    positions = summary["positions"]
    print(f"refsynth demo: the simulated rig's room (seed {args.seed}) scanned from "
          f"{len(positions)} positions, 40 % of the 500 slices each; {seconds:.0f} s")
    for k, position in enumerate(positions, start=1):
        pose, (h, w) = position["pose"], position["panorama"]
        print(f"  position {k}: x = {pose['x']:g} m, z = {pose['z']:g} m, heading "
              f"{pose['heading']:g} deg ({position['scan']}); registered panorama {w}x{h}, "
              f"{100 * position['known']:.0f} % with range; warp a, b, alpha, beta = "
              + ", ".join(f"{v:.2f}" for v in position["warp"]))
    print("MAR (Eq. 13) against the simulator's ground truth, range in m, on every 2nd row "
          "and column of each panorama:")
    print(_format_table(summary["rows"], [
        ("position", "position", ""), ("method", "method", ""),
        ("unknown", "unknown %", ".1f"), ("mar", "MAR (m)", ".4f"), ("rmse", "RMSE (m)", ".4f"),
        ("median_percent", "median |error| / range %", ".2f"), ("seconds", "seconds", ".2f"),
    ]))
    _print_targets(summary["targets"])
    _print_files(summary["files"])
    print("next: python -m refsynth demo --active (active scanning beside the fixed "
          "strategies), python -m refsynth --help")


def _print_files(files) -> None:
    """``wrote:`` and each path, a folder with a trailing slash."""
    print("wrote:")
    for path in files:
        print(f"  {path}{'/' if Path(path).is_dir() else ''}")


def _run_story(run, args, what: str) -> tuple[dict, float]:
    """``run(out, seed=, progress=)`` after the memory check, with the progress line on
    stderr; its summary and the seconds it took."""
    check_memory(case_memory(Case("synthetic-0", "481x114", "x78", "bp", 0)), what,
                 "run demo --quick")
    progress = story_progress()
    start = time.perf_counter()
    try:
        summary = run(Path(args.out), seed=args.seed, progress=progress)
    finally:
        progress.finish()
    return summary, time.perf_counter() - start


def _cmd_story(args) -> int:
    summary, seconds = _run_story(run_pipeline_demo, args, "the demo")
    _print_story(summary, args, seconds)
    return 0


def _cmd_active(args) -> int:
    summary, seconds = _run_story(run_active_demo, args, "the active-scanning demo")
    rounds = summary["rounds"]
    print(f"refsynth demo --active: the simulated rig's room (seed {args.seed}) from position "
          f"1, 40 % of the 500 slices by each strategy; {seconds:.0f} s")
    print(f"  active: a first pass of {len(rounds[0])} evenly spread slices, then "
          f"{len(rounds) - 1} rounds of {', '.join(str(len(r)) for r in rounds[1:])} slices, "
          "each chosen by next_slices (BP) from what was measured")
    print("MAR (Eq. 13) against the simulator's ground truth, range in m, on every 2nd row "
          "and column of each registered panorama:")
    print(_format_table(summary["rows"], [
        ("strategy", "strategy", ""), ("slices", "slices", "d"), ("method", "method", ""),
        ("unknown", "unknown %", ".1f"), ("mar", "MAR (m)", ".4f"),
        ("rmse", "RMSE (m)", ".4f"), ("seconds", "seconds", ".2f"),
    ]))
    print(f"active BP / the best fixed strategy and fill: {summary['ratio']:.3f}")
    _print_files(summary["files"])
    return 0


def _cmd_demo(args) -> int:
    out = check_folder(args.out, "--out")
    check_files_in(out, (*DEMO_FIGURES, *STORY_FILES, *ACTIVE_FILES), "--out")
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    quick = args.quick or args.size is not None
    if quick and args.pipeline:
        raise ValueError("--pipeline (the default story) takes no --quick or --size")
    if args.active and (quick or args.pipeline):
        raise ValueError("--active (its own story) takes no --quick, --size or --pipeline")
    if args.active:
        return _cmd_active(args)
    if not quick:
        return _cmd_story(args)
    if args.size is None:
        args.size = 128
    if args.size < 16:
        raise ValueError(f"--size must be at least 16, got {args.size}")
    size = f"{args.size}x{args.size}"
    check_memory(case_memory(Case("synthetic-0", size, "x78", "bp", 0)),
                 f"the demo at --size {args.size}", "choose a smaller --size")
    rows = run_demo(Path(args.out), size=args.size, seed=args.seed, progress=pixel_progress)
    print(f"refsynth demo: synthetic room {args.size}x{args.size}, seed {args.seed}, range in m")
    print(_format_table(rows, [
        ("sampling", "sampling", ""), ("unknown", "unknown %", ".1f"), ("method", "method", ""),
        ("mar", "MAR (m)", ".4f"), ("rmse", "RMSE (m)", ".4f"), ("seconds", "seconds", ".2f"),
    ]))
    print("figures: " + ", ".join(str(Path(args.out) / name) for name in DEMO_FIGURES))
    return 0


def add_demo_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``demo`` subcommand to an argparse subparsers object (sets ``func=``)."""
    demo = add_subcommand(
        subparsers, "demo",
        help="the paper's story end to end on the simulated rig (--quick: NP, BP and the "
        "classical fills on the synthetic room, one table)",
        description="The paper's story end to end (about a minute): the simulated rig scans "
        "its room from two positions, the scans are registered to the pictures (Appendix A), "
        "NP and BP fill the range (a table of MAR against the ground truth, with nearest and "
        "colorization), and the positions become one 3-D model (PLY, ICP-refined odometry) "
        "and a rendered view. --quick: NP, its ablations, BP and the baselines on the "
        "synthetic room, one table and three figures (about 30 s on two cores). --active: "
        "active scanning (§5) beside stripes and distance-driven slices on the rig.",
        func=_cmd_demo,
    )
    demo.add_argument("--out", default="refsynth-demo",
                      help="folder for the scans, models and figures (default refsynth-demo)")
    demo.add_argument("--quick", action="store_true",
                      help="NP, its ablations, BP and the classical fills on the synthetic room "
                      "instead: one table and three figures, about 30 s (default off)")
    demo.add_argument("--size", type=integer, default=None,
                      help="--quick: the synthetic room's side in pixels, at least 16; implies "
                      "--quick (default 128)")
    demo.add_argument("--seed", type=integer, default=0,
                      help="room, noise and synthesis seed (default 0)")
    demo.add_argument("--active", action="store_true",
                      help="active scanning (§5) instead: from the story's first position the "
                      "rig scans with stripes, distance-driven slices and active rounds at the "
                      "same number of slices; BP and two classical fills on each, one table "
                      "and active_scan.png (about 1-2 minutes; default off)")
    demo.add_argument("--pipeline", action="store_true",
                      help="the default story, named explicitly (default off)")
    return demo
