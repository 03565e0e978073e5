"""Exact area-averaging resizes for arbitrary (non-integer) factors (§3.3).

The paper runs its Middlebury experiments at 450 × 375 (§3.3, Table 4), a
non-integer reduction of the 2014 images; these resizes average each output
cell over exactly the source area it covers, and resize disparity maps with
holes by masked averaging, rescaling their values.

Sizes given as ``size`` follow the paper's notation, **width × height**:
``size=(450, 375)`` gives arrays of shape ``(375, 450)``. An int gives a
square.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth._checks import check_real_array, check_size, is_real

__all__ = ["resize_area", "resize_disparity", "MIN_DISPARITY_COVERAGE"]

#: A resized disparity cell is NaN unless at least this fraction of its area
#: has finite (known) source disparity.
MIN_DISPARITY_COVERAGE = 0.5


def _area_matrix(old: int, new: int) -> np.ndarray:
    """The (new, old) matrix of exact area weights of a 1-D box resize.

    Output cell ``i`` covers ``[i · old/new, (i + 1) · old/new)`` in source
    pixel units; ``A[i, j]`` is the length of its overlap with source pixel
    ``[j, j + 1)`` divided by the cell length, so every row sums to 1 and
    every column to ``new / old``.
    """
    edges = np.arange(new + 1) * old / new
    lo, hi = edges[:-1, None], edges[1:, None]
    j = np.arange(old)[None, :]
    overlap = np.clip(np.minimum(hi, j + 1) - np.maximum(lo, j), 0.0, None)
    return overlap / (old / new)


def resize_area(image: np.ndarray, size: int | tuple[int, int]) -> np.ndarray:
    """Resize by exact area averaging, for any (non-integer) factor.

    Each output pixel is the area-weighted mean of the source pixels its
    footprint covers:

    .. math:: \\mathrm{out}_c = A_{\\mathrm{rows}}\\, \\mathrm{image}_c\\,
              A_{\\mathrm{cols}}^{\\top}

    per channel ``c``, with the 1-D area-weight matrices ``A`` (rows sum to
    1). The image mean is preserved exactly (up to rounding) for any factor,
    since every source pixel contributes the same total weight.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C)
        Real values; NaN and inf propagate into every output pixel whose
        footprint touches them (use :func:`resize_disparity` for data with
        holes).
    size : int or pair of int
        ``(width, height)`` of the result (the paper's "450 × 375"), or an
        int for a square.

    Returns
    -------
    ndarray of shape (height, width) or (height, width, C), float64

    Examples
    --------
    >>> resize_area(np.array([[0.0, 1.0, 2.0, 3.0]]), (2, 1))
    array([[0.5, 2.5]])
    """
    image = check_real_array("image", image, (2, 3))
    width, height = check_size(size)
    rows = _area_matrix(image.shape[0], height)
    cols = _area_matrix(image.shape[1], width)
    values = image.astype(np.float64, copy=False)
    if values.ndim == 2:
        return rows @ values @ cols.T
    return np.stack([rows @ values[..., c] @ cols.T for c in range(values.shape[2])], axis=-1)


def resize_disparity(
    disparity: np.ndarray,
    size: int | tuple[int, int],
    *,
    min_coverage: float = MIN_DISPARITY_COVERAGE,
) -> np.ndarray:
    """Resize a disparity map by masked area averaging, rescaling its values.

    The finite values are area-averaged (:func:`resize_area`'s weights,
    normalised by the area of known source within each output cell); a cell
    whose footprint is less than ``min_coverage`` known becomes NaN.
    Disparities are horizontal pixel offsets, so the values are multiplied by
    ``new_width / old_width`` (the height ratio does not enter).

    Parameters
    ----------
    disparity : ndarray of shape (H, W)
        Non-finite (NaN, ±inf) where unknown, as in Middlebury PFMs.
    size : int or pair of int
        ``(width, height)`` of the result, or an int for a square.
    min_coverage : float, default 0.5
        Fraction of a cell's area that must have known disparity, in (0, 1].

    Returns
    -------
    ndarray of shape (height, width), float64
        NaN where unknown.

    Examples
    --------
    >>> resize_disparity(np.array([[4.0, 8.0, np.inf, np.inf]]), (2, 1))
    array([[ 3., nan]])
    """
    disparity = check_real_array("disparity", disparity, (2,))
    width, height = check_size(size)
    if not is_real(min_coverage):
        raise TypeError(f"The parameter `min_coverage` must be a real number, got {min_coverage!r}")
    if not 0.0 < min_coverage <= 1.0:
        raise ValueError(f"The parameter `min_coverage` must be in (0, 1], got {min_coverage}")
    rows = _area_matrix(disparity.shape[0], height)
    cols = _area_matrix(disparity.shape[1], width)
    known = np.isfinite(disparity)
    total = rows @ np.where(known, disparity, 0.0).astype(np.float64) @ cols.T
    coverage = rows @ known.astype(np.float64) @ cols.T
    enough = coverage >= min_coverage - 1e-12
    out = np.full((height, width), np.nan)
    out[enough] = total[enough] / coverage[enough] * (width / disparity.shape[1])
    return out
