"""The Middlebury stereo scenes: an image with its ground-truth disparity (§3.3, Table 4).

- :func:`motorcycle`: scikit-image's copy of the Middlebury 2014
  *Motorcycle* pair, resized to the paper's 450 × 375 (§3.3, Table 4).
- :func:`load_middlebury`: any Middlebury image + disparity from disk (PFM,
  ``.npy`` or a scaled integer image), optionally resized.
- :func:`require_scikit_image`: the check a command runs before any work when
  it will need the Motorcycle (scikit-image is the optional ``data`` extra).

The resizes are :mod:`refsynth.scenes.resize`'s exact area averages; sizes
are **width × height** as the paper writes them.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 and Table 4, doi:10.1007/s11263-007-0108-2.

D. Scharstein et al., "High-Resolution Stereo Datasets with Subpixel-Accurate
Ground Truth", GCPR 2014 (the Middlebury 2014 datasets, *Motorcycle*).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from refsynth._checks import check_choice, check_crop, check_size, is_real
from refsynth.io import IMAGE_SUFFIXES, read_image, read_range
from refsynth.scenes.resize import resize_area, resize_disparity
from refsynth.scenes.scene import Scene

__all__ = [
    "motorcycle",
    "MOTORCYCLE_CROP",
    "MOTORCYCLE_SIZE",
    "load_middlebury",
    "require_scikit_image",
    "DATA_EXTRA_HINT",
]

#: How to install what :func:`motorcycle` needs.
DATA_EXTRA_HINT = (
    'pip install "refsynth[data]" (in a checkout: pip install -e ".[data]"), '
    "or pip install scikit-image"
)


def require_scikit_image(what: str = "motorcycle()") -> None:
    """Raise ``ImportError`` (one line, saying what to install) unless scikit-image imports.

    Parameters
    ----------
    what : str
        What needs it, for the message (``"the Motorcycle scene"``).
    """
    try:
        from skimage import data  # noqa: F401
    except ImportError as error:
        raise ImportError(
            f"{what} needs scikit-image (for the Middlebury Motorcycle): {DATA_EXTRA_HINT}"
        ) from error


#: The pair's size, (width, height).
MOTORCYCLE_SIZE = (741, 500)

#: The centred 6:5 crop of the pair, ``(rows, cols)``: 600 × 500, which
#: area-resizes to the paper's 450 × 375 without stretching the scene.
MOTORCYCLE_CROP = ((0, 500), (70, 670))


def motorcycle(
    size: int | tuple[int, int] = (450, 375),
    *,
    crop: tuple[tuple[int, int], tuple[int, int]] | None = None,
    units: str = "resized",
) -> Scene:
    """The Middlebury 2014 *Motorcycle* left view and disparity, resized (§3.3, Table 4).

    Loads scikit-image's copy (``skimage.data.stereo_motorcycle()``: left
    view (500, 741, 3) uint8, disparity (500, 741) float32 with ``inf`` where
    unknown), resizes the image with :func:`resize_area` and the disparity
    with :func:`resize_disparity` (NaN where less than half a cell is known;
    values scaled by ``new_width / 741``).

    Parameters
    ----------
    size : int or pair of int, default (450, 375)
        ``(width, height)`` as the paper writes "450 × 375", or an int for a
        square. A size whose aspect differs from 741:500 stretches the scene
        (e.g. 128 gives a 128 × 128 image squeezed horizontally); the
        disparity values follow the horizontal scale.
    crop : pair of (start, stop) pairs, optional
        ``((row_start, row_stop), (col_start, col_stop))`` of the 741 × 500
        pair to keep before resizing; default the whole pair.
        :data:`MOTORCYCLE_CROP` is the centred 6:5 crop, ``((0, 500), (70,
        670))``: 600 × 500, which resizes to 450 × 375 with the same scale
        (0.75) along both axes.
    units : {"resized", "native"}, default "resized"
        The disparity's unit: pixels of the resized image (the values scaled
        by ``width / crop width``), or the pair's own pixels (the values as
        stored). MAR (Eq. 13) is in that unit; a fill that is equivariant to
        a scale of the range (NP, BP and the classical fills are) gives the
        same ratios in both.

    Returns
    -------
    Scene
        ``intensity`` (height, width, 3) float64 in [0, 1], ``range`` the
        disparity in pixels of the resized image (NaN where unknown; in the
        pair's pixels with ``units="native"``), ``units="disparity (px)"``
        (``"disparity (pair px)"`` when native), ``name="motorcycle-<width>x<height>"``
        (with ``-crop<r0>-<r1>,<c0>-<c1>`` and ``-native`` appended when used).

    Raises
    ------
    ValueError
        If ``size`` is not a positive size, ``crop`` is not two non-empty
        ``(start, stop)`` ranges inside the pair, or ``units`` is unknown.
    ImportError
        If scikit-image is not installed (the optional ``data`` extra:
        ``pip install "refsynth[data]"``).

    Examples
    --------
    scikit-image ships the pair (no download). At 90 × 60 the scene is a
    colour image of 60 rows and 90 columns; a few per cent of the disparity
    is unknown (NaN):

    >>> scene = motorcycle((90, 60))
    >>> scene.intensity.shape, scene.units, scene.name
    ((60, 90, 3), 'disparity (px)', 'motorcycle-90x60')

    The centred 6:5 crop, 600 × 500, resized by 0.75, the disparity
    kept in the pair's pixels (4/3 of the resized unit):

    >>> crop = motorcycle((450, 375), crop=MOTORCYCLE_CROP, units="native")
    >>> crop.name, crop.units
    ('motorcycle-450x375-crop0-500,70-670-native', 'disparity (pair px)')
    >>> resized = motorcycle((450, 375), crop=MOTORCYCLE_CROP)
    >>> bool(np.allclose(crop.range * 3 / 4, resized.range, equal_nan=True))
    True
    """
    width, height = check_size(size)
    rows, cols = check_crop(crop, MOTORCYCLE_SIZE[::-1])
    check_choice("units", units, ("resized", "native"))
    require_scikit_image()
    from skimage import data as skimage_data

    left, _, disparity = skimage_data.stereo_motorcycle()
    left = left[rows[0] : rows[1], cols[0] : cols[1]]
    disparity = disparity[rows[0] : rows[1], cols[0] : cols[1]].astype(np.float64)
    intensity = np.clip(resize_area(left / 255.0, (width, height)), 0.0, 1.0)
    disparity = resize_disparity(disparity, (width, height), rescale=units == "resized")
    name = f"motorcycle-{width}x{height}"
    if crop is not None:
        name += f"-crop{rows[0]}-{rows[1]},{cols[0]}-{cols[1]}"
    if units == "native":
        name += "-native"
    return Scene(
        intensity=intensity,
        range=disparity,
        units="disparity (pair px)" if units == "native" else "disparity (px)",
        name=name,
    )


def _read_disparity(path: Path, disparity_scale: float) -> np.ndarray:
    """The disparity, read as every refsynth command reads range (:func:`read_range`)."""
    suffix = path.suffix.lower()
    if suffix not in (".pfm", ".npy") and suffix not in IMAGE_SUFFIXES:
        raise ValueError(
            f"The parameter `disparity` must be a .pfm, .npy or image file, got '{path}'"
        )
    if suffix in IMAGE_SUFFIXES:
        return read_range(path, scale=disparity_scale)
    return read_range(path) / disparity_scale


def load_middlebury(
    image: str | Path,
    disparity: str | Path,
    size: int | tuple[int, int] | None = None,
    name: str | None = None,
    *,
    disparity_scale: float = 1.0,
) -> Scene:
    """A Middlebury (or similar) image with its ground-truth disparity, from disk.

    Parameters
    ----------
    image : str or Path
        The view (PNG, JPEG, PPM …), read with :func:`refsynth.io.read_image`
        as float64 in [0, 1] (alpha dropped).
    disparity : str or Path
        Its disparity map, read by :func:`refsynth.io.read_range` (as every
        refsynth command reads range): a PFM (Middlebury 2014 ``disp0.pfm``;
        ``inf`` = unknown), a ``.npy`` (non-finite = unknown), or a
        single-channel lossless image (PNG, PGM …) of integers where 0 =
        unknown and the stored value is ``disparity × disparity_scale``.
        JPEG and known values <= 0 are refused.
    size : int or pair of int, optional
        ``(width, height)`` to resize to (as :func:`motorcycle`); default:
        keep the size.
    name : str, optional
        Default: the image file's name without suffix, prefixed with its
        folder's name (``"Motorcycle-perfect/im0"``).
    disparity_scale : float, default 1.0
        The factor the stored values carry: 1 for PFM; for the PNG/PGM maps
        of the 2001–2006 datasets see each dataset's README (e.g. 4 for the
        2003 *Cones* and *Teddy* quarter-size maps).

    Returns
    -------
    Scene
        ``range`` the disparity in pixels of the returned image (NaN where
        unknown), ``units="disparity (px)"``.

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    ValueError
        If a file cannot be read, the disparity is not single-channel, or
        the image and disparity sizes differ.

    Examples
    --------
    A 40 × 30 grey view and its PFM disparity (8 px, unknown on the first
    10 columns), halved to 20 × 15: the disparity values halve with the
    width.

    >>> import tempfile
    >>> from refsynth.io import write_pfm, write_unit_png16
    >>> folder = Path(tempfile.mkdtemp())
    >>> view = write_unit_png16(folder / "im0.png", np.full((30, 40), 0.5))
    >>> disparity = np.where(np.arange(40) < 10, np.inf, 8.0) * np.ones((30, 1))
    >>> write_pfm(folder / "disp0.pfm", disparity)
    >>> scene = load_middlebury(view, folder / "disp0.pfm", size=(20, 15))
    >>> scene.shape, float(np.nanmax(scene.range)), int(np.isnan(scene.range[0]).sum())
    ((15, 20), 4.0, 5)
    """
    image_path = Path(image) if isinstance(image, (str, Path)) else None
    disparity_path = Path(disparity) if isinstance(disparity, (str, Path)) else None
    if image_path is None:
        raise TypeError(
            f"The parameter `image` must be a str or a Path, got {type(image).__name__}"
        )
    if disparity_path is None:
        raise TypeError(
            f"The parameter `disparity` must be a str or a Path, got {type(disparity).__name__}"
        )
    if not is_real(disparity_scale):
        raise TypeError(
            f"The parameter `disparity_scale` must be a real number, got {disparity_scale!r}"
        )
    if not (np.isfinite(disparity_scale) and disparity_scale > 0):
        raise ValueError(
            f"The parameter `disparity_scale` must be a finite number > 0, got {disparity_scale}"
        )
    if name is not None and not isinstance(name, str):
        raise TypeError(f"The parameter `name` must be a str or None, got {type(name).__name__}")
    target = None if size is None else check_size(size)

    intensity = read_image(image_path)
    ground_truth = _read_disparity(disparity_path, float(disparity_scale))
    if intensity.shape[:2] != ground_truth.shape:
        raise ValueError(
            f"The parameter `disparity` must match the image's size {intensity.shape[:2]}, "
            f"got {ground_truth.shape}"
        )
    if target is not None:
        intensity = np.clip(resize_area(intensity, target), 0.0, 1.0)
        ground_truth = resize_disparity(ground_truth, target)
    if name is None:
        folder = image_path.resolve().parent.name
        name = f"{folder}/{image_path.stem}" if folder else image_path.stem
    return Scene(
        intensity=intensity.astype(np.float64, copy=False),
        range=ground_truth,
        units="disparity (px)",
        name=name,
    )
