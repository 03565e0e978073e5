"""``python -m refsynth synth``: fill the unknown range of your own image (§3.2).

:func:`add_synth_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`. It reads an intensity image and a partial range,
optionally masks the range, runs :func:`refsynth.synthesize` (NP or BP) and
writes the dense range, and optionally its confidence map, its uncertainty map (the
expected absolute error in the range's unit, :attr:`refsynth.SynthesisResult.uncertainty`)
and a figure.

Units: the dense range comes back in the partial range's unit. The range is
read by :func:`refsynth.io.read_range`, as ``model`` and ``evaluate`` read
it: a ``.npy`` or ``.pfm`` range as stored (NaN or ±inf = unknown); an image
range (PNG, TIFF, PGM …) as its stored integers (0 = unknown), divided by
``--png-scale`` if it is given; JPEG is refused (lossy), and so are known
values <= 0 unless ``--allow-nonpositive`` is given. ``--out`` writes the format its suffix names:
``.npy``, ``.pfm`` (float32) or a 16-bit ``.png`` holding
``round(range × png-scale)`` (0 = unknown; default scale 1, which needs a
range of whole numbers).

The readings of the paper start from ``--readings`` (``refsynth``, the
default, or ``paper``, the paper as printed), passed to
:func:`refsynth.synthesize` as ``readings=``; each reading's own flag
(``--range-copy``, ``--observation`` …) overrides that reading of the preset
(:meth:`refsynth.Readings.replace`).

Every output path (writable, none of the inputs, no two the same), every
option and every limit is checked before the work starts; every file is
written all or nothing (:func:`refsynth._files.write_atomic`).
:func:`pixel_progress` is the command line's progress line for one synthesis
(the ``demo`` and ``figures`` commands use it too). User errors are raised as
ValueError / TypeError / OSError with a one-line message.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.backend_bases import FigureCanvasBase

from refsynth.cli.arguments import (
    add_subcommand,
    check_distinct,
    check_output,
    integer,
    make_parent,
    real,
)
from refsynth.io import (
    IMAGE_SUFFIXES,
    WRITE_SUFFIXES,
    read_array,
    read_range,
    write_array,
    write_unit_png16,
)
from refsynth.plotting.layouts import result_figure, save_figure
from refsynth.synthesis.api import synthesize
from refsynth.synthesis.belief.gap_radius import TRAINING_RADII
from refsynth.synthesis.belief.model import COMPATIBILITIES
from refsynth.synthesis.belief.observation import OBSERVATIONS
from refsynth.synthesis.gap_readings import GAPS
from refsynth.synthesis.range_copy import RANGE_COPIES, check_offset_tolerance
from refsynth.synthesis.readings import DEFAULT_PRESET, PRESETS, Readings, split_options
from refsynth.synthesis.window_reading import WINDOWS

__all__ = ["pixel_progress", "add_synth_parser"]

#: Seconds between progress lines when stderr is not a terminal (a log file, a pipe).
LOG_INTERVAL = 5.0
#: Seconds between ``\r`` updates of the progress line on a terminal.
TTY_INTERVAL = 0.2


def _clock(seconds: float) -> str:
    """``75.2`` → ``"1:15"``; an hour or more → ``"1:02:03"``."""
    seconds = int(seconds)
    hours, rest = divmod(seconds, 3600)
    minutes, seconds = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{seconds:02d}" if hours else f"{minutes}:{seconds:02d}"


def pixel_progress(label: str, *, stream=None, interval: float | None = None,
                   clock: Callable[[], float] = time.monotonic,
                   rate: str | None = None) -> Callable[[int, int], None]:
    """A progress callback for :func:`refsynth.synthesize`, writing to stderr with time left.

    On a terminal the line is updated in place (``\\r``) every
    :data:`TTY_INTERVAL` seconds and ends with the final count. Otherwise
    (a log file, a pipe, a CI job) one line is written every
    :data:`LOG_INTERVAL` seconds, and a last one at the end if any was
    written: a run shorter than the interval writes nothing.

    Parameters
    ----------
    label : str
        What is running, e.g. ``"synthesizing"``.
    stream : file, optional
        Default ``sys.stderr`` (looked up at each call's creation).
    interval : float, optional
        Seconds between lines; default as above.
    clock : callable, default time.monotonic
        The time in seconds (a test passes a fake one).
    rate : str, optional
        The unit of ``done`` (e.g. ``"px"``): each line then also says how
        many are done per second. Default: no rate.

    Returns
    -------
    callable
        ``report(done, total)``, e.g. ``synthesizing: 42 % (155610/370500),
        0:40 elapsed, 3890 px/s, ~0:55 left`` (with ``rate="px"``).

    Examples
    --------
    >>> import io
    >>> ticks = iter([0.0, 6.0, 12.0])
    >>> out = io.StringIO()
    >>> report = pixel_progress("synthesizing", stream=out, rate="px", clock=lambda: next(ticks))
    >>> report(300, 1000); report(1000, 1000)
    >>> print(out.getvalue(), end="")
    synthesizing:  30 % (300/1000), 0:06 elapsed, 50 px/s, ~0:14 left
    synthesizing: 100 % (1000/1000), 0:12 elapsed, 83 px/s
    """
    out = sys.stderr if stream is None else stream
    try:
        tty = bool(out.isatty())
    except (AttributeError, ValueError):
        tty = False
    every = (TTY_INTERVAL if tty else LOG_INTERVAL) if interval is None else interval
    start = clock()
    state = {"last": start, "printed": False, "width": 0, "finished": False}

    def report(done: int, total: int) -> None:
        now = clock()
        finished = done >= total
        if state["finished"] or (not finished and now - state["last"] < every):
            return
        state["finished"] = finished
        if finished and not tty and not state["printed"]:
            return
        elapsed = now - start
        percent = 100.0 * done / total if total else 100.0
        line = f"{label}: {percent:3.0f} % ({done}/{total}), {_clock(elapsed)} elapsed"
        if rate is not None and elapsed > 0:
            line += f", {done / elapsed:.0f} {rate}/s"
        if not finished and done > 0:
            line += f", ~{_clock(elapsed * (total - done) / done)} left"
        state["last"], state["printed"] = now, True
        if tty:
            padding = " " * max(0, state["width"] - len(line))
            state["width"] = len(line)
            print(f"\r{line}{padding}", end="\n" if finished else "", file=out, flush=True)
        else:
            print(line, file=out, flush=True)

    return report


# ----------------------------------------------------------------------------- reading


def _read(path: str, what: str) -> np.ndarray:
    if not Path(path).is_file():
        raise FileNotFoundError(f"{what} file not found: {path}")
    array = read_array(path)
    if array.dtype.kind not in "biuf":
        raise TypeError(f"{what} file {path} must hold real numbers, got dtype {array.dtype}")
    return array


def _is_image(path: str) -> bool:
    return Path(path).suffix.lower() in IMAGE_SUFFIXES


def _read_range(args) -> np.ndarray:
    """The partial range, float64 (H, W), NaN where unknown, in the file's unit.

    Read by :func:`refsynth.io.read_range`, as ``model`` and ``evaluate`` read
    range: an image's stored integers divided by ``--png-scale``; JPEG and
    values <= 0 (without ``--allow-nonpositive``) refused.
    """
    if not Path(args.range).is_file():
        raise FileNotFoundError(f"range file not found: {args.range}")
    partial = read_range(args.range, scale=args.png_scale if _is_image(args.range) else None,
                         allow_nonpositive=args.allow_nonpositive)
    if args.mask is not None:
        mask = _read(args.mask, "mask")
        if mask.ndim == 3:
            mask = mask.max(axis=2)
        if mask.shape != partial.shape:
            raise ValueError(f"mask shape {mask.shape} differs from range shape {partial.shape}")
        partial = np.where(mask > 0, partial, np.nan)
    return partial


# ----------------------------------------------------------------------------- checks

#: The options only one method uses: CLI name -> (attribute, method).
_METHOD_OPTIONS = {
    "--epsilon": ("epsilon", "np"), "--ordering": ("ordering", "np"),
    "--no-isophotes": ("use_isophotes", "np"), "--candidates": ("candidates", "bp"),
    "--proximity": ("proximity", "bp"), "--sigma-i": ("sigma_i", "bp"),
    "--sigma-s": ("sigma_s", "bp"), "--iterations": ("iterations", "bp"),
    "--proposals": ("proposals", "bp"), "--proposal-runs": ("proposal_runs", "bp"),
    "--observation": ("observation", "bp"), "--training-radius": ("training_radius", "bp"),
    "--compatibility": ("compatibility", "bp"), "--offset-tolerance": ("offset_tolerance", "bp"),
}
#: Options of both methods that are not Eq. 2's: passed on only when given.
_BOTH_OPTIONS = ("range_copy", "gaps", "median", "window")
#: Eq. 2's readings, for both methods: passed on only when given.
_EQ2_OPTIONS = ("channels", "range_weight", "missing_range", "colour")
_DEFAULT_RADIUS = 10.0
_DEFAULT_NEIGHBOURHOOD = 5


#: What ``--uncertainty-out`` writes: float maps in the range's unit.
UNCERTAINTY_SUFFIXES = (".npy", ".pfm")


def _check_options(args) -> tuple[Path, Path | None, Path | None, Path | None]:
    """Everything that does not need the files: outputs, method options, --png-scale."""
    inputs = (args.image, args.range, args.mask)
    out = check_output(args.out, "--out", WRITE_SUFFIXES, inputs=inputs)
    confidence = (None if args.confidence is None
                  else check_output(args.confidence, "--confidence", WRITE_SUFFIXES,
                                    inputs=inputs))
    uncertainty = (None if args.uncertainty_out is None
                   else check_output(args.uncertainty_out, "--uncertainty-out",
                                     UNCERTAINTY_SUFFIXES, inputs=inputs))
    figure = None
    if args.figure is not None:
        kinds = sorted(f".{kind}" for kind in FigureCanvasBase.get_supported_filetypes())
        figure = check_output(args.figure, "--figure", kinds, inputs=inputs)
    check_distinct({"--out": out, "--confidence": confidence,
                    "--uncertainty-out": uncertainty, "--figure": figure})
    for option, (name, method) in _METHOD_OPTIONS.items():
        if getattr(args, name) is not None and args.method != method:
            raise ValueError(f"{option} applies to --method {method} only (got --method "
                             f"{args.method})")
    if args.png_scale is not None:
        if args.png_scale <= 0:
            raise ValueError(f"--png-scale must be > 0, got {args.png_scale:g}")
        if not (_is_image(args.range) or out.suffix.lower() == ".png"):
            raise ValueError("--png-scale applies to an image RANGE or a .png --out only")
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    if args.offset_tolerance is not None:
        try:
            check_offset_tolerance(args.offset_tolerance)
        except ValueError:
            raise ValueError("--offset-tolerance must be a power of two from 2**-16 to 1 "
                             f"(e.g. 0.125), got {args.offset_tolerance:g}") from None
    if args.proposal_runs is not None:
        if args.proposals is None:
            raise ValueError("--proposal-runs needs --proposals (np or np-completed)")
        if args.proposal_runs < 1:
            raise ValueError(f"--proposal-runs must be >= 1, got {args.proposal_runs}")
    return out, confidence, uncertainty, figure


def _check_limits(args, shape: tuple[int, int]) -> None:
    """Refuse --radius / --neighbourhood beyond what the image can use."""
    height, width = shape
    reach = math.ceil(math.hypot(height - 1, width - 1))  # reaches every pixel from any pixel
    if args.radius > max(reach, _DEFAULT_RADIUS):
        raise ValueError(
            f"--radius {args.radius:g} is larger than the {width}x{height} image needs: "
            f"{reach} already reaches every pixel; give at most {max(reach, 10)}"
        )
    side = 2 * max(height, width) - 1  # a window of this side covers the image from any pixel
    if args.neighbourhood is not None and args.neighbourhood > max(side, _DEFAULT_NEIGHBOURHOOD):
        raise ValueError(
            f"--neighbourhood {args.neighbourhood} is larger than the {width}x{height} image "
            f"needs: {side} already covers it from every pixel; give at most "
            f"{max(side, _DEFAULT_NEIGHBOURHOOD)}"
        )


def _check_png_out(path: Path, partial: np.ndarray, scale: float | None) -> None:
    """A .png --out stores round(range × scale) in 1..65535: check the known values now.

    Both methods copy measured values, so the dense range spans what the known
    range spans.
    """
    known = partial[np.isfinite(partial)]
    if known.size == 0:
        return
    stored = known * (1.0 if scale is None else scale)
    if scale is None and not np.array_equal(stored, np.rint(stored)):
        raise ValueError(
            f"--out {path} stores whole numbers but the range has fractions "
            f"({known.min():g}..{known.max():g}): give --png-scale (e.g. 1000 for mm from m) "
            "or write .npy / .pfm"
        )
    low, high = float(np.rint(stored.min())), float(np.rint(stored.max()))
    if low < 1 or high > 65535:
        raise ValueError(
            f"--out {path}: the range x {1.0 if scale is None else scale:g} spans "
            f"{low:g}..{high:g}, outside a 16-bit PNG's 1..65535 (0 = unknown); "
            "choose another --png-scale or write .npy / .pfm"
        )


# ----------------------------------------------------------------------------- the command


def _cmd_synth(args) -> int:
    out, confidence_path, uncertainty_path, figure_path = _check_options(args)
    intensity = _read(args.image, "image")
    partial = _read_range(args)
    _check_limits(args, partial.shape)
    if out.suffix.lower() == ".png":
        _check_png_out(out, partial, args.png_scale)
    options = {name: getattr(args, name) for name, _ in _METHOD_OPTIONS.values()}
    options.update({name: getattr(args, name) for name in _EQ2_OPTIONS + _BOTH_OPTIONS
                    if getattr(args, name) is not None})
    keywords, overrides = split_options(options)
    readings = Readings.preset(args.readings).replace(**overrides)
    report = pixel_progress("synthesizing", rate="px")
    if args.method == "bp":  # BP reports per mille of its work: shown as pixels' worth of it
        unknown = int(np.count_nonzero(~np.isfinite(partial)))
        progress = lambda done, total: report(done * unknown // total, unknown)  # noqa: E731
    else:
        progress = report
    result = synthesize(
        intensity, partial, method=args.method, seed=args.seed,
        neighbourhood=args.neighbourhood, radius=args.radius, use_edges=not args.no_edges,
        progress=progress, **keywords, readings=readings,
    )
    scale = 1.0 if args.png_scale is None else args.png_scale
    write_array(make_parent(out), result.range, png_scale=scale)
    unit = "the range file's unit" if args.png_scale is None or not _is_image(args.range) \
        else f"the range file's unit / {args.png_scale:g}"
    print(f"wrote {out}: {result.range.shape[0]}x{result.range.shape[1]} range in {unit}, "
          f"{len(result.order)} pixels synthesized ({args.method.upper()})")
    if confidence_path is not None:
        make_parent(confidence_path)
        if confidence_path.suffix.lower() == ".png":
            write_unit_png16(confidence_path, result.confidence)
            print(f"wrote {confidence_path}: confidence in [0, 1] (16-bit PNG, x 65535)")
        else:
            write_array(confidence_path, result.confidence)
            print(f"wrote {confidence_path}: confidence in [0, 1]")
    if uncertainty_path is not None:
        write_array(make_parent(uncertainty_path), result.uncertainty)
        print(f"wrote {uncertainty_path}: expected absolute error in {unit} (0 = measured)")
    if figure_path is not None:
        fig = result_figure(intensity, result.edges, partial, result.range, units=unit,
                            title=f"{Path(args.image).name}: {args.method.upper()}",
                            uncertainty=result.uncertainty)
        save_figure(fig, make_parent(figure_path), dpi=110)
        print(f"wrote {figure_path}")
    return 0


def add_synth_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``synth`` subcommand to an argparse subparsers object (sets ``func=``)."""
    synth = add_subcommand(
        subparsers, "synth", help="fill the unknown range of your own image",
        description="Fill the unknown range of IMAGE's partial range (Torres-Méndez & Dudek "
        "2008, §3.2) with NP sampling or belief propagation, and write the dense range in "
        "the partial range's unit. Every path and option is checked before the work starts.",
        func=_cmd_synth,
    )
    synth.add_argument("image", help="intensity image: PNG/JPG/TIFF/NPY/PFM, grey or colour")
    synth.add_argument("range", help="partial range: NPY/PFM (NaN or inf = unknown, values as "
                       "stored) or a 16/8-bit PNG/TIFF/PGM (0 = unknown, the stored integers "
                       "/ --png-scale); JPEG is refused (lossy)")
    synth.add_argument("--mask", metavar="FILE",
                       help="known-range mask applied to RANGE (nonzero = known; default none)")
    synth.add_argument("--method", default="np", choices=["np", "bp"],
                       help="np: non-parametric sampling (§3.2.2); bp: belief propagation "
                       "(§3.2.3) (default np)")
    synth.add_argument("--seed", type=integer, default=0,
                       help="seed of NP's random draws (BP's too: NP's fill completes its "
                       "observations by default); the same seed gives the same output "
                       "(default 0)")
    synth.add_argument("--neighbourhood", type=integer, default=None, metavar="N",
                       help="odd side of the NxN MRF neighbourhood (default: --window's)")
    synth.add_argument("--radius", type=real, default=_DEFAULT_RADIUS, metavar="R",
                       help="search radius of Eq. 3 in pixels, at most the image's diagonal "
                       "(default 10)")
    synth.add_argument("--no-edges", action="store_true",
                       help="ignore intensity edges (the paper's no-edge ablation; default: "
                       "use Canny edges)")
    outputs = synth.add_argument_group("outputs (each checked before the work starts)")
    outputs.add_argument("--out", required=True, metavar="FILE",
                         help="dense range: .npy, .pfm (float32) or .png (16-bit, "
                         "round(range x --png-scale), 0 = unknown)")
    outputs.add_argument("--confidence", metavar="FILE",
                         help="also write the confidence map (1 = measured): .npy, .pfm or "
                         ".png (16-bit, confidence x 65535)")
    outputs.add_argument("--uncertainty-out", metavar="FILE",
                         help="also write the uncertainty map, each pixel's expected absolute "
                         "error in the range's unit (0 = measured): .npy or .pfm")
    outputs.add_argument("--figure", metavar="FILE",
                         help="also write a figure (.png, .pdf, .svg ...; default none)")
    outputs.add_argument("--png-scale", type=real, metavar="S",
                         help="stored integer per unit of range: divides a PNG range on input, "
                         "multiplies a .png --out (default: 1, the stored integers)")
    synth.add_argument("--allow-nonpositive", action="store_true",
                       help="accept known range values <= 0 (a signed map; default: refused, "
                       "range is a distance > 0)")
    readings = synth.add_argument_group(
        "the readings of the paper (refsynth.Readings; the docs' departures page gives the "
        "paper's text and the evidence for each)")
    readings.add_argument("--readings", choices=list(PRESETS), default=DEFAULT_PRESET,
                          help="the preset every reading starts from: paper (the paper as "
                          "printed: Eq. 2 as written, Eq. 5's value copy, Fig. 6's BP) or "
                          "refsynth (the measured readings); each flag below overrides one "
                          f"reading of it (default {DEFAULT_PRESET})")
    eq2 = synth.add_argument_group("Eq. 2's readings (both methods; default: the preset's)")
    eq2.add_argument("--channels", choices=["sum", "mean"],
                     help="the intensity term over colour channels: their sum, as Eq. 2, or "
                     "their mean (default: sum in both presets)")
    eq2.add_argument("--range-weight", type=real, metavar="LAMBDA",
                     help="lambda, the weight of the range term against the intensity "
                     "term (default 1 in both presets: the paper's equal weights)")
    eq2.add_argument("--missing-range", choices=["mean", "ignore"],
                     help="offsets where the target has range and a candidate has none: "
                     "charged the mean shared discrepancy (default: refsynth) or left out, "
                     "as Eq. 2 is printed (default: paper)")
    eq2.add_argument("--grey", dest="colour", action="store_const", const=False,
                     help="compare the BT.709 grey level instead of the colour channels "
                     "(default: the colour channels in both presets)")
    both = synth.add_argument_group("what a pixel is given (both methods; default: the "
                                    "preset's)")
    both.add_argument("--range-copy", choices=list(RANGE_COPIES),
                      help="what a pixel gets from the neighbourhood Eq. 5 drew (NP) or its "
                      "MAP label (BP): value, the centre range, as Eq. 5 and Fig. 6 print it "
                      "(default: paper), or offset, that value shifted by the two windows' "
                      "consistent range difference (default: refsynth)")
    both.add_argument("--gaps", choices=list(GAPS),
                      help="what becomes of a column scan's gaps after the fill: copy, every "
                      "pixel as filled (default: paper), or gate, the line across a smooth "
                      "gap and the fill clipped to its bounds across a depth edge (default: "
                      "refsynth)")
    both.add_argument("--median", type=integer, metavar="N",
                      help="after the gaps, each synthesized pixel the median of its N x N "
                      "window: 0, none (default: paper), or an odd N from 3 to 15 (default: "
                      "3, refsynth)")
    both.add_argument("--window", choices=list(WINDOWS),
                      help="the neighbourhood without --neighbourhood: fixed, 5 x 5 (default: "
                      "paper), or gaps, 3 x 3 on a column scan whose gaps are at most 5 "
                      "columns wide and 5 x 5 otherwise (default: refsynth)")
    np_group = synth.add_argument_group("NP only (--method np)")
    np_group.add_argument("--epsilon", type=real, metavar="E",
                          help="tolerance of Eq. 5 (default 0.1)")
    np_group.add_argument("--ordering", choices=["priority", "onion"],
                          help="fill order: priority (Eqs. 10-12) or onion peel (default "
                          "priority)")
    np_group.add_argument("--no-isophotes", dest="use_isophotes", action="store_const",
                          const=False, help="drop the isophote term of Eq. 12 (default: use it)")
    bp_group = synth.add_argument_group("BP only (--method bp; a reading's default is the "
                                        "preset's)")
    bp_group.add_argument("--candidates", type=integer, metavar="K",
                          help="candidate labels per unknown pixel (default 8)")
    bp_group.add_argument("--iterations", type=integer, metavar="N",
                          help="at most this many message-passing sweeps (default 50)")
    bp_group.add_argument("--proximity", type=real, metavar="MU",
                          help="weight of a spatial prior when ranking candidates "
                          "(default 0 in both presets: Eq. 2 alone, as Fig. 6)")
    bp_group.add_argument("--sigma-i", type=real, metavar="S",
                          help="sigma_i of Eq. 7 (default 0.1 in both presets)")
    bp_group.add_argument("--sigma-s", type=real, metavar="S",
                          help="sigma_s of Eq. 6, in units of the known range's span "
                          "(default 0.2 in both presets)")
    bp_group.add_argument("--proposals", choices=["np", "np-completed"],
                          help="NP's fill proposes one more label per pixel (np-completed: "
                          "the training patches' unknown range from NP too) (default: none "
                          "in both presets, Fig. 6's candidates)")
    bp_group.add_argument("--proposal-runs", type=integer, metavar="S",
                          help="with --proposals: this many NP fills propose (default 1)")
    bp_group.add_argument("--observation", choices=list(OBSERVATIONS),
                          help="the observations' range for the candidates' ranking: "
                          "measured, as Fig. 6 (default: paper); np, completed by NP's fill "
                          "(NP's time on top, follows --seed; default: refsynth); "
                          "colorization, by the colorization fill (faster, less accurate); "
                          "colorization-completed, the training patches' too")
    bp_group.add_argument("--training-radius", choices=list(TRAINING_RADII),
                          help="each node's training disc: fixed, Fig. 6's r (default: "
                          "paper), or gap, r widened by the node's distance to the nearest "
                          "measured pixel (default: refsynth)")
    bp_group.add_argument("--offset-tolerance", type=real, metavar="T",
                          help="with the offset copy: how closely the windows' range "
                          "differences must agree for a label to be shifted, a power of two "
                          "fraction of the measured span (default: 0.125 = 2**-3 on NP's "
                          "fill; 0.0078125 = 2**-7, NP's, with the other observations)")
    bp_group.add_argument("--compatibility", choices=list(COMPATIBILITIES),
                          help="Eq. 6 over the two labels' overlap, as printed, or "
                          "overlap-centres, the labels' centres counted as one more shared "
                          "pixel (default: overlap in both presets)")
    return synth
