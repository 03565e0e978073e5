"""``python -m refsynth register IMAGES... --scan SCAN.npz``: Appendix A from the command line.

Builds the panorama from the camera views and registers a partial laser scan
to it (:func:`refsynth.registration.register`), writing ``intensity.npy`` and
``partial_range.npy``, the input of ``python -m refsynth synth``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from refsynth.registration.pipeline import register

__all__ = ["add_register_parser"]


def _cmd_register(args) -> int:
    from refsynth.io import read_array

    images = [read_array(name) for name in args.images]
    scan_path = Path(args.scan)
    if not scan_path.is_file():
        raise FileNotFoundError(f"scan file not found: {scan_path}")
    try:
        with np.load(scan_path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (OSError, EOFError, ValueError, AttributeError) as error:
        raise ValueError(f"cannot read scan file {scan_path} as .npz: {error}") from error
    missing = {"r", "theta", "phi"} - set(arrays)
    if missing:
        raise ValueError(f"scan file {scan_path} lacks the arrays {sorted(missing)}")
    scan = (arrays["r"], arrays["theta"], arrays["phi"])
    angles = np.radians(args.start + args.pan_step * np.arange(len(images)))
    result = register(images, angles, args.focal, scan, refine=not args.no_refine)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    np.save(out / "intensity.npy", result.intensity)
    np.save(out / "partial_range.npy", result.partial_range)
    steps = [entry["misalignment"] for entry in result.history]
    before, after = (steps[0], steps[-1]) if steps else (result.global_info["misalignment"],) * 2
    print(
        f"wrote {out / 'intensity.npy'} and {out / 'partial_range.npy'}: "
        f"{result.intensity.shape[0]}x{result.intensity.shape[1]}, "
        f"{np.isfinite(result.partial_range).mean():.0%} with range; "
        f"warp a={result.warp.a:.2f} b={result.warp.b:.4f} alpha={result.warp.alpha:.2f} "
        f"beta={result.warp.beta:.2f}; edge misalignment {before:.2f} -> {after:.2f} px"
    )
    return 0


def add_register_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``register IMAGES... --scan SCAN.npz`` to a ``python -m refsynth`` subparser set.

    The handler raises ``ValueError``/``TypeError``/``OSError`` with one-line
    messages for user errors.
    """
    parser = subparsers.add_parser(
        "register",
        help="build the panorama from camera views and register a partial laser scan to it",
    )
    parser.add_argument("images", nargs="+", help="camera views in pan order (PNG/JPG/NPY)")
    parser.add_argument("--scan", required=True,
                        help="NPZ with r (n_phi, n_theta), theta (n_theta,), phi (n_phi,) "
                        "in radians, or three flat arrays of samples; NaN r = not measured")
    parser.add_argument("--focal", type=float, required=True, help="focal length in pixels")
    parser.add_argument("--pan-step", type=float, default=18.0,
                        help="degrees between views (default 18)")
    parser.add_argument("--start", type=float, default=0.0,
                        help="pan angle of the first view in the laser's frame, degrees")
    parser.add_argument("--out", default="refsynth-register",
                        help="folder for intensity.npy and partial_range.npy")
    parser.add_argument("--no-refine", action="store_true", help="global warp only (Eq. 21)")
    parser.set_defaults(func=_cmd_register)
    return parser
