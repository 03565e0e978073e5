r"""The warp from the range image to the mosaic (Appendix A.2, Eqs. 20–21).

Both images live on the cylinder of radius ``f`` (Eqs. 14 and 19), so a
laser point ``(φ, h)`` of the range image
(:mod:`refsynth.registration.range_image`) lands in the mosaic at

.. math:: u = a\phi + \alpha, \qquad v = b h + \beta \qquad \text{(Eq. 21)}

with ``a`` and ``b`` absorbing the two images' resolutions (``a ≈ f``,
``b ≈ −1``: the mosaic's rows go down), ``α`` the pan offset and ``β`` the
vertical one. Eq. 21 approximates the exact relation (Eq. 20), whose vertical
offset ``f ΔY / ρ`` depends on each point's distance; :func:`eq20_warp` and
:func:`fit_warp_eq20` are that model, for comparison. What the global warp
leaves is removed by a local displacement field ``d`` on the mosaic
(:func:`refsynth.registration.alignment.refine_local`): the range image is
sampled at ``warp⁻¹(x + d(x))``, and :func:`warp_forward` places laser points
on the mosaic under both.

Coordinates: the mosaic's ``(u, v)`` are (column, row) in pixels, rows down.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.2, Eqs. 20–21,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import ndimage as ndi

from refsynth._checks import check_real

__all__ = [
    "Warp",
    "check_points",
    "fit_line",
    "fit_warp",
    "eq20_warp",
    "fit_warp_eq20",
    "warp_forward",
]


# ----------------------------------------------------------------------------- Eqs. 20–21


class Warp(NamedTuple):
    r"""The global warp of Eq. 21, ``u = a φ + α``, ``v = b h + β``.

    A tuple ``(a, b, alpha, beta)``: ``a`` in mosaic pixels per radian
    (``≈ f``), ``b`` pixels per pixel (``≈ −1``: the mosaic's rows go down),
    ``alpha``, ``beta`` in pixels.

    Examples
    --------
    >>> warp = Warp(a=300.0, b=-1.0, alpha=4.0, beta=90.0)
    >>> phi, h = 0.1, 20.0
    >>> warp.a * phi + warp.alpha, warp.b * h + warp.beta  # (u, v) of Eq. 21
    (34.0, 70.0)
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


def check_points(name: str, points, minimum: int = 1) -> np.ndarray:
    """``points`` as a finite float64 array of shape (N, 2) with N >= ``minimum``, or raise.

    Examples
    --------
    >>> check_points("laser_points", [[0.0, 1.0], [2.0, 3.0]], 2).shape
    (2, 2)
    >>> check_points("laser_points", [0.0, 1.0])
    Traceback (most recent call last):
    ...
    ValueError: The parameter `laser_points` must be an (N, 2) array, got (2,)
    """
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


def fit_line(x: np.ndarray, y: np.ndarray, name: str) -> tuple[float, float]:
    """Least-squares ``y = s x + c``: one of Eq. 21's two lines, ``(slope, offset)``.

    Centred, so the result does not depend on the order of the points.
    ``name`` is the variable ``x`` stands for, in the error raised when the
    points have fewer than two distinct ``x``.

    Examples
    --------
    >>> fit_line(np.array([0.0, 1.0, 2.0]), np.array([1.0, 3.0, 5.0]), "φ")
    (2.0, 1.0)
    """
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
    laser = check_points("laser_points", laser_points, 2)
    camera = check_points("camera_points", camera_points, 2)
    if laser.shape != camera.shape:
        raise ValueError(
            f"The parameters `laser_points` and `camera_points` must have the same shape, "
            f"got {laser.shape} and {camera.shape}"
        )
    a, alpha = fit_line(laser[:, 0], camera[:, 0], "φ")
    b, beta = fit_line(laser[:, 1], camera[:, 1], "h")
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
        The scales (px per radian, px per px), the pan offset and the horizon row, px.
    focal : float
        ``f`` in pixels.
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
    laser = check_points("laser_points", laser_points)
    r = np.asarray(r, dtype=np.float64)
    focal = check_real("focal", focal, positive=True)
    rho = r * focal / np.hypot(focal, laser[:, 1])
    u = a * laser[:, 0] + alpha
    v = b * laser[:, 1] + v0 + focal * delta_y / rho
    return np.column_stack([u, v])


def fit_warp_eq20(laser_points, r, camera_points, focal: float) -> tuple[Warp, float]:
    r"""Least-squares fit of the exact model (Eq. 20), recovering ``ΔY`` too.

    ``u = a φ + α`` as in :func:`fit_warp`; ``v = b h + v_0 + ΔY (f / ρ)``
    is linear in ``(b, v_0, ΔY)``.

    Parameters
    ----------
    laser_points : ndarray of shape (N, 2)
        ``(φ, h)`` of the matched points on the range cylinder (radians,
        pixels).
    r : ndarray of shape (N,)
        Their laser range (the scan's unit); Eq. 20's horizontal distance
        is ``ρ = r f / √(f² + h²)`` (see :func:`eq20_warp`).
    camera_points : ndarray of shape (N, 2)
        ``(u, v)`` of the same points in the mosaic, pixels.
    focal : float
        ``f`` in pixels.

    Returns
    -------
    warp : Warp
        ``(a, b, alpha, v0)`` (``beta`` holds ``v_0``).
    delta_y : float
        The camera's height above the laser, in the unit of ``r``.

    Examples
    --------
    >>> laser = np.array([[0.0, 10.0], [0.5, -20.0], [1.0, 5.0], [0.2, 0.0]])
    >>> r = np.array([2.0, 6.0, 3.0, 8.0])
    >>> camera = eq20_warp(laser, r, a=300, b=-1, alpha=4, v0=90, focal=300, delta_y=0.05)
    >>> warp, delta_y = fit_warp_eq20(laser, r, camera, 300.0)
    >>> round(warp.b, 9), round(warp.beta, 9), round(delta_y, 9)
    (-1.0, 90.0, 0.05)
    """
    laser = check_points("laser_points", laser_points, 3)
    camera = check_points("camera_points", camera_points, 3)
    r = np.asarray(r, dtype=np.float64)
    if laser.shape != camera.shape or r.shape != (laser.shape[0],):
        raise ValueError("The parameters `laser_points`, `r` and `camera_points` must match in N")
    if not np.all(np.isfinite(r) & (r > 0)):
        raise ValueError("The parameter `r` must be finite and > 0")
    focal = check_real("focal", focal, positive=True)
    a, alpha = fit_line(laser[:, 0], camera[:, 0], "φ")
    inverse_rho = np.hypot(focal, laser[:, 1]) / r  # f / ρ
    design = np.column_stack([laser[:, 1], np.ones(laser.shape[0]), inverse_rho])
    (b, v0, delta_y), _, rank, _ = np.linalg.lstsq(design, camera[:, 1], rcond=None)
    if rank < 3:
        raise ValueError("The correspondences must vary in both h and range to fit Eq. 20")
    return Warp(a, float(b), alpha, float(v0)), float(delta_y)


# ----------------------------------------------------------------------------- forward


def warp_forward(warp: Warp, displacement, phi, h, iterations: int = 4) -> np.ndarray:
    r"""Mosaic positions ``(u, v)`` of laser points ``(φ, h)`` under the warp and the local field.

    The range image is resampled on the mosaic at ``warp⁻¹(x + d(x))``
    (:func:`refsynth.registration.alignment.resample_range`): the laser point
    ``e`` appears at the mosaic pixel ``x`` with

    .. math:: x = \mathrm{warp}(e) - d(x)

    found by fixed-point iteration from ``x = warp(e)``, sampling ``d``
    bilinearly (nearest edge value outside the mosaic).

    Parameters
    ----------
    warp : Warp
        The global warp of Eq. 21.
    displacement : ndarray of shape (2, H, W), or None
        The local field ``d = (d_u, d_v)`` on the mosaic, px
        (:func:`refsynth.registration.alignment.refine_local`); None: the
        global warp alone.
    phi, h : array_like of shape (N,)
        The laser points: azimuth (radians), height on the cylinder (px).
    iterations : int, default 4
        Fixed-point steps.

    Returns
    -------
    ndarray of shape (N, 2)
        ``(u, v)`` in the mosaic, px.

    Examples
    --------
    >>> warp = Warp(300.0, -1.0, 10.0, 50.0)
    >>> warp_forward(warp, None, np.array([0.0, 0.1]), np.array([0.0, 20.0]))
    array([[10., 50.],
           [40., 30.]])
    >>> field = np.zeros((2, 60, 60))
    >>> field[1] = 2.0  # every pixel samples the range image 2 rows lower
    >>> warp_forward(warp, field, np.array([0.0]), np.array([0.0]))
    array([[10., 48.]])
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
