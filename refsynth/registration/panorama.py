r"""The cylindrical panorama mosaic (Appendix A.1, Eqs. 14–18).

The camera on the pan unit takes a picture every 18°. Each picture is
projected onto a cylinder of radius ``f`` (the focal length in pixels,
Eq. 14), where a pan becomes a horizontal translation; consecutive pictures
are aligned by a global translation ``t = (t_x, t_y)`` found by Gauss–Newton
on the intensity error over their overlap (Eqs. 15–17), and blended with
the hat weight of Eq. 18 into one mosaic.

Coordinates
-----------
An image of shape ``(H, W)`` has its principal point at its centre,
``(c_x, c_y) = ((W − 1)/2, (H − 1)/2)`` in (col, row) index units, so pixel
``(i, j)`` is the point ``(x, y, f) = (j − c_x, i − c_y, f)`` in the
camera's frame (x right, y **down**, z along the optical axis). Its
cylindrical image has the same shape and centre; cylindrical pixel
``(i, j)`` is the point ``(x_c, y_c) = (f ψ, v) = (j − c_x, i − c_y)`` on
the unrolled cylinder (arc length and height, both in pixels).

Translations and placements all follow one convention: ``t = (t_x, t_y)``
says that ``moving[y, x] ≈ reference[y + t_y, x + t_x]`` — the moving
image's pixel ``(0, 0)`` sits at ``(t_x, t_y)`` in the reference's pixel
frame. A mosaic places image ``k`` with its cylindrical frame's origin at
``offsets[k] = (x, y)`` in mosaic pixels.

Departures from the paper (see :func:`align_translation`): a whole-pixel
search around the known pan step before Gauss–Newton; coarse to fine by
Gaussian blur without decimation (a 10 % overlap is only ~10 px wide);
and, by default, a gain varying linearly across the overlap plus an offset
fitted with ``δt`` in each step, which absorbs the vignetting that otherwise
biases Eq. 17 (``photometric=False`` gives Eqs. 15–17 exactly). The hat
weight of Eq. 18 is evaluated on each view's own perspective frame and
carried through the projection, so it is 0 on the view's real edge.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.1, Eqs. 14–18,
doi:10.1007/s11263-007-0108-2.

R. Szeliski and H.-Y. Shum, "Creating full view panoramic image mosaics and
environment maps", SIGGRAPH 1997, doi:10.1145/258734.258861 (cylindrical
warps, translational alignment, gap closing for 360° panoramas).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Real

import numpy as np
from scipy import ndimage as ndi

__all__ = [
    "project_to_cylinder",
    "cylinder_coordinates",
    "perspective_coordinates",
    "cylindrical_warp",
    "cylindrical_unwarp",
    "gauss_newton_step",
    "align_translation",
    "hat_weight",
    "hat_weights",
    "blend",
    "Mosaic",
    "mosaic",
]

#: Smallest number of overlapping pixels :func:`align_translation` accepts.
MIN_OVERLAP_PIXELS = 16

#: Gaussian blur (σ in pixels) of the coarse-to-fine levels, coarsest first;
#: the last level is the image itself (σ = 0).
_LEVEL_SIGMAS = (4.0, 2.0, 1.0, 0.0)

#: A blur level is skipped unless the overlap is this many σ wide and high: normalised
#: convolution next to the edge of the data shifts the blurred images.
_OVERLAP_PER_SIGMA = 6.0

#: Sample coordinates this close outside the grid (rounding errors) are moved onto its edge.
_SNAP = 1e-6


# ----------------------------------------------------------------------------- validation


def _check_focal(focal) -> float:
    if isinstance(focal, (bool, np.bool_)) or not isinstance(focal, Real):
        raise TypeError(f"The parameter `focal` must be a real number, got {type(focal).__name__}")
    focal = float(focal)
    if not (math.isfinite(focal) and focal > 0):
        raise ValueError(f"The parameter `focal` must be finite and > 0, got {focal}")
    return focal


def _check_real(name: str, value, *, minimum: float | None = None, positive=False) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Real):
        raise TypeError(f"The parameter `{name}` must be a real number, got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"The parameter `{name}` must be finite, got {value}")
    if positive and value <= 0:
        raise ValueError(f"The parameter `{name}` must be > 0, got {value}")
    if minimum is not None and value < minimum:
        raise ValueError(f"The parameter `{name}` must be >= {minimum}, got {value}")
    return value


def _check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"The parameter `{name}` must be an integer, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"The parameter `{name}` must be >= {minimum}, got {value}")
    return int(value)


def _check_order(order) -> int:
    if isinstance(order, (bool, np.bool_)) or order not in (0, 1, 3):
        raise ValueError(f"The parameter `order` must be 0, 1 or 3, got {order!r}")
    return int(order)


def _check_image(name: str, image, *, allow_nan: bool = True, colour: bool = True) -> np.ndarray:
    """``image`` as float64 (H, W) or (H, W, C); integers scaled to [0, 1]."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"The parameter `{name}` must be a numpy array, got {type(image).__name__}")
    if image.dtype == np.bool_ or not (
        np.issubdtype(image.dtype, np.integer) or np.issubdtype(image.dtype, np.floating)
    ):
        raise TypeError(f"The parameter `{name}` must be a real numeric array, got {image.dtype}")
    if image.ndim not in ((2, 3) if colour else (2,)) or min(image.shape[:2], default=0) < 2:
        expected = "(H, W) or (H, W, C)" if colour else "(H, W)"
        raise ValueError(
            f"The parameter `{name}` must be an image of shape {expected} with H, W >= 2, "
            f"got shape {image.shape}"
        )
    if np.issubdtype(image.dtype, np.integer):
        values = image.astype(np.float64) / float(np.iinfo(image.dtype).max)
    else:
        values = image.astype(np.float64)
    if np.isinf(values).any() or (not allow_nan and np.isnan(values).any()):
        what = "finite" if not allow_nan else "finite or NaN (NaN = no data)"
        raise ValueError(f"The parameter `{name}` must be {what}")
    return values


def _check_pair(name: str, value) -> np.ndarray:
    array = np.asarray(value, dtype=np.float64) if _is_real_sequence(value) else None
    if array is None or array.shape != (2,) or not np.all(np.isfinite(array)):
        raise ValueError(f"The parameter `{name}` must be a pair of finite numbers, got {value!r}")
    return array


def _is_real_sequence(value) -> bool:
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return False
    return array.dtype != np.bool_ and (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    )


def _grey(image: np.ndarray) -> np.ndarray:
    """Luminance of a float (H, W, 3) image (BT.709, as refsynth.synthesis.canny.to_grey); grey as is."""
    if image.ndim == 2:
        return image
    if image.shape[2] == 3:
        return image @ np.array([0.2125, 0.7154, 0.0721])
    return image.mean(axis=2)


# ----------------------------------------------------------------------------- Eq. 14


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
    focal = _check_focal(focal)
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
    focal = _check_focal(focal)
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
    focal = _check_focal(focal)
    x_c, y_c = np.asarray(x_c, dtype=np.float64), np.asarray(y_c, dtype=np.float64)
    angle = x_c / focal
    front = np.abs(angle) < np.pi / 2
    safe = np.where(front, angle, 0.0)
    x = np.where(front, focal * np.tan(safe), np.nan)
    y = np.where(front, y_c / np.cos(safe), np.nan)
    return x, y


def _sample(image: np.ndarray, rows: np.ndarray, cols: np.ndarray, order: int) -> np.ndarray:
    """Interpolate a (H, W) or (H, W, C) float image at fractional (rows, cols); NaN outside.

    Order 1 (bilinear) samples NaN pixels as NaN. Order 3 (cubic B-spline) fills
    NaN pixels with their nearest valid value before the spline prefilter and
    returns NaN wherever the bilinear sample would be NaN.
    """
    if image.ndim == 3:
        return np.stack(
            [_sample(image[..., c], rows, cols, order) for c in range(image.shape[2])], axis=-1
        )
    # snap coordinates a rounding error outside the grid onto its edge
    rows = np.where((rows > -_SNAP) & (rows < 0), 0.0, rows)
    rows = np.where((rows > image.shape[0] - 1) & (rows < image.shape[0] - 1 + _SNAP),
                    image.shape[0] - 1.0, rows)
    cols = np.where((cols > -_SNAP) & (cols < 0), 0.0, cols)
    cols = np.where((cols > image.shape[1] - 1) & (cols < image.shape[1] - 1 + _SNAP),
                    image.shape[1] - 1.0, cols)
    coords = np.stack([rows, cols])
    inside = np.isfinite(rows) & np.isfinite(cols)
    coords = np.where(inside, coords, -2.0)
    if order <= 1:
        out = ndi.map_coordinates(image, coords, order=order, mode="constant", cval=np.nan)
        return np.where(inside, out, np.nan)
    invalid = np.isnan(image)
    filled = image
    if invalid.any():
        if invalid.all():
            return np.full(rows.shape, np.nan)
        index = ndi.distance_transform_edt(invalid, return_distances=False, return_indices=True)
        filled = image[tuple(index)]
    out = ndi.map_coordinates(filled, coords, order=3, mode="nearest")
    valid = ndi.map_coordinates(
        np.where(invalid, np.nan, 0.0), coords, order=1, mode="constant", cval=np.nan
    )
    return np.where(inside & np.isfinite(valid), out, np.nan)


def _centre(shape: tuple[int, ...]) -> tuple[float, float]:
    """The principal point ``(c_x, c_y)`` of an image of ``shape``."""
    return (shape[1] - 1) / 2.0, (shape[0] - 1) / 2.0


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
    focal = _check_focal(focal)
    values = _check_image("image", image)
    order = _check_order(order)
    shape = _check_shape(output_shape, values.shape[:2])
    cx_out, cy_out = _centre(shape)
    cx_in, cy_in = _centre(values.shape)
    rows, cols = np.indices(shape, dtype=np.float64)
    x, y = perspective_coordinates(cols - cx_out, rows - cy_out, focal)
    return _sample(values, y + cy_in, x + cx_in, order)


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
    focal = _check_focal(focal)
    values = _check_image("cylinder", cylinder)
    order = _check_order(order)
    shape = _check_shape(output_shape, values.shape[:2])
    cx_out, cy_out = _centre(shape)
    cx_in, cy_in = _centre(values.shape)
    rows, cols = np.indices(shape, dtype=np.float64)
    x_c, y_c = cylinder_coordinates(cols - cx_out, rows - cy_out, focal)
    return _sample(values, y_c + cy_in, x_c + cx_in, order)


def _check_shape(shape, default: tuple[int, int]) -> tuple[int, int]:
    if shape is None:
        return (int(default[0]), int(default[1]))
    if (
        not isinstance(shape, (tuple, list))
        or len(shape) != 2
        or not all(isinstance(n, (int, np.integer)) and not isinstance(n, bool) for n in shape)
        or min(shape) < 1
    ):
        raise ValueError(
            f"The parameter `output_shape` must be a pair of positive integers, got {shape!r}"
        )
    return int(shape[0]), int(shape[1])


# ----------------------------------------------------------------------------- Eqs. 15–17


def _gradients(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Central differences ``(∂I/∂x, ∂I/∂y)``; NaN next to NaN and on the border."""
    gx = np.full(image.shape, np.nan)
    gy = np.full(image.shape, np.nan)
    gx[:, 1:-1] = (image[:, 2:] - image[:, :-2]) / 2.0
    gy[1:-1, :] = (image[2:, :] - image[:-2, :]) / 2.0
    return gx, gy


def _step(
    reference: np.ndarray,
    gradients: tuple[np.ndarray, np.ndarray],
    moving: np.ndarray,
    translation: np.ndarray,
    order: int,
    photometric: bool = False,
) -> tuple[np.ndarray, float, int]:
    """One Eq. 17 update: ``(δt, RMS error e_i, number of pixels)``.

    With ``photometric``, the least squares also fit a gain varying linearly
    across the overlap and an offset, ``I0 ≈ (1 + p0 + p1 x̃ + p2 ỹ) I1 + p3``
    (x̃, ỹ: pixel coordinates centred on the overlap and scaled to [−1, 1]),
    and ``e_i`` is the error left after that fit.
    """
    rows, cols = np.indices(moving.shape, dtype=np.float64)
    y = rows + translation[1]
    x = cols + translation[0]
    warped = _sample(reference, y, x, order)
    gx = _sample(gradients[0], y, x, 1)
    gy = _sample(gradients[1], y, x, 1)
    use = np.isfinite(warped) & np.isfinite(gx) & np.isfinite(gy) & np.isfinite(moving)
    count = int(use.sum())
    if count < MIN_OVERLAP_PIXELS:
        return np.full(2, np.nan), np.nan, count
    e = warped[use] - moving[use]  # e_i = I1(x'_i) − I0(x_i)
    g = np.stack([gx[use], gy[use]])  # g_i = ∇I1(x'_i)
    columns = g
    if photometric:
        u, w = cols[use], rows[use]
        u = (u - u.mean()) / max(np.ptp(u) / 2, 1.0)
        w = (w - w.mean()) / max(np.ptp(w) / 2, 1.0)
        i1 = warped[use]
        columns = np.vstack([g, i1, u * i1, w * i1, np.ones_like(i1)])
    hessian = columns @ columns.T  # Σ g_i g_iᵀ (Eq. 17), with the photometric unknowns
    rhs = -(columns @ e)  # −Σ e_i g_i
    scale = np.sqrt(np.diag(hessian))
    if not np.all(np.isfinite(hessian)) or np.any(scale == 0):
        return np.full(2, np.nan), float(np.sqrt(np.mean(e**2))), count
    normalised = hessian / np.outer(scale, scale)
    if np.linalg.cond(normalised) > 1e10:
        return np.full(2, np.nan), float(np.sqrt(np.mean(e**2))), count
    solution = np.linalg.solve(normalised, rhs / scale) / scale
    residual = e + columns.T @ solution
    return solution[:2], float(np.sqrt(np.mean(residual**2))), count


def gauss_newton_step(
    reference: np.ndarray,
    moving: np.ndarray,
    translation=(0.0, 0.0),
    *,
    order: int = 1,
) -> np.ndarray:
    r"""One Gauss–Newton update of the translation between two images (Eqs. 15–17).

    With the current translation ``t``, each pixel ``x_i`` of the moving
    image ``I0`` corresponds to ``x'_i = x_i + t`` in the reference ``I1``.
    Linearising the intensity error of Eq. 15,

    .. math:: E(\delta t) = \sum_i [I_1(x'_i + \delta t) - I_0(x_i)]^2
              \approx \sum_i [g_i^\top \delta t + e_i]^2 \qquad \text{(Eq. 16)}

    with ``e_i = I1(x'_i) − I0(x_i)`` and ``g_i = ∇I1(x'_i)``, gives the
    least-squares update

    .. math:: \Big(\sum_i g_i g_i^\top\Big)\,\delta t = -\sum_i e_i g_i \qquad \text{(Eq. 17)}

    The sums run over the overlap: pixels where both images have data.

    Parameters
    ----------
    reference : ndarray of shape (H1, W1)
        ``I1``; NaN = no data.
    moving : ndarray of shape (H0, W0)
        ``I0``; NaN = no data.
    translation : pair of float, default (0, 0)
        The current ``t = (t_x, t_y)``: ``moving[y, x] ≈ reference[y + t_y, x + t_x]``.
    order : {1, 3}, default 1
        Interpolation of ``I1`` at ``x'_i`` (bilinear or cubic B-spline).
        The gradients are central differences, interpolated bilinearly.

    Returns
    -------
    ndarray of shape (2,)
        ``δt = (δt_x, δt_y)``; add it to ``translation``.

    Raises
    ------
    ValueError
        If the images overlap in fewer than 16 pixels at ``translation``,
        or the overlap has no texture in some direction (singular
        ``Σ g gᵀ``).

    Examples
    --------
    >>> y, x = np.mgrid[0:40, 0:40] / 6.0
    >>> reference = np.sin(x) + np.cos(0.7 * y)
    >>> moving = np.sin(x + 0.1 / 6.0) + np.cos(0.7 * (y - 0.05 / 6.0))  # t = (0.1, -0.05)
    >>> np.round(gauss_newton_step(reference, moving), 3)
    array([ 0.1 , -0.05])
    """
    ref = _check_image("reference", reference, colour=False)
    mov = _check_image("moving", moving, colour=False)
    t = _check_pair("translation", translation)
    order = _check_order(order)
    delta, _, count = _step(ref, _gradients(ref), mov, t, order)
    if count < MIN_OVERLAP_PIXELS:
        raise ValueError(
            f"The images overlap in {count} pixels at translation {tuple(t)}; "
            f"need at least {MIN_OVERLAP_PIXELS}"
        )
    if not np.all(np.isfinite(delta)):
        raise ValueError("The overlap has no texture in some direction (Σ g gᵀ is singular)")
    return delta


def _blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur by normalised convolution: NaN pixels neither contribute nor survive."""
    if sigma == 0:
        return image
    valid = np.isfinite(image)
    numerator = ndi.gaussian_filter(np.where(valid, image, 0.0), sigma, mode="constant")
    denominator = ndi.gaussian_filter(valid.astype(np.float64), sigma, mode="constant")
    with np.errstate(invalid="ignore", divide="ignore"):
        out = numerator / denominator
    return np.where(valid, out, np.nan)


def align_translation(
    reference: np.ndarray,
    moving: np.ndarray,
    initial=(0.0, 0.0),
    *,
    levels: int = 4,
    search=(4, 3),
    photometric: bool = True,
    tol: float = 1e-3,
    max_iter: int = 50,
    order: int = 1,
) -> np.ndarray:
    r"""Translation between two overlapping cylindrical images (Eqs. 15–17).

    Iterates the Gauss–Newton step of Eq. 17 (:func:`gauss_newton_step`),
    ``t ← t + δt``, coarse to fine, until ``|δt| < tol``:

    .. math:: \Big(\sum_i g_i g_i^\top\Big)\,\delta t = -\sum_i e_i g_i

    Parameters
    ----------
    reference : ndarray of shape (H1, W1) or (H1, W1, 3)
        ``I1``; colour is reduced to luminance; NaN = no data.
    moving : ndarray of shape (H0, W0) or (H0, W0, 3)
        ``I0``; NaN = no data.
    initial : pair of float, default (0, 0)
        The starting ``t`` (e.g. ``(f · pan_step, 0)`` from the known pan
        step), in the convention of the result.
    levels : int, default 4
        Number of coarse-to-fine levels, at most 4: Gaussian blurs of
        σ = 4, 2, 1 px and then the images themselves (the last ``levels``
        of these).
    search : pair of int, default (4, 3)
        Before Gauss–Newton, try every whole-pixel shift of ``initial`` within
        ``±search[0]`` px horizontally and ``±search[1]`` px vertically on
        the coarsest level and start from the one with the smallest mean
        squared error (among shifts that keep at least half the largest
        overlap). ``(0, 0)`` starts Gauss–Newton at ``initial`` itself.
    photometric : bool, default True
        Also fit, in each step's least squares, a gain varying linearly
        across the overlap and an offset: ``I0 ≈ (1 + p0 + p1 x̃ + p2 ỹ) I1 +
        p3`` (x̃, ỹ: the moving image's coordinates centred on the overlap,
        scaled to [−1, 1]). Vignetting darkens the two images in opposite
        directions across their overlap (the paper's footnote 8), which
        biases Eq. 17 by up to 0.3 px at 30 % overlap on the rig; these
        four unknowns take it up. ``False`` is Eqs. 15–17 exactly.
    tol : float, default 1e-3
        Stop a level when ``|δt|`` falls below this, in pixels.
    max_iter : int, default 50
        Most Gauss–Newton steps per level.
    order : {1, 3}, default 1
        Interpolation of the reference (bilinear or cubic B-spline).

    Returns
    -------
    ndarray of shape (2,)
        ``[t_x, t_y]`` such that ``moving[y, x] ≈ reference[y + t_y, x + t_x]``.

    Raises
    ------
    ValueError
        If the images do not overlap (fewer than 16 pixels) or the overlap
        has no texture, at the start or during the iteration.

    Notes
    -----
    1. Both images are blurred by normalised convolution (pixels without
       data neither contribute nor receive values), coarsest first.
    2. Whole-pixel search around ``initial`` (an addition to the paper's
       method: with a 10 % overlap, about 10 px, a pan error of 2–4 px
       puts Gauss–Newton outside its basin, and a step that overshoots
       shrinks the overlap until nothing is left).
    3. At each level, Gauss–Newton steps from the previous level's ``t``:
       sample ``I1`` and its central-difference gradient at ``x_i + t``
       (``map_coordinates``), keep the pixels where both images have data,
       solve the 2×2 system of Eq. 17 with array sums (6×6 with the
       photometric unknowns), and add ``δt``.
    4. The coarse-to-fine levels are a Gaussian scale space *without*
       decimation: with 10 % overlap of views 100–140 px wide, the overlap
       is only 10–14 px wide, and halving it would leave too few columns;
       blurring widens the basin of convergence just as a pyramid does.
       A level whose σ exceeds 1/6 of the overlap's width or height is
       skipped (near the edge of the data, normalised convolution shifts
       the blurred images), and a step is cut to at most max(σ, 1) px.

    Examples
    --------
    >>> y, x = np.mgrid[0:60, 0:80] / 5.0
    >>> scene = np.sin(x) * np.cos(0.8 * y) + 0.3 * np.sin(0.5 * x + y)
    >>> reference, moving = scene[:, :60], scene[3:, 45:]  # t = (45, 3)
    >>> np.round(align_translation(reference, moving, initial=(43.0, 0.0)), 4)
    array([45.,  3.])
    """
    ref = _grey(_check_image("reference", reference))
    mov = _grey(_check_image("moving", moving))
    t = _check_pair("initial", initial)
    levels = _check_int("levels", levels, 1)
    if levels > len(_LEVEL_SIGMAS):
        raise ValueError(f"The parameter `levels` must be <= {len(_LEVEL_SIGMAS)}, got {levels}")
    tol = _check_real("tol", tol, positive=True)
    max_iter = _check_int("max_iter", max_iter, 1)
    order = _check_order(order)
    if order == 0:
        raise ValueError("The parameter `order` must be 1 or 3 for alignment, got 0")
    search = _check_search(search)
    sigmas = _LEVEL_SIGMAS[len(_LEVEL_SIGMAS) - levels :]
    if search[0] > 0 or search[1] > 0:
        t = _search(_blur(ref, sigmas[0]), _blur(mov, sigmas[0]), t, search)
    narrowest = _overlap_extent(ref, mov, t)
    for sigma in sigmas:
        if sigma > narrowest / _OVERLAP_PER_SIGMA:
            continue
        ref_s, mov_s = _blur(ref, sigma), _blur(mov, sigma)
        gradients = _gradients(ref_s)
        for _ in range(max_iter):
            delta, _, count = _step(ref_s, gradients, mov_s, t, order, photometric)
            if count < MIN_OVERLAP_PIXELS:
                raise ValueError(
                    f"The images overlap in {count} pixels at translation "
                    f"({t[0]:.2f}, {t[1]:.2f}); need at least {MIN_OVERLAP_PIXELS}"
                )
            if not np.all(np.isfinite(delta)):
                raise ValueError(
                    "The overlap has no texture in some direction (Σ g gᵀ is singular)"
                )
            length = np.hypot(*delta)
            if length > max(sigma, 1.0):  # a step this long leaves the linearisation
                delta *= max(sigma, 1.0) / length
            t = t + delta
            if np.hypot(*delta) < tol:
                break
    return t


# ----------------------------------------------------------------------------- Eq. 18


def _check_search(search) -> tuple[int, int]:
    if (
        not isinstance(search, (tuple, list))
        or len(search) != 2
        or not all(isinstance(n, (int, np.integer)) and not isinstance(n, bool) for n in search)
        or min(search) < 0
    ):
        raise ValueError(
            f"The parameter `search` must be a pair of non-negative integers, got {search!r}"
        )
    return int(search[0]), int(search[1])


def _overlap_extent(reference, moving, t) -> float:
    """The smaller of the overlap's width and height (px) at translation ``t``."""
    rows, cols = np.indices(moving.shape, dtype=np.float64)
    both = np.isfinite(_sample(reference, rows + t[1], cols + t[0], 1)) & np.isfinite(moving)
    if not both.any():
        return 0.0
    return float(min(both.any(axis=0).sum(), both.any(axis=1).sum()))


def _search(reference, moving, initial, search) -> np.ndarray:
    """The whole-pixel shift of ``initial`` with the least mean squared error (step 2)."""
    rows, cols = np.indices(moving.shape, dtype=np.float64)
    best, best_error, counts, errors, shifts = initial, np.inf, [], [], []
    for dy in range(-search[1], search[1] + 1):
        for dx in range(-search[0], search[0] + 1):
            t = initial + (dx, dy)
            warped = _sample(reference, rows + t[1], cols + t[0], 1)
            difference = (warped - moving)[np.isfinite(warped) & np.isfinite(moving)]
            counts.append(difference.size)
            errors.append(np.mean(difference**2) if difference.size else np.inf)
            shifts.append(t)
    enough = np.asarray(counts) >= max(0.5 * max(counts), MIN_OVERLAP_PIXELS)
    for t, error, ok in zip(shifts, errors, enough):
        if ok and error < best_error:
            best, best_error = t, error
    return np.asarray(best, dtype=np.float64)


def hat_weight(x, y, width: float, height: float) -> np.ndarray:
    r"""The hat weighting function of Eq. 18.

    .. math:: w(x, y) = \Big(1 - \frac{|x - w/2|}{w/2}\Big)
                        \Big(1 - \frac{|y - h/2|}{h/2}\Big)

    on the continuous image ``[0, w] × [0, h]``: 1 at the centre, falling
    linearly to 0 on the border; 0 outside.

    Parameters
    ----------
    x, y : array_like
        Continuous image coordinates (pixel ``(i, j)`` covers
        ``[j, j + 1) × [i, i + 1)``, its centre is ``(j + ½, i + ½)``).
    width, height : float
        ``w`` and ``h`` of the image, > 0.

    Returns
    -------
    ndarray
        The weights, in [0, 1].

    Examples
    --------
    >>> hat_weight([0.0, 2.5, 5.0, 3.75], 2.0, 5.0, 4.0)
    array([0. , 1. , 0. , 0.5])
    """
    width = _check_real("width", width, positive=True)
    height = _check_real("height", height, positive=True)
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    wx = 1.0 - np.abs(x - width / 2) / (width / 2)
    wy = 1.0 - np.abs(y - height / 2) / (height / 2)
    return np.clip(wx, 0.0, None) * np.clip(wy, 0.0, None)


def hat_weights(shape: tuple[int, int]) -> np.ndarray:
    """Eq. 18 sampled at the pixel centres of an image of ``shape = (H, W)``.

    Every pixel gets a positive weight (the border pixels' centres are half a
    pixel inside the image's edge): ``w = (1/W) (1/H)`` in the corners, the
    largest at the centre.

    Examples
    --------
    >>> hat_weights((1, 4)) * 4
    array([[1., 3., 3., 1.]])
    """
    height, width = _check_shape(shape, (1, 1))
    rows, cols = np.indices((height, width), dtype=np.float64)
    return hat_weight(cols + 0.5, rows + 0.5, width, height)


def blend(
    images: Sequence[np.ndarray],
    offsets,
    *,
    focal: float | None = None,
    shape: tuple[int, int] | None = None,
    period: float | None = None,
    order: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    r"""Place images on a common grid and blend them with the hat weight (Eq. 18).

    Each mosaic pixel is the weighted mean of the images that cover it,

    .. math:: M(p) = \frac{\sum_k w_k(p)\, I_k(p - o_k)}{\sum_k w_k(p)}

    with ``o_k`` the placement of image ``k`` and ``w_k`` the hat weight of
    Eq. 18 in image ``k``'s own (perspective) frame, so that it is 1 at the
    image's centre and 0 on its edge.

    Parameters
    ----------
    images : sequence of ndarray of shape (H_k, W_k) or (H_k, W_k, C)
        With ``focal``: perspective views, projected onto the cylinder here
        (one interpolation from the view to the mosaic). Without: images
        already on the common surface (cylindrical, or a planar mosaic).
    offsets : array_like of shape (N, 2)
        ``(x, y)``: where the origin of image ``k``'s cylindrical frame sits
        in the mosaic, ``image_k[y, x] ≈ mosaic[y + o_y, x + o_x]``.
    focal : float, optional
        Focal length in pixels; see ``images``.
    shape : pair of int, optional
        ``(H, W)`` of the mosaic; default: just large enough to hold every
        image (offsets should then be >= 0).
    period : float, optional
        For a 360° mosaic: the circumference ``2πf`` in pixels; each image
        is also placed at ``o_x ± period``.
    order : {1, 0, 3}, default 1
        Interpolation order.

    Returns
    -------
    mosaic : ndarray of shape (H, W) or (H, W, C), float64
        NaN where no image has data.
    weight : ndarray of shape (H, W), float64
        ``Σ_k w_k``, 0 where no image has data.

    Examples
    --------
    >>> scene = np.arange(40.0).reshape(4, 10)
    >>> out, weight = blend([scene[:, :6], scene[:, 3:]], [(0, 0), (3, 0)])
    >>> bool(np.allclose(out, scene))
    True
    """
    if not isinstance(images, (list, tuple)) or len(images) == 0:
        raise ValueError("The parameter `images` must be a non-empty list of images")
    values = [_check_image(f"images[{k}]", image) for k, image in enumerate(images)]
    channels = {v.shape[2:] for v in values}
    if len(channels) != 1:
        raise ValueError("The parameter `images` must hold images with the same number of channels")
    offsets = np.asarray(offsets, dtype=np.float64) if _is_real_sequence(offsets) else None
    if offsets is None or offsets.shape != (len(values), 2) or not np.all(np.isfinite(offsets)):
        raise ValueError(
            f"The parameter `offsets` must be a finite array of shape ({len(values)}, 2)"
        )
    if focal is not None:
        focal = _check_focal(focal)
    if period is not None:
        period = _check_real("period", period, positive=True)
    order = _check_order(order)
    if shape is None:
        height = int(np.ceil(max(o[1] + v.shape[0] for o, v in zip(offsets, values)) - 1e-9))
        width = int(np.ceil(max(o[0] + v.shape[1] for o, v in zip(offsets, values)) - 1e-9))
        shape = (max(height, 1), max(width, 1))
    shape = _check_shape(shape, (1, 1))
    (extra,) = channels
    total = np.zeros((*shape, *extra))
    weight = np.zeros(shape)
    rows, cols = np.indices(shape, dtype=np.float64)
    shifts = (0.0,) if period is None else (-period, 0.0, period)
    for value, (ox, oy) in zip(values, offsets):
        cx, cy = _centre(value.shape)
        for shift in shifts:
            x_c = cols - ox - shift - cx
            y_c = rows - oy - cy
            inside = (np.abs(x_c) <= value.shape[1]) & (np.abs(y_c) <= value.shape[0])
            if not inside.any():
                continue
            if focal is None:
                x, y = x_c, y_c
            else:
                x, y = perspective_coordinates(x_c, y_c, focal)
            x, y = np.where(inside, x + cx, np.nan), np.where(inside, y + cy, np.nan)
            sample = _sample(value, y, x, order)
            w = hat_weight(x + 0.5, y + 0.5, value.shape[1], value.shape[0])
            finite = np.isfinite(sample) if sample.ndim == 2 else np.isfinite(sample).all(axis=2)
            w = np.where(finite & np.isfinite(w), w, 0.0)
            sample = np.where(finite[(...,) + (None,) * len(extra)], sample, 0.0)
            total += w[(...,) + (None,) * len(extra)] * sample
            weight += w
    with np.errstate(invalid="ignore", divide="ignore"):
        out = total / weight[(...,) + (None,) * len(extra)]
    out[weight == 0] = np.nan
    return out, weight


# ----------------------------------------------------------------------------- the mosaic


@dataclass(frozen=True, eq=False)
class Mosaic:
    """What :func:`mosaic` returns.

    Attributes
    ----------
    image : ndarray of shape (H, W) or (H, W, C), float64
        The blended cylindrical mosaic (Eq. 18); NaN where no view has data.
        Column spacing: 1 px of arc on the cylinder of radius ``focal``
        (``1/focal`` rad).
    weight : ndarray of shape (H, W), float64
        Sum of the hat weights; 0 where no view has data.
    offsets : ndarray of shape (N, 2)
        ``(x, y)`` of each view's cylindrical frame in the mosaic
        (``view_k[y, x] ≈ image[y + o_y, x + o_x]``).
    translations : ndarray of shape (N − 1, 2), or (N, 2) for 360°
        The aligned translation of each consecutive pair (view ``k + 1``
        against view ``k``; for 360° the last is view 0 against view
        ``N − 1``), after closing the loop.
    focal : float
        ``f`` in pixels.
    view_shape : tuple of int
        ``(H, W)`` of the views.
    start_angle : float
        The pan angle (radians) of view 0, as given.
    period : float or None
        ``2πf`` for a 360° mosaic, else None.
    """

    image: np.ndarray
    weight: np.ndarray
    offsets: np.ndarray
    translations: np.ndarray
    focal: float
    view_shape: tuple[int, int]
    start_angle: float
    period: float | None

    def column_of(self, psi) -> np.ndarray:
        """The mosaic column of pan angle ``psi`` (radians), measured through view 0.

        ``o_x(0) + c_x + f (ψ − start_angle)``: exact for view 0 and, as the
        views' alignment, to the fraction of a pixel elsewhere.
        """
        cx, _ = _centre(self.view_shape)
        return self.offsets[0, 0] + cx + self.focal * (np.asarray(psi) - self.start_angle)

    @property
    def horizon_row(self) -> float:
        """The mosaic row of the horizon (``v = 0``) of view 0: ``o_y(0) + c_y``."""
        _, cy = _centre(self.view_shape)
        return float(self.offsets[0, 1] + cy)


def _check_views(images) -> list[np.ndarray]:
    if not isinstance(images, (list, tuple)) and not (
        isinstance(images, np.ndarray) and images.ndim in (3, 4)
    ):
        raise TypeError(
            "The parameter `images` must be a list of images or an array of shape "
            f"(N, H, W[, C]), got {type(images).__name__}"
        )
    views = [_check_image(f"images[{k}]", image, allow_nan=False) for k, image in enumerate(images)]
    if len(views) < 2:
        raise ValueError(f"The parameter `images` must hold at least 2 views, got {len(views)}")
    if len({v.shape for v in views}) != 1:
        raise ValueError(
            "The parameter `images` must hold views of one shape, got "
            f"{sorted({v.shape for v in views})}"
        )
    return views


def mosaic(
    images: Sequence[np.ndarray],
    focal: float,
    pan_step,
    *,
    start_angle: float = 0.0,
    full_circle: bool = False,
    levels: int = 4,
    search=(4, 3),
    photometric: bool = True,
    tol: float = 1e-3,
    max_iter: int = 50,
    order: int = 1,
) -> Mosaic:
    r"""A cylindrical panorama from views taken while panning (Appendix A.1).

    Parameters
    ----------
    images : sequence of ndarray of shape (H, W) or (H, W, C), or ndarray (N, H, W[, C])
        The perspective views in pan order, principal point at the centre,
        finite. Integer images are scaled to [0, 1].
    focal : float
        Focal length ``f`` in pixels (the cylinder's radius).
    pan_step : float or array_like of shape (N − 1,)
        The known pan step between consecutive views, radians (18° = π/10
        in the paper), or one step per pair; only the start of the
        alignment. Positive = panning to the right.
    start_angle : float, default 0
        The pan angle of view 0, radians; recorded in the result so that
        :meth:`Mosaic.column_of` can place pan angles (the laser's
        azimuths) on the mosaic.
    full_circle : bool, default False
        The views cover 360°: also align view 0 against the last view, and
        spread the loop's closing error evenly over the pairs.
    levels, search, photometric, tol, max_iter, order
        Passed to :func:`align_translation`; ``order`` also interpolates
        the views into the mosaic.

    Returns
    -------
    Mosaic

    Notes
    -----
    1. Project every view onto the cylinder of radius ``f`` (Eq. 14,
       :func:`cylindrical_warp`).
    2. Align each consecutive pair (view ``k + 1`` against view ``k``) by
       Eqs. 15–17 (:func:`align_translation`) from ``t = (f · pan_step, 0)``.
    3. For 360°, the translations around the loop must add up to
       ``(2πf, 0)``; subtract an equal share of the difference from each
       (Szeliski & Shum 1997).
    4. Place view ``k`` at the sum of the translations before it, shifted so
       that the smallest offsets are 0, and blend with Eq. 18
       (:func:`blend`), sampling each perspective view directly (one
       interpolation).

    Examples
    --------
    >>> y, x = np.mgrid[0:50, 0:200] / 4.0
    >>> cylinder = np.sin(x) * np.cos(0.7 * y) + 0.5 * np.cos(0.3 * x - 0.2 * y)
    >>> views = [cylindrical_unwarp(cylinder[:, c:c + 80], 300.0)[:, 2:-2] for c in (0, 50, 100)]
    >>> result = mosaic(views, 300.0, 48 / 300.0)
    >>> np.round(result.translations, 1) + 0.0
    array([[50.,  0.],
           [50.,  0.]])
    """
    views = _check_views(images)
    focal = _check_focal(focal)
    n = len(views)
    steps = np.asarray(pan_step, dtype=np.float64) if _is_real_sequence(pan_step) else None
    if steps is None or steps.ndim > 1 or not np.all(np.isfinite(steps)):
        raise ValueError(
            f"The parameter `pan_step` must be a finite number or array, got {pan_step!r}"
        )
    pairs = n if full_circle else n - 1
    steps = np.broadcast_to(steps, (pairs,)) if steps.ndim == 0 else steps
    if steps.shape != (pairs,):
        raise ValueError(
            f"The parameter `pan_step` must be a number or have {pairs} entries, "
            f"got {steps.shape[0]}"
        )
    start_angle = _check_real("start_angle", start_angle)
    if not isinstance(full_circle, (bool, np.bool_)):
        raise TypeError(f"The parameter `full_circle` must be a bool, got {full_circle!r}")
    order = _check_order(order)

    cylinders = [_grey(cylindrical_warp(view, focal, order=order)) for view in views]
    translations = np.empty((pairs, 2))
    for k in range(pairs):
        reference, moving = cylinders[k], cylinders[(k + 1) % n]
        translations[k] = align_translation(
            reference, moving, (focal * steps[k], 0.0), levels=levels, search=search,
            photometric=photometric, tol=tol, max_iter=max_iter, order=order,
        )
    period = None
    if full_circle:
        period = 2 * np.pi * focal
        translations -= (translations.sum(axis=0) - np.array([period, 0.0])) / pairs
    offsets = np.vstack([np.zeros(2), np.cumsum(translations[: n - 1], axis=0)])
    offsets -= offsets.min(axis=0)
    shape = None
    if full_circle:
        height = int(np.ceil(offsets[:, 1].max() + views[0].shape[0] - 1e-9))
        shape = (height, int(round(period)))
    image, weight = blend(views, offsets, focal=focal, shape=shape, period=period, order=order)
    return Mosaic(
        image=image,
        weight=weight,
        offsets=offsets,
        translations=translations,
        focal=focal,
        view_shape=views[0].shape[:2],
        start_angle=start_angle,
        period=period,
    )
