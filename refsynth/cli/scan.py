"""``python -m refsynth scan``: acquire a partial range scan (§3.1, §4).

:func:`add_scan_parser` adds the ``scan`` subcommand to the main parser of
:mod:`refsynth.cli.main`; ``python -m refsynth.cli.scan scan ...`` runs it on its
own. User errors are raised as ValueError / TypeError / OSError with a
one-line message (the main entry point prints ``refsynth scan: error: ...``
and exits with status 2).

Examples::

    python -m refsynth scan --simulate --out scan-0 --strategy stripes --fraction 0.4
    python -m refsynth scan --simulate --out scan-0 --faults corrupt=0.05,drop=0.02,disconnect=1
    python -m refsynth scan --simulate --out scan-0 --resume
    python -m refsynth scan --pan-port /dev/ttyUSB0 --laser-port /dev/ttyUSB1 --out scan-1
"""

from __future__ import annotations

import argparse
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
    RigSimulator,
    ScanSettings,
    run_scan,
)
from refsynth.acquisition.scan_folder import saved_manifest

__all__ = ["add_scan_parser", "run_scan_command", "main"]


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


def add_scan_parser(subparsers) -> None:
    """Add the ``scan`` subcommand to an ``argparse`` subparsers object (sets ``func=``)."""
    scan = subparsers.add_parser(
        "scan",
        help="acquire a partial range scan with the pan unit and the rangefinder",
        description="Acquire a partial range scan (Torres-Mendez & Dudek 2008, sections 3.1 "
        "and 4): 500 slices over 180 degrees, of which a sampling strategy chooses some; "
        "pictures every 18 degrees. Every slice is saved as soon as it is validated, so an "
        "interrupted scan resumes with --resume.",
    )
    where = scan.add_argument_group("devices")
    where.add_argument("--simulate", action="store_true",
                       help="use the simulated rig (pseudo-terminals, the synthetic room)")
    where.add_argument("--pan-port", help="the pan unit's port or pyserial URL")
    where.add_argument("--laser-port", help="the rangefinder's port or pyserial URL")
    where.add_argument("--pan-baud", type=_positive(int), default=9600,
                       help="pan unit baud rate (default 9600)")
    where.add_argument("--laser-baud", type=_positive(int), default=115200,
                       help="rangefinder baud rate (default 115200)")
    where.add_argument("--timeout", type=_positive(float), default=None,
                       help="deadline of one request in seconds (default 0.2 simulated, 0.5 real)")
    where.add_argument("--sweep-time", type=float, default=None,
                       help="seconds per mirror revolution, added per averaged sample to a "
                       "slice's deadline (default 0 simulated, 0.25 real)")
    where.add_argument("--retries", type=int, default=8,
                       help="times a failed request is sent again (default 8)")
    scan.add_argument("--out", required=True, help="output folder")
    scan.add_argument("--resume", action="store_true",
                      help="continue the scan in --out (its saved settings are used)")
    what = scan.add_argument_group("sampling (a new scan; default: stripes, 0.4)")
    what.add_argument("--strategy", choices=STRATEGIES, default=None,
                      help="which slices: stripes (default), every n-th, distance-driven "
                      "(Fig. 2, after a coarse pass), all")
    what.add_argument("--fraction", type=_fraction, default=None,
                      help="fraction of the 500 slices to scan (default 0.4)")
    what.add_argument("--step", type=_positive(int), default=None,
                      help="every: scan every STEP-th slice (default 1/fraction, rounded)")
    what.add_argument("--stripe-width", type=_positive(int), default=None,
                      help="stripes: slices per stripe (default 4)")
    what.add_argument("--average", type=_positive(int), default=None,
                      help="samples averaged per position (default 10)")
    what.add_argument("--no-camera", action="store_true", default=None,
                      help="take no pictures")
    sim = scan.add_argument_group("simulator")
    sim.add_argument("--seed", type=int, default=None, help="room and noise seed (default 0)")
    sim.add_argument("--faults", default=None,
                     help="faults on the wire, e.g. corrupt=0.05,drop=0.02,disconnect=1,"
                     "delay=0.01 (also error=, disconnect_after=)")
    scan.add_argument("--quiet", action="store_true", help="no progress on stderr")
    scan.set_defaults(func=run_scan_command)


def _settings(args, out: Path) -> ScanSettings | None:
    given = {
        "strategy": args.strategy, "fraction": args.fraction, "step": args.step,
        "stripe_width": args.stripe_width, "average": args.average,
        "camera": False if args.no_camera else None,
    }
    given = {key: value for key, value in given.items() if value is not None}
    if args.resume and not given:
        return None  # the folder's own settings
    saved = saved_manifest(out).get("settings") if args.resume else None
    if isinstance(saved, dict):
        try:  # only what was given on the command line is compared with the saved scan
            return replace(ScanSettings.from_dict(saved), **given)
        except (ValueError, TypeError):
            pass  # run_scan reports the bad manifest
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


def run_scan_command(args) -> int:
    """The ``scan`` subcommand: returns the exit status (0)."""
    if args.retries < 0:
        raise ValueError(f"--retries must be >= 0, got {args.retries}")
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
    out = Path(args.out)
    settings = _settings(args, out)
    sweep = args.sweep_time if args.sweep_time is not None else (0.0 if args.simulate else 0.25)
    timeout = args.timeout if args.timeout is not None else (0.2 if args.simulate else 0.5)
    if sweep < 0:
        raise ValueError(f"--sweep-time must be >= 0, got {sweep}")

    with ExitStack() as stack:
        if args.simulate:
            faults = Faults.parse(args.faults)
            seed = 0 if args.seed is None else args.seed
            if args.resume and args.seed is None:
                seed = saved_manifest(out).get("source", {}).get("seed", seed)
            simulator = stack.enter_context(
                RigSimulator(seed=seed, faults=faults, camera_dir=out / "images"))
            pan_port, laser_port = simulator.pan_port, simulator.laser_port
            source = {"simulated": True, "seed": seed, "faults": str(faults)}
        else:
            pan_port, laser_port = args.pan_port, args.laser_port
            source = {"simulated": False, "ports": [pan_port, laser_port]}
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
