"""``python -m refsynth register [IMAGES...] --scan SCAN``: Appendix A from the command line.

Builds the panorama from the camera views and registers a partial laser scan
to it (:func:`refsynth.registration.register`), writing ``intensity.npy`` and
``partial_range.npy``, the input of ``python -m refsynth synth``, and
``camera.json``, the registered panorama's camera (focal length, the column
of pan angle 0 and the row of the horizon from the warp of Eq. 21), which
``python -m refsynth model --camera-file`` reads
(:func:`refsynth.cli.model.write_registered_camera`).

``--scan`` is a scan folder written by ``python -m refsynth scan`` (or its
``manifest.json`` or ``scan.npz``), read with
:func:`refsynth.acquisition.load_scan`: then the pictures, their pan angles
and the focal length come from the scan's own manifest unless given. Any
other ``.npz`` holding ``r``, ``theta`` and ``phi`` works too, with
``--focal`` and ``--start`` given. Only the columns of scanned slices are
measured in ``partial_range.npy``: the scan is put on the cylinder at the
rig's pan step (``--slice-step``; a scan folder's own, 0.36°), never
stretched across the positions no slice was taken at; the summary line says
which fraction of the columns is measured and where the step came from. A
registration that does not converge (no
depth edge of the scan matched an intensity edge: the misalignment is NaN)
is an error, not a result: ``register`` exits with status 2 and writes
nothing.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from refsynth._files import check_output_path, write_atomic
from refsynth.acquisition import load_scan
from refsynth.acquisition.scan_folder import read_npz
from refsynth.cli.arguments import add_subcommand
from refsynth.cli.model import write_registered_camera
from refsynth.registration.pipeline import register

__all__ = ["add_register_parser"]

#: The largest array a bare ``--scan`` NPZ may hold (bytes): a whole 360° scan of 2000 ×
#: 2000 float64 samples.
_MAX_ARRAY_BYTES = 2000 * 2000 * 8 + 4096
#: ``--start`` farther than this from the manifest's angle of the first view is warned about.
_START_TOLERANCE_DEG = 1.0


def _scan_folder(path: Path) -> Path | None:
    """The scan folder ``path`` names (the folder, its manifest.json or its scan.npz), or None."""
    if path.is_dir():
        return path
    if path.name == "manifest.json" or (path.name == "scan.npz"
                                        and (path.parent / "manifest.json").is_file()):
        return path.parent
    return None


def _read_scan(path: Path):
    """``(r, theta, phi)``, the scan's pictures ``[(path, pan angle rad)]`` (or None), its
    focal length (or None) and the rig's slice step in radians (or None)."""
    if not path.exists():
        raise FileNotFoundError(f"scan file not found: {path}")
    folder = _scan_folder(path)
    if folder is not None:
        scan = load_scan(folder)
        pictures = [(picture.path, picture.pan_angle) for picture in scan.images]
        return (scan.r, scan.theta, scan.phi), pictures, scan.focal, scan.slice_step
    arrays = read_npz(path, ("r", "theta", "phi"), _MAX_ARRAY_BYTES)
    return (arrays["r"], arrays["theta"], arrays["phi"]), None, None, None


def _slice_step(args, recorded: float | None, scan) -> tuple[float, str]:
    """The rig's slice step (radians) and where it comes from, for the summary line."""
    if args.slice_step is not None:
        if not (math.isfinite(args.slice_step) and 0 < args.slice_step <= 180):
            raise ValueError(f"--slice-step must be an angle in degrees in (0, 180], got "
                             f"{args.slice_step:g}")
        return math.radians(args.slice_step), "--slice-step"
    if recorded is not None:
        return recorded, "the scan's manifest.json"
    phi = np.unique(np.round(np.asarray(scan[2], dtype=np.float64)[np.isfinite(scan[2])], 9))
    gaps = np.diff(phi)
    gaps = gaps[gaps > 1e-9]
    if gaps.size == 0:
        raise ValueError(f"give --slice-step: {args.scan} holds a single slice")
    return float(gaps.min()), ("the smallest gap between the scan's slices: give --slice-step "
                               "if the rig's is finer")


def _views(args, pictures) -> tuple[list[str], np.ndarray]:
    """The views to read and their pan angles (radians)."""
    names = list(args.images)
    if not names:
        if not pictures:
            raise ValueError("give the camera views (IMAGES): the scan lists no pictures")
        names = [str(p) for p, _ in pictures]
    if args.start is None and args.pan_step is None:
        if pictures is None:
            raise ValueError(f"give --start (and --pan-step if not 18): {args.scan} has no "
                             "manifest.json to read the views' pan angles from")
        by_path = {Path(p).resolve(): angle for p, angle in pictures}
        angles = []
        for name in names:
            angle = by_path.get(Path(name).resolve())
            if angle is None:
                raise ValueError(f"{name} is not one of the pictures of the scan "
                                 f"({', '.join(Path(p).name for p, _ in pictures[:3])}, ...): "
                                 "give --start and --pan-step for other views")
            angles.append(angle)
        return names, np.asarray(angles)
    step = 18.0 if args.pan_step is None else args.pan_step
    start = args.start
    if start is None:
        if not pictures:
            raise ValueError(f"give --start: {args.scan} has no manifest.json pictures to read "
                             "the first view's pan angle from")
        start = math.degrees(pictures[0][1])
    for name, value in (("--start", start), ("--pan-step", step)):
        if not math.isfinite(value) or abs(value) > 360:
            raise ValueError(f"{name} must be a finite angle in degrees within ±360, got {value:g}")
    if pictures and args.start is not None:
        recorded = math.degrees(pictures[0][1])
        if abs(recorded - start) > _START_TOLERANCE_DEG:
            print(f"refsynth register: warning: --start {start:g} puts the first view at "
                  f"{start:g} degrees; the scan's manifest.json has {recorded:g}",
                  file=sys.stderr)
    return names, np.radians(start + step * np.arange(len(names)))


def _cmd_register(args) -> int:
    from refsynth.io import read_array

    if not args.out.strip():
        raise ValueError("--out must name a folder, got an empty string")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out '{out}' is not a folder")
    scan, pictures, recorded_focal, recorded_step = _read_scan(Path(args.scan))
    slice_step, step_source = _slice_step(args, recorded_step, scan)
    focal = args.focal if args.focal is not None else recorded_focal
    if focal is None:
        raise ValueError(f"give --focal: {args.scan} has no manifest.json to read it from")
    if not (math.isfinite(focal) and 0 < focal < 1e6):
        raise ValueError(f"--focal must be a focal length in pixels, got {focal:g}")
    names, angles = _views(args, pictures)
    targets = [out / name for name in ("intensity.npy", "partial_range.npy", "camera.json")]
    inputs = [args.scan, *names]
    if out.is_dir():  # an output naming an input is refused before the work
        for target in targets:
            check_output_path(target, name="--out", inputs=inputs)
    images = [read_array(name) for name in names]
    result = register(images, angles, focal, scan, refine=not args.no_refine,
                      slice_step=slice_step)
    misalignment = result.global_info["misalignment"]
    if not math.isfinite(misalignment):
        raise ValueError(
            "registration did not converge: no depth edge of the scan matched an intensity "
            f"edge of the panorama (edge misalignment {misalignment:.2f} px); check the views' "
            f"pan angles (--start, --pan-step; first view at {math.degrees(angles[0]):g} "
            f"degrees) and --focal ({focal:g})")
    steps = [entry["misalignment"] for entry in result.history if math.isfinite(
        entry["misalignment"])]
    if steps:
        report = f"edge misalignment {steps[0]:.2f} -> {steps[-1]:.2f} px"
    elif result.history:
        report = (f"edge misalignment {misalignment:.2f} px (the global warp; the local "
                  "stretch matched no depth-edge segment)")
    else:
        report = f"edge misalignment {misalignment:.2f} px (the global warp)"
    out.mkdir(parents=True, exist_ok=True)
    for target, array in zip(targets, (result.intensity, result.partial_range)):
        write_atomic(target, lambda stream, a=array: np.save(stream, a, allow_pickle=False))
    camera = write_registered_camera(targets[2], result, focal)
    measured = np.isfinite(result.partial_range).any(axis=0).mean()
    print(
        f"wrote {targets[0]}, {targets[1]} and {camera}: "
        f"{result.intensity.shape[0]}x{result.intensity.shape[1]}, "
        f"{np.isfinite(result.partial_range).mean():.0%} with range, {measured:.0%} of the "
        f"columns measured (slice step {math.degrees(slice_step):.4g} degrees, from "
        f"{step_source}); "
        f"warp a={result.warp.a:.2f} b={result.warp.b:.4f} alpha={result.warp.alpha:.2f} "
        f"beta={result.warp.beta:.2f}; {report}"
    )
    return 0


def add_register_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``register [IMAGES...] --scan SCAN`` to a ``python -m refsynth`` subparser set.

    The handler raises ``ValueError``/``TypeError``/``OSError`` with one-line
    messages for user errors, and when the registration does not converge.
    """
    parser = add_subcommand(
        subparsers, "register",
        help="build the panorama from camera views and register a partial laser scan to it",
        description="Register a partial laser scan to the panorama of the camera views "
        "(Torres-Mendez & Dudek 2008, Appendix A). With a scan folder written by 'scan', the "
        "views, their pan angles and the focal length come from its manifest.json unless "
        "given. Fails (exit 2) if the registration does not converge.",
        func=_cmd_register,
    )
    parser.add_argument("images", nargs="*", metavar="IMAGES",
                        help="camera views in pan order (PNG/JPG/NPY) (default: the pictures "
                        "the scan's manifest.json lists)")
    parser.add_argument("--scan", required=True,
                        help="a scan folder written by 'scan' (or its manifest.json or "
                        "scan.npz), or an NPZ with r (n_phi, n_theta), theta (n_theta,), phi "
                        "(n_phi,) in radians, or three flat arrays of samples; NaN r = not "
                        "measured (required)")
    parser.add_argument("--focal", type=float, default=None, metavar="PIXELS",
                        help="focal length in pixels (default: the scan's manifest.json; "
                        "required for a bare NPZ)")
    parser.add_argument("--pan-step", type=float, default=None, metavar="DEGREES",
                        help="degrees between views, with --start (default: each picture's "
                        "angle from the scan's manifest.json; 18 with --start)")
    parser.add_argument("--start", type=float, default=None, metavar="DEGREES",
                        help="pan angle of the first view in the laser's frame, degrees "
                        "(default: from the scan's manifest.json; required for a bare NPZ)")
    parser.add_argument("--out", default="refsynth-register", metavar="DIR",
                        help="folder for intensity.npy, partial_range.npy and camera.json "
                        "(default: %(default)s)")
    parser.add_argument("--slice-step", type=float, default=None, metavar="DEGREES",
                        help="the rig's pan step between two adjacent slice positions: only "
                        "the columns of scanned slices are measured (default: the scan "
                        "folder's, 0.36; for a bare NPZ the smallest gap between its slices)")
    parser.add_argument("--no-refine", action="store_true",
                        help="global warp only, Eq. 21 (default: off, the local stretch too)")
    return parser
