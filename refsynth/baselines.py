"""Comparison fills that are not in the paper.

These are what users reach for today to fill a partial depth map; refsynth's
results tables put them beside NP and BP so that the comparison is honest.
Each function takes the same inputs as :func:`refsynth.synthesize` and returns
the dense range (measured pixels unchanged).

References
----------
Torres-Méndez & Dudek (2008), §3.3, doi:10.1007/s11263-007-0108-2 (the
experiments these baselines are set beside).
"""

from __future__ import annotations

import numpy as np
from scipy import interpolate, ndimage, sparse
from scipy.sparse import linalg as sparse_linalg

from refsynth.synthesis import validate_inputs

__all__ = ["nearest_fill", "linear_fill", "harmonic_fill", "BASELINES"]


def nearest_fill(intensity: np.ndarray, partial_range: np.ndarray) -> np.ndarray:
    """Copy each unknown pixel's range from the nearest measured pixel (Euclidean).

    The intensity is validated but not used. Ties between equally near
    measured pixels are resolved as ``scipy.ndimage.distance_transform_edt``
    resolves them (deterministically).

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
    partial_range : ndarray of shape (H, W), NaN where unknown

    Returns
    -------
    ndarray of shape (H, W), float64

    Notes
    -----
    Disparity and indoor range are piecewise constant, so this fill, which
    never interpolates across a depth edge, is a strong baseline on MAR.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, np.nan, 4.0]] * 2)
    >>> nearest_fill(np.zeros((2, 4)), partial)[0].tolist()
    [1.0, 1.0, 4.0, 4.0]
    """
    _, range_values = validate_inputs(intensity, partial_range)
    unknown = ~np.isfinite(range_values)
    _, (rows, cols) = ndimage.distance_transform_edt(unknown, return_indices=True)
    return range_values[rows, cols]


def linear_fill(intensity: np.ndarray, partial_range: np.ndarray) -> np.ndarray:
    """Piecewise-linear interpolation over a Delaunay triangulation of the known pixels.

    ``scipy.interpolate.griddata(method="linear")``; pixels outside the convex
    hull of the known pixels take the nearest known value. The intensity is
    validated but not used.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
    partial_range : ndarray of shape (H, W), NaN where unknown

    Returns
    -------
    ndarray of shape (H, W), float64

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, 3.0]] * 3)
    >>> linear_fill(np.zeros((3, 3)), partial)[1].tolist()
    [1.0, 2.0, 3.0]
    """
    _, range_values = validate_inputs(intensity, partial_range)
    known = np.isfinite(range_values)
    out = nearest_fill(intensity, partial_range)
    points = np.argwhere(known)
    targets = np.argwhere(~known)
    if points.shape[0] >= 3 and np.linalg.matrix_rank(points - points[0]) == 2:
        values = interpolate.griddata(points, range_values[known], targets, method="linear")
        inside = np.isfinite(values)
        out[targets[inside, 0], targets[inside, 1]] = values[inside]
    return out


def harmonic_fill(intensity: np.ndarray, partial_range: np.ndarray) -> np.ndarray:
    """The harmonic (Laplace) fill: ``∇²R = 0`` on the unknown pixels, known ones fixed.

    The 4-neighbour discrete Laplacian, with reflecting (Neumann) image
    borders, solved as one sparse linear system (``scipy.sparse.linalg.spsolve``).
    The intensity is validated but not used.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
    partial_range : ndarray of shape (H, W), NaN where unknown

    Returns
    -------
    ndarray of shape (H, W), float64

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[0.0, np.nan, np.nan, 3.0]] * 2)
    >>> np.round(harmonic_fill(np.zeros((2, 4)), partial)[0], 6).tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    _, range_values = validate_inputs(intensity, partial_range)
    H, W = range_values.shape
    known = np.isfinite(range_values)
    index = np.full(H * W, -1, dtype=np.int64)
    unknown = np.flatnonzero(~known)
    index[unknown] = np.arange(unknown.size)
    values = np.where(known, range_values, 0.0).ravel()
    rows, cols = np.divmod(unknown, W)
    diag = np.zeros(unknown.size)
    rhs = np.zeros(unknown.size)
    a_rows, a_cols = [], []
    for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        r, c = rows + dr, cols + dc
        inside = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        diag += inside
        nb = (r * W + c)[inside]
        me = np.flatnonzero(inside)
        is_known = known.ravel()[nb]
        rhs[me[is_known]] += values[nb[is_known]]
        a_rows.append(me[~is_known])
        a_cols.append(index[nb[~is_known]])
    a_rows, a_cols = np.concatenate(a_rows), np.concatenate(a_cols)
    matrix = sparse.csr_matrix(
        (np.concatenate([diag, -np.ones(a_rows.size)]),
         (np.concatenate([np.arange(unknown.size), a_rows]),
          np.concatenate([np.arange(unknown.size), a_cols]))),
        shape=(unknown.size, unknown.size),
    )
    # every 4-connected unknown region borders a known pixel (there is one), so the
    # system is non-singular
    out = values.copy()
    out[unknown] = sparse_linalg.spsolve(matrix.tocsc(), rhs)
    return out.reshape(H, W)


#: The comparison fills by name, as the command line and the benchmarks use them.
BASELINES = {"nearest": nearest_fill, "linear": linear_fill, "harmonic": harmonic_fill}
