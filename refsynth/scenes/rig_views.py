r"""The registration test rig's camera: views every 18° (§4.1; Appendix A.1).

The rig's camera turns on the pan axis with the laser
(:mod:`refsynth.scenes.rig`) and takes a perspective view every
``pan_step``, each with a small error on its pan angle and a vertical
jitter, kept as ground truth (:class:`RigViews`) so that the mosaic and the
laser–camera registration can be scored in pixels
(:mod:`refsynth.registration.scoring`):

- :func:`render_views`: views ray-cast in the rig's room, anti-aliased by
  supersampling, with vignetting and noise.
- :func:`texture_views`: views cut out of a real photograph wrapped on the
  cylinder, with known pan angles and jitter (alignment on real image
  statistics).
- :func:`view_width`: the view width giving a wanted overlap between
  neighbours.

Vertical jitter is rendered as the translation the paper's model assumes
(Eq. 15): view ``k`` sees the cylinder shifted by ``jitter[k]`` pixels along
its axis, so the true translations are exact. (A physical tilt of 1 px
would shift the cylinder by ``cos(x_c / f)`` px, 0.985 px at the edge of a
view 137 px wide at f = 300 — a model error of 0.015 px.)

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §4.1, Appendix A.1, Eqs. 14–15,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from refsynth._checks import check_image, check_int, check_real, grey
from refsynth.scenes.portable import (
    hypot2,
    portable_arctan,
    portable_arctan2,
    portable_cos,
    portable_sin,
    portable_tan,
)
from refsynth.scenes.rig import CAMERA_STEP, FOCAL, cast_rig_rays
from refsynth.scenes.room import RoomGeometry

__all__ = ["view_width", "RigViews", "render_views", "texture_views"]


def _cylinder_coordinates(x, y, focal: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Perspective image coordinates → unrolled-cylinder coordinates (Eq. 14).

    .. math:: x_c = f \arctan\frac{x}{f}, \qquad y_c = \frac{f\,y}{\sqrt{x^2 + f^2}}

    The formula of :func:`refsynth.registration.cylinder.cylinder_coordinates`,
    restated so that the scenes do not depend on the registration stage; with
    :mod:`refsynth.scenes.portable`'s arctan and square root, the same bits on
    every machine.
    """
    return focal * portable_arctan2(x, focal), focal * y / hypot2(x, focal)


def view_width(focal: float, pan_step: float, overlap: float) -> int:
    r"""Width (px) of perspective views whose cylindrical images overlap by ``overlap``.

    A view ``W`` px wide covers ``W_c = 2 f \arctan(W / 2f)`` px of the
    cylinder (Eq. 14); consecutive views ``f · pan_step`` apart overlap by
    ``1 − f · pan_step / W_c`` (Appendix A.1: 10–30 % between images taken
    every 18°).

    Parameters
    ----------
    focal : float
        The focal length ``f`` in pixels, > 0 (the rig's is 300).
    pan_step : float
        The pan angle between consecutive views, radians, > 0.
    overlap : float
        The wanted overlap, a fraction in [0, 1) of a view's cylindrical
        width.

    Returns
    -------
    int
        The nearest even width, px.

    Raises
    ------
    ValueError
        If ``overlap`` is not in [0, 1), or the views would need a field of
        view of 180° or more.

    Examples
    --------
    >>> view_width(300.0, np.radians(18), 0.10), view_width(300.0, np.radians(18), 0.30)
    (106, 136)
    """
    focal = check_real("focal", focal, positive=True)
    pan_step = check_real("pan_step", pan_step, positive=True)
    overlap = check_real("overlap", overlap, minimum=0.0)
    if overlap >= 1:
        raise ValueError(f"The parameter `overlap` must be in [0, 1), got {overlap}")
    covered = focal * pan_step / (1 - overlap)
    if covered >= np.pi * focal:
        raise ValueError("The views would need a field of view of 180° or more")
    return 2 * int(round(focal * portable_tan(covered / (2 * focal))))


@dataclass(frozen=True, eq=False)
class RigViews:
    """Camera views and their ground truth (:func:`render_views`, :func:`texture_views`).

    Attributes
    ----------
    images : ndarray of shape (N, H, W), float64
        The perspective views, in [0, 1].
    pan_angles : ndarray of shape (N,)
        The nominal pan angles (radians) the rig was told.
    true_pan : ndarray of shape (N,)
        The angles it actually took.
    jitter : ndarray of shape (N,)
        The vertical shift (px, down) of each view on the cylinder.
    focal : float
    translations : ndarray of shape (N − 1, 2)
        The true ``t`` of view ``k + 1`` against view ``k`` in their
        cylindrical frames: ``(f (ψ_{k+1} − ψ_k), J_{k+1} − J_k)``.

    Examples
    --------
    Five views a radian apart cut from a random texture; the true
    translations (Eq. 15's ``t``) follow from the poses drawn:

    >>> photo = np.random.default_rng(0).random((40, 300))
    >>> views = texture_views(photo, focal=50.0, pan_step=1.0)
    >>> views.images.shape, views.translations.shape
    ((5, 30, 62), (4, 2))
    >>> bool(np.all(views.translations[:, 0] == views.focal * np.diff(views.true_pan)))
    True
    """

    images: np.ndarray
    pan_angles: np.ndarray
    true_pan: np.ndarray
    jitter: np.ndarray
    focal: float
    translations: np.ndarray


def _rig_views(images, nominal, true_pan, shifts, focal) -> RigViews:
    """The views with their poses, and the true translations between neighbours."""
    return RigViews(
        images=images,
        pan_angles=nominal,
        true_pan=true_pan,
        jitter=shifts,
        focal=focal,
        translations=np.stack([focal * np.diff(true_pan), np.diff(shifts)], axis=1),
    )


def _view_rays(shape, focal, pan, jitter, supersample, rng):
    """Directions of the sub-pixel rays of a view, (H, W, s², 3).

    Stratified (jittered) supersampling: one ray at a uniform random place in
    each of the s × s cells of every pixel, so that the area a pixel sees of
    an edge is not rounded to multiples of 1/s (that would round edge
    positions to 1/s px and bias sub-pixel alignment).
    """
    height, width = shape
    cells = np.arange(supersample) / supersample - 0.5
    sub = (supersample, supersample)
    rows, cols = np.indices(shape, dtype=np.float64)
    x = (cols - (width - 1) / 2)[..., None, None] + cells[None, None, None, :]
    y = (rows - (height - 1) / 2)[..., None, None] + cells[None, None, :, None]
    x = x + rng.uniform(0, 1 / supersample, (*shape, *sub))
    y = y + rng.uniform(0, 1 / supersample, (*shape, *sub))
    x_c, y_c = _cylinder_coordinates(x, y, focal)
    psi = pan + x_c / focal
    v = y_c + jitter
    directions = np.stack([portable_sin(psi), -v / focal, portable_cos(psi)], axis=-1)
    return directions.reshape(height, width, -1, 3)


def _vignetting(shape, focal, strength):
    """Natural vignetting ``1 − s (1 − cos⁴ θ)``, θ the angle off the optical axis."""
    rows, cols = np.indices(shape, dtype=np.float64)
    r2 = (cols - (shape[1] - 1) / 2) ** 2 + (rows - (shape[0] - 1) / 2) ** 2
    f2 = focal * focal
    cos4 = (f2 / (f2 + r2)) ** 2
    return 1.0 - strength * (1.0 - cos4)


def _draw_poses(rng, n_views, pan_step, start_angle, pan_error, jitter):
    nominal = start_angle + pan_step * np.arange(n_views)
    true_pan = nominal + rng.uniform(-pan_error, pan_error, n_views)
    shifts = rng.uniform(-jitter, jitter, n_views)
    return nominal, true_pan, shifts


def render_views(
    room: RoomGeometry,
    *,
    focal: float = FOCAL,
    n_views: int = 11,
    pan_step: float = CAMERA_STEP,
    start_angle: float = -math.pi / 2,
    height: int = 240,
    overlap: float = 0.2,
    pan_error: float = math.radians(0.4),
    jitter: float = 1.5,
    vignetting: float = 1.0,
    noise: float = 0.005,
    supersample: int = 3,
    seed: int | None = 0,
) -> RigViews:
    """Perspective views of the room from the rig's camera, every ``pan_step``.

    View ``k`` is taken at the pan angle ``start_angle + k · pan_step`` plus
    an error drawn uniformly in ``±pan_error``, shifted vertically on the
    cylinder by a jitter drawn in ``±jitter`` px, darkened towards its
    corners by natural vignetting ``1 − s (1 − cos⁴ θ)``, averaged over
    ``supersample²`` rays per pixel (stratified at random: anti-aliasing
    without rounding edge positions to ``1/supersample`` px), with Gaussian
    noise.

    Parameters
    ----------
    room : RoomGeometry
        From :func:`~refsynth.scenes.rig.rig_room`.
    focal : float, default 300
        px (§4.1).
    n_views : int, default 11
        11 views every 18° cover 180° (view centres at −90° … 90°).
    pan_step : float, default 18° (radians)
    start_angle : float, default −90° (radians)
    height : int, default 240
    overlap : float, default 0.2
        Fraction of a view's cylindrical width shared with the next; sets
        the width (:func:`view_width`).
    pan_error : float, default 0.4° (radians)
    jitter : float, default 1.5
        px.
    vignetting : float, default 1
        ``s``: 0 for none, 1 for the cos⁴ law.
    noise : float, default 0.005
        Standard deviation of the additive Gaussian noise.
    supersample : int, default 3
    seed : int or None, default 0
        Draws the pose errors and the noise.

    Returns
    -------
    RigViews
        ``images`` of shape ``(n_views, height, W)``, ``W`` from
        :func:`view_width`.

    Examples
    --------
    Two small views (f = 30 px, 8 rows, one ray per pixel):

    >>> from refsynth.scenes.rig import rig_room
    >>> views = render_views(rig_room(0), focal=30.0, n_views=2, height=8, supersample=1)
    >>> views.images.shape, views.translations.shape
    ((2, 8, 12), (1, 2))
    """
    focal = check_real("focal", focal, positive=True)
    n_views = check_int("n_views", n_views, 2)
    pan_step = check_real("pan_step", pan_step, positive=True)
    start_angle = check_real("start_angle", start_angle)
    height = check_int("height", height, 8)
    width = view_width(focal, pan_step, overlap)
    pan_error = check_real("pan_error", pan_error, minimum=0.0)
    jitter = check_real("jitter", jitter, minimum=0.0)
    vignetting = check_real("vignetting", vignetting, minimum=0.0)
    noise = check_real("noise", noise, minimum=0.0)
    supersample = check_int("supersample", supersample, 1)
    rng = np.random.default_rng(seed)
    nominal, true_pan, shifts = _draw_poses(rng, n_views, pan_step, start_angle, pan_error, jitter)
    shade = _vignetting((height, width), focal, vignetting)
    images = np.empty((n_views, height, width))
    for k in range(n_views):
        rays = _view_rays((height, width), focal, true_pan[k], shifts[k], supersample, rng)
        _, intensity = cast_rig_rays(room, np.zeros(3), rays)
        total = intensity[..., 0]
        for sample in range(1, intensity.shape[-1]):  # left to right (portable)
            total = total + intensity[..., sample]
        images[k] = (total / intensity.shape[-1]) * shade
    images = np.clip(images + rng.normal(0.0, noise, images.shape), 0.0, 1.0)
    return _rig_views(images, nominal, true_pan, shifts, focal)


def texture_views(
    texture: np.ndarray,
    *,
    focal: float = FOCAL,
    n_views: int | None = None,
    pan_step: float = CAMERA_STEP,
    height: int | None = None,
    overlap: float = 0.1,
    pan_error: float = math.radians(0.4),
    jitter: float = 1.5,
    vignetting: float = 0.0,
    noise: float = 0.0,
    seed: int | None = 0,
) -> RigViews:
    r"""Perspective views cut out of a photograph wrapped on the cylinder of radius ``f``.

    The photograph is the unrolled cylinder, one pixel per pixel of arc:
    texture column ``c`` is the pan angle ``c / f``. View ``k`` looks at pan
    angle ``ψ_k`` (nominal ``k · pan_step`` from the first view that fits,
    plus an error in ``±pan_error``) and sees the cylinder shifted by a
    jitter in ``±jitter`` px; each of its pixels ``(x, y)`` samples the
    texture at

    .. math:: (c, r) = (c_0 + f\,\psi_k + x_c,\; r_0 + y_c + J_k)

    with ``(x_c, y_c)`` from Eq. 14 (:func:`~refsynth.registration.cylinder.cylinder_coordinates`),
    by cubic B-spline interpolation (the aligner interpolates bilinearly, so
    the views are not made with the aligner's own interpolator).

    Parameters
    ----------
    texture : ndarray of shape (H_t, W_t) or (H_t, W_t, 3)
        The photograph; colour is reduced to luminance, integers scaled to
        [0, 1].
    focal : float, default 300
    n_views : int, optional
        Default: as many as fit in the texture's width.
    pan_step : float, default 18° (radians)
    height : int, optional
        Default: the texture's height minus a margin of ``2 jitter + 4`` px.
    overlap : float, default 0.1
        Sets the views' width (:func:`view_width`).
    pan_error, jitter, vignetting, noise, seed
        As in :func:`render_views`.

    Returns
    -------
    RigViews
        ``pan_angles`` are the nominal angles from the texture's column 0.

    Examples
    --------
    >>> y, x = np.mgrid[0:60, 0:400] / 5.0
    >>> views = texture_views(np.sin(x) * np.cos(y), focal=100.0, pan_step=0.5, overlap=0.2)
    >>> views.images.shape
    (7, 50, 64)
    """
    photo = grey(check_image("texture", texture, allow_nan=False))
    focal = check_real("focal", focal, positive=True)
    pan_step = check_real("pan_step", pan_step, positive=True)
    pan_error = check_real("pan_error", pan_error, minimum=0.0)
    jitter = check_real("jitter", jitter, minimum=0.0)
    width = view_width(focal, pan_step, overlap)
    margin = 2 * jitter + 4
    if height is None:
        height = int(photo.shape[0] - 2 * np.ceil(margin / 2 + jitter))
    height = check_int("height", height, 8)
    half_c = focal * portable_arctan((width / 2) / focal)  # half the cylindrical width
    first = half_c + 2 + focal * pan_error
    fits = int((photo.shape[1] - 2 * first) // (focal * pan_step)) + 1
    if n_views is None:
        n_views = fits
    n_views = check_int("n_views", n_views, 2)
    if n_views > fits or height + margin > photo.shape[0]:
        raise ValueError(
            f"The parameter `texture` of shape {photo.shape[:2]} is too small for {n_views} views "
            f"of {height}x{width} px every {math.degrees(pan_step):.1f}° at f = {focal:g}"
        )
    rng = np.random.default_rng(seed)
    nominal, true_pan, shifts = _draw_poses(rng, n_views, pan_step, first / focal, pan_error,
                                            jitter)
    rows, cols = np.indices((height, width), dtype=np.float64)
    x_c, y_c = _cylinder_coordinates(cols - (width - 1) / 2, rows - (height - 1) / 2, focal)
    centre_row = (photo.shape[0] - 1) / 2
    coefficients = ndi.spline_filter(photo, order=3)
    images = np.empty((n_views, height, width))
    for k in range(n_views):
        coords = np.stack([centre_row + y_c + shifts[k], focal * true_pan[k] + x_c])
        images[k] = ndi.map_coordinates(coefficients, coords, order=3, prefilter=False)
    images *= _vignetting((height, width), focal, check_real("vignetting", vignetting,
                                                               minimum=0.0))
    images = images + rng.normal(0.0, check_real("noise", noise, minimum=0.0), images.shape)
    return _rig_views(images, nominal, true_pan, shifts, focal)
