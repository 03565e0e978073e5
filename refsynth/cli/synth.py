"""``python -m refsynth synth``: fill the unknown range of your own image (§3.2).

:func:`add_synth_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`: it reads an intensity image and a partial range
(NPY/PFM: NaN or inf = unknown; an image file: 0 = unknown), optionally
masks the range, runs :func:`refsynth.synthesize` and writes the dense range
(and a figure). :func:`pixel_progress` is the command line's progress line
for one synthesis, which the ``demo`` and ``figures`` commands use too. User
errors are raised as ValueError / TypeError / OSError with a one-line message.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from refsynth.io import read_array
from refsynth.plotting.layouts import result_figure
from refsynth.synthesis.api import synthesize

__all__ = ["pixel_progress", "add_synth_parser"]


def pixel_progress(label: str) -> Callable[[int, int], None] | None:
    """A progress callback writing ``label: done/total pixels`` on one stderr line.

    None (no progress) when stderr is not a terminal.
    """
    if not sys.stderr.isatty():
        return None
    start = time.perf_counter()

    def report(done: int, total: int) -> None:
        end = "\n" if done >= total else ""
        rate = done / max(time.perf_counter() - start, 1e-9)
        print(f"\r{label}: {done}/{total} pixels ({rate:,.0f}/s)", end=end, file=sys.stderr)

    return report


def _read(path: str, what: str) -> np.ndarray:
    if not Path(path).is_file():
        raise FileNotFoundError(f"{what} file not found: {path}")
    return read_array(path)


def _cmd_synth(args) -> int:
    intensity = _read(args.image, "image")
    partial = _read(args.range, "range").astype(np.float64)
    if partial.ndim == 3:
        raise ValueError(f"range file must hold a single channel, got shape {partial.shape}")
    if Path(args.range).suffix.lower() not in (".npy", ".pfm"):
        partial[partial == 0] = np.nan  # image files: 0 marks unknown range
    partial[np.isinf(partial)] = np.nan  # PFM: inf marks unknown
    if args.mask is not None:
        mask = _read(args.mask, "mask")
        if mask.ndim == 3:
            mask = mask.mean(axis=2)
        if mask.shape != partial.shape:
            raise ValueError(f"mask shape {mask.shape} differs from range shape {partial.shape}")
        partial = np.where(mask > 0, partial, np.nan)
    result = synthesize(
        intensity, partial, method=args.method, seed=args.seed,
        neighbourhood=args.neighbourhood, radius=args.radius, epsilon=args.epsilon,
        use_edges=not args.no_edges, use_isophotes=not args.no_isophotes,
        ordering=args.ordering, progress=pixel_progress("synthesizing"),
    )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.save(out, result.range)
    print(f"wrote {out}: {result.range.shape[0]}x{result.range.shape[1]} range, "
          f"{len(result.order)} pixels synthesized")
    if args.figure:
        fig = result_figure(intensity, result.edges, partial, result.range,
                            title=f"{Path(args.image).name}: {args.method.upper()}")
        fig.savefig(args.figure, dpi=110)
        print(f"wrote {args.figure}")
    return 0


def add_synth_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``synth`` subcommand to an argparse subparsers object (sets ``func=``)."""
    synth = subparsers.add_parser("synth", help="fill the unknown range of your own image")
    synth.add_argument("image", help="intensity image: PNG/JPG/NPY/PFM")
    synth.add_argument("range", help="partial range: NPY/PFM (NaN or inf = unknown) "
                       "or PNG (0 = unknown)")
    synth.add_argument("--out", required=True, help="output .npy file")
    synth.add_argument("--mask", help="known-range mask (nonzero = known) applied to RANGE")
    synth.add_argument("--figure", help="also write a PNG figure here")
    synth.add_argument("--method", default="np", choices=["np", "bp"])
    synth.add_argument("--seed", type=int, default=0)
    synth.add_argument("--neighbourhood", type=int, default=5)
    synth.add_argument("--radius", type=float, default=10.0)
    synth.add_argument("--epsilon", type=float, default=0.1)
    synth.add_argument("--ordering", default="priority", choices=["priority", "onion"])
    synth.add_argument("--no-edges", action="store_true")
    synth.add_argument("--no-isophotes", action="store_true")
    synth.set_defaults(func=_cmd_synth)
    return synth
