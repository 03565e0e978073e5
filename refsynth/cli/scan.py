"""``python -m refsynth scan``: acquire a partial range scan (§3.1, §4).

:func:`add_scan_parser` adds the ``scan`` subcommand to the main parser of
:mod:`refsynth.cli.main`; ``python -m refsynth.cli.scan scan ...`` runs it on its
own. User errors are raised as ValueError / TypeError / OSError with a
one-line message (the main entry point prints ``refsynth scan: error: ...``
and exits with status 2).

Examples::

    python -m refsynth scan --simulate --out scan-0 --strategy stripes --fraction 0.4
    python -m refsynth scan --simulate --out scan-a --strategy active --fraction 0.4
    python -m refsynth scan --simulate --out scan-0 --faults corrupt=0.05,drop=0.02,disconnect=1
    python -m refsynth scan --simulate --out scan-0 --resume
    python -m refsynth scan --simulate --out scan-1 --pose 1.0,0.8,-20
    python -m refsynth scan --pan-port /dev/ttyUSB0 --laser-port /dev/ttyUSB1 --out scan-1

``--resume`` checks the folder before trusting it
(:mod:`refsynth.acquisition.resume`): files it cannot trust are set aside
into ``rejected/`` and acquired again; a folder whose ``manifest.json`` is
gone is resumed with the scan's settings given (``--strategy``, ...), the
GS window (``--average``) defaulting to the one the slice files record. A
scan killed at any moment resumes so: a slice written but not yet in the
manifest is checked and kept, a cut-short temporary file finished or
removed. The folder is locked while a scan runs: a second ``scan`` into it
exits with status 2 (``'OUT' is in use by another scan``). Symbolic links
are never written through: one in place of a slice, a picture or a
temporary file is set aside, and a ``manifest.json``, ``slices/``,
``images/`` or ``rejected/`` that is a link is refused.

``--strategy active`` (§5, active sensing) scans ``--first-fraction`` of the
slices evenly spread with every picture, then rounds of ``--per-round`` of the
slices, each chosen by :func:`refsynth.acquisition.next_slices` where the
synthesis from what is measured so far is least sure, until ``--fraction``;
``manifest.json`` records each round's slices (``rounds``) before it is
scanned, and a resumed scan chooses the rounds it lacks the same way.

``--pose X,Z,HEADING`` says where the rig stands (metres, metres, degrees):
refsynth's frame (x right, y up, z forward) with the heading turning the
rig's pan angle 0 from z towards x, the convention of
:class:`refsynth.model.Pose` (``y = 0``). The simulator scans its room from
there (:class:`refsynth.acquisition.RigPose`); a real scan only records it.
Either way it is saved in ``manifest.json`` as ``source.pose = {"x": …, "z":
…, "heading": DEGREES}`` (an entry of ``model --poses``'s ``poses.json``); a
scan without ``source.pose`` was taken at the origin (0, 0, 0).
"""

from __future__ import annotations

import argparse
import math
import sys
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path

from refsynth.acquisition import (
    STRATEGIES,
    Faults,
    PanUnit,
    Rangefinder,
    RigError,
    RigPose,
    RigSimulator,
    ScanSettings,
    run_scan,
)
from refsynth.acquisition.link import MAX_BAUD, MAX_RETRIES, MAX_SECONDS
from refsynth.acquisition.resume import resumed_manifest, slice_window
from refsynth.cli.arguments import add_subcommand

__all__ = ["add_scan_parser", "run_scan_command", "main"]


#: Bounds of the device options (the drivers' own): beyond them a deadline overflows the
#: clock, or nothing sensible is asked for.
_MAX_TIMEOUT, _MAX_RETRIES, _MAX_BAUD = MAX_SECONDS, MAX_RETRIES, MAX_BAUD
_MAX_SWEEP = 60.0
#: The two serial devices: option prefix, what --help calls it, its default baud rate.
_DEVICES = (("pan", "pan unit", 9600), ("laser", "rangefinder", 115200))


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got {text}")
    return value


def _positive(kind):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a {kind.__name__}: {text!r}") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
        return value

    parse.__name__ = kind.__name__
    return parse


def add_scan_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``scan`` (§3.1: acquire a partial range scan, real or simulated) to a subparser set.

    ``--help`` shows the devices, the sampling and the simulator options each
    in a group of its own. Returns the subcommand's parser.
    """
    scan = add_subcommand(
        subparsers, "scan",
        help="acquire a partial range scan with the pan unit and the rangefinder",
        description="Acquire a partial range scan (Torres-Mendez & Dudek 2008, sections 3.1 "
        "and 4): 500 slices over 180 degrees, of which a sampling strategy chooses some; "
        "pictures every 18 degrees. Every slice is saved as soon as it is validated, so an "
        "interrupted scan resumes with --resume, which checks every file first and never "
        "deletes or overwrites one (what it cannot trust is moved into OUT/rejected/).",
        func=run_scan_command,
    )
    where = scan.add_argument_group("devices")
    where.add_argument("--simulate", action="store_true",
                       help="use the simulated rig (pseudo-terminals, the synthetic room) "
                       "instead of ports (default: off)")
    for device, name, _ in _DEVICES:
        where.add_argument(f"--{device}-port", metavar="PORT",
                           help=f"the {name}'s port or pyserial URL (required without --simulate)")
    for device, name, baud in _DEVICES:
        where.add_argument(f"--{device}-baud", type=_positive(int), default=baud, metavar="BAUD",
                           help=f"{name} baud rate (default: %(default)s)")
    where.add_argument("--timeout", type=_positive(float), default=None, metavar="SECONDS",
                       help=f"deadline of one request, at most {_MAX_TIMEOUT:g} s (default: "
                       "0.2 simulated, 0.5 real)")
    where.add_argument("--sweep-time", type=float, default=None, metavar="SECONDS",
                       help="seconds per mirror revolution, added per averaged sample to a "
                       f"slice's deadline, at most {_MAX_SWEEP:g} (default: 0 simulated, "
                       "0.25 real)")
    where.add_argument("--retries", type=int, default=8,
                       help="times a failed request is sent again, at most "
                       f"{_MAX_RETRIES} (default: %(default)s)")
    scan.add_argument("--out", required=True, metavar="DIR",
                      help="output folder: slices/, images/, manifest.json, scan.npz (required)")
    scan.add_argument("--resume", action="store_true",
                      help="continue the scan in --out with its saved settings; without a "
                      "manifest.json, give the scan's settings to rebuild it from the slice "
                      "files (default: off)")
    what = scan.add_argument_group("sampling (a new scan; default: stripes, 0.4)")
    what.add_argument("--strategy", choices=STRATEGIES, default=None,
                      help="which slices: stripes, every n-th, distance-driven (Fig. 2, "
                      "after a coarse pass over every 10th slice), active (where the synthesis "
                      "is least sure, in rounds after an evenly spread first pass), all "
                      "(default: stripes)")
    what.add_argument("--fraction", type=_fraction, default=None,
                      help="fraction of the 500 slices to scan, in (0, 1] (default: 0.4)")
    what.add_argument("--first-fraction", type=_fraction, default=None, metavar="FRACTION",
                      help="active: fraction of the 500 slices the evenly spread first pass "
                      "scans, in (0, 1] (default: 0.2)")
    what.add_argument("--per-round", type=_fraction, default=None, metavar="FRACTION",
                      help="active: fraction of the 500 slices each later round scans, in "
                      "(0, 1] (default: 0.05)")
    what.add_argument("--step", type=_positive(int), default=None,
                      help="every: scan every STEP-th slice (default: 1/fraction, rounded)")
    what.add_argument("--stripe-width", type=_positive(int), default=None, metavar="SLICES",
                      help="stripes: consecutive slices per stripe (default: 4)")
    what.add_argument("--average", type=_positive(int), default=None, metavar="SAMPLES",
                      help="samples averaged per position, 1-99 (default: 10; on --resume "
                      "without manifest.json, the slice files' own)")
    what.add_argument("--no-camera", action="store_true", default=None,
                      help="take no pictures (default: a picture every 18 degrees)")
    sim = scan.add_argument_group("simulator")
    sim.add_argument("--seed", type=int, default=None,
                     help="room and noise seed, >= 0 (default: 0; on --resume, the saved one)")
    sim.add_argument("--pose", type=_pose, default=None, metavar="X,Z,HEADING",
                     help="where the rig stands: metres right (x) and forward (z) of the "
                     "simulated room's centre, heading in degrees from z towards x (as "
                     "refsynth.model.Pose); the simulator scans from there, a real scan "
                     "records it; saved in manifest.json; write --pose=-1,2,30 for a "
                     "negative X (default: 0,0,0; on --resume, the saved one)")
    sim.add_argument("--faults", default=None, metavar="SPEC",
                     help="faults on the wire, each key at most once: corrupt=, drop=, error= "
                     "(fractions of replies), delay= (seconds), disconnect= (a count), "
                     "disconnect_after=; e.g. corrupt=0.05,drop=0.02,disconnect=1 "
                     "(default: none)")
    scan.add_argument("--quiet", action="store_true",
                      help="no progress on stderr (default: off)")
    return scan


def _pose(text: str) -> RigPose:
    """An argparse type: ``X,Z,HEADING`` (metres, metres, degrees) as a RigPose."""
    parts = text.split(",")
    try:
        x, z, heading = (float(part) for part in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be X,Z,HEADING (metres, metres, degrees), got {text!r}") from None
    if not all(map(math.isfinite, (x, z, heading))) or abs(heading) > 360:
        raise argparse.ArgumentTypeError(
            f"must be finite, the heading within ±360 degrees, got {text!r}")
    return RigPose(x=x, z=z, heading=math.radians(heading))


def _scan_pose(args, saved: dict) -> RigPose | None:
    """The pose asked for (``--pose``), or the saved scan's on --resume; None: the origin,
    not recorded."""
    recorded = saved.get("source", {}).get("pose") if saved else None
    if recorded is not None:
        recorded = RigPose.from_dict(recorded)
        if args.pose is not None and args.pose.as_dict() != recorded.as_dict():
            raise ValueError(f"cannot resume '{args.out}': --pose differs from the saved scan's "
                             f"({recorded.as_dict()})")
        return recorded
    if args.pose is not None and saved:
        raise ValueError(f"cannot resume '{args.out}' with --pose: the saved scan was taken "
                         "at the origin (its manifest.json records no pose)")
    return args.pose


def _settings(args, out: Path, saved: dict) -> ScanSettings | None:
    """The settings asked for: only what was given on the command line, over the saved
    scan's (on --resume) or the slice files' GS window (on --resume without a manifest)."""
    given = {
        "strategy": args.strategy, "fraction": args.fraction, "step": args.step,
        "stripe_width": args.stripe_width, "average": args.average,
        "first_fraction": args.first_fraction, "per_round": args.per_round,
        "camera": False if args.no_camera else None,
    }
    given = {key: value for key, value in given.items() if value is not None}
    strategy = given.get("strategy", saved.get("settings", {}).get("strategy"))
    if strategy != "active" and ({"first_fraction", "per_round"} & set(given)):
        raise ValueError("--first-fraction and --per-round are for --strategy active")
    if strategy == "active" and given.get("camera") is False:
        raise ValueError("--strategy active needs the pictures: it takes no --no-camera")
    if args.resume and not given:
        return None  # the folder's own settings
    if saved:  # only what was given on the command line is compared with the saved scan
        return replace(ScanSettings.from_dict(saved["settings"]), **given)
    if args.resume:
        given = {**(slice_window(out) or {}), **given}
    return ScanSettings(**given)


def _progress(quiet: bool):
    if quiet:
        return None
    tty = sys.stderr.isatty()
    last = [-1]

    def report(done: int, total: int, pan_index: int) -> None:
        if tty:
            end = "\n" if done >= total else ""
            print(f"\rscan: {done}/{total} slices (pan {pan_index})", end=end, file=sys.stderr)
        elif done * 10 // total != last[0] or done == total:
            last[0] = done * 10 // total
            print(f"scan: {done}/{total} slices (pan {pan_index})", file=sys.stderr)

    return report


def _check_options(args) -> None:
    """The device and simulator options, in one line each (before any work)."""
    if not args.out.strip():
        raise ValueError("--out must name a folder, got an empty string")
    if not 0 <= args.retries <= _MAX_RETRIES:
        raise ValueError(f"--retries must be >= 0 and <= {_MAX_RETRIES}, got {args.retries}")
    if args.simulate:
        if args.pan_port or args.laser_port:
            raise ValueError("--simulate takes no --pan-port / --laser-port")
    else:
        if not (args.pan_port and args.laser_port):
            raise ValueError("give --simulate, or both --pan-port and --laser-port")
        if args.faults is not None or args.seed is not None:
            raise ValueError("--faults and --seed are for --simulate")
    if args.seed is not None and args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    if args.timeout is not None and not args.timeout <= _MAX_TIMEOUT:
        raise ValueError(f"--timeout must be a finite number of seconds <= {_MAX_TIMEOUT:g}, "
                         f"got {args.timeout:g}")
    if args.sweep_time is not None and not (math.isfinite(args.sweep_time)
                                            and 0 <= args.sweep_time <= _MAX_SWEEP):
        raise ValueError(f"--sweep-time must be >= 0 and <= {_MAX_SWEEP:g} seconds, got "
                         f"{args.sweep_time:g}")
    for device, _, _ in _DEVICES:
        baud = getattr(args, f"{device}_baud")
        if baud > _MAX_BAUD:
            raise ValueError(f"--{device}-baud must be <= {_MAX_BAUD}, got {baud}")


def run_scan_command(args) -> int:
    """The ``scan`` subcommand: returns the exit status (0)."""
    _check_options(args)
    out = Path(args.out)
    saved = resumed_manifest(out)[0] if args.resume else {}
    settings = _settings(args, out, saved)
    pose = _scan_pose(args, saved)
    faults = Faults.parse(args.faults) if args.simulate else None
    sweep = args.sweep_time if args.sweep_time is not None else (0.0 if args.simulate else 0.25)
    timeout = args.timeout if args.timeout is not None else (0.2 if args.simulate else 0.5)

    with ExitStack() as stack:
        if args.simulate:
            seed = 0 if args.seed is None else args.seed
            if args.resume and args.seed is None:
                seed = saved.get("source", {}).get("seed", seed)
            simulator = stack.enter_context(
                RigSimulator(seed=seed, faults=faults, camera_dir=out / "images", pose=pose))
            pan_port, laser_port = simulator.pan_port, simulator.laser_port
            source = {"simulated": True, "seed": seed, "faults": str(faults)}
        else:
            pan_port, laser_port = args.pan_port, args.laser_port
            source = {"simulated": False, "ports": [pan_port, laser_port]}
        if pose is not None:
            source["pose"] = pose.as_dict()
        pan = stack.enter_context(PanUnit(pan_port, baudrate=args.pan_baud,
                                          timeout=timeout, retries=args.retries))
        laser = stack.enter_context(Rangefinder(laser_port, baudrate=args.laser_baud,
                                                timeout=timeout, retries=args.retries,
                                                sweep_time=sweep))
        try:
            summary = run_scan(out, pan, laser, settings, resume=args.resume, source=source,
                               camera_dir_is_local=args.simulate,
                               progress=_progress(args.quiet))
        except RigError as error:
            raise RigError(error.device, error.command,
                           f"{error.detail} (what was acquired is saved in {out}: "
                           "continue with --resume)") from error
    print(f"refsynth scan: {summary}")
    print(f"wrote {out / 'scan.npz'} ({summary.planned} slices), {out / 'manifest.json'}, "
          f"{out / 'slices'}/, {out / 'images'}/")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the ``scan`` subcommand on its own (as the main CLI does): exit status."""
    parser = argparse.ArgumentParser(prog="python -m refsynth.cli.scan")
    subparsers = parser.add_subparsers(dest="command", required=True)
    add_scan_parser(subparsers)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, TypeError, OSError) as error:
        print(f"refsynth {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
