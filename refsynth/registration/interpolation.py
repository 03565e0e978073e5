"""Images sampled between their pixels: the resampling under every warp of Appendix A.1.

The cylindrical projection (Eq. 14), the Gauss–Newton alignment (Eqs. 15–17)
and the blend (Eq. 18) all look an image up at fractional pixel positions.
They share :func:`sample_image`, which treats NaN as "no data" (the outside
of a warped view, an unscanned column) rather than as a number, and the
checks of what such a lookup is asked for: the interpolation order and the
shape of the output grid (a pair of integers, :func:`check_int_pair`).

Coordinates are ``(rows, cols)`` in index units: pixel ``(i, j)`` is sampled
exactly at ``(i, j)``.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage as ndi

from refsynth._checks import is_int

__all__ = ["ORDERS", "check_order", "check_int_pair", "check_shape", "sample_image"]

#: The interpolation orders refsynth offers: nearest, bilinear, cubic B-spline.
ORDERS = (0, 1, 3)

#: Sample coordinates this close outside the grid (rounding errors) are moved onto its edge.
_SNAP = 1e-6


def check_order(order) -> int:
    """``order`` as an ``int`` if it is one of :data:`ORDERS`, or raise ``ValueError``.

    Examples
    --------
    >>> check_order(3)
    3
    >>> check_order(2)
    Traceback (most recent call last):
    ...
    ValueError: The parameter `order` must be 0, 1 or 3, got 2
    """
    if isinstance(order, (bool, np.bool_)) or order not in ORDERS:
        raise ValueError(f"The parameter `order` must be 0, 1 or 3, got {order!r}")
    return int(order)


def check_int_pair(name: str, value, *, positive: bool = True) -> tuple[int, int]:
    """``value`` as two ``int``, each >= 1 (``positive``) or >= 0, or raise ``ValueError``.

    The check of an output grid's ``(H, W)`` (:func:`check_shape`) and of a
    search's half-widths (``refsynth.registration.translation.align_translation``).

    Examples
    --------
    >>> check_int_pair("search", (3, 0), positive=False)
    (3, 0)
    >>> check_int_pair("search", (3, -1), positive=False)
    Traceback (most recent call last):
    ...
    ValueError: The parameter `search` must be a pair of non-negative integers, got (3, -1)
    """
    if (
        not isinstance(value, (tuple, list))
        or len(value) != 2
        or not all(is_int(n) for n in value)
        or min(value) < (1 if positive else 0)
    ):
        kind = "positive" if positive else "non-negative"
        raise ValueError(f"The parameter `{name}` must be a pair of {kind} integers, got {value!r}")
    return int(value[0]), int(value[1])


def check_shape(name: str, shape, default: tuple[int, int]) -> tuple[int, int]:
    """``shape`` as ``(H, W)``, two integers >= 1; ``default`` if ``shape`` is None.

    Examples
    --------
    >>> check_shape("output_shape", None, (4, 5))
    (4, 5)
    >>> check_shape("output_shape", (4, 0), (4, 5))
    Traceback (most recent call last):
    ...
    ValueError: The parameter `output_shape` must be a pair of positive integers, got (4, 0)
    """
    if shape is None:
        return (int(default[0]), int(default[1]))
    return check_int_pair(name, shape)


def sample_image(image: np.ndarray, rows: np.ndarray, cols: np.ndarray, order: int) -> np.ndarray:
    """Interpolate a (H, W) or (H, W, C) float image at fractional ``(rows, cols)``.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C), float
        NaN marks pixels without data.
    rows, cols : ndarray
        Where to sample, in index units (one shape); NaN = nowhere.
    order : {0, 1, 3}
        Nearest, bilinear (``scipy.ndimage.map_coordinates``) or cubic
        B-spline. Order 0 and 1 sample NaN pixels as NaN. Order 3 fills NaN
        pixels with their nearest valid value before the spline prefilter
        and returns NaN wherever the bilinear sample would be NaN.

    Returns
    -------
    ndarray of shape ``rows.shape`` (+ ``(C,)``)
        NaN outside the grid (coordinates a rounding error outside it are
        moved onto its edge) and where there is no data.

    Examples
    --------
    >>> image = np.array([[0.0, 1.0], [2.0, 3.0]])
    >>> sample_image(image, np.array([0.5, 0.0, 1.5]), np.array([0.5, 1.0, 0.0]), 1)
    array([1.5, 1. , nan])
    """
    if image.ndim == 3:
        return np.stack(
            [sample_image(image[..., c], rows, cols, order) for c in range(image.shape[2])],
            axis=-1,
        )
    # snap coordinates a rounding error outside the grid onto its edge
    rows = np.where((rows > -_SNAP) & (rows < 0), 0.0, rows)
    rows = np.where((rows > image.shape[0] - 1) & (rows < image.shape[0] - 1 + _SNAP),
                    image.shape[0] - 1.0, rows)
    cols = np.where((cols > -_SNAP) & (cols < 0), 0.0, cols)
    cols = np.where((cols > image.shape[1] - 1) & (cols < image.shape[1] - 1 + _SNAP),
                    image.shape[1] - 1.0, cols)
    coords = np.stack([rows, cols])
    inside = np.isfinite(rows) & np.isfinite(cols)
    coords = np.where(inside, coords, -2.0)
    if order <= 1:
        out = ndi.map_coordinates(image, coords, order=order, mode="constant", cval=np.nan)
        return np.where(inside, out, np.nan)
    invalid = np.isnan(image)
    filled = image
    if invalid.any():
        if invalid.all():
            return np.full(rows.shape, np.nan)
        index = ndi.distance_transform_edt(invalid, return_distances=False, return_indices=True)
        filled = image[tuple(index)]
    out = ndi.map_coordinates(filled, coords, order=3, mode="nearest")
    valid = ndi.map_coordinates(
        np.where(invalid, np.nan, 0.0), coords, order=1, mode="constant", cval=np.nan
    )
    return np.where(inside & np.isfinite(valid), out, np.nan)
