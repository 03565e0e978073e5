r"""Test scenes for registration (Appendix A; §3.1 and §4.1 of the paper).

A synthetic stand-in for the authors' rig: a camera and a laser rangefinder
on one pan unit, both centred on the pan axis, the laser ``ΔY`` below the
camera. The camera takes a picture every 18°; the laser sweeps vertical
slices every 0.36° and returns spherical samples ``(r, θ, φ)``. Everything
is ray-cast in one room with the ground truth kept, so that registration
can be scored in pixels:

- :func:`rig_room`: a room of walls 5–8 m from the rig (§4.1: r = 5–8 m)
  with furniture 1.5–4.5 m away, textured walls, posters, doors, tiled
  floor; Lambertian shading.
- :func:`render_views`: the camera's perspective views every ``pan_step``,
  with a small random error on each pan angle, vertical jitter, vignetting
  and noise, anti-aliased by supersampling.
- :func:`laser_scan`: the spherical scan, partial (stripes of slices), with
  range noise, from a laser ``ΔY`` below the camera whose azimuth zero is
  turned by ``pan_offset`` from the camera's.
- :func:`mosaic_position`: where a 3-D point truly lands in a mosaic built
  from the views (the ground truth of laser–camera registration).
- :func:`texture_views`: views cut out of a real photograph wrapped on the
  cylinder, with known pan angles and jitter (alignment on real image
  statistics).

The rig room is not :func:`refsynth.scenes.datasets.synthetic_room`: that scene is
a single forward view with side walls 2.6–3.4 m away and no wall behind the
camera; a panning rig needs a room that is textured all round at the
paper's 5–8 m.

Vertical jitter is rendered as the translation the paper's model assumes
(Eq. 15): view ``k`` sees the cylinder shifted by ``jitter[k]`` pixels along
its axis, so the true translations are exact. (A physical tilt of 1 px
would shift the cylinder by ``cos(x_c / f)`` px, 0.985 px at the edge of a
view 137 px wide at f = 300 — a model error of 0.015 px.)

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.1, §4.1, Appendix A,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from refsynth.registration.panorama import (
    Mosaic,
    _check_focal,
    _check_int,
    _check_real,
    cylinder_coordinates,
)

__all__ = [
    "RigRoom",
    "rig_room",
    "cast_rays",
    "view_width",
    "RigViews",
    "render_views",
    "LaserScan",
    "laser_scan",
    "mosaic_position",
    "registration_errors",
    "texture_views",
]

#: The paper's rig (§3.1, §4.1): focal length (px), laser–camera offset (m),
#: camera step (rad), laser pan step (rad), mirror step (rad).
FOCAL = 300.0
DELTA_Y = 0.05
CAMERA_STEP = math.radians(18.0)
LASER_PAN_STEP = math.radians(0.36)
MIRROR_STEP = 2 * math.pi / 2000

_AMBIENT = 0.35


# ----------------------------------------------------------------------------- the room


@dataclass(frozen=True, eq=False)
class RigRoom:
    """A room around the rig; build with :func:`rig_room`, render with :func:`cast_rays`.

    World frame: the camera centre at the origin, y up, z along pan angle 0,
    x to the right (pan angles grow from z towards x).

    Attributes
    ----------
    lower, upper : ndarray of shape (3,)
        The room box, ``lower <= p <= upper`` (walls, floor, ceiling).
    boxes : ndarray of shape (K, 8)
        Furniture: centre (3), half sizes (3), yaw about y (rad), albedo
        (modulated by ±20 % with a wood-like grain).
    wall_albedo : ndarray of shape (4,)
        Base albedo of the walls at −x, +x, −z, +z.
    waves : ndarray of shape (4, M, 4)
        Per wall, smooth albedo variation: amplitude, spatial frequencies
        along the wall and up (cycles/m), phase.
    posters : ndarray of shape (P, 7)
        Wall index, along-wall extent (2), height extent (2), albedo,
        stripe frequency (cycles/m; 0 = plain).
    light : ndarray of shape (3,)
        Unit direction towards the distant light.
    seed : int or None
    """

    lower: np.ndarray
    upper: np.ndarray
    boxes: np.ndarray
    wall_albedo: np.ndarray
    waves: np.ndarray
    posters: np.ndarray
    light: np.ndarray
    seed: int | None


def rig_room(seed: int | None = 0) -> RigRoom:
    """A furnished room around the rig, drawn from ``seed`` (§4.1: walls 5–8 m away).

    Walls 5–8 m from the rig, floor 1.1–1.3 m below the camera, ceiling
    2.6–3.0 m above the floor; 8–11 boxes of furniture (0.3–1.2 m wide,
    0.5–2.0 m high) 1.5–4.5 m from the rig in every direction; on each wall
    a smooth albedo variation (a few sinusoids of 0.3–2 m wavelength),
    posters (plain or striped) and a door; a tiled floor.

    Parameters
    ----------
    seed : int or None, default 0

    Returns
    -------
    RigRoom

    Examples
    --------
    >>> room = rig_room(1)
    >>> bool(np.all(room.upper[[0, 2]] >= 5) and np.all(room.lower[[0, 2]] <= -5))
    True
    """
    if seed is not None:
        _check_int("seed", seed, 0)
    rng = np.random.default_rng(seed)
    camera_height = rng.uniform(1.1, 1.3)
    walls = rng.uniform(5.0, 8.0, size=4)  # distances to −x, +x, −z, +z
    lower = np.array([-walls[0], -camera_height, -walls[2]])
    upper = np.array([walls[1], rng.uniform(2.6, 3.0) - camera_height, walls[3]])
    wall_albedo = rng.uniform(0.55, 0.75, size=4)
    n_waves = 6
    waves = np.stack(
        [
            rng.uniform(0.02, 0.06, size=(4, n_waves)),
            rng.uniform(0.5, 3.0, size=(4, n_waves)) * rng.choice([-1, 1], size=(4, n_waves)),
            rng.uniform(0.3, 2.5, size=(4, n_waves)) * rng.choice([-1, 1], size=(4, n_waves)),
            rng.uniform(0, 2 * np.pi, size=(4, n_waves)),
        ],
        axis=-1,
    )
    posters = []
    for wall in range(4):
        along = walls[[2, 2, 0, 0][wall]] + walls[[3, 3, 1, 1][wall]]  # the wall's length
        start = -walls[[2, 2, 0, 0][wall]]
        cursor = start + rng.uniform(0.3, 1.0)
        while cursor < start + along - 1.5:
            width = rng.uniform(0.5, 1.4)
            kind = rng.integers(3)
            if kind == 0:  # a door
                bottom, top, albedo, stripes = lower[1], lower[1] + 2.05, rng.uniform(0.2, 0.35), 0
            else:  # a poster
                bottom = rng.uniform(-0.3, 0.4)
                top = bottom + rng.uniform(0.4, 1.0)
                albedo = rng.uniform(0.15, 0.95)
                stripes = rng.uniform(2.0, 6.0) if kind == 2 else 0.0
            posters.append([wall, cursor, cursor + width, bottom, top, albedo, stripes])
            cursor += width + rng.uniform(0.4, 1.5)
    boxes = []
    for _ in range(int(rng.integers(8, 12))):
        for _ in range(100):
            azimuth = rng.uniform(-np.pi, np.pi)
            distance = rng.uniform(1.5, 4.5)
            half = np.array([rng.uniform(0.15, 0.6), 0.0, rng.uniform(0.15, 0.5)])
            half[1] = rng.uniform(0.25, 1.0)
            centre = np.array(
                [distance * np.sin(azimuth), lower[1] + half[1], distance * np.cos(azimuth)]
            )
            radius = float(np.hypot(half[0], half[2]))
            clear = all(
                np.hypot(*(centre - b[:3])[[0, 2]]) > radius + np.hypot(b[3], b[5]) + 0.1
                for b in boxes
            )
            inside = np.all(centre[[0, 2]] - radius > lower[[0, 2]] + 0.2) and np.all(
                centre[[0, 2]] + radius < upper[[0, 2]] - 0.2
            )
            if clear and inside:
                break
        boxes.append([*centre, *half, rng.uniform(-0.8, 0.8), rng.uniform(0.2, 0.9)])
    light = np.array([rng.uniform(-0.5, 0.5), rng.uniform(0.6, 0.9), rng.uniform(-0.5, 0.5)])
    return RigRoom(
        lower=lower,
        upper=upper,
        boxes=np.array(boxes),
        wall_albedo=wall_albedo,
        waves=waves,
        posters=np.array(posters),
        light=light / np.linalg.norm(light),
        seed=seed,
    )


def _ray_box(origin, directions, centre, half, yaw):
    """Slab-method hit distance (inf on a miss) and world normal of a yawed box.

    Only the rays that pass through the box's bounding sphere are intersected.
    """
    distance = np.full(directions.shape[:-1], np.inf)
    normal = np.zeros(directions.shape)
    offset = centre - origin
    reach = float(np.linalg.norm(half))
    gap = float(np.linalg.norm(offset))
    if gap > reach:
        along = directions @ (offset / gap)
        candidate = along > np.sqrt(1.0 - (reach / gap) ** 2)
    else:
        candidate = np.ones(directions.shape[:-1], dtype=bool)
    if not candidate.any():
        return distance, normal
    cos, sin = np.cos(yaw), np.sin(yaw)
    to_local = np.array([[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]])
    start = to_local @ (-offset)
    local = directions[candidate] @ to_local.T
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - start) / local
        t2 = (half - start) / local
    near = np.fmin(t1, t2)
    far = np.fmax(t1, t2)
    t_enter = np.maximum(np.maximum(near[:, 0], near[:, 1]), near[:, 2])
    t_exit = np.minimum(np.minimum(far[:, 0], far[:, 1]), far[:, 2])
    hit = (t_enter <= t_exit) & (t_enter > 0)
    axis = near.argmax(axis=-1)
    component = local[np.arange(local.shape[0]), axis]
    face = np.zeros_like(local)
    face[np.arange(local.shape[0]), axis] = -np.sign(component)
    distance[candidate] = np.where(hit, t_enter, np.inf)
    normal[candidate] = face @ to_local
    return distance, normal


def cast_rays(room: RigRoom, origin, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray-cast the room: distance and shaded intensity along each ray.

    Parameters
    ----------
    room : RigRoom
    origin : array_like of shape (3,)
        The common start of the rays, inside the room.
    directions : ndarray of shape (..., 3)
        Ray directions (normalised here).

    Returns
    -------
    distance : ndarray of shape (...)
        Euclidean distance (m) from ``origin`` to the first surface hit.
    intensity : ndarray of shape (...)
        ``albedo · (0.35 + 0.65 max(0, n·l))``, in [0, 1], no noise.
    """
    origin = np.asarray(origin, dtype=np.float64)
    rays = np.asarray(directions, dtype=np.float64)
    rays = rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    # the room: the exit of the box
    with np.errstate(divide="ignore", invalid="ignore"):
        exits = np.where(
            rays > 0, (room.upper - origin) / rays,
            np.where(rays < 0, (room.lower - origin) / rays, np.inf),
        )
    axis = exits.argmin(axis=-1)
    distance = np.take_along_axis(exits, axis[..., None], axis=-1)[..., 0]
    sign = np.sign(np.take_along_axis(rays, axis[..., None], axis=-1)[..., 0])
    normal = np.zeros_like(rays)
    np.put_along_axis(normal, axis[..., None], -sign[..., None], axis=-1)
    point = origin + rays * distance[..., None]
    albedo = _room_albedo(room, point, axis, sign)
    for box in room.boxes:
        hit, hit_normal = _ray_box(origin, rays, box[:3], box[3:6], box[6])
        closer = hit < distance
        distance = np.where(closer, hit, distance)
        normal[closer] = hit_normal[closer]
        albedo[closer] = _box_albedo(box, origin + rays[closer] * hit[closer][:, None])
    shading = _AMBIENT + (1 - _AMBIENT) * np.clip(normal @ room.light, 0.0, None)
    return distance, np.clip(albedo * shading, 0.0, 1.0)


def _box_albedo(box: np.ndarray, point: np.ndarray) -> np.ndarray:
    """A box's albedo with a wood-like grain: waves along its own x and z, wavy with height."""
    offset = point - box[:3]
    cos, sin = np.cos(box[6]), np.sin(box[6])
    along = offset[:, 0] * cos - offset[:, 2] * sin + offset[:, 0] * sin + offset[:, 2] * cos
    along = along + 0.04 * np.sin(2 * np.pi * offset[:, 1] / 0.5)
    return box[7] * (0.8 + 0.2 * np.sin(2 * np.pi * along / 0.15 + 7 * box[7]))


def _room_albedo(room: RigRoom, point, axis, sign) -> np.ndarray:
    """Albedo of the walls (smooth waves, posters, doors, skirting), floor tiles, ceiling."""
    x, y, z = point[..., 0], point[..., 1], point[..., 2]
    wall = np.where(axis == 0, np.where(sign < 0, 0, 1), np.where(sign < 0, 2, 3))
    wall = np.where(axis == 1, -1, wall)
    along = np.where(axis == 0, z, x)
    albedo = np.where(wall >= 0, room.wall_albedo[np.clip(wall, 0, 3)], 0.0)
    for index in range(4):
        on = np.nonzero(wall == index)
        a, h = along[on], y[on]
        amplitude, fa, fy, phase = np.moveaxis(room.waves[index], -1, 0)
        value = albedo[on] + (
            amplitude * np.sin(2 * np.pi * (a[:, None] * fa + h[:, None] * fy) + phase)
        ).sum(axis=-1)
        for _, a0, a1, y0, y1, poster, stripes in room.posters[room.posters[:, 0] == index]:
            inside = (a >= a0) & (a <= a1) & (h >= y0) & (h <= y1)
            canvas = (a >= a0 + 0.04) & (a <= a1 - 0.04) & (h >= y0 + 0.04) & (h <= y1 - 0.04)
            pattern = poster * (0.75 + 0.25 * np.sin(2 * np.pi * stripes * (a + h)))
            value = np.where(inside, np.where(canvas, pattern, 0.1), value)
        albedo[on] = np.where(h < room.lower[1] + 0.12, 0.2, value)  # skirting board
    floor = (axis == 1) & (sign < 0)
    tiles = np.where((np.floor(x / 0.6) + np.floor(z / 0.6)) % 2 == 0, 0.55, 0.4)
    albedo = np.where(floor, tiles, albedo)
    return np.where((axis == 1) & (sign > 0), 0.85, albedo)


# ----------------------------------------------------------------------------- camera views


def view_width(focal: float, pan_step: float, overlap: float) -> int:
    r"""Width (px) of perspective views whose cylindrical images overlap by ``overlap``.

    A view ``W`` px wide covers ``W_c = 2 f \arctan(W / 2f)`` px of the
    cylinder; consecutive views ``f · pan_step`` apart overlap by
    ``1 − f · pan_step / W_c``. Returns the nearest even width.

    Examples
    --------
    >>> view_width(300.0, np.radians(18), 0.10), view_width(300.0, np.radians(18), 0.30)
    (106, 136)
    """
    focal = _check_focal(focal)
    pan_step = _check_real("pan_step", pan_step, positive=True)
    overlap = _check_real("overlap", overlap, minimum=0.0)
    if overlap >= 1:
        raise ValueError(f"The parameter `overlap` must be in [0, 1), got {overlap}")
    covered = focal * pan_step / (1 - overlap)
    if covered >= np.pi * focal:
        raise ValueError("The views would need a field of view of 180° or more")
    return 2 * int(round(focal * np.tan(covered / (2 * focal))))


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
    """

    images: np.ndarray
    pan_angles: np.ndarray
    true_pan: np.ndarray
    jitter: np.ndarray
    focal: float
    translations: np.ndarray


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
    x_c, y_c = cylinder_coordinates(x, y, focal)
    psi = pan + x_c / focal
    v = y_c + jitter
    directions = np.stack([np.sin(psi), -v / focal, np.cos(psi)], axis=-1)
    return directions.reshape(height, width, -1, 3)


def _vignetting(shape, focal, strength):
    """Natural vignetting ``1 − s (1 − cos⁴ θ)``, θ the angle off the optical axis."""
    rows, cols = np.indices(shape, dtype=np.float64)
    r2 = (cols - (shape[1] - 1) / 2) ** 2 + (rows - (shape[0] - 1) / 2) ** 2
    cos4 = (focal**2 / (focal**2 + r2)) ** 2
    return 1.0 - strength * (1.0 - cos4)


def _draw_poses(rng, n_views, pan_step, start_angle, pan_error, jitter):
    nominal = start_angle + pan_step * np.arange(n_views)
    true_pan = nominal + rng.uniform(-pan_error, pan_error, n_views)
    shifts = rng.uniform(-jitter, jitter, n_views)
    return nominal, true_pan, shifts


def render_views(
    room: RigRoom,
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
    room : RigRoom
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
    """
    focal = _check_focal(focal)
    n_views = _check_int("n_views", n_views, 2)
    pan_step = _check_real("pan_step", pan_step, positive=True)
    start_angle = _check_real("start_angle", start_angle)
    height = _check_int("height", height, 8)
    width = view_width(focal, pan_step, overlap)
    pan_error = _check_real("pan_error", pan_error, minimum=0.0)
    jitter = _check_real("jitter", jitter, minimum=0.0)
    vignetting = _check_real("vignetting", vignetting, minimum=0.0)
    noise = _check_real("noise", noise, minimum=0.0)
    supersample = _check_int("supersample", supersample, 1)
    rng = np.random.default_rng(seed)
    nominal, true_pan, shifts = _draw_poses(rng, n_views, pan_step, start_angle, pan_error, jitter)
    shade = _vignetting((height, width), focal, vignetting)
    images = np.empty((n_views, height, width))
    for k in range(n_views):
        rays = _view_rays((height, width), focal, true_pan[k], shifts[k], supersample, rng)
        _, intensity = cast_rays(room, np.zeros(3), rays)
        images[k] = intensity.mean(axis=-1) * shade
    images = np.clip(images + rng.normal(0.0, noise, images.shape), 0.0, 1.0)
    return RigViews(
        images=images,
        pan_angles=nominal,
        true_pan=true_pan,
        jitter=shifts,
        focal=focal,
        translations=np.stack([focal * np.diff(true_pan), np.diff(shifts)], axis=1),
    )


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

    with ``(x_c, y_c)`` from Eq. 14 (:func:`~refsynth.registration.panorama.cylinder_coordinates`),
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
    from refsynth.registration.panorama import _check_image, _grey

    grey = _grey(_check_image("texture", texture, allow_nan=False))
    focal = _check_focal(focal)
    pan_step = _check_real("pan_step", pan_step, positive=True)
    pan_error = _check_real("pan_error", pan_error, minimum=0.0)
    jitter = _check_real("jitter", jitter, minimum=0.0)
    width = view_width(focal, pan_step, overlap)
    margin = 2 * jitter + 4
    if height is None:
        height = int(grey.shape[0] - 2 * np.ceil(margin / 2 + jitter))
    height = _check_int("height", height, 8)
    half_c = focal * np.arctan((width / 2) / focal)  # half the cylindrical width
    first = half_c + 2 + focal * pan_error
    fits = int((grey.shape[1] - 2 * first) // (focal * pan_step)) + 1
    if n_views is None:
        n_views = fits
    n_views = _check_int("n_views", n_views, 2)
    if n_views > fits or height + margin > grey.shape[0]:
        raise ValueError(
            f"The parameter `texture` of shape {grey.shape[:2]} is too small for {n_views} views "
            f"of {height}x{width} px every {math.degrees(pan_step):.1f}° at f = {focal:g}"
        )
    rng = np.random.default_rng(seed)
    nominal, true_pan, shifts = _draw_poses(rng, n_views, pan_step, first / focal, pan_error,
                                            jitter)
    rows, cols = np.indices((height, width), dtype=np.float64)
    x_c, y_c = cylinder_coordinates(cols - (width - 1) / 2, rows - (height - 1) / 2, focal)
    centre_row = (grey.shape[0] - 1) / 2
    coefficients = ndi.spline_filter(grey, order=3)
    images = np.empty((n_views, height, width))
    for k in range(n_views):
        coords = np.stack([centre_row + y_c + shifts[k], focal * true_pan[k] + x_c])
        images[k] = ndi.map_coordinates(coefficients, coords, order=3, prefilter=False)
    images *= _vignetting((height, width), focal, _check_real("vignetting", vignetting,
                                                               minimum=0.0))
    images = images + rng.normal(0.0, _check_real("noise", noise, minimum=0.0), images.shape)
    return RigViews(
        images=images,
        pan_angles=nominal,
        true_pan=true_pan,
        jitter=shifts,
        focal=focal,
        translations=np.stack([focal * np.diff(true_pan), np.diff(shifts)], axis=1),
    )


# ----------------------------------------------------------------------------- laser


@dataclass(frozen=True, eq=False)
class LaserScan:
    """A spherical laser scan and its ground truth (:func:`laser_scan`).

    Attributes
    ----------
    r : ndarray of shape (n_phi, n_theta)
        Range (m) from the laser's centre; NaN on slices not scanned.
    theta : ndarray of shape (n_theta,)
        Mirror angle from the vertical (up) axis, radians, increasing.
    phi : ndarray of shape (n_phi,)
        Azimuth of each slice in the laser's frame, radians, increasing.
    points : ndarray of shape (n_phi, n_theta, 3)
        The true surface points hit (world frame, m), for every slice.
    delta_y : float
        The camera is ``delta_y`` m above the laser.
    pan_offset : float
        The laser's azimuth 0 is the camera's pan angle ``pan_offset``.
    """

    r: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    points: np.ndarray
    delta_y: float
    pan_offset: float


def laser_scan(
    room: RigRoom,
    *,
    delta_y: float = DELTA_Y,
    phi_range: tuple[float, float] = (-math.radians(100), math.radians(100)),
    pan_step: float = LASER_PAN_STEP,
    theta_range: tuple[float, float] = (math.radians(55), math.radians(125)),
    theta_step: float = MIRROR_STEP,
    pan_offset: float = math.radians(1.0),
    noise: float = 0.005,
    stripes: tuple[int, int] | None = (10, 15),
    seed: int | None = 0,
) -> LaserScan:
    """The rig's spherical laser scan of the room (§3.1): slices every 0.36°.

    The laser's centre is ``delta_y`` below the camera's, on the pan axis.
    Slice ``j`` is the vertical sweep at azimuth ``φ_j`` (laser frame; the
    world azimuth is ``φ_j + pan_offset``), sampled at mirror angles
    ``θ_i`` from the vertical axis. Ranges carry Gaussian noise. With
    ``stripes = (rw, xw)``, runs of ``rw`` scanned slices alternate with
    ``xw`` skipped ones (the paper scans 30–50 % of the slices; (10, 15)
    scans 40 %); the skipped slices are NaN.

    Parameters
    ----------
    room : RigRoom
    delta_y : float, default 0.05
        m (§4.1).
    phi_range : pair of float, default (−100°, 100°)
        Azimuths of the first and last slice (radians).
    pan_step : float, default 0.36° (radians)
    theta_range : pair of float, default (55°, 125°)
    theta_step : float, default 360° / 2000 (radians)
        The mirror encoder's step.
    pan_offset : float, default 1° (radians)
    noise : float, default 0.005
        m.
    stripes : pair of int or None, default (10, 15)
        None scans every slice.
    seed : int or None, default 0

    Returns
    -------
    LaserScan
    """
    delta_y = _check_real("delta_y", delta_y)
    pan_step = _check_real("pan_step", pan_step, positive=True)
    theta_step = _check_real("theta_step", theta_step, positive=True)
    pan_offset = _check_real("pan_offset", pan_offset)
    noise = _check_real("noise", noise, minimum=0.0)
    phi = np.arange(phi_range[0], phi_range[1] + pan_step / 2, pan_step)
    theta = np.arange(theta_range[0], theta_range[1] + theta_step / 2, theta_step)
    if phi.size < 2 or theta.size < 2:
        raise ValueError("The parameters `phi_range` and `theta_range` must span 2 steps or more")
    world = phi[:, None] + pan_offset
    directions = np.stack(
        np.broadcast_arrays(
            np.sin(theta) * np.sin(world), np.cos(theta), np.sin(theta) * np.cos(world)
        ),
        axis=-1,
    )
    origin = np.array([0.0, -delta_y, 0.0])
    distance, _ = cast_rays(room, origin, directions)
    rng = np.random.default_rng(seed)
    r = distance + rng.normal(0.0, noise, distance.shape)
    if stripes is not None:
        rw, xw = (_check_int("stripes", s, 0) for s in stripes)
        if rw < 1:
            raise ValueError(f"The parameter `stripes` must scan >= 1 slice per run, got {rw}")
        scanned = np.arange(phi.size) % (rw + xw) < rw
        r[~scanned] = np.nan
    points = origin + directions * distance[..., None]
    return LaserScan(r=r, theta=theta, phi=phi, points=points, delta_y=delta_y,
                     pan_offset=pan_offset)


def mosaic_position(points: np.ndarray, mosaic: Mosaic, views: RigViews) -> np.ndarray:
    """Where 3-D points truly appear in a mosaic built from ``views``.

    A point at pan angle ``ψ`` and scanline ``v`` (Eq. 14, camera centre at
    the origin) appears in view ``k``'s cylindrical frame at
    ``(c_x + f (ψ − ψ_k), c_y + v − J_k)`` (true pan ``ψ_k`` and jitter
    ``J_k``), and the mosaic puts that frame at ``offsets[k]``. The view
    whose centre is nearest in pan is used, so the position carries that
    view's placement error (the mosaic's own, as its pixels do).

    Parameters
    ----------
    points : ndarray of shape (..., 3)
        World points (m).
    mosaic : Mosaic
        Built from ``views.images``.
    views : RigViews

    Returns
    -------
    ndarray of shape (..., 2)
        ``(col, row)`` in mosaic pixels.
    """
    points = np.asarray(points, dtype=np.float64)
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    psi = np.arctan2(x, z)
    v = -views.focal * y / np.hypot(x, z)  # scanline, down
    nearest = np.abs(_wrap(psi[..., None] - views.true_pan)).argmin(axis=-1)
    height, width = mosaic.view_shape
    col = (
        mosaic.offsets[nearest, 0] + (width - 1) / 2
        + views.focal * _wrap(psi - views.true_pan[nearest])
    )
    row = mosaic.offsets[nearest, 1] + (height - 1) / 2 + v - views.jitter[nearest]
    return np.stack([col, row], axis=-1)


def registration_errors(
    registration, scan: LaserScan, views: RigViews, *, stages: dict | None = None
) -> dict:
    """Laser–camera registration error against the rig's ground truth, in mosaic pixels.

    For each depth edge of the registered range image
    (:func:`refsynth.registration.laser_camera.range_edges`), the sample on its near
    side (the occluding surface the edge belongs to) is mapped onto the
    mosaic by each stage of the registration and compared with where its
    3-D point truly appears (:func:`mosaic_position`). The *edge
    misalignment* is the error along the edge's normal — horizontal for a
    vertical edge, vertical for a horizontal one — the distance between the
    range edge and the intensity edge it should lie on.

    Parameters
    ----------
    registration : refsynth.registration.laser_camera.Registration
    scan : LaserScan
        The scan that was registered (its true points).
    views : RigViews
        The views the mosaic was built from.
    stages : dict, optional
        More mappings to score: name → function ``(phi, h, r) -> (N, 2)``
        mosaic positions of laser samples (e.g. the exact Eq. 20).

    Returns
    -------
    dict
        For each stage — ``"nominal"`` (the rig's nominal geometry),
        ``"global"`` (Eq. 21), ``"local"`` (after the stretch) — a dict
        with ``mean`` and ``rms`` of the edge misalignment over all depth
        edges, ``mean_u`` over vertical and ``mean_v`` over horizontal
        edges, and ``samples`` (mean 2-D error over every scanned sample
        inside the mosaic, edges or not); plus ``n_u`` and ``n_v``.
    """
    from refsynth.registration.laser_camera import _forward, range_edges

    cylinder = registration.cylinder
    found = range_edges(cylinder)
    row, col = cylinder.index(found.phi, found.h)
    # the two samples across each edge; keep the nearer one
    c0 = np.where(found.axis == 0, np.floor(col + 1e-9), np.round(col)).astype(int)
    r0 = np.where(found.axis == 1, np.floor(row + 1e-9), np.round(row)).astype(int)
    c1, r1 = c0 + (found.axis == 0), r0 + (found.axis == 1)
    first_nearer = cylinder.range[r0, c0] <= cylinder.range[r1, c1]
    cols, rows = np.where(first_nearer, c0, c1), np.where(first_nearer, r0, r1)

    def samples(cols, rows):
        slice_index = np.round((cylinder.phi[cols] - scan.phi[0]) / (scan.phi[1] - scan.phi[0]))
        slice_index = slice_index.astype(int)
        wanted = np.arctan2(views.focal, cylinder.h[rows])
        mirror = np.clip(np.searchsorted(scan.theta, wanted), 1, scan.theta.size - 1)
        left_closer = wanted - scan.theta[mirror - 1] < scan.theta[mirror] - wanted
        mirror = np.where(left_closer, mirror - 1, mirror)
        h = views.focal / np.tan(scan.theta[mirror])
        truth = mosaic_position(scan.points[slice_index, mirror], registration.mosaic, views)
        return scan.phi[slice_index], h, scan.r[slice_index, mirror], truth

    phi, h, r, truth = samples(cols, rows)
    every_row, every_col = np.nonzero(np.isfinite(cylinder.range))
    all_phi, all_h, all_r, all_truth = samples(every_col, every_row)
    height, width = registration.mosaic.weight.shape
    inside = (all_truth[:, 0] >= 0) & (all_truth[:, 0] < width)
    inside &= (all_truth[:, 1] >= 0) & (all_truth[:, 1] < height)
    vertical, horizontal = found.axis == 0, found.axis == 1
    mappings = {
        name: (lambda p, q, _, w=warp, d=displacement: _forward(w, d, p, q))
        for name, warp, displacement in [
            ("nominal", registration.initial, None),
            ("global", registration.warp, None),
            ("local", registration.warp, registration.displacement),
        ]
    }
    mappings.update(stages or {})
    out: dict = {"n_u": int(vertical.sum()), "n_v": int(horizontal.sum())}
    for name, mapping in mappings.items():
        error = mapping(phi, h, r) - truth
        normal = np.abs(np.where(vertical, error[:, 0], error[:, 1]))
        everywhere = mapping(all_phi[inside], all_h[inside], all_r[inside])
        out[name] = {
            "mean": float(normal.mean()),
            "rms": float(np.sqrt(np.mean(normal**2))),
            "mean_u": float(normal[vertical].mean()) if vertical.any() else float("nan"),
            "mean_v": float(normal[horizontal].mean()) if horizontal.any() else float("nan"),
            "samples": float(np.mean(np.hypot(*(everywhere - all_truth[inside]).T))),
        }
    return out


def _wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


__all__ += ["FOCAL", "DELTA_Y", "CAMERA_STEP", "LASER_PAN_STEP", "MIRROR_STEP"]
