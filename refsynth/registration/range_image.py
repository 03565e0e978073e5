r"""The laser's scan on the camera's cylinder (Appendix A.2, Eq. 19).

The laser's spherical samples ``(r, θ, φ)`` are mapped onto the cylinder of
radius ``f``, the camera's focal length, on which the panorama mosaic lives
(Eq. 14, :mod:`refsynth.registration.cylinder`):

.. math:: P(r, \theta, \phi) \to P\Big(r, \phi, \frac{f}{\tan\theta}\Big) \to P(r, \phi, h)

so that range and intensity are both cylindrical images and differ only by
the warp of Eqs. 20–21 (:mod:`refsynth.registration.warp`).

Coordinates
-----------
- Laser: ``θ`` is the mirror angle from the vertical (up) axis, ``φ`` the
  azimuth (pan), radians; ``r`` the distance from the laser's centre
  (:func:`spherical_to_cartesian`: ``y`` up, ``φ`` from ``z`` towards ``x``).
- Cylindrical range image (:class:`CylindricalRange`): column ``j`` is the
  azimuth ``phi[j]`` (uniform step, the scan's pan step), row ``i`` the
  height ``h[i]`` in pixels on the cylinder of radius ``f`` (decreasing: row
  0 is the top).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.2, Eq. 19,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_real

#: The most columns a cylindrical range image may have (a step of 0.00036° over 360°).
_MAX_COLUMNS = 1_000_000

__all__ = [
    "spherical_to_cartesian",
    "cartesian_to_spherical",
    "spherical_to_cylindrical",
    "CylindricalRange",
    "scan_to_cylinder",
]


def spherical_to_cartesian(r, theta, phi) -> np.ndarray:
    r"""Laser samples ``(r, θ, φ)`` → points ``(x, y, z)`` in the laser's frame.

    .. math:: (x, y, z) = r\,(\sin\theta \sin\phi,\; \cos\theta,\; \sin\theta \cos\phi)

    ``θ`` from the vertical (y, up) axis, ``φ`` from z towards x: the
    spherical samples of Eq. 19 (App. A.2).

    Parameters
    ----------
    r : array_like
        Range (the scan's unit).
    theta : array_like
        Polar angle from the vertical axis, radians (``π/2`` is level).
    phi : array_like
        Azimuth (pan angle), radians. ``r``, ``theta`` and ``phi``
        broadcast together.

    Returns
    -------
    ndarray of shape (..., 3)
        ``(x, y, z)`` on the last axis.

    Examples
    --------
    >>> np.round(spherical_to_cartesian(2.0, np.pi / 2, np.pi / 2), 12) + 0.0
    array([2., 0., 0.])
    """
    r, theta, phi = (np.asarray(a, dtype=np.float64) for a in (r, theta, phi))
    return np.stack(
        np.broadcast_arrays(
            r * np.sin(theta) * np.sin(phi), r * np.cos(theta), r * np.sin(theta) * np.cos(phi)
        ),
        axis=-1,
    )


def cartesian_to_spherical(points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points ``(x, y, z)`` → ``(r, θ, φ)``, the inverse of :func:`spherical_to_cartesian`.

    The spherical coordinates of Eq. 19 (App. A.2).

    Parameters
    ----------
    points : array_like of shape (..., 3)
        ``(x, y, z)`` in the laser's frame.

    Returns
    -------
    r, theta, phi : ndarray of shape (...)
        Range, polar angle from the vertical axis and azimuth (radians).

    Examples
    --------
    >>> r, theta, phi = cartesian_to_spherical([0.0, 1.0, 1.0])
    >>> round(float(r), 6), round(float(np.degrees(theta)), 6), float(phi)
    (1.414214, 45.0, 0.0)
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim < 1 or points.shape[-1] != 3:
        raise ValueError(f"The parameter `points` must have shape (..., 3), got {points.shape}")
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    rho = np.hypot(x, z)
    return np.hypot(rho, y), np.arctan2(rho, y), np.arctan2(x, z)


def spherical_to_cylindrical(r, theta, phi, focal: float):
    r"""Map laser samples onto the cylinder of radius ``f`` (Eq. 19).

    .. math:: P(r, \theta, \phi) \to P\Big(r, \phi, \frac{f}{\tan\theta}\Big)
              \to P(r, \phi, h)

    ``h = f / tan θ`` is where the ray meets the cylinder of radius ``f``
    about the vertical axis (Eq. 14's ``v`` for the laser's own centre); the
    sample keeps its range ``r`` and azimuth ``φ``.

    Parameters
    ----------
    r, theta, phi : array_like
        Range, mirror angle from the vertical axis in (0, π), azimuth.
    focal : float
        The radius ``f``: the camera's focal length in pixels.

    Returns
    -------
    r, phi, h : ndarray
        Broadcast to a common shape.

    Examples
    --------
    >>> [round(float(value), 9) for value in spherical_to_cylindrical(5.0, np.pi / 4, 0.3, 300.0)]
    [5.0, 0.3, 300.0]
    """
    focal = check_real("focal", focal, positive=True)
    r, theta, phi = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (r, theta, phi)))
    if np.any((theta <= 0) | (theta >= np.pi)):
        raise ValueError("The parameter `theta` must lie in (0, π): the cylinder has no pole")
    return r.copy(), phi.copy(), np.asarray(focal / np.tan(theta))


@dataclass(frozen=True, eq=False)
class CylindricalRange:
    """A cylindrical range image of radius ``focal`` (Eq. 19).

    Attributes
    ----------
    range : ndarray of shape (rows, cols), float64
        ``r`` (the scan's unit); NaN where nothing was scanned.
    phi : ndarray of shape (cols,)
        Azimuth of each column, radians, increasing by a uniform step.
    h : ndarray of shape (rows,)
        Height of each row on the cylinder, pixels, decreasing (row 0 on
        top).
    focal : float
        The cylinder's radius ``f``, pixels.

    Examples
    --------
    >>> image = CylindricalRange(np.array([[5.0, 5.0], [2.0, np.nan]]), np.array([0.0, 0.01]),
    ...                          np.array([1.0, 0.0]), 300.0)
    >>> image.range.shape, float(image.phi[1] - image.phi[0]), image.focal
    ((2, 2), 0.01, 300.0)
    """

    range: np.ndarray
    phi: np.ndarray
    h: np.ndarray
    focal: float

    @property
    def phi_step(self) -> float:
        """The azimuth step between columns (radians)."""
        return float(self.phi[1] - self.phi[0]) if self.phi.size > 1 else 1.0

    @property
    def h_step(self) -> float:
        """The height step between rows (pixels, > 0)."""
        return float(self.h[0] - self.h[1]) if self.h.size > 1 else 1.0

    def index(self, phi, h) -> tuple[np.ndarray, np.ndarray]:
        """Fractional ``(row, col)`` of ``(φ, h)`` in :attr:`range`."""
        col = (np.asarray(phi, dtype=np.float64) - self.phi[0]) / self.phi_step
        row = (self.h[0] - np.asarray(h, dtype=np.float64)) / self.h_step
        return row, col


def _check_scan(r, theta, phi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A structured scan ``r (n_phi, n_theta)`` from structured or flat input."""
    arrays = []
    for name, value in (("r", r), ("theta", theta), ("phi", phi)):
        array = np.asarray(value)
        if array.dtype == np.bool_ or not (
            np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
        ):
            raise TypeError(
                f"The parameter `{name}` must be a real numeric array, got {array.dtype}"
            )
        arrays.append(array.astype(np.float64))
    r, theta, phi = arrays
    if r.ndim > 1 and theta.shape == r.shape and phi.shape == r.shape:
        r, theta, phi = r.ravel(), theta.ravel(), phi.ravel()  # per-sample angles
    if r.ndim == 1 and theta.shape == r.shape and phi.shape == r.shape:
        # flat samples: recover the grid of slices × mirror positions
        keep = np.isfinite(theta) & np.isfinite(phi)
        r, theta, phi = r[keep], theta[keep], phi[keep]
        phis, col = np.unique(np.round(phi, 9), return_inverse=True)
        thetas, row = np.unique(np.round(theta, 9), return_inverse=True)
        grid = np.full((phis.size, thetas.size), np.nan)
        grid[col, row] = r
        r, theta, phi = grid, thetas, phis
    if r.ndim != 2 or theta.shape != (r.shape[1],) or phi.shape != (r.shape[0],):
        raise ValueError(
            "The scan must be `r` of shape (n_phi, n_theta) with `theta` (n_theta,) and `phi` "
            f"(n_phi,), or three arrays of one shape; got shapes {r.shape}, "
            f"{theta.shape}, {phi.shape}"
        )
    if r.size == 0 or not np.isfinite(r).any():
        raise ValueError("The parameter `r` has no finite range (nothing was scanned)")
    if np.isinf(r).any() or (r[np.isfinite(r)] <= 0).any():
        raise ValueError("The parameter `r` must be > 0 or NaN (NaN = not scanned)")
    if not (np.all(np.isfinite(theta)) and np.all((theta > 0) & (theta < np.pi))):
        raise ValueError("The parameter `theta` must be finite and in (0, π)")
    if not np.all(np.isfinite(phi)):
        raise ValueError("The parameter `phi` must be finite")
    order_t, order_p = np.argsort(theta), np.argsort(phi)
    return r[np.ix_(order_p, order_t)], theta[order_t], phi[order_p]


def scan_to_cylinder(
    r,
    theta,
    phi,
    focal: float,
    *,
    h_step: float = 1.0,
    h_range: tuple[float, float] | None = None,
    phi_step: float | None = None,
) -> CylindricalRange:
    r"""A spherical scan as a cylindrical range image of radius ``f`` (Eq. 19).

    Each sample goes to ``(φ, h = f / tan θ)`` (:func:`spherical_to_cylindrical`).
    The image has one column per pan step (the scan's slices; slices not
    scanned are NaN columns) and one row per ``h_step`` pixels of height on
    the cylinder: with ``h_step = 1`` its rows have the mosaic's vertical
    pixel size. Each row takes, in each slice, the sample whose ``θ`` is
    nearest to ``arctan(f / h)`` — NaN if that sample is more than half the
    local mirror step away (beyond the scan) or was not measured.

    Parameters
    ----------
    r : ndarray of shape (n_phi, n_theta), or any shape shared with ``theta`` and ``phi``
        Ranges; NaN = not measured. Per-sample angles (``theta`` and ``phi``
        of ``r``'s shape, e.g. flat, or ``refsynth.acquisition``'s ``scan.npz``)
        must lie on a grid of slices × mirror positions.
    theta : ndarray of shape (n_theta,), or ``r``'s shape
        Mirror angles from the vertical axis, in (0, π).
    phi : ndarray of shape (n_phi,), or ``r``'s shape
        Azimuths of the slices.
    focal : float
        The camera's focal length, pixels.
    h_step : float, default 1
        Pixels of height per row.
    h_range : pair of float, optional
        ``(h_min, h_max)``; default: the scan's ``θ`` range.
    phi_step : float, optional
        Azimuth per column: the rig's step between adjacent slice positions,
        so that every position not scanned is a NaN column; at most the
        smallest gap between slices. Default: the smallest gap between
        slices (the rig's step only if two adjacent positions were scanned).

    Returns
    -------
    CylindricalRange

    Examples
    --------
    >>> theta = np.arctan2(300.0, [50.0, 0.0, -50.0])  # h = 50, 0, -50 px
    >>> r = np.array([[5.0, 5.0, 5.0], [6.0, np.nan, 6.0]])
    >>> image = scan_to_cylinder(r, theta, [0.0, 0.01], 300.0, h_step=25.0)
    >>> image.h.round(6) + 0.0
    array([ 50.,  25.,   0., -25., -50.])
    >>> image.range
    array([[ 5.,  6.],
           [ 5.,  6.],
           [ 5., nan],
           [ 5.,  6.],
           [ 5.,  6.]])
    """
    r, theta, phi = _check_scan(r, theta, phi)
    focal = check_real("focal", focal, positive=True)
    h_step = check_real("h_step", h_step, positive=True)
    heights = focal / np.tan(theta)  # decreasing with θ
    if h_range is None:
        h_range = (heights.min(), heights.max())
    h_min, h_max = (check_real("h_range", v) for v in h_range)
    if h_min >= h_max:
        raise ValueError(f"The parameter `h_range` must be increasing, got {h_range!r}")
    gaps = np.diff(phi)
    smallest = float(gaps[gaps > 1e-9].min()) if np.any(gaps > 1e-9) else None
    if phi_step is None:
        phi_step = 1.0 if smallest is None else smallest
    phi_step = check_real("phi_step", phi_step, positive=True)
    if smallest is not None and phi_step > smallest * (1 + 1e-6):
        raise ValueError(f"The parameter `phi_step` must be at most the smallest gap between "
                         f"slices ({smallest:.6g} rad), got {phi_step:.6g}")
    if (phi[-1] - phi[0]) / phi_step > _MAX_COLUMNS:
        raise ValueError(f"The parameter `phi_step` must leave at most {_MAX_COLUMNS} columns "
                         f"over the scan's azimuth span, got {phi_step:.6g} rad")
    n_rows = int(np.floor((h_max - h_min) / h_step + 1e-6)) + 1
    h = h_max - h_step * np.arange(n_rows)
    n_cols = int(round((phi[-1] - phi[0]) / phi_step)) + 1
    columns = phi[0] + phi_step * np.arange(n_cols)
    # rows: the nearest mirror position to θ(h), if within half the local step
    wanted = np.arctan2(focal, h)
    index = np.clip(np.searchsorted(theta, wanted), 1, theta.size - 1) if theta.size > 1 else None
    if index is None:
        nearest = np.zeros(n_rows, dtype=int)
        ok = np.abs(theta[0] - wanted) < 1e-9
    else:
        left, right = theta[index - 1], theta[index]
        nearest = np.where(wanted - left <= right - wanted, index - 1, index)
        local = np.diff(theta)[np.clip(nearest - (nearest == theta.size - 1), 0, None)]
        ok = np.abs(theta[nearest] - wanted) <= 0.5 * local + 1e-12
    image = np.full((n_rows, n_cols), np.nan)
    slot = np.round((phi - phi[0]) / phi_step).astype(int)
    values = r[:, nearest].T  # (rows, slices)
    values[~ok] = np.nan
    image[:, slot] = values
    return CylindricalRange(range=image, phi=columns, h=h, focal=focal)
