"""``python -m refsynth figures``: regenerate every PNG in ``figures/``.

:func:`add_figures_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`; the figures themselves are
:func:`refsynth.plotting.figures.make_figures`'s (the analogues of the
paper's Figs. 7, 11, 13, 16 and 17, and the demos'). Several need the
Middlebury Motorcycle, hence scikit-image (the ``data`` extra): it is checked
before any work, as is the output folder. Progress goes to stderr. User
errors are raised as ValueError / OSError / ImportError with a one-line
message.
"""

from __future__ import annotations

import argparse
import sys
import time

from refsynth.cli.arguments import add_subcommand, check_files_in, check_folder, integer
from refsynth.cli.synth import pixel_progress
from refsynth.plotting.figures import FIGURES, make_figures
from refsynth.scenes.middlebury import require_scikit_image

__all__ = ["add_figures_parser"]


def _cmd_figures(args) -> int:
    if args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    out = check_folder(args.out, "--out")
    check_files_in(out, FIGURES, "--out")
    require_scikit_image("`python -m refsynth figures`")
    start = time.perf_counter()

    def log(text: str) -> None:
        print(f"[{time.perf_counter() - start:5.0f} s] {text}", file=sys.stderr, flush=True)

    written = make_figures(out, quick=args.quick, jobs=args.jobs, log=log,
                           progress=pixel_progress)
    for path in written:
        print(f"wrote {path}")
    print(f"refsynth figures: {len(written)} figures in {time.perf_counter() - start:.0f} s",
          file=sys.stderr)
    return 0


def add_figures_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``figures`` subcommand to an argparse subparsers object.

    The handler (``args.func``) returns 0; user errors raise ``ValueError`` or
    ``OSError`` with a one-line message.
    """
    parser = add_subcommand(
        subparsers, "figures",
        help="regenerate figures/ (the paper's figure analogues and the demo's)",
        description="Write every figure of figures/: the main demo's three (the model view "
        "and the panorama's NP and BP), the quick demo's three, the analogues of the "
        "paper's Figs. 7, 11, 13, 16 and 17, MAR against the unknown fraction, and BP's "
        "confidence against its error. Deterministic: the same PNG bytes on every run. "
        'Needs scikit-image for the Motorcycle (pip install "refsynth[data]").',
        func=_cmd_figures,
    )
    parser.add_argument("--out", default="figures", help="output folder (default figures)")
    parser.add_argument("--quick", action="store_true",
                        help="small scenes and no main demo, for a smoke test (not the "
                        "committed figures; default off)")
    parser.add_argument("--jobs", type=integer, default=1,
                        help="local processes for the MAR-against-fraction grid (default 1)")
    return parser
