"""The MRF model's building blocks (§3.2.1): augmented voxels and neighbourhoods.

An *augmented voxel* ``V_p`` is a pixel's intensity together with its range,
where the range may be missing. Its *neighbourhood* ``N_p`` is the n×n window
centred on it (5×5 by default, 3×3 for very sparse data). The Gaussian window
``G`` of Eq. 2 weighs the offsets of that window, heavier at the centre.

This module holds the pieces every method shares: the window, its offsets,
and the extraction of (partial) neighbourhoods as arrays.

References
----------
Torres-Méndez & Dudek (2008), §3.2.1, doi:10.1007/s11263-007-0108-2.
A. A. Efros and T. K. Leung, "Texture synthesis by non-parametric sampling",
ICCV 1999 (the Gaussian window, σ = n / 6.4).
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth._checks import check_int, check_real

__all__ = [
    "gaussian_window",
    "window_offsets",
    "disc_offsets",
    "intensity_patches",
    "range_patches",
]


def gaussian_window(n: int, sigma: float | None = None) -> np.ndarray:
    r"""The Gaussian window ``G`` of Eq. 2 over an n×n neighbourhood.

    .. math:: G(\sigma, v - v_0) \propto \exp\left(-\frac{\|v - v_0\|^2}{2\sigma^2}\right)

    Parameters
    ----------
    n : int
        Odd side of the neighbourhood.
    sigma : float, optional
        Standard deviation in pixels; default ``n / 6.4`` as in Efros & Leung
        (1999), whose sampling scheme §3.2.2 follows.

    Returns
    -------
    ndarray of shape (n, n), float64
        Non-negative weights summing to 1, largest at the centre.

    Examples
    --------
    >>> g = gaussian_window(5)
    >>> g.shape, round(float(g.sum()), 12), bool(g[2, 2] == g.max())
    ((5, 5), 1.0, True)
    """
    n = check_int("n", n, minimum=1)
    if n % 2 == 0:
        raise ValueError(f"The parameter `n` must be a positive odd integer, got {n}")
    sigma = n / 6.4 if sigma is None else check_real("sigma", sigma, positive=True)
    h = n // 2
    v = np.arange(-h, h + 1, dtype=np.float64)
    g = np.exp(-(v[:, None] ** 2 + v[None, :] ** 2) / (2.0 * sigma**2))
    return g / g.sum()


def window_offsets(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column offsets of the n×n window ``N_p``, in raster order (row-major; §3.2.1).

    The offsets ``v − v0`` over which Eq. 2 sums.

    Parameters
    ----------
    n : int
        Odd side of the neighbourhood (the paper's 5, or 3 for very sparse data).

    Returns
    -------
    dr, dc : ndarray of shape (n²,), int
        From ``(-n // 2, -n // 2)`` to ``(n // 2, n // 2)``, ``(0, 0)`` in the middle.

    Examples
    --------
    >>> dr, dc = window_offsets(3)
    >>> dr.tolist(), dc.tolist()
    ([-1, -1, -1, 0, 0, 0, 1, 1, 1], [-1, 0, 1, -1, 0, 1, -1, 0, 1])
    """
    h = n // 2
    dr, dc = np.mgrid[-h : h + 1, -h : h + 1]
    return dr.ravel(), dc.ravel()


def disc_offsets(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Row and column offsets ``v`` with ``‖v‖ ≤ radius`` (Eq. 3), centre excluded.

    The pixels ``q`` of the local training set ``A_p`` lie at these offsets from ``p``
    (Eq. 3: ``distance(p, q) ≤ r``, the paper's ``r = 10``).

    Parameters
    ----------
    radius : float
        The search radius ``r`` in pixels (Euclidean distance, inclusive).

    Returns
    -------
    dr, dc : ndarray of shape (K,), int
        Row and column offsets in raster order, ``(0, 0)`` left out.

    Examples
    --------
    >>> dr, dc = disc_offsets(1.0)   # the 4-neighbours: the diagonals are √2 away
    >>> list(zip(dr.tolist(), dc.tolist()))
    [(-1, 0), (0, -1), (0, 1), (1, 0)]
    """
    k = int(np.floor(radius))
    dr, dc = np.mgrid[-k : k + 1, -k : k + 1]
    inside = (dr**2 + dc**2 <= radius**2) & ((dr != 0) | (dc != 0))
    return dr[inside], dc[inside]


def intensity_patches(image: np.ndarray, n: int) -> np.ndarray:
    """All n×n intensity neighbourhoods of an image.

    The image is extended beyond its border by mirror reflection
    (``numpy.pad(mode="symmetric")``), so border pixels have whole windows.

    Parameters
    ----------
    image : ndarray of shape (H, W, C), float
        The intensity, ``C = 1`` for grey, 3 for colour.
    n : int
        The odd side of the patch ``N_p``.

    Returns
    -------
    ndarray of shape (H, W, n, n, C)
        A read-only view; ``out[r, c]`` is the window centred on ``(r, c)``.

    Examples
    --------
    >>> image = np.arange(6.0).reshape(2, 3, 1)
    >>> patches = intensity_patches(image, 3)
    >>> patches.shape, patches[0, 0, :, :, 0].tolist()   # mirrored at the top-left corner
    ((2, 3, 3, 3, 1), [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [3.0, 3.0, 4.0]])
    """
    h = n // 2
    padded = np.pad(image, ((h, h), (h, h), (0, 0)), mode="symmetric")
    view = sliding_window_view(padded, (n, n), axis=(0, 1))  # (H, W, C, n, n)
    return view.transpose(0, 1, 3, 4, 2)


def range_patches(range_image: np.ndarray, n: int) -> np.ndarray:
    """All n×n range neighbourhoods, NaN where the range is unknown or off the image.

    Parameters
    ----------
    range_image : ndarray of shape (H, W), float
        The partial range, NaN where unknown (neither measured nor yet synthesized).
    n : int
        The odd side of the range patch. Unlike :func:`intensity_patches`, the image
        is not mirrored: the offsets off the image are NaN, unknown like any missing range.

    Returns
    -------
    ndarray of shape (H, W, n, n)
        A read-only view; ``out[r, c]`` is the partial range neighbourhood of ``(r, c)``.

    Examples
    --------
    >>> partial = np.array([[1.0, np.nan], [3.0, 4.0]])
    >>> range_patches(partial, 3)[0, 0]
    array([[nan, nan, nan],
           [nan,  1., nan],
           [nan,  3.,  4.]])
    """
    h = n // 2
    padded = np.pad(range_image, h, mode="constant", constant_values=np.nan)
    return sliding_window_view(padded, (n, n))
