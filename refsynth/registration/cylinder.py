r"""The camera's cylinder (Appendix A.1, Eq. 14): points, coordinates and images.

The camera on the pan unit takes a picture every 18°. Each picture is
projected onto a cylinder of radius ``f`` (the focal length in pixels), where
a pan becomes a horizontal translation (:mod:`refsynth.registration.translation`):

.. math:: \psi = \arctan\frac{x}{z}, \qquad v = f\,\frac{y}{\sqrt{x^2 + z^2}}

This module holds Eq. 14 for scene points (:func:`project_to_cylinder`), for
image coordinates (:func:`cylinder_coordinates` and its inverse
:func:`perspective_coordinates`) and for whole images
(:func:`cylindrical_warp` and its inverse :func:`cylindrical_unwarp`).

Coordinates
-----------
An image of shape ``(H, W)`` has its principal point at its centre,
``(c_x, c_y) = ((W − 1)/2, (H − 1)/2)`` in (col, row) index units
(:func:`principal_point`), so pixel ``(i, j)`` is the point
``(x, y, f) = (j − c_x, i − c_y, f)`` in the camera's frame (x right, y
**down**, z along the optical axis). Its cylindrical image has the same shape
and centre; cylindrical pixel ``(i, j)`` is the point
``(x_c, y_c) = (f ψ, v) = (j − c_x, i − c_y)`` on the unrolled cylinder (arc
length and height, both in pixels).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.1, Eq. 14,
doi:10.1007/s11263-007-0108-2.

R. Szeliski and H.-Y. Shum, "Creating full view panoramic image mosaics and
environment maps", SIGGRAPH 1997, doi:10.1145/258734.258861 (cylindrical
warps).
"""

from __future__ import annotations

import numpy as np

from refsynth._checks import check_image, check_real
from refsynth.registration.interpolation import check_order, check_shape, sample_image

__all__ = [
    "project_to_cylinder",
    "cylinder_coordinates",
    "perspective_coordinates",
    "principal_point",
    "cylindrical_warp",
    "cylindrical_unwarp",
]


def project_to_cylinder(points: np.ndarray, focal: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Map scene points onto the cylinder of radius ``f`` (Eq. 14).

    .. math:: \psi = \arctan\frac{x}{z}, \qquad v = f\,\frac{y}{\sqrt{x^2 + z^2}}

    Parameters
    ----------
    points : ndarray of shape (..., 3)
        ``(x, y, z)`` in the camera's frame (z forward along the pan angle
        0, x to the right, y along the cylinder's axis); ``x`` and ``z`` not
        both 0.
    focal : float
        The radius ``f`` of the cylinder, the camera's focal length in
        pixels.

    Returns
    -------
    psi : ndarray of shape (...)
        The pan angle, radians in (−π, π] (``arctan2(x, z)``, so points
        behind the camera keep their side).
    v : ndarray of shape (...)
        The scanline: the height on the cylinder, in pixels, with the sign
        of ``y``.

    Examples
    --------
    >>> psi, v = project_to_cylinder(np.array([1.0, 2.0, 1.0]), 300.0)
    >>> float(np.degrees(psi)), round(float(v), 3)
    (45.0, 424.264)
    """
    focal = check_real("focal", focal, positive=True)
    points = np.asarray(points, dtype=np.float64)
    if points.ndim < 1 or points.shape[-1] != 3:
        raise ValueError(f"The parameter `points` must have shape (..., 3), got {points.shape}")
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    rho = np.hypot(x, z)
    if np.any(rho == 0):
        raise ValueError("The parameter `points` must not lie on the cylinder's axis (x = z = 0)")
    return np.arctan2(x, z), focal * y / rho


def cylinder_coordinates(x, y, focal: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Perspective image coordinates → unrolled-cylinder coordinates (Eq. 14).

    A pixel at ``(x, y)`` from the principal point (x right, y down, in
    pixels) is the point ``(x, y, f)``; Eq. 14 puts it at

    .. math:: x_c = f\,\psi = f \arctan\frac{x}{f}, \qquad
              y_c = v = \frac{f\,y}{\sqrt{x^2 + f^2}}

    on the cylinder of radius ``f`` unrolled into a plane (arc length and
    height, in pixels). :func:`perspective_coordinates` is the inverse.

    Parameters
    ----------
    x, y : array_like
        Perspective coordinates in pixels from the principal point.
    focal : float
        Focal length ``f`` in pixels.

    Returns
    -------
    x_c, y_c : ndarray
        Cylindrical coordinates in pixels.

    Examples
    --------
    >>> xc, yc = cylinder_coordinates(300.0, 300.0, 300.0)
    >>> round(float(xc), 4), round(float(yc), 4)
    (235.6194, 212.132)
    """
    focal = check_real("focal", focal, positive=True)
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    return focal * np.arctan2(x, focal), focal * y / np.hypot(x, focal)


def perspective_coordinates(x_c, y_c, focal: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Unrolled-cylinder coordinates → perspective image coordinates (inverse of Eq. 14).

    .. math:: x = f \tan\frac{x_c}{f}, \qquad y = \frac{y_c}{\cos(x_c / f)}

    Defined for ``|x_c| < π f / 2`` (in front of the camera); elsewhere the
    result is NaN.

    Parameters
    ----------
    x_c, y_c : array_like
        Cylindrical coordinates in pixels (arc length, height).
    focal : float
        Focal length ``f`` in pixels.

    Returns
    -------
    x, y : ndarray
        Perspective coordinates in pixels from the principal point.

    Examples
    --------
    >>> x, y = perspective_coordinates(*cylinder_coordinates(12.0, -7.0, 300.0), 300.0)
    >>> round(float(x), 12), round(float(y), 12)
    (12.0, -7.0)
    """
    focal = check_real("focal", focal, positive=True)
    x_c, y_c = np.asarray(x_c, dtype=np.float64), np.asarray(y_c, dtype=np.float64)
    angle = x_c / focal
    front = np.abs(angle) < np.pi / 2
    safe = np.where(front, angle, 0.0)
    x = np.where(front, focal * np.tan(safe), np.nan)
    y = np.where(front, y_c / np.cos(safe), np.nan)
    return x, y


def principal_point(shape: tuple[int, ...]) -> tuple[float, float]:
    """The principal point ``(c_x, c_y)`` of an image of ``shape``: its centre, (col, row).

    Examples
    --------
    >>> principal_point((4, 5))
    (2.0, 1.5)
    """
    return (shape[1] - 1) / 2.0, (shape[0] - 1) / 2.0


def _remap(name: str, image, focal, output_shape, order, lookup) -> np.ndarray:
    """Resample ``image`` by inverse mapping through ``lookup``, one of Eq. 14's coordinate maps.

    The output pixel at ``(x, y)`` from the output's centre reads the input
    at ``lookup(x, y, focal)`` from the input's centre.
    """
    focal = check_real("focal", focal, positive=True)
    values = check_image(name, image)
    order = check_order(order)
    shape = check_shape("output_shape", output_shape, values.shape[:2])
    cx_out, cy_out = principal_point(shape)
    cx_in, cy_in = principal_point(values.shape)
    rows, cols = np.indices(shape, dtype=np.float64)
    x, y = lookup(cols - cx_out, rows - cy_out, focal)
    return sample_image(values, y + cy_in, x + cx_in, order)


def cylindrical_warp(
    image: np.ndarray,
    focal: float,
    *,
    output_shape: tuple[int, int] | None = None,
    order: int = 1,
) -> np.ndarray:
    r"""Project a perspective image onto the cylinder of radius ``f`` (Eq. 14).

    By inverse mapping: every pixel of the cylindrical image, at
    ``(x_c, y_c)`` from its centre, looks up the perspective image at

    .. math:: x = f \tan\frac{x_c}{f}, \qquad y = \frac{y_c}{\cos(x_c/f)}

    (:func:`perspective_coordinates`) by bilinear interpolation
    (``order=1``, ``scipy.ndimage.map_coordinates``).

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C)
        The perspective image, principal point at its centre. Integer images
        are scaled to [0, 1]; NaN marks pixels without data.
    focal : float
        Focal length ``f`` in pixels.
    output_shape : pair of int, optional
        ``(H, W)`` of the cylindrical image; default: the input's.
    order : {1, 0, 3}, default 1
        Interpolation order: bilinear (the default), nearest, or cubic
        B-spline.

    Returns
    -------
    ndarray of shape (H', W') or (H', W', C), float64
        The cylindrical image; NaN where the ray falls outside the
        perspective image (a barrel-shaped valid region, narrower than the
        input by ``W − 2 f arctan(W / 2f)`` pixels).

    See Also
    --------
    cylindrical_unwarp : the inverse.

    Examples
    --------
    >>> image = np.arange(20.0).reshape(4, 5)
    >>> bool(np.allclose(cylindrical_warp(image, 1e6), image))
    True
    """
    return _remap("image", image, focal, output_shape, order, perspective_coordinates)


def cylindrical_unwarp(
    cylinder: np.ndarray,
    focal: float,
    *,
    output_shape: tuple[int, int] | None = None,
    order: int = 1,
) -> np.ndarray:
    r"""Render a perspective image from a cylindrical one (the inverse of Eq. 14's warp).

    Every perspective pixel ``(x, y)`` looks up the cylindrical image at
    :func:`cylinder_coordinates` ``(x, y)``:

    .. math:: x_c = f \arctan\frac{x}{f}, \qquad y_c = \frac{f\,y}{\sqrt{x^2 + f^2}}

    Parameters
    ----------
    cylinder : ndarray of shape (H, W) or (H, W, C)
        The cylindrical image, centred on the optical axis; NaN = no data.
    focal : float
        Focal length ``f`` in pixels.
    output_shape : pair of int, optional
        ``(H, W)`` of the perspective image; default: the input's.
    order : {1, 0, 3}, default 1
        Interpolation order.

    Returns
    -------
    ndarray of shape (H', W') or (H', W', C), float64
        NaN where the cylindrical image has no data.

    Examples
    --------
    >>> image = np.add.outer(np.arange(9.0), np.arange(11.0))  # a linear ramp
    >>> back = cylindrical_unwarp(cylindrical_warp(image, 40.0), 40.0)
    >>> bool(np.nanmax(np.abs(back - image)) < 0.01)
    True
    """
    return _remap("cylinder", cylinder, focal, output_shape, order, cylinder_coordinates)
