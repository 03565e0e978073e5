"""``python -m refsynth demo``: the main job, and its table.

:func:`add_demo_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`. The work is :func:`refsynth.plotting.demo.run_demo`
(the synthetic room: NP, its ablations, BP and the baselines on two
samplings) or, with ``--pipeline``, :func:`refsynth.plotting.demo.run_pipeline_demo`
(simulated scan → registration → synthesis); this module prints their
results. User errors are raised as ValueError with a one-line message.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from refsynth.cli.synth import pixel_progress
from refsynth.plotting.demo import DEMO_FIGURES, run_demo, run_pipeline_demo

__all__ = ["add_demo_parser"]


def _format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """A plain-text table: ``columns`` are (row key, title, format spec or "")."""
    header = [title for _, title, _ in columns]
    body = [[format(row[key], fmt) if fmt else str(row[key]) for key, _, fmt in columns]
            for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in body)) for i, h in enumerate(header)]
    line = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths))  # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, body)])


def _cmd_demo(args) -> int:
    if args.pipeline:
        summary = run_pipeline_demo(Path(args.out), seed=args.seed, progress=pixel_progress)
        h, w = summary["panorama"]
        print(f"refsynth demo --pipeline: simulated scan ({args.out}/scan), registered panorama "
              f"{w}x{h}, {100 * summary['known']:.0f} % with range; warp a, b, alpha, beta = "
              + ", ".join(f"{v:.2f}" for v in summary["warp"]))
        for method, seconds in summary["seconds"].items():
            figure = Path(args.out) / f"pipeline_{method}.png"
            print(f"{method.upper()}: {seconds:.1f} s -> {figure}")
        return 0
    if args.size < 16:
        raise ValueError(f"--size must be at least 16, got {args.size}")
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
    demo = subparsers.add_parser("demo", help="run the main job on the bundled synthetic room")
    demo.add_argument("--out", default="refsynth-demo", help="folder for the figures")
    demo.add_argument("--size", type=int, default=128, help="image side in pixels (default 128)")
    demo.add_argument("--seed", type=int, default=0, help="scene and synthesis seed")
    demo.add_argument("--pipeline", action="store_true",
                      help="acquire with the simulated rig, register, then synthesize "
                      "(instead of the pre-aligned synthetic room)")
    demo.set_defaults(func=_cmd_demo)
    return demo
