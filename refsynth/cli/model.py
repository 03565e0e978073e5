"""``python -m refsynth model``: stage 3 from the command line — a dense range to a PLY model.

Two forms::

    python -m refsynth model DENSE.npy --intensity IMAGE --camera cylindrical --focal 300 \\
        --out room.ply [--confidence CONF.npy] [--partial PARTIAL.npy] \\
        [--uncertainty UNC.npy [--max-uncertainty U] [--drop-uncertain FRACTION]]
        [--max-jump FRACTION] [--ascii]
    python -m refsynth model DENSE.npy --camera-file REGISTERED/camera.json --out room.ply
    python -m refsynth model DISP.npy --camera pinhole --focal F --cx CX --cy CY \\
        [--disparity --baseline B --doffs D] --out model.ply
    python -m refsynth model --merge a.ply b.ply --poses poses.json --out world.ply [--refine]

The first builds one scan position's model (:func:`refsynth.model.build_model`)
and writes it (:func:`refsynth.model.write_ply`); the second puts several
models in one world frame (:func:`refsynth.model.merge_models`, optionally
after :func:`refsynth.model.refine_poses`). ``poses.json`` is a list, one
entry per PLY in order, of ``{"x": …, "z": …, "heading": DEGREES, "y": …}``
(refsynth's frame: x right, y up, z forward; ``y`` optional) or of
``{"matrix": [[4 × 4]]}``.

DENSE and ``--partial`` are read as ``synth`` reads range
(:func:`refsynth.io.read_range`): ``.npy`` / ``.pfm`` as stored, an image's
stored integers divided by ``--png-scale`` (so ``synth --out dense_mm.png
--png-scale 1000`` comes back in metres with ``model dense_mm.png --png-scale
1000``); JPEG and values <= 0 (without ``--allow-nonpositive``) are refused.
Which points were measured comes from ``--partial`` only: without it every
point is marked synthesized, and a note on stderr says so (a confidence of 1
is no evidence: BP's belief reaches it at synthesized pixels). Outputs are
checked before any work (writable, none of the inputs) and written all or
nothing.

``--uncertainty UNC.npy`` (``synth --uncertainty-out``: each pixel's expected absolute error
in the range's unit, 0 where measured) gives every vertex an ``uncertainty`` property beside
its ``confidence``; ``--max-uncertainty U`` drops the points whose uncertainty exceeds ``U``
(in the range's unit; the range's own unit even with ``--disparity``) and the triangles that
use them; ``--drop-uncertain FRACTION`` drops that fraction of the synthesized points, the most
uncertain first, which uses only the map's ranking (on column samplings the map's scale
overstates the error, its ranking holds: ``docs/uncertainty.md``).

The camera file
---------------
A registered panorama's camera is not the centred one that ``--focal``
alone gives: its pan angle 0 and horizon sit where the warp of Eq. 21 puts
them in the crop. ``python -m refsynth register`` therefore writes
``camera.json`` beside ``intensity.npy`` (:func:`write_registered_camera`), and
``model --camera-file camera.json`` reads it (:func:`read_camera_file`)
instead of ``--camera``, ``--focal``, ``--cx``, ``--cy``, ``--phi-step`` and
``--h-step``. It holds::

    {"format": "refsynth-camera/1", "camera": "cylindrical",
     "focal": 300.0, "cx": …, "cy": …, "phi_step_rad": 0.00333…, "h_step": 1.0,
     "shape": [H, W], "warp": {"a": …, "b": …, "alpha": …, "beta": …},
     "crop": [row0, row1, col0, col1]}

``cx``, ``cy``, ``phi_step_rad`` and ``h_step`` are those of
:meth:`refsynth.model.CylindricalCamera.from_warp` (``Δφ = 1/a``, ``c_x = α −
col0``, ``Δh = −1/b``, ``c_y = β − row0``); ``shape`` is the panorama's, which
the dense range must have; ``warp`` and ``crop`` are a record of where they
came from. A pinhole camera's file has ``"camera": "pinhole"``, ``focal``,
``cx`` and ``cy``.

:func:`add_model_parser` adds the subcommand to :mod:`refsynth.cli.main`'s
parser. User errors are raised as ValueError / TypeError / OSError with a
one-line message (``main`` prints it and exits with status 2).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from refsynth._files import write_atomic
from refsynth.cli.arguments import (
    add_subcommand,
    check_distinct,
    check_output,
    make_parent,
    prefixed,
    real,
)
from refsynth.io import IMAGE_SUFFIXES, read_array, read_range
from refsynth.model import (
    DEFAULT_MAX_JUMP,
    CylindricalCamera,
    PinholeCamera,
    Pose,
    build_model,
    disparity_to_depth,
    grid_faces,
    merge_models,
    pose_matrix,
    read_ply,
    refine_poses,
    write_ply,
)

__all__ = ["add_model_parser", "read_poses", "write_camera_file", "write_registered_camera",
           "read_camera_file", "CAMERA_FORMAT"]

#: The camera file's format tag.
CAMERA_FORMAT = "refsynth-camera/1"
#: A camera file is a few hundred bytes.
_MAX_CAMERA_BYTES = 65536
_CAMERA_OPTIONS = ("camera", "focal", "cx", "cy", "phi_step", "h_step")
#: What --camera-file replaces.
_CAMERA_FLAGS = tuple(f"--{name.replace('_', '-')}" for name in _CAMERA_OPTIONS)


def _max_jump(text: str) -> float | None:
    if text.lower() in ("off", "none"):
        return None
    value = real(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0 (or 'off'), got {text}")
    return value


def _read(path: str | None, what: str) -> np.ndarray | None:
    if path is None:
        return None
    if not Path(path).is_file():
        raise FileNotFoundError(f"{what} file not found: {path}")
    return read_array(path)


def _read_range(path: str | None, what: str, args) -> np.ndarray | None:
    """A range file (DENSE or --partial) read as ``synth`` reads range (:func:`read_range`)."""
    if path is None:
        return None
    if not Path(path).is_file():
        raise FileNotFoundError(f"{what} file not found: {path}")
    image = Path(path).suffix.lower() in IMAGE_SUFFIXES
    return read_range(path, scale=args.png_scale if image else None,
                      allow_nonpositive=args.allow_nonpositive)


def _single(array: np.ndarray, what: str, shape=None) -> np.ndarray:
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[..., 0]
    if array.ndim != 2:
        raise ValueError(f"{what} must hold one channel (H, W), got shape {array.shape}")
    if shape is not None and array.shape != shape:
        raise ValueError(f"{what} shape {array.shape} differs from the range's {shape}")
    if array.dtype == np.bool_ or not np.issubdtype(array.dtype, np.number):
        raise ValueError(f"{what} must be numeric, got {array.dtype}")
    return array.astype(np.float64)


def write_camera_file(path, camera, shape, *, warp=None, crop=None) -> Path:
    """Write ``camera`` (Cylindrical or Pinhole) of an image of ``shape`` as a camera file.

    ``warp`` (anything with ``a``, ``b``, ``alpha``, ``beta``) and ``crop``
    (``(row0, row1, col0, col1)``) are recorded as provenance. Returns the path.
    """
    record = {"format": CAMERA_FORMAT}
    if isinstance(camera, CylindricalCamera):
        record.update(camera="cylindrical", focal=camera.focal, cx=camera.cx, cy=camera.cy,
                      phi_step_rad=camera.phi_step, h_step=camera.h_step)
    elif isinstance(camera, PinholeCamera):
        record.update(camera="pinhole", focal=camera.focal, cx=camera.cx, cy=camera.cy)
    else:
        raise TypeError(f"The parameter `camera` must be a CylindricalCamera or a "
                        f"PinholeCamera, got {type(camera).__name__}")
    record["shape"] = [int(n) for n in shape]
    if warp is not None:
        record["warp"] = {k: float(getattr(warp, k)) for k in ("a", "b", "alpha", "beta")}
    if crop is not None:
        record["crop"] = [int(v) for v in crop]
    return write_atomic(path, (json.dumps(record, indent=1) + "\n").encode("utf-8"))


def write_registered_camera(path, registration, focal: float) -> Path:
    """The camera file of a registered panorama (a :class:`refsynth.registration.Registration`).

    Its camera is :meth:`CylindricalCamera.from_warp` of the global warp
    (Eq. 21) at the crop's origin, for the ``registration.intensity`` grid.
    """
    crop = registration.crop
    camera = CylindricalCamera.from_warp(registration.warp, focal, origin=(crop[0], crop[2]))
    return write_camera_file(path, camera, registration.intensity.shape[:2],
                             warp=registration.warp, crop=crop)


def _read_json(path: Path, what: str, max_bytes: int):
    """The JSON value in ``path`` (a ``what``, at most ``max_bytes``); one-line errors naming it."""
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    if path.stat().st_size > max_bytes:
        raise ValueError(f"{path} is not a {what} ({path.stat().st_size} bytes)")
    try:
        return json.loads(path.read_bytes().decode("utf-8"))
    except RecursionError:
        raise ValueError(f"cannot read {path} as JSON: it is nested too deeply") from None
    except ValueError as error:  # JSONDecodeError, UnicodeDecodeError, a 5000-digit integer
        reason = " ".join(str(error).split())
        raise ValueError(f"cannot read {path} as JSON: {reason}") from None


def read_camera_file(path) -> tuple[CylindricalCamera | PinholeCamera, tuple[int, int]]:
    """The camera and the image shape of a camera file (module docstring for the format)."""
    path = Path(path)
    record = _read_json(path, "camera file", _MAX_CAMERA_BYTES)
    if not isinstance(record, dict) or record.get("format") != CAMERA_FORMAT:
        raise ValueError(f"{path} is not a camera file (format {CAMERA_FORMAT!r}, as "
                         "'register' writes)")
    kind = record.get("camera")
    keys = {"cylindrical": ("focal", "cx", "cy", "phi_step_rad", "h_step"),
            "pinhole": ("focal", "cx", "cy")}.get(kind)
    if keys is None:
        raise ValueError(f"{path}: camera must be 'cylindrical' or 'pinhole', got {kind!r}")
    values = [_finite(record.get(key)) for key in keys]
    if any(v is None for v in values):
        raise ValueError(f"{path}: {', '.join(keys)} must be finite numbers")
    shape = record.get("shape")
    if not (isinstance(shape, list) and len(shape) == 2
            and all(isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in shape)):
        raise ValueError(f"{path}: shape must be [rows, columns], got {shape!r}")
    if kind == "pinhole":
        camera = PinholeCamera(*values)
    else:
        focal, cx, cy, phi_step, h_step = values
        camera = CylindricalCamera(focal, cx=cx, cy=cy, phi_step=phi_step, h_step=h_step)
    return camera, (shape[0], shape[1])


def _camera(args, shape):
    if args.camera_file is not None:
        given = [flag for flag, name in zip(_CAMERA_FLAGS, _CAMERA_OPTIONS)
                 if getattr(args, name) is not None]
        if given:
            raise ValueError(f"--camera-file gives the camera: drop {', '.join(given)}")
        camera, expected = read_camera_file(args.camera_file)
        if tuple(expected) != tuple(shape):
            raise ValueError(f"the range is {shape[0]}x{shape[1]} (rows x columns) but "
                             f"{args.camera_file} is the camera of a {expected[0]}x{expected[1]} "
                             "image")
        if args.disparity and not isinstance(camera, PinholeCamera):
            raise ValueError("--disparity needs a pinhole camera (a rectified pair)")
        return camera
    if args.focal is None:
        raise ValueError("--focal is required to build a model (or give --camera-file)")
    rows, cols = shape
    cx = (cols - 1) / 2 if args.cx is None else args.cx
    cy = (rows - 1) / 2 if args.cy is None else args.cy
    if args.camera == "pinhole":
        if args.phi_step is not None or args.h_step is not None:
            raise ValueError("--phi-step and --h-step are for --camera cylindrical")
        return PinholeCamera(args.focal, cx=cx, cy=cy)
    phi_step = None if args.phi_step is None else math.radians(args.phi_step)
    return CylindricalCamera(args.focal, cx=cx, cy=cy, phi_step=phi_step,
                             h_step=1.0 if args.h_step is None else args.h_step)


#: What ``model`` says when it does not know which pixels were measured.
NO_PARTIAL_NOTE = ("refsynth model: no --partial given: every point is marked synthesized "
                   "(its range is not known to be measured); give --partial with the measured "
                   "range (DENSE itself if all of it was measured) to mark the measured points")


def _check_png_scale(args, ranges: list[str | None]) -> None:
    if args.png_scale is None:
        return
    if args.png_scale <= 0:
        raise ValueError(f"--png-scale must be > 0, got {args.png_scale:g}")
    if not any(p is not None and Path(p).suffix.lower() in IMAGE_SUFFIXES for p in ranges):
        raise ValueError("--png-scale applies to an image DENSE or --partial (PNG, TIFF, PGM "
                         "...) only")


def _cmd_build(args) -> int:
    if args.poses or args.refine or args.voxel is not None or args.poses_out:
        raise ValueError("--poses, --refine, --voxel and --poses-out are for --merge")
    if args.camera_file is None:
        if args.focal is None:
            raise ValueError("--focal is required to build a model (or give --camera-file)")
        args.camera = args.camera or "cylindrical"
        if args.disparity and args.camera != "pinhole":
            raise ValueError("--disparity needs --camera pinhole (a rectified pair)")
    inputs = (args.dense, args.intensity, args.confidence, args.partial, args.camera_file,
              args.uncertainty)
    out = check_output(args.out, "--out", (".ply",), inputs=inputs)
    for flag, value in (("--max-uncertainty", args.max_uncertainty),
                        ("--drop-uncertain", args.drop_uncertain)):
        if value is not None and args.uncertainty is None:
            raise ValueError(f"{flag} needs --uncertainty UNC.npy (synth --uncertainty-out)")
    if args.max_uncertainty is not None and not args.max_uncertainty >= 0:
        raise ValueError(f"--max-uncertainty must be >= 0, got {args.max_uncertainty:g}")
    if args.drop_uncertain is not None and not 0 <= args.drop_uncertain <= 1:
        raise ValueError(f"--drop-uncertain must be a fraction in [0, 1], got "
                         f"{args.drop_uncertain:g}")
    _check_png_scale(args, [args.dense, args.partial])
    dense = _single(_read_range(args.dense, "range", args), "range")
    if not args.disparity and (args.baseline is not None or args.doffs != 0.0):
        raise ValueError("--baseline and --doffs are for --disparity")
    if args.disparity and args.baseline is None:
        raise ValueError("--disparity needs --baseline (and --doffs if not 0)")
    camera = _camera(args, dense.shape)
    kind = "pinhole" if isinstance(camera, PinholeCamera) else "cylindrical"
    if args.disparity:
        dense = disparity_to_depth(dense, camera.focal, args.baseline, args.doffs)
    intensity = _read(args.intensity, "intensity")
    if intensity is not None and intensity.shape[:2] != dense.shape:
        raise ValueError(f"intensity shape {intensity.shape} differs from the range's "
                         f"{dense.shape}")
    confidence = _read(args.confidence, "confidence")
    if confidence is not None:
        confidence = _single(confidence, "confidence", dense.shape)
    uncertainty = _read(args.uncertainty, "uncertainty")
    if uncertainty is not None:
        uncertainty = _single(uncertainty, "uncertainty", dense.shape)
        there = np.isfinite(dense) & (dense > 0)
        if not (np.isfinite(uncertainty[there]).all() and (uncertainty[there] >= 0).all()):
            raise ValueError(f"uncertainty {args.uncertainty} must be finite and >= 0 where "
                             "there is range")
    partial = _read_range(args.partial, "partial range", args)
    if partial is not None:
        partial = _single(partial, "partial range", dense.shape)
        measured = np.isfinite(partial)
    else:  # a confidence of 1 does not say "measured": BP's belief reaches it too
        measured = np.zeros(dense.shape, dtype=bool)
    model = build_model(dense, camera, intensity=intensity, confidence=confidence,
                        measured=measured, max_jump=args.max_jump,
                        min_confidence=args.min_confidence,
                        wrap=False if args.no_wrap else None, uncertainty=uncertainty,
                        max_uncertainty=args.max_uncertainty,
                        drop_uncertain=args.drop_uncertain or 0.0)
    write_ply(make_parent(out), model, ascii=args.ascii,
              coordinates="float32" if args.float32 else "float64",
              comments=[f"camera {kind} focal {camera.focal}"])
    kept = np.zeros(dense.shape, dtype=bool)
    kept[model.pixels[:, 0], model.pixels[:, 1]] = True
    wrap = not args.no_wrap and camera.covers_360(dense.shape[1])
    every = len(grid_faces(dense, valid=kept, max_jump=None, wrap=wrap))
    if partial is None:
        print(NO_PARTIAL_NOTE, file=sys.stderr)
    uncertain = ""
    if args.max_uncertainty is not None or args.drop_uncertain:
        with np.errstate(invalid="ignore"):
            reachable = np.isfinite(dense) & (dense > 0)
        if confidence is not None and args.min_confidence > 0:
            reachable &= confidence >= args.min_confidence
        uncertain = f"; {int(reachable.sum()) - model.n_vertices} dropped as too uncertain"
    print(f"wrote {out}: {model.n_vertices} vertices ({int(model.synthesized.sum())} "
          f"synthesized{uncertain}), {model.n_faces} triangles ({every - model.n_faces} dropped "
          f"at depth jumps), {'ascii' if args.ascii else 'binary'}")
    return 0


#: A poses file holds a few numbers per scan: anything larger is not one.
_MAX_POSES_BYTES = 1 << 24
_POSE_KEYS = ("x", "y", "z", "heading")


def _finite(value) -> float | None:
    """``value`` as a finite float if it is a JSON number that is one, else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)  # an integer such as 10**400 overflows here
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def _matrix(value, where: str) -> np.ndarray:
    """A pose's ``"matrix"``: 4 rows of 4 finite numbers, a rigid transform."""
    rows = value if isinstance(value, list) else None
    if rows is None or len(rows) != 4 or not all(isinstance(r, list) and len(r) == 4
                                                 for r in rows):
        raise ValueError(f"{where}: matrix must be 4 rows of 4 numbers ([[R, t], [0, 0, 0, 1]])")
    numbers = [[_finite(v) for v in row] for row in rows]
    if any(v is None for row in numbers for v in row):
        raise ValueError(f"{where}: matrix must hold finite numbers only")
    try:
        return pose_matrix(numbers)
    except ValueError as error:
        raise ValueError(f"{where}: {error}") from None


def read_poses(path) -> list[np.ndarray]:
    """The poses of ``poses.json``: 4×4 transforms (module docstring for the format).

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        One line naming the file (and the pose): not UTF-8 JSON, nested too
        deeply, not a list of objects, unknown keys, a value that is not a
        finite number (``1e999``, ``10**400``, a string), a matrix that is
        not 4×4 numbers or not rigid.
    """
    path = Path(path)
    entries = _read_json(path, "poses file", _MAX_POSES_BYTES)
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise ValueError(f"{path} must hold a JSON list of objects, one pose per PLY")
    poses = []
    for k, entry in enumerate(entries):
        where = f"pose {k} in {path}"
        if "matrix" in entry:
            if len(entry) > 1:
                raise ValueError(f"{where}: give a matrix or x, z, heading, y, not both")
            poses.append(_matrix(entry["matrix"], where))
            continue
        unknown = set(entry) - set(_POSE_KEYS)
        if unknown:
            raise ValueError(f"{where} has unknown keys {sorted(unknown)} "
                             "(x, z, heading in degrees, y; or matrix)")
        values = {key: _finite(entry.get(key, 0.0)) for key in _POSE_KEYS}
        bad = [key for key, value in values.items() if value is None]
        if bad:
            raise ValueError(f"{where}: {', '.join(bad)} must be "
                             f"{'a finite number' if len(bad) == 1 else 'finite numbers'}, got "
                             f"{', '.join(repr(entry[key])[:30] for key in bad)}")
        values["heading"] = math.radians(values["heading"])
        poses.append(Pose(**values).matrix())
    return poses


def _cmd_merge(args) -> int:
    if (args.dense is not None or args.intensity or args.confidence or args.partial
            or args.uncertainty or args.max_uncertainty is not None
            or args.drop_uncertain is not None):
        raise ValueError("--merge takes PLY files only (no DENSE, --intensity, --confidence, "
                         "--partial, --uncertainty, --max-uncertainty, --drop-uncertain)")
    if not args.poses:
        raise ValueError("--merge needs --poses poses.json")
    if args.png_scale is not None or args.allow_nonpositive:
        raise ValueError("--png-scale and --allow-nonpositive are for a DENSE range, not --merge")
    inputs = (*args.merge, args.poses)
    out = check_output(args.out, "--out", (".ply",), inputs=inputs)
    poses_out = None if args.poses_out is None else check_output(args.poses_out, "--poses-out",
                                                                 (".json",), inputs=inputs)
    check_distinct({"--out": out, "--poses-out": poses_out})
    poses = read_poses(args.poses)
    if len(poses) != len(args.merge):
        raise ValueError(f"{args.poses} holds {len(poses)} poses for {len(args.merge)} PLY files")
    models = []
    for name in args.merge:
        if not Path(name).is_file():
            raise FileNotFoundError(f"PLY file not found: {name}")
        models.append(read_ply(name))
    if args.refine:
        poses, results = refine_poses(models, poses, voxel=args.voxel)
        for k, result in enumerate(results[1:], start=1):
            pose = Pose.from_matrix(poses[k])
            print(f"refined {args.merge[k]}: x={pose.x:.4f} z={pose.z:.4f} "
                  f"heading={math.degrees(pose.heading):.3f} deg y={pose.y:.4f} "
                  f"({result.iterations} ICP iterations, rms {result.rms:.4g})")
    merged = merge_models(models, poses, voxel=args.voxel)
    write_ply(make_parent(out), merged, ascii=args.ascii,
              coordinates="float32" if args.float32 else "float64",
              comments=[f"merged from {len(models)} scans"])
    if poses_out is not None:
        write_atomic(make_parent(poses_out), (json.dumps(
            [{"matrix": np.asarray(p).tolist()} for p in poses], indent=1) + "\n").encode())
        print(f"wrote {poses_out}")
    total = sum(m.n_vertices for m in models)
    print(f"wrote {out}: {merged.n_vertices} vertices from {len(models)} scans "
          f"({total - merged.n_vertices} fused away in the overlap), {merged.n_faces} triangles")
    return 0


def _cmd_model(args) -> int:
    if args.merge:
        return _cmd_merge(args)
    if args.dense is None:
        raise ValueError("give a dense range DENSE.npy, or --merge A.ply B.ply ...")
    return _cmd_build(args)


def add_model_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``model`` (stage 3: dense range → PLY; PLYs + poses → one PLY) to a subparser set.

    ``--help`` shows the per-pixel inputs, the meshing, the camera, the pinhole
    disparity and the merging options each in a group of its own.
    """
    parser = add_subcommand(
        subparsers, "model",
        help="stage 3: build a coloured 3-D model (PLY) from a dense range, or merge models",
        description="Stage 3 of the paper: back-project a dense range image (cylindrical "
        "panorama or pinhole camera) to coloured points, mesh them without bridging depth "
        "discontinuities and write a PLY; or merge several PLYs by their poses.",
        func=_cmd_model,
    )
    parser.add_argument("dense", nargs="?", help="dense range: NPY/PFM (values as stored) or "
                        "a 16/8-bit PNG/TIFF/PGM (the stored integers / --png-scale, 0 = "
                        "unknown), read as synth reads range: Euclidean distance for --camera "
                        "cylindrical, depth or --disparity for pinhole")
    parser.add_argument("--out", required=True, metavar="PLY",
                        help="the .ply file to write (required)")
    parser.add_argument("--ascii", action="store_true",
                        help="write an ASCII PLY (default: binary little-endian)")
    parser.add_argument("--float32", action="store_true",
                        help="write x, y, z as float (default: double)")
    inputs = parser.add_argument_group("per-pixel inputs (on DENSE's grid)")
    inputs.add_argument("--intensity", metavar="IMAGE",
                        help="the registered intensity (PNG/JPG/NPY), grey or RGB (default: "
                        "mid-grey points)")
    inputs.add_argument("--confidence", metavar="NPY",
                        help="per-pixel confidence in [0, 1] (default: 1 everywhere)")
    inputs.add_argument("--uncertainty", metavar="NPY",
                        help="per-pixel expected absolute error in the range's unit (synth "
                        "--uncertainty-out; 0 = measured): a per-vertex property of the PLY "
                        "(default: none)")
    inputs.add_argument("--partial", metavar="FILE",
                        help="the partial (measured) range, NaN (0 in an image) where unknown, "
                        "read as DENSE is: marks each point measured or synthesized (default: "
                        "every point is marked synthesized, with a note on stderr; a "
                        "confidence of 1 does not say measured)")
    inputs.add_argument("--png-scale", type=real, metavar="S",
                        help="stored integer per unit of range of an image DENSE / --partial, "
                        "as synth's --png-scale (default: 1, the stored integers)")
    inputs.add_argument("--allow-nonpositive", action="store_true",
                        help="accept known values <= 0 in DENSE / --partial (e.g. a disparity "
                        "with --doffs; a point whose depth is not > 0 is left out of the "
                        "model; default: refused, range is a distance > 0)")
    mesh = parser.add_argument_group("meshing")
    mesh.add_argument("--max-jump", type=_max_jump, default=DEFAULT_MAX_JUMP,
                      metavar="FRACTION", help="drop triangles whose edge jumps by more than "
                      "FRACTION x the nearer range per pixel (default 0.05; 'off' keeps all)")
    mesh.add_argument("--min-confidence", type=real, default=0.0,
                      help="drop points whose confidence is below this (default 0)")
    mesh.add_argument("--max-uncertainty", type=real, default=None, metavar="U",
                      help="drop points whose uncertainty (--uncertainty, in the range's "
                      "unit) exceeds U, with their triangles (default: none dropped)")
    mesh.add_argument("--drop-uncertain", type=real, default=None, metavar="FRACTION",
                      help="drop this fraction (0-1) of the synthesized points, the most "
                      "uncertain (--uncertainty) first, with their triangles: the map's "
                      "ranking, not its scale (default: none dropped)")
    _add_camera_options(parser.add_argument_group(
        "camera (of DENSE: --camera-file, or --focal and the rest)"))
    _add_disparity_options(parser.add_argument_group(
        "pinhole disparity (DENSE of a rectified pair)"))
    _add_merge_options(parser.add_argument_group(
        "merging (--merge PLY ... instead of DENSE)"))
    return parser


def _add_camera_options(group) -> None:
    """The range image's camera (Eqs. 14, 19), or the camera file 'register' wrote."""
    group.add_argument("--camera-file", metavar="JSON",
                       help="the camera.json that 'register' writes beside intensity.npy: "
                       "the registered panorama's focal, pan-angle-0 column and horizon row "
                       f"(instead of {', '.join(_CAMERA_FLAGS)})")
    group.add_argument("--camera", choices=["cylindrical", "pinhole"], default=None,
                       help="the range image's camera: a cylindrical panorama (Eqs. 14, 19) "
                       "or a pinhole (default: cylindrical)")
    group.add_argument("--focal", type=real, metavar="PIXELS",
                       help="focal length f in pixels, the cylinder's radius (required "
                       "without --camera-file)")
    for option, what in (("--cx", "column of pan angle 0"), ("--cy", "row of the horizon")):
        group.add_argument(option, type=real, help=f"{what} / of the principal point (default: "
                           "the centre; a registered panorama's is in its camera.json)")
    cylindrical = prefixed(group, "cylindrical: ")
    cylindrical("--phi-step", type=real, metavar="DEGREES",
                help="degrees of pan per column (default 180/(pi f), one pixel of arc)")
    cylindrical("--h-step", type=real, metavar="PIXELS",
                help="pixels of height per row (default 1)")
    group.add_argument("--no-wrap", action="store_true",
                       help="do not join the last column to the first of a 360° panorama "
                       "(default: joined when the columns cover 360°)")


def _add_disparity_options(group) -> None:
    """A pinhole range given as a disparity: ``depth = f B / (d + doffs)``."""
    group.add_argument("--disparity", action="store_true",
                       help="pinhole: DENSE is a disparity; depth = f B / (d + doffs) "
                       "(default: DENSE is the depth)")
    with_disparity = prefixed(group, "with --disparity: ")
    with_disparity("--baseline", type=real,
                   help="the baseline B (the depth's unit, e.g. mm; required with --disparity)")
    with_disparity("--doffs", type=real, default=0.0, help="doffs in pixels (default 0)")


def _add_merge_options(group) -> None:
    """Several scans' PLYs in one world frame (``merge_models``, after ``refine_poses``)."""
    group.add_argument("--merge", nargs="+", metavar="PLY",
                       help="merge these models (in their scanners' frames) by --poses "
                       "(instead of DENSE)")
    with_merge = prefixed(group, "with --merge: ")
    with_merge("--poses", metavar="JSON",
               help="poses.json, one pose per PLY (required with --merge)")
    with_merge("--refine", action="store_true",
               help="refine the poses by point-to-plane ICP (default: the poses as given)")
    with_merge("--voxel", type=real, help="fusion voxel size (default 3x the point spacing)")
    with_merge("--poses-out", metavar="JSON",
               help="write the (refined) poses as JSON (default: not written)")
