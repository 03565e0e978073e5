"""Real RGB-D and stereo data from disk: an image with its depth or disparity (§3.3, Table 4).

- :func:`load_rgbd`: an image and its ground-truth depth or disparity (PNG
  of stored integers, ``.npy`` or ``.pfm``), with the file's scale and its
  invalid values, an optional crop, and optionally the protocol of Table 4:
  the largest centred crop of the target's aspect (6:5 for 450 × 375), then
  an exact area resize.
- :func:`centre_crop`: that centred crop, as ``((row_start, row_stop),
  (col_start, col_stop))``.
- :func:`read_scene_metadata` and :func:`load_rgbd_folder`: a folder holding
  an image, a truth file and a small ``scene.json`` naming them with their
  scale, invalid values, kind, unit and crop; each entry may also be given
  as an argument.

The result is a :class:`~refsynth.scenes.scene.Scene`: ``intensity`` float64
in [0, 1], (H, W) or (H, W, 3); ``range`` float64 in the stated unit, NaN
where the file has no valid value. ``scene.intensity`` and ``np.where(known,
scene.range, np.nan)`` are what :func:`refsynth.synthesize` takes, and
:func:`refsynth.evaluation.metrics.mar` scores the fill (Eq. 13) only where
the truth is finite.

Resizing follows :mod:`refsynth.scenes.resize`: the image by exact area
averages, the truth by masked area averages (NaN where less than half a
cell is valid). A disparity's values follow the horizontal scale (pixels of
the returned image), as :func:`refsynth.scenes.motorcycle`'s do; a depth's
do not change.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 and Table 4, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from refsynth._checks import check_choice, check_crop, check_size, is_int, is_real
from refsynth.io import IMAGE_SUFFIXES, read_image, read_npy, read_pfm
from refsynth.scenes.resize import resize_area, resize_disparity
from refsynth.scenes.scene import Scene

__all__ = [
    "KINDS",
    "METADATA_FILE",
    "TABLE4_SIZE",
    "load_rgbd",
    "centre_crop",
    "read_scene_metadata",
    "load_rgbd_folder",
]

#: What the truth file holds: a depth (larger = farther) or a disparity (larger = nearer).
KINDS = ("depth", "disparity")
#: The metadata file :func:`read_scene_metadata` reads in a scene folder.
METADATA_FILE = "scene.json"
#: Table 4's size, (width, height).
TABLE4_SIZE = (450, 375)

_TRUTH_SUFFIXES = (".npy", ".pfm", *IMAGE_SUFFIXES)
_DEFAULT_UNITS = {"depth": "m", "disparity": "disparity (px)"}
_METADATA_KEYS = ("image", "truth", "scale", "invalid", "kind", "units", "crop", "name")


# ----------------------------------------------------------------------------- checks


def _check_path(name: str, value) -> Path:
    if not isinstance(value, (str, Path)):
        raise TypeError(
            f"The parameter `{name}` must be a str or a Path, got {type(value).__name__}"
        )
    return Path(value)


def _check_scale(scale) -> float:
    if not is_real(scale):
        raise TypeError(f"The parameter `scale` must be a real number, got {scale!r}")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"The parameter `scale` must be a finite number > 0, got {scale}")
    return float(scale)


def _check_invalid(invalid) -> tuple[float, ...]:
    if invalid is None:
        return ()
    if is_real(invalid):
        invalid = (invalid,)
    if not isinstance(invalid, (tuple, list)) or not all(is_real(v) for v in invalid):
        raise TypeError(
            "The parameter `invalid` must be a real number or a sequence of them (the stored "
            f"values that mean 'no measurement'), got {invalid!r}"
        )
    return tuple(float(v) for v in invalid)


# ----------------------------------------------------------------------------- reading


def _read_truth(path: Path, scale: float, invalid: tuple[float, ...]) -> np.ndarray:
    """The stored values ÷ ``scale``, NaN where non-finite or equal to an ``invalid`` value."""
    suffix = path.suffix.lower()
    if suffix == ".pfm":
        stored = read_pfm(path)
    elif suffix == ".npy":
        stored = read_npy(path)
    elif suffix in IMAGE_SUFFIXES:
        stored = read_image(path, raw=True)
    else:
        raise ValueError(
            f"The parameter `truth` must be a .npy, .pfm or image file "
            f"({', '.join(IMAGE_SUFFIXES)}), got '{path}'"
        )
    if stored.dtype.kind not in "iuf":
        raise ValueError(
            f"The parameter `truth` must hold real numbers, got dtype {stored.dtype} from '{path}'"
        )
    if stored.ndim != 2:
        raise ValueError(
            f"The parameter `truth` must hold a single-channel (H, W) map, "
            f"got shape {stored.shape} from '{path}'"
        )
    values = stored.astype(np.float64)
    missing = ~np.isfinite(values)
    for value in invalid:
        missing |= values == value
    return np.where(missing, np.nan, values / scale)


def centre_crop(
    shape: tuple[int, int], size: int | tuple[int, int] = TABLE4_SIZE
) -> tuple[tuple[int, int], tuple[int, int]]:
    """The largest centred crop of ``shape`` with the aspect of ``size`` (Table 4's protocol).

    Table 4 runs at 450 × 375 (6:5); an image of another aspect is cut to
    6:5 about its centre before it is area-resized, so that the scene is not
    stretched.

    Parameters
    ----------
    shape : pair of int
        ``(height, width)`` of the image (numpy's order).
    size : int or pair of int, default (450, 375)
        ``(width, height)`` whose aspect the crop takes (the paper's order).

    Returns
    -------
    ((row_start, row_stop), (col_start, col_stop))
        Rows kept whole and columns cut when the image is wider than the
        aspect, and the other way round; the odd pixel goes to the end.

    Raises
    ------
    ValueError
        If ``shape`` or ``size`` is not a pair of positive integers.

    Examples
    --------
    The Motorcycle's 741 × 500 pair: its 600 central columns.

    >>> centre_crop((500, 741))
    ((0, 500), (70, 670))
    >>> centre_crop((426, 560))
    ((0, 426), (24, 535))
    """
    if not (isinstance(shape, (tuple, list)) and len(shape) == 2
            and all(is_int(n) and n > 0 for n in shape)):
        raise ValueError(
            f"The parameter `shape` must be a pair of positive integers (height, width), "
            f"got {shape!r}"
        )
    height, width = int(shape[0]), int(shape[1])
    aspect_w, aspect_h = check_size(size)
    if width * aspect_h > height * aspect_w:        # wider than the aspect: cut columns
        kept = max(1, min(width, int(round(height * aspect_w / aspect_h))))
        start = (width - kept) // 2
        return (0, height), (start, start + kept)
    kept = max(1, min(height, int(round(width * aspect_h / aspect_w))))
    start = (height - kept) // 2
    return (start, start + kept), (0, width)


def load_rgbd(
    image: str | Path,
    truth: str | Path,
    *,
    scale: float = 1.0,
    invalid: float | Sequence[float] | None = (0,),
    kind: str = "depth",
    units: str | None = None,
    crop: tuple[tuple[int, int], tuple[int, int]] | None = None,
    size: int | tuple[int, int] | None = None,
    name: str | None = None,
) -> Scene:
    """An image and its ground-truth depth or disparity from disk, as refsynth's arrays.

    The steps, in order: read both files; check that their sizes agree;
    mark the truth's invalid values NaN and divide the rest by ``scale``;
    keep ``crop``; then, if ``size`` is given, Table 4's protocol (§3.3):
    the largest centred crop of ``size``'s aspect (:func:`centre_crop`) and
    an exact area resize to ``size`` (:func:`~refsynth.scenes.resize_area`
    for the image, :func:`~refsynth.scenes.resize_disparity` for the truth).

    Parameters
    ----------
    image : str or Path
        The intensity image (PNG, JPEG, PPM …), read with
        :func:`refsynth.io.read_image` as float64 in [0, 1]; grey stays
        (H, W), colour is (H, W, 3), alpha is dropped.
    truth : str or Path
        The registered depth or disparity: a single-channel image of stored
        integers (8 or 16 bit), a ``.npy`` or a ``.pfm``. Its value in
        ``units`` is ``stored / scale``.
    scale : float, default 1.0
        What the stored values carry: 1000 for millimetre depth PNGs (NYU
        Depth v2), 2 for the half-size Middlebury 2005 disparity PNGs.
    invalid : real or sequence of real or None, default (0,)
        Stored values that mean "no measurement" (0 for Kinect and
        Middlebury PNGs; also 65535 for some sensors). Non-finite values
        (NaN, ±inf) are always invalid; None: no other.
    kind : {"depth", "disparity"}, default "depth"
        A depth grows with distance; a disparity shrinks with it, and its
        values follow a horizontal resize.
    units : str, optional
        The unit's name for tables; default ``"m"`` for a depth and
        ``"disparity (px)"`` for a disparity.
        :func:`refsynth.evaluation.cases.known_mask` takes a unit that
        starts with ``"disparity"`` as a disparity (Fig. 2's coarse range is
        then its inverse).
    crop : ((int, int), (int, int)), optional
        ``((row_start, row_stop), (col_start, col_stop))`` of the files to
        keep before anything else, e.g. NYU Depth v2's
        ``((45, 471), (41, 601))`` (inside its undistortion border).
    size : int or pair of int, optional
        ``(width, height)`` to bring the crop to by Table 4's protocol, e.g.
        ``(450, 375)``; default: keep the crop's size.
    name : str, optional
        For tables; default the image's folder and stem (``"room/image"``).

    Returns
    -------
    Scene
        ``intensity`` float64 in [0, 1]; ``range`` float64 in ``units``,
        NaN where invalid; ``units``; ``name``.

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    TypeError
        If an argument has the wrong type.
    ValueError
        If a file cannot be read, the truth is not single-channel or not
        real, the image and the truth differ in size, ``scale`` is not a
        finite number > 0, ``kind`` is unknown, ``crop`` lies outside the
        files or is empty, or ``size`` is not a positive size.

    Examples
    --------
    A 40 × 30 colour image and its depth in millimetres as a 16-bit PNG
    (0 = none on the first 5 columns), read in metres and brought to 12 × 10
    (6:5): the centred 36 × 30 crop, area-resized by a third.

    >>> import tempfile
    >>> from PIL import Image
    >>> folder = Path(tempfile.mkdtemp())
    >>> rgb = np.zeros((30, 40, 3), np.uint8); rgb[..., 0] = 255
    >>> Image.fromarray(rgb).save(folder / "image.png")
    >>> depth = np.full((30, 40), 2500, np.uint16); depth[:, :5] = 0
    >>> Image.fromarray(depth).save(folder / "depth.png")
    >>> scene = load_rgbd(folder / "image.png", folder / "depth.png", scale=1000)
    >>> scene.intensity.shape, scene.units, float(np.nanmax(scene.range))
    ((30, 40, 3), 'm', 2.5)
    >>> small = load_rgbd(folder / "image.png", folder / "depth.png", scale=1000, size=(12, 10))
    >>> small.range.shape, int(np.isnan(small.range).sum(axis=1)[0])
    ((10, 12), 1)

    What :func:`refsynth.synthesize` takes, for every fourth column known:

    >>> known = np.isfinite(small.range) & (np.arange(12) % 4 == 3)
    >>> partial = np.where(known, small.range, np.nan)
    """
    image_path = _check_path("image", image)
    truth_path = _check_path("truth", truth)
    scale = _check_scale(scale)
    invalid = _check_invalid(invalid)
    kind = check_choice("kind", kind, KINDS)
    if units is not None and not isinstance(units, str):
        raise TypeError(f"The parameter `units` must be a str or None, got {type(units).__name__}")
    if name is not None and not isinstance(name, str):
        raise TypeError(f"The parameter `name` must be a str or None, got {type(name).__name__}")
    target = None if size is None else check_size(size)
    for what, path in (("image", image_path), ("truth", truth_path)):
        if not path.is_file():
            raise FileNotFoundError(f"The parameter `{what}` names no file: '{path}'")

    intensity = read_image(image_path)
    ground_truth = _read_truth(truth_path, scale, invalid)
    if intensity.shape[:2] != ground_truth.shape:
        raise ValueError(
            f"The parameter `truth` must match the image's size (H, W) = {intensity.shape[:2]}, "
            f"got {ground_truth.shape} from '{truth_path}'"
        )
    (r0, r1), (c0, c1) = check_crop(crop, ground_truth.shape)
    intensity = intensity[r0:r1, c0:c1]
    ground_truth = ground_truth[r0:r1, c0:c1]
    if target is not None:
        (r0, r1), (c0, c1) = centre_crop(ground_truth.shape, target)
        intensity = np.clip(resize_area(intensity[r0:r1, c0:c1], target), 0.0, 1.0)
        ground_truth = resize_disparity(ground_truth[r0:r1, c0:c1], target,
                                        rescale=kind == "disparity")
    if name is None:
        folder = image_path.resolve().parent.name
        name = f"{folder}/{image_path.stem}" if folder else image_path.stem
    return Scene(
        intensity=np.ascontiguousarray(intensity, dtype=np.float64),
        range=np.ascontiguousarray(ground_truth, dtype=np.float64),
        units=_DEFAULT_UNITS[kind] if units is None else units,
        name=name,
    )


# ----------------------------------------------------------------------------- folders


def read_scene_metadata(folder: str | Path) -> dict:
    """A scene folder's ``scene.json``: the files and how to read them.

    The file is a JSON object with the keys of :func:`load_rgbd`: ``image``
    and ``truth`` (file names relative to the folder; required), and
    optionally ``scale``, ``invalid`` (a list), ``kind``, ``units``,
    ``crop`` (``[[row_start, row_stop], [col_start, col_stop]]``) and
    ``name``. Unknown keys are refused, so that a misspelt one is not
    silently ignored.

    Parameters
    ----------
    folder : str or Path
        The scene's folder.

    Returns
    -------
    dict
        The entries, with ``image`` and ``truth`` as paths inside ``folder``
        and ``crop`` as a pair of pairs.

    Raises
    ------
    FileNotFoundError
        If the folder has no ``scene.json``.
    ValueError
        If it is not a JSON object, lacks ``image`` or ``truth``, or has an
        unknown key.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "scene.json").write_text(
    ...     '{"image": "rgb.jpg", "truth": "depth.png", "scale": 1000, '
    ...     '"crop": [[45, 471], [41, 601]]}')
    >>> meta = read_scene_metadata(folder)
    >>> meta["image"].name, meta["scale"], meta["crop"]
    ('rgb.jpg', 1000, ((45, 471), (41, 601)))
    """
    folder = _check_path("folder", folder)
    path = folder / METADATA_FILE
    if not path.is_file():
        raise FileNotFoundError(f"No {METADATA_FILE} in '{folder}'")
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"Cannot read '{path}' as JSON: {error}") from None
    if not isinstance(meta, dict):
        raise ValueError(f"'{path}' must hold a JSON object, got {type(meta).__name__}")
    unknown = sorted(set(meta) - set(_METADATA_KEYS))
    if unknown:
        raise ValueError(f"'{path}' has unknown keys {unknown}: expected {list(_METADATA_KEYS)}")
    for key in ("image", "truth"):
        if not isinstance(meta.get(key), str) or not meta[key]:
            raise ValueError(f"'{path}' must name the `{key}` file (a non-empty string)")
        meta[key] = folder / meta[key]
    if isinstance(meta.get("crop"), list):
        meta["crop"] = tuple(tuple(part) if isinstance(part, list) else part
                             for part in meta["crop"])
    if isinstance(meta.get("invalid"), list):
        meta["invalid"] = tuple(meta["invalid"])
    return meta


def load_rgbd_folder(
    folder: str | Path, *, size: int | tuple[int, int] | None = None, **overrides
) -> Scene:
    """Load a scene folder: its ``scene.json``, with any entry overridden by an argument.

    Parameters
    ----------
    folder : str or Path
        A folder with a ``scene.json`` (:func:`read_scene_metadata`); without
        one, ``image`` and ``truth`` must be given (relative to the folder or
        absolute).
    size : int or pair of int, optional
        As in :func:`load_rgbd`: Table 4's protocol to ``(width, height)``.
    **overrides
        Any keyword of :func:`load_rgbd` (``image``, ``truth``, ``scale``,
        ``invalid``, ``kind``, ``units``, ``crop``, ``name``); they replace
        the file's entries.

    Returns
    -------
    Scene
        Named after the folder unless a name is given.

    Raises
    ------
    FileNotFoundError
        If there is no ``scene.json`` and ``image`` or ``truth`` is missing,
        or a file does not exist.
    TypeError
        If an override is not a keyword of :func:`load_rgbd`.
    ValueError
        As :func:`read_scene_metadata` and :func:`load_rgbd`.

    Examples
    --------
    A folder with a grey image and a float depth in metres (NaN = none):

    >>> import tempfile
    >>> from refsynth.io import write_unit_png16
    >>> folder = Path(tempfile.mkdtemp()) / "corridor"
    >>> folder.mkdir()
    >>> _ = write_unit_png16(folder / "image.png", np.full((10, 12), 0.5))
    >>> np.save(folder / "gt.npy", np.full((10, 12), 3.0, np.float32))
    >>> _ = (folder / "scene.json").write_text('{"image": "image.png", "truth": "gt.npy"}')
    >>> scene = load_rgbd_folder(folder)
    >>> scene.name, scene.range.shape, scene.units
    ('corridor', (10, 12), 'm')
    >>> load_rgbd_folder(folder, kind="disparity").units
    'disparity (px)'
    """
    folder = _check_path("folder", folder)
    unknown = sorted(set(overrides) - set(_METADATA_KEYS))
    if unknown:
        raise TypeError(
            f"load_rgbd_folder() got unexpected keyword arguments {unknown}: "
            f"expected {list(_METADATA_KEYS)}"
        )
    if (folder / METADATA_FILE).is_file():
        meta = read_scene_metadata(folder)
    elif "image" in overrides and "truth" in overrides:
        meta = {}
    else:
        raise FileNotFoundError(
            f"No {METADATA_FILE} in '{folder}': give `image` and `truth` (and their scale, "
            "invalid values, kind) as arguments or write the file"
        )
    for key in ("image", "truth"):
        if key in overrides:
            overrides[key] = folder / _check_path(key, overrides[key])
    meta.update(overrides)
    meta.setdefault("name", folder.resolve().name)
    image, truth = meta.pop("image"), meta.pop("truth")
    return load_rgbd(image, truth, size=size, **meta)
