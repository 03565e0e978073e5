r"""Laser–camera registration: panorama with depth (Appendix A.2, Eqs. 19–21).

The laser's spherical samples ``(r, θ, φ)`` are mapped onto a cylinder of
radius ``f``, the camera's focal length (Eq. 19), so that range and the
panorama mosaic (:mod:`refsynth.registration.panorama`) are both cylindrical images. A
global warp from the range image's ``(φ, h)`` to the mosaic's ``(u, v)``

.. math:: u = a\phi + \alpha, \qquad v = b h + \beta \qquad \text{(Eq. 21)}

is fitted by least squares from corresponding points; it approximates the
exact relation (Eq. 20), whose vertical offset ``f ΔY / r`` depends on each
point's distance. What the global warp leaves (the paper: 5–7 px) is
removed locally: range edges (depth discontinuities) are matched to
intensity edges (Canny), and the range image is "stretched" by a
displacement field interpolated cubically between these control points,
until the misalignment falls below a threshold. Only the partial range is
needed.

Coordinates
-----------
- Laser: ``θ`` is the mirror angle from the vertical (up) axis, ``φ`` the
  azimuth (pan), radians; ``r`` the distance from the laser's centre.
- Cylindrical range image: column ``j`` is the azimuth ``phi[j]``
  (uniform step, the scan's pan step), row ``i`` the height ``h[i]`` in
  pixels on the cylinder of radius ``f`` (decreasing: row 0 is the top).
- Mosaic: ``(u, v)`` = (column, row) in pixels, rows down; so ``b ≈ −1``.

Readings and departures
-----------------------
- The paper takes "two or more corresponding points" without saying where
  they come from; :func:`register` finds them itself: a chamfer search of
  the offsets, then least squares on depth edges matched to intensity edges
  (:func:`align_global`). By default only ``α`` and ``β`` are fitted
  (``a = f``, ``b = −1`` from the geometry): with a partial scan the
  horizontal depth edges are mostly tops of furniture, whose height on the
  cylinder correlates with their parallax, and fitting ``b`` to them biases
  it by several per cent. :func:`fit_warp` is the paper's four-parameter
  fit for given correspondences.
- The local stretch moves only ``v`` by default: in the paper's own sensor
  model (a vertical offset ``ΔY`` and a common pan axis, Eq. 20) ``u = a φ
  + α`` is exact and Eq. 21's error is vertical. Range edges are matched as
  segments (a vote along each segment) rather than pixel by pixel, and the
  cubic interpolation of the control points is anchored at zero away from
  them, so that the stretch stays where edges asked for it.
- The stopping threshold is half the range image's sample spacing along
  each axis: below it a depth edge's position is not known.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.2, Eqs. 19–21,
doi:10.1007/s11263-007-0108-2.

D. Cobzas, "Image-Based Models with Applications in Mobile Robotics", PhD
thesis, University of Alberta (2003) (the image-based registration the paper
follows).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy import interpolate
from scipy import ndimage as ndi

from refsynth.registration.panorama import (
    Mosaic,
    _check_focal,
    _check_real,
    _grey,
    mosaic,
)
from refsynth.synthesis.canny import canny, sobel_gradients

__all__ = [
    "spherical_to_cartesian",
    "cartesian_to_spherical",
    "spherical_to_cylindrical",
    "CylindricalRange",
    "scan_to_cylinder",
    "Warp",
    "fit_warp",
    "eq20_warp",
    "fit_warp_eq20",
    "RangeEdges",
    "range_edges",
    "intensity_edges",
    "match_edges",
    "match_segments",
    "align_global",
    "refine_local",
    "resample_range",
    "Registration",
    "register",
    "register_scan",
    "add_register_parser",
]


# ----------------------------------------------------------------------------- Eq. 19


def spherical_to_cartesian(r, theta, phi) -> np.ndarray:
    r"""Laser samples ``(r, θ, φ)`` → points ``(x, y, z)`` in the laser's frame.

    .. math:: (x, y, z) = r\,(\sin\theta \sin\phi,\; \cos\theta,\; \sin\theta \cos\phi)

    ``θ`` from the vertical (y, up) axis, ``φ`` from z towards x.

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
    focal = _check_focal(focal)
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
        Azimuth per column; default: the smallest gap between slices.

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
    focal = _check_focal(focal)
    h_step = _check_real("h_step", h_step, positive=True)
    heights = focal / np.tan(theta)  # decreasing with θ
    if h_range is None:
        h_range = (heights.min(), heights.max())
    h_min, h_max = (_check_real("h_range", v) for v in h_range)
    if h_min >= h_max:
        raise ValueError(f"The parameter `h_range` must be increasing, got {h_range!r}")
    gaps = np.diff(phi)
    if phi_step is None:
        phi_step = float(gaps[gaps > 1e-9].min()) if np.any(gaps > 1e-9) else 1.0
    phi_step = _check_real("phi_step", phi_step, positive=True)
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


# ----------------------------------------------------------------------------- Eqs. 20–21


class Warp(NamedTuple):
    r"""The global warp of Eq. 21, ``u = a φ + α``, ``v = b h + β``.

    A tuple ``(a, b, alpha, beta)``: ``a`` in mosaic pixels per radian
    (``≈ f``), ``b`` pixels per pixel (``≈ −1``: the mosaic's rows go down),
    ``alpha``, ``beta`` in pixels.
    """

    a: float
    b: float
    alpha: float
    beta: float

    def apply(self, phi, h) -> tuple[np.ndarray, np.ndarray]:
        """``(u, v)`` of laser points ``(φ, h)``."""
        return self.a * np.asarray(phi) + self.alpha, self.b * np.asarray(h) + self.beta

    def invert(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """``(φ, h)`` of mosaic points ``(u, v)``."""
        return (np.asarray(u) - self.alpha) / self.a, (np.asarray(v) - self.beta) / self.b


def _check_points(name: str, points, minimum: int = 1) -> np.ndarray:
    array = np.asarray(points, dtype=np.float64) if np.ndim(points) else None
    if array is None or array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"The parameter `{name}` must be an (N, 2) array, got {np.shape(points)}")
    if array.shape[0] < minimum:
        raise ValueError(
            f"The parameter `{name}` must hold at least {minimum} points, got {array.shape[0]}"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"The parameter `{name}` must be finite")
    return array


def _line_fit(x: np.ndarray, y: np.ndarray, name: str) -> tuple[float, float]:
    """Least-squares ``y = s x + c`` (centred, so the result does not depend on the order)."""
    spread = x - x.mean()
    denominator = spread @ spread
    if denominator <= 1e-12 * max(1.0, float(np.abs(x).max()) ** 2) * x.size:
        raise ValueError(f"The correspondences must have at least 2 distinct {name} values")
    slope = float(spread @ (y - y.mean()) / denominator)
    return slope, float(y.mean() - slope * x.mean())


def fit_warp(laser_points, camera_points) -> Warp:
    r"""Least-squares fit of the global warp (Eq. 21) from correspondences.

    .. math:: u = a\phi + \alpha, \qquad v = b h + \beta

    minimising ``Σ (a φ_i + α − u_i)² + (b h_i + β − v_i)²``. The two
    equations share no unknown, so this is two straight-line fits.

    Parameters
    ----------
    laser_points : array_like of shape (N, 2)
        ``(φ, h)`` in the cylindrical range image (radians, pixels); N >= 2
        with at least two distinct ``φ`` and two distinct ``h``.
    camera_points : array_like of shape (N, 2)
        The corresponding ``(u, v)`` in the mosaic (pixels).

    Returns
    -------
    Warp
        ``(a, b, alpha, beta)``.

    Examples
    --------
    >>> laser = np.array([[0.0, 10.0], [0.5, -20.0], [1.0, 5.0]])
    >>> camera = np.column_stack([300 * laser[:, 0] + 12, -laser[:, 1] + 90])
    >>> tuple(round(p, 9) for p in fit_warp(laser, camera))
    (300.0, -1.0, 12.0, 90.0)
    """
    laser = _check_points("laser_points", laser_points, 2)
    camera = _check_points("camera_points", camera_points, 2)
    if laser.shape != camera.shape:
        raise ValueError(
            f"The parameters `laser_points` and `camera_points` must have the same shape, "
            f"got {laser.shape} and {camera.shape}"
        )
    a, alpha = _line_fit(laser[:, 0], camera[:, 0], "φ")
    b, beta = _line_fit(laser[:, 1], camera[:, 1], "h")
    return Warp(a, b, alpha, beta)


def eq20_warp(laser_points, r, *, a, b, alpha, v0, focal, delta_y):
    r"""The exact mapping of Eq. 20, in mosaic coordinates (rows down).

    .. math:: u = a\phi + \alpha, \qquad
              v = b h + v_0 + \frac{f\,\Delta Y}{\rho}, \qquad
              \rho = \frac{r f}{\sqrt{f^2 + h^2}}

    The paper writes ``v = f (Y − ΔY)/ρ = b h − f ΔY / r`` with ``v`` up and
    ``r`` for the horizontal distance ``ρ``; in the mosaic (rows down,
    ``b ≈ −1``) the parallax term changes sign and ``v_0`` is the row of
    the horizon. Eq. 21 replaces ``v_0 + f ΔY / ρ`` by a constant ``β``.

    Parameters
    ----------
    laser_points : array_like of shape (N, 2)
        ``(φ, h)``.
    r : array_like of shape (N,)
        Their ranges (same unit as ``delta_y``).
    a, b, alpha, v0 : float
    focal : float
    delta_y : float
        The camera's height above the laser.

    Returns
    -------
    ndarray of shape (N, 2)
        ``(u, v)``.

    Examples
    --------
    >>> eq20_warp([[0.0, 0.0]], [5.0], a=300, b=-1, alpha=0, v0=100, focal=300, delta_y=0.05)
    array([[  0., 103.]])
    """
    laser = _check_points("laser_points", laser_points)
    r = np.asarray(r, dtype=np.float64)
    focal = _check_focal(focal)
    rho = r * focal / np.hypot(focal, laser[:, 1])
    u = a * laser[:, 0] + alpha
    v = b * laser[:, 1] + v0 + focal * delta_y / rho
    return np.column_stack([u, v])


def fit_warp_eq20(laser_points, r, camera_points, focal: float) -> tuple[Warp, float]:
    r"""Least-squares fit of the exact model (Eq. 20), recovering ``ΔY`` too.

    ``u = a φ + α`` as in :func:`fit_warp`; ``v = b h + v_0 + ΔY (f / ρ)``
    is linear in ``(b, v_0, ΔY)``.

    Returns
    -------
    warp : Warp
        ``(a, b, alpha, v0)`` (``beta`` holds ``v_0``).
    delta_y : float

    Examples
    --------
    >>> laser = np.array([[0.0, 10.0], [0.5, -20.0], [1.0, 5.0], [0.2, 0.0]])
    >>> r = np.array([2.0, 6.0, 3.0, 8.0])
    >>> camera = eq20_warp(laser, r, a=300, b=-1, alpha=4, v0=90, focal=300, delta_y=0.05)
    >>> warp, delta_y = fit_warp_eq20(laser, r, camera, 300.0)
    >>> round(warp.b, 9), round(warp.beta, 9), round(delta_y, 9)
    (-1.0, 90.0, 0.05)
    """
    laser = _check_points("laser_points", laser_points, 3)
    camera = _check_points("camera_points", camera_points, 3)
    r = np.asarray(r, dtype=np.float64)
    if laser.shape != camera.shape or r.shape != (laser.shape[0],):
        raise ValueError("The parameters `laser_points`, `r` and `camera_points` must match in N")
    if not np.all(np.isfinite(r) & (r > 0)):
        raise ValueError("The parameter `r` must be finite and > 0")
    focal = _check_focal(focal)
    a, alpha = _line_fit(laser[:, 0], camera[:, 0], "φ")
    inverse_rho = np.hypot(focal, laser[:, 1]) / r  # f / ρ
    design = np.column_stack([laser[:, 1], np.ones(laser.shape[0]), inverse_rho])
    (b, v0, delta_y), _, rank, _ = np.linalg.lstsq(design, camera[:, 1], rcond=None)
    if rank < 3:
        raise ValueError("The correspondences must vary in both h and range to fit Eq. 20")
    return Warp(a, float(b), alpha, float(v0)), float(delta_y)


# ----------------------------------------------------------------------------- edges


class RangeEdges(NamedTuple):
    """Depth discontinuities of a cylindrical range image (:func:`range_edges`).

    Attributes
    ----------
    phi, h : ndarray of shape (N,)
        The edge points: midway between two adjacent samples across the jump.
    axis : ndarray of shape (N,), int
        0: the samples are side by side (a vertical edge; it fixes ``u``);
        1: one above the other (a horizontal edge; it fixes ``v``).
    r : ndarray of shape (N,)
        The nearer sample's range (the occluding side, to which the edge
        belongs).
    segment : ndarray of shape (N,), int
        Edge points of one axis that touch (8-connected in the range image)
        form a segment, cut into pieces of at most ``segment_length``
        points; one id per piece.
    """

    phi: np.ndarray
    h: np.ndarray
    axis: np.ndarray
    r: np.ndarray
    segment: np.ndarray


def range_edges(
    cylinder: CylindricalRange,
    *,
    jump: float = 0.2,
    relative: float = 0.1,
    segment_length: int = 12,
) -> RangeEdges:
    """Depth discontinuities ("3-D edges") of a partial cylindrical range image.

    Two adjacent samples (in a row or a column), both measured, are across a
    depth discontinuity if their ranges differ by more than ``jump`` and by
    more than ``relative`` times the nearer one. Pairs with an unmeasured
    sample are skipped: the edge of the scanned area is not an edge.

    Parameters
    ----------
    cylinder : CylindricalRange
    jump : float, default 0.2
        In the range's unit (m).
    relative : float, default 0.1
    segment_length : int, default 12
        Most points per segment (:attr:`RangeEdges.segment`).

    Returns
    -------
    RangeEdges

    Examples
    --------
    >>> image = CylindricalRange(np.array([[5.0, 5.0], [2.0, 2.0]]), np.array([0.0, 0.01]),
    ...                          np.array([1.0, 0.0]), 300.0)
    >>> found = range_edges(image)
    >>> found.axis, found.h, found.segment
    (array([1, 1]), array([0.5, 0.5]), array([0, 0]))
    """
    jump = _check_real("jump", jump, minimum=0.0)
    relative = _check_real("relative", relative, minimum=0.0)
    segment_length = _check_count("segment_length", segment_length)
    values = cylinder.range
    found = []
    next_id = 0
    for axis, (first, second) in enumerate(
        [(values[:, :-1], values[:, 1:]), (values[:-1, :], values[1:, :])]
    ):
        near = np.fmin(first, second)
        with np.errstate(invalid="ignore"):
            step = np.abs(first - second)
            edge = (step > jump) & (step > relative * near)
        labels, _ = ndi.label(edge, structure=np.ones((3, 3), dtype=bool))
        rows, cols = np.nonzero(edge)
        label = labels[rows, cols]
        # cut each segment into pieces of at most `segment_length` points along it
        along = cols if axis == 1 else rows
        order = np.lexsort((along, label))
        rank = np.empty(order.size, dtype=np.int64)
        first_of = np.searchsorted(label[order], label[order])
        rank[order] = np.arange(order.size) - first_of
        piece = label * (rows.size + 1) + rank // segment_length
        _, segment = np.unique(piece, return_inverse=True)
        if axis == 0:
            phi = cylinder.phi[cols] + cylinder.phi_step / 2
            h = cylinder.h[rows]
        else:
            phi = cylinder.phi[cols]
            h = cylinder.h[rows] - cylinder.h_step / 2
        found.append((phi, h, np.full(rows.size, axis), near[rows, cols], segment + next_id))
        next_id += int(segment.max()) + 1 if segment.size else 0
    phi, h, axis, r, segment = (np.concatenate(parts) for parts in zip(*found))
    return RangeEdges(phi=phi, h=h, axis=axis, r=r, segment=segment.astype(np.int64))


def _check_count(name: str, value) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"The parameter `{name}` must be an integer, got {type(value).__name__}")
    if value < 1:
        raise ValueError(f"The parameter `{name}` must be >= 1, got {value}")
    return int(value)


def intensity_edges(
    image: np.ndarray, *, sigma: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Canny edges of the mosaic and the direction of its gradient ("2-D edges").

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, 3)
        The mosaic; NaN where no view has data (no edges there, nor within
        a pixel of it).
    sigma : float, default 1
        Canny's smoothing (px).

    Returns
    -------
    edges : ndarray of shape (H, W), bool
    gx, gy : ndarray of shape (H, W)
        Sobel derivatives of the smoothed image along columns and rows.
    """
    grey = _grey(np.asarray(image, dtype=np.float64))
    valid = np.isfinite(grey)
    filled = np.where(valid, grey, 0.0)
    edges = canny(filled, sigma=sigma, mask=valid)
    numerator = ndi.gaussian_filter(filled, sigma)
    denominator = ndi.gaussian_filter(valid.astype(np.float64), sigma)
    smooth = np.where(valid, numerator / np.maximum(denominator, 1e-12), 0.0)
    gy, gx = sobel_gradients(smooth)
    return edges, gx, gy


def _candidates(positions, axis, edges, gx, gy, radius):
    """Intensity edges along each range edge's normal: ``(hits, offsets)``, both (N, 2R+1).

    ``hits[i, k]``: a Canny pixel whose gradient points along ``axis[i]``
    (within 45°) lies ``k − R`` px from ``positions[i]`` (rounded) along the
    axis; ``offsets[i, k]``: its sub-pixel position relative to
    ``positions[i]`` (a parabola through the gradient magnitude at the pixel
    and its two neighbours along the axis), NaN where there is no hit.
    """
    height, width = edges.shape
    magnitude = np.hypot(gx, gy)
    compatible = (edges & (np.abs(gx) >= np.abs(gy)), edges & (np.abs(gy) >= np.abs(gx)))
    base = np.round(positions).astype(np.int64)
    steps = np.arange(-radius, radius + 1)
    hits = np.zeros((len(positions), steps.size), dtype=bool)
    offsets = np.full((len(positions), steps.size), np.nan)
    for which in (0, 1):
        pick = np.nonzero(axis == which)[0]
        if pick.size == 0:
            continue
        cols = base[pick, 0][:, None] + (steps if which == 0 else 0)
        rows = base[pick, 1][:, None] + (steps if which == 1 else 0)
        cols, rows = np.broadcast_arrays(cols, rows)
        inside = (rows >= 1) & (rows < height - 1) & (cols >= 1) & (cols < width - 1)
        rr, cc = np.clip(rows, 1, height - 2), np.clip(cols, 1, width - 2)
        hit = inside & compatible[which][rr, cc]
        dr, dc = (0, 1) if which == 0 else (1, 0)
        m0, m1, m2 = magnitude[rr - dr, cc - dc], magnitude[rr, cc], magnitude[rr + dr, cc + dc]
        curvature = m0 - 2 * m1 + m2
        with np.errstate(invalid="ignore", divide="ignore"):
            fraction = np.where(curvature < 0, 0.5 * (m0 - m2) / curvature, 0.0)
        target = (cc if which == 0 else rr) + np.clip(fraction, -0.5, 0.5)
        hits[pick] = hit
        offsets[pick] = np.where(hit, target - positions[pick, which][:, None], np.nan)
    return hits, offsets


def match_edges(
    positions: np.ndarray,
    axis: np.ndarray,
    edges: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    radius: int,
) -> np.ndarray:
    """Match each range edge to the nearest compatible intensity edge along its normal.

    A range edge at mosaic position ``(u, v)`` with ``axis = 0`` (vertical
    edge) is searched along its row, ``axis = 1`` along its column, within
    ``±radius`` px, for a Canny pixel whose gradient points along the same
    axis (within 45°). The nearest one wins and is placed to a fraction of
    a pixel by a parabola through the gradient magnitude at it and its two
    neighbours along the axis.

    Parameters
    ----------
    positions : ndarray of shape (N, 2)
        ``(u, v)`` of the range edges in the mosaic.
    axis : ndarray of shape (N,)
    edges, gx, gy : ndarray of shape (H, W)
        From :func:`intensity_edges`.
    radius : int

    Returns
    -------
    ndarray of shape (N,)
        Where the matched intensity edge is, along the axis, relative to the
        range edge (px); NaN where nothing matched.

    Examples
    --------
    >>> edges = np.zeros((9, 9), dtype=bool)
    >>> edges[:, 6] = True
    >>> gx, gy = np.ones((9, 9)), np.zeros((9, 9))
    >>> match_edges(np.array([[4.0, 4.0], [1.0, 4.0]]), np.array([0, 0]), edges, gx, gy, 3)
    array([ 2., nan])
    """
    positions = _check_points("positions", positions)
    axis = np.asarray(axis)
    hits, offsets = _candidates(positions, axis, edges, gx, gy, int(radius))
    distance = np.where(hits, np.abs(np.arange(-radius, radius + 1)), np.inf)
    best = distance.argmin(axis=1)
    out = offsets[np.arange(len(positions)), best]
    return np.where(np.isfinite(distance.min(axis=1)), out, np.nan)


def match_segments(
    positions: np.ndarray,
    found: RangeEdges,
    edges: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    radius: int,
    *,
    support: float = 0.5,
    distinct: float = 0.7,
) -> tuple[np.ndarray, np.ndarray]:
    """Match each range-edge segment as a whole to intensity edges: one offset per segment.

    Every point of a segment votes for the offsets (along its normal,
    within ``±radius`` px, ±1 px tolerance) at which a compatible intensity
    edge lies (:func:`match_edges`' candidates). The segment takes the most
    voted offset if at least ``support`` of its points voted for it and no
    other offset two or more pixels away got ``distinct`` as many votes;
    its offset is the median of those points' sub-pixel positions. A wrong
    intensity edge (a texture line, a skirting board beside a box top that
    blends into the floor) rarely runs along a whole segment at one
    offset, and a parallel one two pixels off makes the segment ambiguous.

    Returns
    -------
    offset : ndarray of shape (N,)
        The segment's offset, for each of its points; NaN if unmatched.
    votes : ndarray of shape (N,)
        The fraction of the segment's points that agreed.
    """
    radius = int(radius)
    hits, offsets = _candidates(positions, found.axis, edges, gx, gy, radius)
    near = ndi.maximum_filter1d(hits.astype(np.int64), 3, axis=1)  # ±1 px tolerance
    n_segments = int(found.segment.max()) + 1 if found.segment.size else 0
    votes = np.zeros((n_segments, hits.shape[1]))
    np.add.at(votes, found.segment, near)
    size = np.bincount(found.segment, minlength=n_segments)
    steps = np.arange(-radius, radius + 1)
    best = (votes - 1e-3 * np.abs(steps)).argmax(axis=1)  # ties: the smaller offset
    peak = votes[np.arange(n_segments), best]
    rival = np.where(np.abs(steps[None, :] - steps[best][:, None]) >= 2, votes, 0).max(axis=1)
    accepted = (peak >= np.maximum(support * size, 2)) & (rival < distinct * peak)
    # each point's candidate nearest the segment's offset, within 1.5 px
    wanted = steps[best][found.segment]
    gap = np.where(np.isfinite(offsets), np.abs(offsets - wanted[:, None]), np.inf)
    nearest = gap.argmin(axis=1)
    point_offset = np.where(
        gap.min(axis=1) <= 1.5, offsets[np.arange(len(offsets)), nearest], np.nan
    )
    # the median of each segment's finite point offsets (sorted by segment, then value)
    finite = np.isfinite(point_offset)
    values, owners = point_offset[finite], found.segment[finite]
    order = np.lexsort((values, owners))
    values = values[order]
    counts = np.bincount(owners, minlength=n_segments)
    starts = np.cumsum(counts) - counts
    has = counts > 0
    median = np.full(n_segments, np.nan)
    lower, upper = (starts + (counts - 1) // 2)[has], (starts + counts // 2)[has]
    median[has] = 0.5 * (values[lower] + values[upper])
    segment_offset = np.where(accepted, median, np.nan)
    agreement = np.where(size > 0, peak / np.maximum(size, 1), 0.0)
    return segment_offset[found.segment], agreement[found.segment]


# ----------------------------------------------------------------------------- registration


def _forward(warp: Warp, displacement, phi, h, iterations: int = 4) -> np.ndarray:
    """Mosaic positions of laser points under the warp and the local field.

    The inverse map is ``x ↦ warp⁻¹(x + d(x))``; its inverse, ``x = warp(e) −
    d(x)``, is found by fixed-point iteration.
    """
    u0, v0 = warp.apply(phi, h)
    start = np.column_stack([u0, v0])
    if displacement is None:
        return start
    position = start.copy()
    for _ in range(iterations):
        coords = np.stack([position[:, 1], position[:, 0]])
        du = ndi.map_coordinates(displacement[0], coords, order=1, mode="nearest")
        dv = ndi.map_coordinates(displacement[1], coords, order=1, mode="nearest")
        position = start - np.column_stack([du, dv])
    return position


def _robust_line(x, y, name, slope: float, fit_slope: bool, rounds: int = 3):
    """Line fit with residuals beyond 3 × 1.4826 MAD (at least 0.5 px) trimmed.

    With ``fit_slope`` False, or when the kept points have a single ``x``,
    only the offset is fitted and ``slope`` is kept.
    """
    keep = np.ones(x.size, dtype=bool)
    for _ in range(rounds):
        s, c = slope, float(np.median(y[keep] - slope * x[keep]))
        if fit_slope:
            try:
                s, c = _line_fit(x[keep], y[keep], name)
            except ValueError:
                pass
        residual = y - (s * x + c)
        spread = 1.4826 * np.median(np.abs(residual[keep] - np.median(residual[keep])))
        keep = np.abs(residual) <= max(3 * spread, 0.5)
    return s, c


def align_global(
    image: np.ndarray,
    cylinder: CylindricalRange,
    initial: Warp,
    *,
    search: int = 12,
    radii=(3, 2),
    fit_scale: bool = False,
    min_spread: float = 0.25,
    edges=None,
    jump: float = 0.2,
) -> tuple[Warp, dict]:
    r"""The global warp (Eq. 21) from automatic edge correspondences.

    1. Range edges (:func:`range_edges`) are placed on the mosaic with
       ``initial``; the whole-pixel shift of ``(α, β)`` within
       ``±search`` px that brings them closest to intensity edges of the
       same orientation (mean truncated distance, a chamfer match) is
       applied.
    2. Each range edge is matched to the nearest compatible intensity edge
       along its normal (:func:`match_edges`) within each radius of
       ``radii`` in turn, and Eq. 21 is refitted by least squares with
       outliers trimmed: ``u = a φ + α`` from the vertical edges, ``v = b h
       + β`` from the horizontal ones.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, 3)
        The mosaic.
    cylinder : CylindricalRange
    initial : Warp
        From the rig's nominal geometry: ``(f, −1/h_step·h_step, column of
        φ = 0, horizon row)``.
    search : int, default 12
    radii : sequence of int, default (3, 2)
    fit_scale : bool, default False
        Also fit ``a`` and ``b`` (else keep those of ``initial`` and fit
        the offsets only; see :func:`register` for why that is the
        default).
    min_spread : float, default 0.25
        A scale (``a``, ``b``) is fitted only from matches spread over at
        least this fraction of the mosaic's width (height); otherwise only
        the offset (``α``, ``β``) is. Partial scans in stripes have few
        vertical depth edges, often all in one place.
    edges : tuple, optional
        ``intensity_edges(image)``, if already computed.
    jump : float, default 0.2
        Passed to :func:`range_edges`.

    Returns
    -------
    warp : Warp
    info : dict
        ``shift`` (the chamfer shift), ``matches`` (per round), and
        ``misalignment`` (mean |offset| of the matches of the last round, px).
    """
    edge_map, gx, gy = intensity_edges(image) if edges is None else edges
    found = range_edges(cylinder, jump=jump)
    if found.phi.size < 4:
        raise ValueError(
            f"The range image has {found.phi.size} depth edges; registration needs at least 4"
        )
    # 1. chamfer search on the offsets
    along_x = edge_map & (np.abs(gx) >= np.abs(gy))
    along_y = edge_map & (np.abs(gy) >= np.abs(gx))
    distance = [
        ndi.distance_transform_edt(~mask) if mask.any() else np.full(mask.shape, np.inf)
        for mask in (along_x, along_y)
    ]
    u, v = initial.apply(found.phi, found.h)
    shifts = np.arange(-search, search + 1)
    best, best_cost = (0, 0), np.inf
    height, width = edge_map.shape
    truncate = 4.0
    for dv in shifts:
        for du in shifts:
            cols = np.round(u + du).astype(int)
            rows = np.round(v + dv).astype(int)
            inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
            if inside.sum() < 4:
                continue
            cost_x = distance[0][rows[inside], cols[inside]]
            cost_y = distance[1][rows[inside], cols[inside]]
            cost = np.minimum(np.where(found.axis[inside] == 0, cost_x, cost_y), truncate)
            # points that fall off the mosaic count as unmatched
            total = (cost.sum() + truncate * (~inside).sum()) / inside.size
            if total < best_cost - 1e-12:
                best, best_cost = (int(du), int(dv)), total
    warp = Warp(initial.a, initial.b, initial.alpha + best[0], initial.beta + best[1])
    info: dict = {"shift": best, "matches": []}
    # 2. match and refit, with shrinking radii
    misalignment = np.nan
    for radius in radii:
        for _ in range(3):
            positions = _forward(warp, None, found.phi, found.h)
            offset = match_edges(positions, found.axis, edge_map, gx, gy, int(radius))
            matched = np.isfinite(offset)
            vertical = matched & (found.axis == 0)
            horizontal = matched & (found.axis == 1)
            info["matches"].append(int(matched.sum()))
            if not matched.any():
                break
            misalignment = float(np.mean(np.abs(offset[matched])))
            target_u = positions[vertical, 0] + offset[vertical]
            target_v = positions[horizontal, 1] + offset[horizontal]
            # a scale needs correspondences spread over the image; else fit the offset only
            spread_u = np.ptp(positions[vertical, 0]) if vertical.any() else 0.0
            spread_v = np.ptp(positions[horizontal, 1]) if horizontal.any() else 0.0
            scale_u = fit_scale and spread_u >= min_spread * edge_map.shape[1]
            scale_v = fit_scale and spread_v >= min_spread * edge_map.shape[0]
            a, alpha = warp.a, warp.alpha
            if vertical.any():
                a, alpha = _robust_line(found.phi[vertical], target_u, "φ", warp.a, scale_u)
            b, beta = warp.b, warp.beta
            if horizontal.any():
                b, beta = _robust_line(found.h[horizontal], target_v, "h", warp.b, scale_v)
            warp = Warp(a, b, alpha, beta)
    info["misalignment"] = misalignment
    return warp, info


def _interpolate_field(centres, values, anchors, shape, spacing: float) -> np.ndarray:
    """Cubic (Clough–Tocher) interpolation of control values, anchored at 0.

    ``anchors`` are points known to need no correction (segments that
    matched where they are). More zero anchors are put on a grid of
    ``spacing`` px wherever no control point is within ``spacing``, so that
    a correction stays local to the edges that asked for it instead of
    spreading across the panorama.
    """
    step = 4
    grid_r, grid_c = np.mgrid[0 : shape[0] + step : step, 0 : shape[1] + step : step]
    far_r, far_c = np.mgrid[0 : shape[0] + spacing : spacing, 0 : shape[1] + spacing : spacing]
    far = np.column_stack([far_c.ravel(), far_r.ravel()])
    gap = np.min(np.hypot(*(far[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)), axis=1)
    points = np.vstack([centres, anchors.reshape(-1, 2), far[gap > spacing]])
    values = np.concatenate([values, np.zeros(len(points) - len(values))])
    coarse = interpolate.griddata(points, values, (grid_c, grid_r), method="cubic", fill_value=0.0)
    r, c = np.indices(shape, dtype=np.float64)
    return ndi.map_coordinates(coarse, [r / step, c / step], order=3, mode="nearest")


def _segment_means(found: RangeEdges, positions: np.ndarray, values: np.ndarray, keep):
    """Per segment with ``keep``: the mean position of its points and its value."""
    ids = np.unique(found.segment[keep])
    counts = np.bincount(found.segment, minlength=int(found.segment.max()) + 1)
    sums = np.zeros((counts.size, 2))
    np.add.at(sums, found.segment, positions)
    centres = sums[ids] / counts[ids, None]
    first = np.zeros(counts.size, dtype=np.int64)
    first[found.segment[::-1]] = np.arange(found.segment.size)[::-1]
    return centres, values[first[ids]]


def refine_local(
    image: np.ndarray,
    cylinder: CylindricalRange,
    warp: Warp,
    *,
    max_iter: int = 6,
    radius: int = 5,
    axes: str = "v",
    spacing: float = 24.0,
    support: float = 0.5,
    distinct: float = 0.7,
    edges=None,
    jump: float = 0.2,
) -> tuple[np.ndarray, list[dict]]:
    r"""Local alignment: stretch the range image onto the intensity edges (App. A.2).

    The range image is sampled at ``warp⁻¹(x + d(x))`` for each mosaic pixel
    ``x`` (:func:`resample_range`); the displacement field ``d`` starts at 0.
    Each iteration:

    1. places the range edges on the mosaic (solving ``x = warp(e) − d(x)``);
    2. matches each segment of range edges, as a whole, to the intensity
       edges of the same orientation along its normal within ``radius``
       px (:func:`match_segments`); its offset is the misalignment at that
       control point;
    3. stops if no matched segment is misaligned by more than the
       threshold — half the range image's sample spacing along that axis,
       the resolution below which a depth edge's position is unknown;
    4. otherwise interpolates the offsets of the misaligned segments
       cubically (Clough–Tocher) between the control points — anchored at
       zero at the segments that match where they are and far from any
       control point (:func:`_interpolate_field`) — adds the result to
       ``d`` (the "stretch") and checks again for matchings.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, 3)
        The mosaic.
    cylinder : CylindricalRange
        The (partial) range image.
    warp : Warp
        The global warp (:func:`align_global` or :func:`fit_warp`).
    max_iter : int, default 6
    radius : int, default 5
        Search radius (px).
    axes : {"v", "uv"}, default "v"
        Which components of ``d`` to estimate. The paper's sensor model
        (Eq. 20) has the laser and the camera on one pan axis, a vertical
        offset ``ΔY`` apart: ``u = a φ + α`` is exact and what Eq. 21 leaves
        is vertical (``f ΔY / ρ`` varies with each point's distance), so by
        default only ``d_v`` is stretched. ``"uv"`` stretches both (for a
        rig whose axes are not aligned); vertical depth edges in a partial
        scan are located to ±1 slice only, which limits ``d_u``.
    spacing : float, default 24
        Zero anchors are put this far apart away from the control points.
    support, distinct : float
        Passed to :func:`match_segments`.
    edges : tuple, optional
        ``intensity_edges(image)``, if already computed.
    jump : float, default 0.2
        Passed to :func:`range_edges`.

    Returns
    -------
    displacement : ndarray of shape (2, H, W)
        ``d = (d_u, d_v)`` in px.
    history : list of dict
        Per iteration: ``misalignment`` (mean |offset| over the points of
        the matched segments, px), ``matched`` (their fraction of all range
        edge points) and ``controls`` (control points that moved).
    """
    if axes not in ("v", "uv", "u"):
        raise ValueError(f"The parameter `axes` must be 'v', 'u' or 'uv', got {axes!r}")
    edge_map, gx, gy = intensity_edges(image) if edges is None else edges
    found = range_edges(cylinder, jump=jump)
    shape = edge_map.shape
    threshold = (abs(warp.a) * cylinder.phi_step / 2, abs(warp.b) * cylinder.h_step / 2)
    displacement = np.zeros((2, *shape))
    history: list[dict] = []
    for _ in range(max_iter + 1):
        positions = _forward(warp, displacement, found.phi, found.h)
        offset, _ = match_segments(
            positions, found, edge_map, gx, gy, radius, support=support, distinct=distinct
        )
        matched = np.isfinite(offset)
        entry = {
            "misalignment": float(np.mean(np.abs(offset[matched]))) if matched.any() else np.nan,
            "matched": float(matched.mean()) if matched.size else 0.0,
            "controls": 0,
        }
        history.append(entry)
        if len(history) > max_iter:
            break
        update = np.zeros_like(displacement)
        for component in [("u", "v").index(axis) for axis in axes]:
            pick = matched & (found.axis == component)
            if not pick.any():
                continue
            target = positions.copy()
            target[:, component] += np.where(pick, offset, 0.0)
            # the range edge at `positions` must move to `target`: d(target) += positions − target
            centres, values = _segment_means(found, target, -offset, pick)
            moved = np.abs(values) > threshold[component]
            if not moved.any():
                continue
            entry["controls"] += int(moved.sum())
            update[component] = _interpolate_field(
                centres[moved], values[moved], centres[~moved], shape, spacing
            )
        if entry["controls"] == 0:
            break
        displacement += update
    return displacement, history


def resample_range(
    cylinder: CylindricalRange,
    warp: Warp,
    shape: tuple[int, int],
    displacement: np.ndarray | None = None,
) -> np.ndarray:
    """The range image on the mosaic's grid: ``R(x) = range(warp⁻¹(x + d(x)))``.

    Nearest-sample lookup: range is not interpolated across the jumps of
    depth edges, and unscanned slices stay NaN.

    Returns
    -------
    ndarray of shape ``shape``
        NaN where nothing was scanned.
    """
    rows, cols = np.indices(shape, dtype=np.float64)
    if displacement is not None:
        cols = cols + displacement[0]
        rows = rows + displacement[1]
    phi, h = warp.invert(cols, rows)
    row, col = cylinder.index(phi, h)
    r_i, c_i = np.round(row).astype(np.int64), np.round(col).astype(np.int64)
    inside = (r_i >= 0) & (r_i < cylinder.range.shape[0]) & (c_i >= 0)
    inside &= c_i < cylinder.range.shape[1]
    out = np.full(shape, np.nan)
    out[inside] = cylinder.range[r_i[inside], c_i[inside]]
    return out


@dataclass(frozen=True, eq=False)
class Registration:
    """What :func:`register` returns: everything between the views + scan and synthesis.

    Attributes
    ----------
    intensity : ndarray of shape (H, W) or (H, W, C)
        The mosaic cropped to the largest rectangle every pixel of which is
        covered (finite everywhere).
    partial_range : ndarray of shape (H, W)
        The registered range on the same grid; NaN where not scanned.
    crop : tuple of int
        ``(row0, row1, col0, col1)`` of the crop in the mosaic.
    mosaic : Mosaic
    cylinder : CylindricalRange
    initial : Warp
        The warp from the rig's nominal geometry.
    warp : Warp
        The global warp (Eq. 21) after :func:`align_global`.
    displacement : ndarray of shape (2, H_m, W_m) or None
        The local field of :func:`refine_local` on the whole mosaic.
    global_info : dict
    history : list of dict
        The local refinement's iterations (misalignment before → after).
    """

    intensity: np.ndarray
    partial_range: np.ndarray
    crop: tuple[int, int, int, int]
    mosaic: Mosaic
    cylinder: CylindricalRange
    initial: Warp
    warp: Warp
    displacement: np.ndarray | None
    global_info: dict = field(default_factory=dict)
    history: list = field(default_factory=list)

    def forward(self, phi, h) -> np.ndarray:
        """Mosaic ``(u, v)`` (full mosaic, not the crop) of laser points ``(φ, h)``."""
        phi, h = np.broadcast_arrays(np.asarray(phi, float), np.asarray(h, float))
        out = _forward(self.warp, self.displacement, phi.ravel(), h.ravel())
        return out.reshape(*phi.shape, 2)


def _covered_rectangle(weight: np.ndarray) -> tuple[int, int, int, int]:
    """The rows and columns, as ``(row0, row1, col0, col1)``, all of whose pixels are covered.

    Rows: those covered across the whole covered column span; columns: the
    longest run of fully covered columns within those rows.
    """
    covered = weight > 0
    columns = np.nonzero(covered.any(axis=0))[0]
    full_rows = np.nonzero(covered[:, columns[0] : columns[-1] + 1].all(axis=1))[0]
    if full_rows.size == 0:  # fall back: the rows covered in most columns
        counts = covered.sum(axis=1)
        full_rows = np.nonzero(counts >= np.percentile(counts[counts > 0], 50))[0]
    row0, row1 = int(full_rows[0]), int(full_rows[-1]) + 1
    # the longest contiguous run of rows in [row0, row1) that are fully covered
    runs = np.split(full_rows, np.nonzero(np.diff(full_rows) > 1)[0] + 1)
    longest = max(runs, key=len)
    row0, row1 = int(longest[0]), int(longest[-1]) + 1
    good = covered[row0:row1].all(axis=0)
    idx = np.nonzero(good)[0]
    runs = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1)
    longest = max(runs, key=len)
    return row0, row1, int(longest[0]), int(longest[-1]) + 1


def register(
    images,
    pan_angles,
    focal: float,
    scan,
    *,
    refine: bool = True,
    fit_scale: bool = False,
    search: int = 12,
    jump: float = 0.2,
    full_circle: bool = False,
) -> Registration:
    """Camera views + a partial spherical scan → registered intensity and range (App. A).

    1. The cylindrical mosaic of the views (Eqs. 14–18, :func:`refsynth.registration.panorama.mosaic`),
       started from the known pan angles.
    2. The scan on the cylinder of radius ``f`` (Eq. 19, :func:`scan_to_cylinder`).
    3. The global warp (Eq. 21) from the rig's nominal geometry (``a = f``,
       ``b = −1``, the laser's azimuth 0 at the camera's pan angle 0, the
       horizon at view 0's centre row), refined on edge correspondences
       (:func:`align_global`).
    4. With ``refine``, the local stretch (:func:`refine_local`).
    5. The range resampled on the mosaic's grid (:func:`resample_range`),
       and both cropped to the fully covered rectangle.

    Parameters
    ----------
    images : sequence of ndarray of shape (H, W) or (H, W, 3)
        The camera views in pan order (every 18° in the paper).
    pan_angles : array_like of shape (N,)
        Their nominal pan angles, radians, in the laser's azimuth frame.
    focal : float
        Focal length, pixels.
    scan : tuple ``(r, theta, phi)``
        The spherical scan (see :func:`scan_to_cylinder`); NaN = not
        measured.
    refine : bool, default True
    fit_scale : bool, default False
        Also fit ``a``, ``b`` of Eq. 21 to the automatic edge matches. Off
        by default: both images are cylinders of radius ``f`` with pixels
        of one size, so ``a = f`` and ``b = −1`` up to the encoders'
        calibration, and in a partial scan the horizontal depth edges are
        mostly tops of furniture, whose height ``h`` correlates with their
        parallax ``f ΔY / ρ``, which biases ``b`` (by 4–7 % on the rig).
    search : int, default 12
        Chamfer search of the offsets (px).
    jump : float, default 0.2
        Depth discontinuity threshold (the scan's unit).
    full_circle : bool, default False
        The views cover 360°.

    Returns
    -------
    Registration
    """
    focal = _check_focal(focal)
    angles = np.asarray(pan_angles, dtype=np.float64)
    if angles.ndim != 1 or not np.all(np.isfinite(angles)):
        raise ValueError("The parameter `pan_angles` must be a 1-D array of finite angles")
    if angles.size != len(images):
        raise ValueError(
            f"The parameter `pan_angles` must have one angle per image ({len(images)}), "
            f"got {angles.size}"
        )
    if not isinstance(scan, (tuple, list)) or len(scan) != 3:
        raise TypeError("The parameter `scan` must be a tuple (r, theta, phi)")
    steps = np.diff(angles)
    if full_circle:
        steps = np.append(steps, 2 * np.pi - (angles[-1] - angles[0]))
    pano = mosaic(images, focal, steps, start_angle=float(angles[0]), full_circle=full_circle)
    height = pano.image.shape[0]
    h_top = pano.horizon_row + 4.0  # rows of the mosaic, in h, with a margin
    cylinder = scan_to_cylinder(
        *scan, focal, h_range=(pano.horizon_row - height - 4.0, h_top)
    )
    initial = Warp(focal, -1.0, float(pano.column_of(0.0)), pano.horizon_row)
    edges = intensity_edges(pano.image)
    warp, global_info = align_global(
        pano.image, cylinder, initial, search=search, fit_scale=fit_scale, edges=edges, jump=jump
    )
    displacement, history = None, []
    if refine:
        displacement, history = refine_local(pano.image, cylinder, warp, edges=edges, jump=jump)
    full_range = resample_range(cylinder, warp, pano.weight.shape, displacement)
    row0, row1, col0, col1 = _covered_rectangle(pano.weight)
    return Registration(
        intensity=pano.image[row0:row1, col0:col1].copy(),
        partial_range=full_range[row0:row1, col0:col1].copy(),
        crop=(row0, row1, col0, col1),
        mosaic=pano,
        cylinder=cylinder,
        initial=initial,
        warp=warp,
        displacement=displacement,
        global_info=global_info,
        history=history,
    )


def register_scan(images, pan_angles, focal: float, scan, **options):
    """Camera views + partial scan → ``(intensity, partial_range, info)`` for ``synthesize()``.

    A thin front end to :func:`register` (same parameters): the intensity is
    the cropped mosaic (finite everywhere), the partial range is on the same
    grid with NaN where the laser did not scan, and ``info`` is the
    :class:`Registration`.

    Examples
    --------
    >>> from refsynth.scenes.registration_rig import rig_room, render_views, laser_scan
    >>> room = rig_room(0)
    >>> views = render_views(room, n_views=3, start_angle=-0.3, height=96, supersample=1)
    >>> scan = laser_scan(room, phi_range=(-0.5, 0.5), stripes=None)
    >>> intensity, partial, info = register_scan(
    ...     views.images, views.pan_angles, 300.0, (scan.r, scan.theta, scan.phi))
    >>> intensity.shape == partial.shape and bool(np.isfinite(intensity).all())
    True
    """
    result = register(images, pan_angles, focal, scan, **options)
    return result.intensity, result.partial_range, result


# ----------------------------------------------------------------------------- command line


def _cmd_register(args) -> int:
    from refsynth.io import read_array

    images = [read_array(name) for name in args.images]
    scan_path = Path(args.scan)
    if not scan_path.is_file():
        raise FileNotFoundError(f"scan file not found: {scan_path}")
    try:
        with np.load(scan_path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (OSError, EOFError, ValueError, AttributeError) as error:
        raise ValueError(f"cannot read scan file {scan_path} as .npz: {error}") from error
    missing = {"r", "theta", "phi"} - set(arrays)
    if missing:
        raise ValueError(f"scan file {scan_path} lacks the arrays {sorted(missing)}")
    scan = (arrays["r"], arrays["theta"], arrays["phi"])
    angles = np.radians(args.start + args.pan_step * np.arange(len(images)))
    result = register(images, angles, args.focal, scan, refine=not args.no_refine)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    np.save(out / "intensity.npy", result.intensity)
    np.save(out / "partial_range.npy", result.partial_range)
    steps = [entry["misalignment"] for entry in result.history]
    before, after = (steps[0], steps[-1]) if steps else (result.global_info["misalignment"],) * 2
    print(
        f"wrote {out / 'intensity.npy'} and {out / 'partial_range.npy'}: "
        f"{result.intensity.shape[0]}x{result.intensity.shape[1]}, "
        f"{np.isfinite(result.partial_range).mean():.0%} with range; "
        f"warp a={result.warp.a:.2f} b={result.warp.b:.4f} alpha={result.warp.alpha:.2f} "
        f"beta={result.warp.beta:.2f}; edge misalignment {before:.2f} -> {after:.2f} px"
    )
    return 0


def add_register_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``register IMAGES... --scan SCAN.npz`` to a ``python -m refsynth`` subparser set.

    The handler raises ``ValueError``/``TypeError``/``OSError`` with one-line
    messages for user errors.
    """
    parser = subparsers.add_parser(
        "register",
        help="build the panorama from camera views and register a partial laser scan to it",
    )
    parser.add_argument("images", nargs="+", help="camera views in pan order (PNG/JPG/NPY)")
    parser.add_argument("--scan", required=True,
                        help="NPZ with r (n_phi, n_theta), theta (n_theta,), phi (n_phi,) "
                        "in radians, or three flat arrays of samples; NaN r = not measured")
    parser.add_argument("--focal", type=float, required=True, help="focal length in pixels")
    parser.add_argument("--pan-step", type=float, default=18.0,
                        help="degrees between views (default 18)")
    parser.add_argument("--start", type=float, default=0.0,
                        help="pan angle of the first view in the laser's frame, degrees")
    parser.add_argument("--out", default="refsynth-register",
                        help="folder for intensity.npy and partial_range.npy")
    parser.add_argument("--no-refine", action="store_true", help="global warp only (Eq. 21)")
    parser.set_defaults(func=_cmd_register)
    return parser



