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
from scipy import ndimage

from refsynth.synthesis import validate_inputs

__all__ = ["nearest_fill"]


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
