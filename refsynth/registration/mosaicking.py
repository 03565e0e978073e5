r"""The panorama mosaic (Appendix A.1, Eq. 18): aligned views blended with the hat weight.

The views, projected onto the cylinder of radius ``f`` (Eq. 14,
:mod:`refsynth.registration.cylinder`) and aligned pair by pair (Eqs. 15–17,
:mod:`refsynth.registration.translation`), are blended into one mosaic, each
pixel the mean of the views that cover it weighted by the hat function

.. math:: w(x, y) = \Big(1 - \frac{|x - w/2|}{w/2}\Big)\Big(1 - \frac{|y - h/2|}{h/2}\Big)
          \qquad \text{(Eq. 18)}

The hat weight is evaluated on each view's own perspective frame and carried
through the projection, so it is 0 on the view's real edge. A mosaic places
view ``k`` with its cylindrical frame's origin at ``offsets[k] = (x, y)`` in
mosaic pixels: ``view_k[y, x] ≈ mosaic[y + o_y, x + o_x]``, the convention of
the translations.

References
----------
Torres-Méndez & Dudek (2008), Appendix A.1, Eqs. 14–18, doi:10.1007/s11263-007-0108-2.

Szeliski & Shum (1997), SIGGRAPH, doi:10.1145/258734.258861: gap closing for
360° panoramas (the full references: :mod:`refsynth.registration.translation`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_image, check_real, grey
from refsynth.registration.cylinder import (
    cylindrical_warp,
    perspective_coordinates,
    principal_point,
)
from refsynth.registration.interpolation import check_order, check_shape, sample_image
from refsynth.registration.translation import align_translation

__all__ = ["hat_weight", "hat_weights", "blend", "Mosaic", "mosaic"]


def _real_array(value) -> np.ndarray | None:
    """``value`` as a float64 array if it holds real numbers (not bool), else None."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return None
    if array.dtype == np.bool_ or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        return None
    return np.asarray(value, dtype=np.float64)


# ----------------------------------------------------------------------------- Eq. 18


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
    width = check_real("width", width, positive=True)
    height = check_real("height", height, positive=True)
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    wx = 1.0 - np.abs(x - width / 2) / (width / 2)
    wy = 1.0 - np.abs(y - height / 2) / (height / 2)
    return np.clip(wx, 0.0, None) * np.clip(wy, 0.0, None)


def hat_weights(shape: tuple[int, int]) -> np.ndarray:
    """Eq. 18 sampled at the pixel centres of an image of ``shape = (H, W)``.

    Every pixel gets a positive weight (the border pixels' centres are half a
    pixel inside the image's edge): ``w = (1/W) (1/H)`` in the corners, the
    largest at the centre.

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)`` of the view.

    Returns
    -------
    ndarray of shape (H, W), float64
        The weights of Eq. 18.

    Examples
    --------
    >>> hat_weights((1, 4)) * 4
    array([[1., 3., 3., 1.]])
    """
    height, width = check_shape("shape", shape, (1, 1))
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
    values = [check_image(f"images[{k}]", image) for k, image in enumerate(images)]
    channels = {v.shape[2:] for v in values}
    if len(channels) != 1:
        raise ValueError("The parameter `images` must hold images with the same number of channels")
    offsets = _real_array(offsets)
    if offsets is None or offsets.shape != (len(values), 2) or not np.all(np.isfinite(offsets)):
        raise ValueError(
            f"The parameter `offsets` must be a finite array of shape ({len(values)}, 2)"
        )
    if focal is not None:
        focal = check_real("focal", focal, positive=True)
    if period is not None:
        period = check_real("period", period, positive=True)
    order = check_order(order)
    if shape is None:
        height = int(np.ceil(max(o[1] + v.shape[0] for o, v in zip(offsets, values)) - 1e-9))
        width = int(np.ceil(max(o[0] + v.shape[1] for o, v in zip(offsets, values)) - 1e-9))
        shape = (max(height, 1), max(width, 1))
    shape = check_shape("shape", shape, (1, 1))
    (extra,) = channels
    total = np.zeros((*shape, *extra))
    weight = np.zeros(shape)
    rows, cols = np.indices(shape, dtype=np.float64)
    shifts = (0.0,) if period is None else (-period, 0.0, period)
    for value, (ox, oy) in zip(values, offsets):
        cx, cy = principal_point(value.shape)
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
            sample = sample_image(value, y, x, order)
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

    Examples
    --------
    >>> from refsynth.registration.examples import example_rig
    >>> views, _ = example_rig()
    >>> result = mosaic(views.images, views.focal, views.pan_angles[1] - views.pan_angles[0])
    >>> result.image.shape, result.offsets.shape, result.translations.shape, result.period
    ((81, 107), (2, 2), (1, 2), None)
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
        cx, _ = principal_point(self.view_shape)
        return self.offsets[0, 0] + cx + self.focal * (np.asarray(psi) - self.start_angle)

    @property
    def horizon_row(self) -> float:
        """The mosaic row of the horizon (``v = 0``) of view 0: ``o_y(0) + c_y``."""
        _, cy = principal_point(self.view_shape)
        return float(self.offsets[0, 1] + cy)


def _check_views(images) -> list[np.ndarray]:
    if not isinstance(images, (list, tuple)) and not (
        isinstance(images, np.ndarray) and images.ndim in (3, 4)
    ):
        raise TypeError(
            "The parameter `images` must be a list of images or an array of shape "
            f"(N, H, W[, C]), got {type(images).__name__}"
        )
    views = [check_image(f"images[{k}]", image, allow_nan=False) for k, image in enumerate(images)]
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
        Passed to :func:`~refsynth.registration.translation.align_translation`;
        ``order`` also interpolates the views into the mosaic.

    Returns
    -------
    Mosaic

    Notes
    -----
    1. Project every view onto the cylinder of radius ``f`` (Eq. 14,
       :func:`~refsynth.registration.cylinder.cylindrical_warp`).
    2. Align each consecutive pair (view ``k + 1`` against view ``k``) by
       Eqs. 15–17 (:func:`~refsynth.registration.translation.align_translation`)
       from ``t = (f · pan_step, 0)``.
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
    >>> from refsynth.registration.cylinder import cylindrical_unwarp
    >>> views = [cylindrical_unwarp(cylinder[:, c:c + 80], 300.0)[:, 2:-2] for c in (0, 50, 100)]
    >>> result = mosaic(views, 300.0, 48 / 300.0)
    >>> np.round(result.translations, 1) + 0.0
    array([[50.,  0.],
           [50.,  0.]])
    """
    views = _check_views(images)
    focal = check_real("focal", focal, positive=True)
    n = len(views)
    steps = _real_array(pan_step)
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
    start_angle = check_real("start_angle", start_angle)
    if not isinstance(full_circle, (bool, np.bool_)):
        raise TypeError(f"The parameter `full_circle` must be a bool, got {full_circle!r}")
    order = check_order(order)

    cylinders = [grey(cylindrical_warp(view, focal, order=order)) for view in views]
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
