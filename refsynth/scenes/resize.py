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


def _area_weights(old: int, new: int) -> tuple[np.ndarray, np.ndarray]:
    """The exact area weights of a 1-D box resize, as a band: ``(first, weights)``.

    Output cell ``i`` covers ``[i · old/new, (i + 1) · old/new)`` in source
    pixel units; ``weights[i, t]`` is the length of its overlap with source
    pixel ``j = first[i] + t`` (``[j, j + 1)``) divided by the cell length, so
    every row sums to 1 and every source pixel gets ``new / old`` in all. A
    cell meets at most ``ceil(old / new) + 1`` source pixels; weights past the
    last source pixel are 0.
    """
    edges = np.arange(new + 1) * old / new
    lo, hi = edges[:-1, None], edges[1:, None]
    first = np.minimum(np.floor(edges[:-1]).astype(np.int64), old - 1)
    j = first[:, None] + np.arange(-(-old // new) + 1)[None, :]
    overlap = np.clip(np.minimum(hi, j + 1) - np.maximum(lo, j), 0.0, None)
    weights = np.where(j < old, overlap / (old / new), 0.0)
    return first, weights


def _box_resize(values: np.ndarray, new: int, axis: int) -> np.ndarray:
    """Area-average ``values`` along ``axis`` to ``new`` cells, in a fixed order.

    Per output cell, the sum over its source pixels in ascending order, each
    ``weight · value``, as elementwise array operations over the other axes:
    no BLAS product and no reduction whose order a library chooses, so the
    result is the same bits on every machine. Source pixels of
    weight 0 are skipped, so a NaN or inf reaches only the cells it lies in.
    """
    values = np.moveaxis(values, axis, 0)
    old = values.shape[0]
    first, weights = _area_weights(old, new)
    shape = (new,) + (1,) * (values.ndim - 1)
    total = None
    for t in range(weights.shape[1]):
        w = weights[:, t].reshape(shape)
        source = values[np.minimum(first + t, old - 1)]
        with np.errstate(invalid="ignore"):
            term = np.where(w > 0, w * source, 0.0)
        total = term if total is None else total + term
    return np.moveaxis(total, 0, axis)


def _resize(values: np.ndarray, width: int, height: int) -> np.ndarray:
    """Rows first (each output row from its source rows), then columns."""
    return _box_resize(_box_resize(values, height, 0), width, 1)


def resize_area(image: np.ndarray, size: int | tuple[int, int]) -> np.ndarray:
    """Resize by exact area averaging, for any (non-integer) factor.

    Each output pixel is the area-weighted mean of the source pixels its
    footprint covers:

    .. math:: \\mathrm{out}_c = A_{\\mathrm{rows}}\\, \\mathrm{image}_c\\,
              A_{\\mathrm{cols}}^{\\top}

    per channel ``c``, with the 1-D area-weight matrices ``A`` (rows sum to
    1). The image mean is preserved exactly (up to rounding) for any factor,
    since every source pixel contributes the same total weight.

    The products are evaluated in a fixed order, not by BLAS: first each
    output row as the sum over its source rows in ascending order, then each
    output column likewise, so that the result is the same bits whatever the
    BLAS library, kernel or thread count.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C)
        Real values; NaN and inf propagate into the output pixels whose
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
    return _resize(image.astype(np.float64, copy=False), width, height)


def resize_disparity(
    disparity: np.ndarray,
    size: int | tuple[int, int],
    *,
    min_coverage: float = MIN_DISPARITY_COVERAGE,
    rescale: bool = True,
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
    rescale : bool, default True
        Multiply the values by ``new_width / old_width`` (disparity in pixels
        of the result); ``False`` keeps the source's pixel unit.

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
    known = np.isfinite(disparity)
    total = _resize(np.where(known, disparity, 0.0).astype(np.float64), width, height)
    coverage = _resize(known.astype(np.float64), width, height)
    enough = coverage >= min_coverage - 1e-12
    out = np.full((height, width), np.nan)
    out[enough] = total[enough] / coverage[enough]
    if rescale:
        out[enough] *= width / disparity.shape[1]
    return out
