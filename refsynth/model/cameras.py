r"""The two cameras of stage 3: a range image back to 3-D points, and points back to pixels.

Stage 3 of the paper (§1: "(3) data integration for model representation")
starts from what stage 2 returns: a dense range image on the grid of an
intensity image. Turning it into points needs the camera that made the grid.
refsynth meets two:

- :class:`CylindricalCamera`, the panorama of the registration stage
  (Appendix A): column ``j`` is the pan angle ``φ`` and row ``i`` the height
  ``h`` on the cylinder of radius ``f`` (Eqs. 14 and 19). Its range is the
  **Euclidean distance** from the optical centre — what the laser measures
  and what :func:`refsynth.registration.scan_to_cylinder` stores in each
  pixel (Eq. 19 keeps ``r``).
- :class:`PinholeCamera` ``(f, c_x, c_y)``, the Middlebury pairs (§3.3): its
  range is the **depth** ``z`` along the optical axis, which a disparity
  gives as ``z = f B / (d + d_offs)`` (:func:`disparity_to_depth`).

Frame
-----
Both cameras use refsynth's frame (Eq. 14, :func:`refsynth.registration.project_to_cylinder`,
:func:`refsynth.scenes.rig_room`): x to the right, y up,
z forward (pan angle 0); pan angles grow from z towards x. Image rows go
down and columns right, so an image reads as the view from the camera.

For the cylinder, a pixel ``(i, j)`` is the ray through the point
``(f sin φ, h, f cos φ)`` of the cylinder (Eq. 14 inverted; Eq. 19's
``h = f / tan θ``), so with range ``r``

.. math:: \mathbf{p} = \frac{r}{\sqrt{1 + (h/f)^2}}\,
          \Big(\sin\phi,\; \frac{h}{f},\; \cos\phi\Big), \qquad
          \phi = (j - c_x)\,\Delta\phi, \quad h = (c_y - i)\,\Delta h

and the inverse is Eq. 14, ``φ = arctan(x / z)``, ``h = f y / √(x² + z²)``,
with ``r = |p|``. For the pinhole, ``p = z ((j − c_x) / f, (c_y − i) / f, 1)``.

References
----------
Torres-Méndez & Dudek (2008; in full in :mod:`refsynth.model`), §1 (the three
stages), Appendix A (Eqs. 14, 19), doi:10.1007/s11263-007-0108-2.

D. Scharstein et al., "High-resolution stereo datasets with subpixel-accurate
ground truth", GCPR 2014 (the Middlebury ``calib.txt``: ``Z = baseline · f /
(d + doffs)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_real, check_real_array

__all__ = ["CylindricalCamera", "PinholeCamera", "disparity_to_depth", "check_range_image"]


def check_range_image(range_image, name: str = "range_image") -> np.ndarray:
    """``range_image`` as a float64 (H, W) copy: finite and > 0 = a point, anything else = none.

    Raises ``TypeError``/``ValueError`` naming the parameter for a non-array,
    a non-real dtype, or a shape other than (H, W) with H, W >= 1.
    """
    array = check_real_array(name, range_image, ndims=(2,))
    return array.astype(np.float64)


def _check_points(points) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim < 1 or points.shape[-1] != 3:
        raise ValueError(f"The parameter `points` must have shape (..., 3), got {points.shape}")
    return points


def _grid(shape) -> tuple[np.ndarray, np.ndarray]:
    if (
        not isinstance(shape, (tuple, list))
        or len(shape) != 2
        or not all(isinstance(n, (int, np.integer)) and n >= 1 for n in shape)
    ):
        raise ValueError(f"The parameter `shape` must be a pair of integers >= 1, got {shape!r}")
    return np.arange(shape[0], dtype=np.float64), np.arange(shape[1], dtype=np.float64)


def _finite_positive(range_image: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return np.isfinite(range_image) & (range_image > 0)


@dataclass(frozen=True)
class CylindricalCamera:
    r"""The panorama's camera: a cylinder of radius ``f`` about the vertical axis (Eqs. 14, 19).

    Column ``j`` looks along the pan angle ``φ = (j − c_x) Δφ`` and row ``i``
    at the height ``h = (c_y − i) Δh`` on the cylinder (pixels, positive up).
    The range of a pixel is the Euclidean distance from the optical centre.

    Parameters
    ----------
    focal : float
        ``f``, the cylinder's radius in pixels (the camera's focal length).
    cx : float
        The (fractional) column of pan angle 0.
    cy : float
        The (fractional) row of the horizon, ``h = 0``.
    phi_step : float, optional
        ``Δφ``, radians per column; default ``1 / f`` (the mosaic's columns:
        one pixel of arc on the cylinder).
    h_step : float, default 1
        ``Δh``, pixels of height per row (> 0: rows go down).

    Examples
    --------
    >>> camera = CylindricalCamera(300.0, cx=0.0, cy=1.0)
    >>> points = camera.back_project(np.full((3, 2), 5.0))
    >>> np.round(points[1, 0], 12) + 0.0          # the horizon, pan angle 0: straight ahead
    array([0., 0., 5.])
    >>> row, col, r = camera.project(points[0, 1])
    >>> round(float(row), 9) + 0.0, round(float(col), 9), round(float(r), 9)
    (0.0, 1.0, 5.0)
    """

    focal: float
    cx: float
    cy: float
    phi_step: float | None = None
    h_step: float = 1.0

    #: What a pixel's range measures.
    range_kind = "distance"

    def __post_init__(self):
        object.__setattr__(self, "focal", check_real("focal", self.focal, positive=True))
        object.__setattr__(self, "cx", check_real("cx", self.cx))
        object.__setattr__(self, "cy", check_real("cy", self.cy))
        step = 1.0 / self.focal if self.phi_step is None else self.phi_step
        object.__setattr__(self, "phi_step", check_real("phi_step", step, positive=True))
        object.__setattr__(self, "h_step", check_real("h_step", self.h_step, positive=True))

    # -- constructors --------------------------------------------------------------------

    @classmethod
    def centred(cls, focal: float, shape, **steps) -> CylindricalCamera:
        """Pan angle 0 and the horizon at the centre of an image of ``shape`` (H, W)."""
        rows, cols = _grid(shape)
        return cls(focal, cx=(cols.size - 1) / 2, cy=(rows.size - 1) / 2, **steps)

    @classmethod
    def panorama(cls, focal: float, shape) -> CylindricalCamera:
        """A 360° panorama of ``shape`` (H, W): ``Δφ = 2π / W``, column 0 at pan angle 0."""
        rows, cols = _grid(shape)
        return cls(focal, cx=0.0, cy=(rows.size - 1) / 2, phi_step=2 * math.pi / cols.size)

    @classmethod
    def from_cylinder(cls, cylinder) -> CylindricalCamera:
        """The camera of a cylindrical range image (Eq. 19).

        ``cylinder`` is a :class:`refsynth.registration.CylindricalRange` (or
        anything with its ``phi``, ``h``, ``focal``, ``phi_step``, ``h_step``):
        column ``j`` at ``phi[j]``, row ``i`` at ``h[i]``.
        """
        phi_step, h_step = float(cylinder.phi_step), float(cylinder.h_step)
        return cls(
            float(cylinder.focal),
            cx=-float(cylinder.phi[0]) / phi_step,
            cy=float(cylinder.h[0]) / h_step,
            phi_step=phi_step,
            h_step=h_step,
        )

    @classmethod
    def from_warp(cls, warp, focal: float, origin=(0, 0)) -> CylindricalCamera:
        r"""The camera of a registered panorama, through the global warp of Eq. 21.

        Eq. 21 places the laser's ``(φ, h)`` at the mosaic's ``(u, v) = (aφ + α,
        bh + β)``; a pixel ``(i, j)`` of an image cut from the mosaic at
        ``origin = (row0, col0)`` (e.g. ``Registration.crop[0]`` and
        ``crop[2]``) is ``u = j + col0``, ``v = i + row0``, hence ``Δφ = 1/a``,
        ``c_x = α − col0``, ``Δh = −1/b``, ``c_y = β − row0``. The points are in
        the laser's frame, whose distances the range image holds. (The local
        stretch of the registration, a fraction of a pixel, is ignored.)

        Parameters
        ----------
        warp : refsynth.registration.Warp
            Or anything with ``a``, ``b``, ``alpha``, ``beta`` (``a > 0``,
            ``b < 0``: rows go down).
        focal : float
            The cylinder's radius ``f`` of Eq. 19 (pixels).
        origin : pair of int, default (0, 0)
        """
        a, b = float(warp.a), float(warp.b)
        if not (a > 0 and b < 0):
            raise ValueError(
                f"The parameter `warp` must have a > 0 and b < 0 (rows go down), got a={a}, b={b}"
            )
        row0, col0 = (check_real("origin", float(v)) for v in origin)
        return cls(
            focal, cx=float(warp.alpha) - col0, cy=float(warp.beta) - row0,
            phi_step=1.0 / a, h_step=-1.0 / b,
        )

    # -- the grid ------------------------------------------------------------------------

    def azimuth(self, cols) -> np.ndarray:
        """``φ`` of (fractional) columns, radians."""
        return (np.asarray(cols, dtype=np.float64) - self.cx) * self.phi_step

    def height(self, rows) -> np.ndarray:
        """``h`` of (fractional) rows, pixels on the cylinder, positive up."""
        return (self.cy - np.asarray(rows, dtype=np.float64)) * self.h_step

    def covers_360(self, width: int) -> bool:
        """Whether ``width`` columns close the circle (to within half a column)."""
        return abs(width * self.phi_step - 2 * math.pi) <= 0.5 * self.phi_step

    def directions(self, shape) -> np.ndarray:
        """Unit rays of every pixel of an image of ``shape`` (H, W): (H, W, 3)."""
        rows, cols = _grid(shape)
        phi = self.azimuth(cols)[None, :]
        slope = (self.height(rows) / self.focal)[:, None]
        norm = np.sqrt(1.0 + slope * slope)
        x, y, z = np.broadcast_arrays(np.sin(phi) / norm, slope / norm, np.cos(phi) / norm)
        return np.stack([x, y, z], axis=-1)

    def back_project(self, range_image) -> np.ndarray:
        """Points (H, W, 3) of a range image of Euclidean distances; NaN where there is no range.

        A pixel has a point where its range is finite and > 0.
        """
        r = check_range_image(range_image)
        r[~_finite_positive(r)] = np.nan
        return self.directions(r.shape) * r[..., None]

    def project(self, points, width: int | None = None):
        """Points (..., 3) → fractional ``(row, col, range)`` (Eq. 14, ``range = |p|``).

        The pan angle is taken within ±π of pan angle 0 (column ``c_x``), or,
        given the image ``width``, of the image's centre column, so that
        ``project(back_project(R))`` returns each pixel of any panorama up to
        360°. Points on the cylinder's axis (x = z = 0) give NaN.
        """
        p = _check_points(points)
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        rho = np.hypot(x, z)
        centre = 0.0 if width is None else float(self.azimuth((width - 1) / 2))
        phi = np.arctan2(x, z)
        phi = centre + np.mod(phi - centre + math.pi, 2 * math.pi) - math.pi
        with np.errstate(divide="ignore", invalid="ignore"):
            h = np.where(rho > 0, self.focal * y / rho, np.nan)
        col = np.where(rho > 0, self.cx + phi / self.phi_step, np.nan)
        row = self.cy - h / self.h_step
        return row, col, np.sqrt(rho * rho + y * y)


@dataclass(frozen=True)
class PinholeCamera:
    r"""A pinhole camera ``(f, c_x, c_y)``, square pixels, no distortion; range = depth ``z``.

    .. math:: \mathbf{p} = z\,\Big(\frac{j - c_x}{f},\; \frac{c_y - i}{f},\; 1\Big)

    (y up, as refsynth's frame; rows go down). Middlebury's ``calib.txt``
    gives ``cam0 = [f 0 cx; 0 f cy; 0 0 1]``.

    Parameters
    ----------
    focal : float
        ``f`` in pixels.
    cx, cy : float
        The principal point (column, row).

    Examples
    --------
    >>> camera = PinholeCamera(500.0, cx=1.0, cy=1.0)
    >>> camera.back_project(np.full((3, 3), 2.0))[0, 2]
    array([0.004, 0.004, 2.   ])
    """

    focal: float
    cx: float
    cy: float

    #: What a pixel's range measures.
    range_kind = "depth"

    def __post_init__(self):
        object.__setattr__(self, "focal", check_real("focal", self.focal, positive=True))
        object.__setattr__(self, "cx", check_real("cx", self.cx))
        object.__setattr__(self, "cy", check_real("cy", self.cy))

    @classmethod
    def centred(cls, focal: float, shape) -> PinholeCamera:
        """The principal point at the centre of an image of ``shape`` (H, W)."""
        rows, cols = _grid(shape)
        return cls(focal, cx=(cols.size - 1) / 2, cy=(rows.size - 1) / 2)

    def covers_360(self, width: int) -> bool:
        """Always False: a pinhole sees less than a half space."""
        return False

    def directions(self, shape) -> np.ndarray:
        """Rays ``((j − c_x)/f, (c_y − i)/f, 1)`` of every pixel (z = 1, not unit): (H, W, 3)."""
        rows, cols = _grid(shape)
        x = ((cols - self.cx) / self.focal)[None, :]
        y = ((self.cy - rows) / self.focal)[:, None]
        x, y, z = np.broadcast_arrays(x, y, 1.0)
        return np.stack([x, y, z], axis=-1)

    def back_project(self, depth) -> np.ndarray:
        """Points (H, W, 3) of a depth image; NaN where the depth is not finite and > 0."""
        z = check_range_image(depth, "depth")
        z[~_finite_positive(z)] = np.nan
        return self.directions(z.shape) * z[..., None]

    def project(self, points, width: int | None = None):
        """Points (..., 3) → fractional ``(row, col, depth)``; NaN for z <= 0 (behind)."""
        p = _check_points(points)
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            front = z > 0
            col = np.where(front, self.cx + self.focal * x / z, np.nan)
            row = np.where(front, self.cy - self.focal * y / z, np.nan)
        return row, col, np.where(front, z, np.nan)


def disparity_to_depth(disparity, focal: float, baseline: float, doffs: float = 0.0):
    r"""Depth from a rectified pair's disparity: ``z = f B / (d + d_offs)``.

    Parameters
    ----------
    disparity : ndarray
        ``d`` in pixels; NaN, ``inf`` (Middlebury's unknown) or ``d + d_offs
        <= 0`` give NaN.
    focal : float
        ``f`` in pixels (> 0).
    baseline : float
        ``B``, the distance between the optical centres (> 0), in the unit
        wanted for ``z`` (Middlebury: mm).
    doffs : float, default 0
        ``d_offs``, the difference of the two principal points' columns.

    Returns
    -------
    ndarray of the same shape, float64

    Examples
    --------
    >>> disparity_to_depth(np.array([10.0, np.inf, -1.0]), 1000.0, 0.1)
    array([10., nan, nan])
    """
    array = check_real_array("disparity", np.asarray(disparity))
    focal = check_real("focal", focal, positive=True)
    baseline = check_real("baseline", baseline, positive=True)
    doffs = check_real("doffs", doffs)
    d = array.astype(np.float64) + doffs
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isfinite(d) & (d > 0), focal * baseline / d, np.nan)
