r"""The registration test rig: its room and its laser scan (§3.1, §4.1; Appendix A).

A synthetic stand-in for the authors' rig: a camera and a laser rangefinder
on one pan unit, both centred on the pan axis, the laser ``ΔY`` below the
camera. The camera takes a picture every 18°
(:mod:`refsynth.scenes.rig_views`); the laser sweeps vertical slices every
0.36° and returns spherical samples ``(r, θ, φ)``. Everything is ray-cast in
one room with the ground truth kept, so that registration can be scored in
pixels (:mod:`refsynth.registration.scoring`):

- :func:`rig_room`: a room of walls 5–8 m from the rig (§4.1: r = 5–8 m)
  with furniture 1.5–4.5 m away, textured walls, posters, doors, tiled
  floor; Lambertian shading. A :class:`~refsynth.scenes.room.RoomGeometry`
  with a :class:`RigTexture`, ray-cast by :mod:`refsynth.scenes.room`.
- :func:`cast_rig_rays`: distance and noise-free intensity along rays from
  a point of the rig.
- :func:`laser_scan`: the spherical scan, partial (stripes of slices), with
  range noise, from a laser ``ΔY`` below the camera whose azimuth zero is
  turned by ``pan_offset`` from the camera's.

The rig room is not :func:`refsynth.scenes.synthetic.synthetic_room`'s: that
scene is a single forward view with side walls 2.6–3.4 m away and no wall
behind the camera; a panning rig needs a room that is textured all round at
the paper's 5–8 m. The two share the room model and the ray caster.

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

from refsynth._checks import check_int, check_real
from refsynth.scenes.portable import hypot2, norm3, portable_cos, portable_sin
from refsynth.scenes.room import Intersections, RoomGeometry, cast_rays

__all__ = [
    "RigTexture",
    "rig_room",
    "cast_rig_rays",
    "LaserScan",
    "laser_scan",
    "FOCAL",
    "DELTA_Y",
    "CAMERA_STEP",
    "LASER_PAN_STEP",
    "MIRROR_STEP",
]

#: The paper's rig (§3.1, §4.1): focal length (px), laser–camera offset (m),
#: camera step (rad), laser pan step (rad), mirror step (rad).
FOCAL = 300.0
DELTA_Y = 0.05
CAMERA_STEP = math.radians(18.0)
LASER_PAN_STEP = math.radians(0.36)
MIRROR_STEP = 2 * math.pi / 2000


# ----------------------------------------------------------------------------- the room


@dataclass(frozen=True, eq=False)
class RigTexture:
    """The albedo of the rig room's surfaces (a :class:`~refsynth.scenes.room.Texture`).

    Attributes
    ----------
    wall_albedo : ndarray of shape (4,)
        Base albedo of the walls at −x, +x, −z, +z.
    waves : ndarray of shape (4, M, 4)
        Per wall, smooth albedo variation: amplitude, spatial frequencies
        along the wall and up (cycles/m), phase.
    posters : ndarray of shape (P, 7)
        Wall index, along-wall extent (2), height extent (2), albedo,
        stripe frequency (cycles/m; 0 = plain). Doors are dark posters
        from the floor up.

    Notes
    -----
    The walls carry the waves, the posters and a skirting board (0.2, the
    lowest 12 cm); the floor a checkerboard of 0.6 m tiles (0.55 / 0.4); the
    ceiling 0.85; every box a wood-like grain, ±20 % about its albedo.

    Examples
    --------
    >>> texture = rig_room(0).texture
    >>> texture.wall_albedo.shape, texture.waves.shape, texture.posters.shape[1]
    ((4,), (4, 6, 4), 7)
    """

    wall_albedo: np.ndarray
    waves: np.ndarray
    posters: np.ndarray

    def albedo(
        self, room: RoomGeometry, rays: np.ndarray, origin: np.ndarray, hits: Intersections
    ) -> np.ndarray:
        """The albedo of the surface each ray hits, shape ``rays.shape[:-1]``."""
        albedo = self._room_albedo(room, hits.exit, hits.axis, hits.sign)
        for index, box in enumerate(room.boxes):
            on = hits.box == index
            albedo[on] = _box_albedo(box, origin + rays[on] * hits.distance[on][:, None])
        return albedo

    def _room_albedo(self, room: RoomGeometry, point, axis, sign) -> np.ndarray:
        """Albedo of the walls (smooth waves, posters, doors, skirting), floor tiles, ceiling."""
        x, y, z = point[..., 0], point[..., 1], point[..., 2]
        wall = np.where(axis == 0, np.where(sign < 0, 0, 1), np.where(sign < 0, 2, 3))
        wall = np.where(axis == 1, -1, wall)
        along = np.where(axis == 0, z, x)
        albedo = np.where(wall >= 0, self.wall_albedo[np.clip(wall, 0, 3)], 0.0)
        for index in range(4):
            on = np.nonzero(wall == index)
            a, h = along[on], y[on]
            waves = np.zeros(a.shape)
            for amplitude, fa, fy, phase in self.waves[index]:  # left to right (portable)
                waves = waves + amplitude * portable_sin(2 * np.pi * (a * fa + h * fy) + phase)
            value = albedo[on] + waves
            for _, a0, a1, y0, y1, poster, stripes in self.posters[self.posters[:, 0] == index]:
                inside = (a >= a0) & (a <= a1) & (h >= y0) & (h <= y1)
                canvas = (a >= a0 + 0.04) & (a <= a1 - 0.04) & (h >= y0 + 0.04) & (h <= y1 - 0.04)
                pattern = poster * (0.75 + 0.25 * portable_sin(2 * np.pi * stripes * (a + h)))
                value = np.where(inside, np.where(canvas, pattern, 0.1), value)
            albedo[on] = np.where(h < room.lower[1] + 0.12, 0.2, value)  # skirting board
        floor = (axis == 1) & (sign < 0)
        tiles = np.where((np.floor(x / 0.6) + np.floor(z / 0.6)) % 2 == 0, 0.55, 0.4)
        albedo = np.where(floor, tiles, albedo)
        return np.where((axis == 1) & (sign > 0), 0.85, albedo)


def _box_albedo(box: np.ndarray, point: np.ndarray) -> np.ndarray:
    """A box's albedo with a wood-like grain: waves along its own x and z, wavy with height."""
    offset = point - box[:3]
    cos, sin = portable_cos(box[6]), portable_sin(box[6])
    along = offset[:, 0] * cos - offset[:, 2] * sin + offset[:, 0] * sin + offset[:, 2] * cos
    along = along + 0.04 * portable_sin(2 * np.pi * offset[:, 1] / 0.5)
    return box[7] * (0.8 + 0.2 * portable_sin(2 * np.pi * along / 0.15 + 7 * box[7]))


def rig_room(seed: int | None = 0) -> RoomGeometry:
    """A furnished room around the rig, drawn from ``seed`` (§4.1: walls 5–8 m away).

    Walls 5–8 m from the rig, floor 1.1–1.3 m below the camera, ceiling
    2.6–3.0 m above the floor; 8–11 boxes of furniture (0.3–1.2 m wide,
    0.5–2.0 m high) 1.5–4.5 m from the rig in every direction; on each wall
    a smooth albedo variation (a few sinusoids of 0.3–2 m wavelength),
    posters (plain or striped) and a door; a tiled floor.

    World frame: the camera centre at the origin, y up, z along pan angle 0,
    x to the right (pan angles grow from z towards x).

    Parameters
    ----------
    seed : int or None, default 0

    Returns
    -------
    RoomGeometry
        A closed room box, the furniture's rows in ``boxes``, a
        :class:`RigTexture`.

    Examples
    --------
    >>> room = rig_room(1)
    >>> bool(np.all(room.upper[[0, 2]] >= 5) and np.all(room.lower[[0, 2]] <= -5))
    True
    """
    if seed is not None:
        check_int("seed", seed, 0)
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
            centre = np.array([distance * portable_sin(azimuth), lower[1] + half[1],
                               distance * portable_cos(azimuth)])
            radius = hypot2(half[0], half[2])
            clear = all(
                hypot2(*(centre - b[:3])[[0, 2]]) > radius + hypot2(b[3], b[5]) + 0.1
                for b in boxes
            )
            inside = np.all(centre[[0, 2]] - radius > lower[[0, 2]] + 0.2) and np.all(
                centre[[0, 2]] + radius < upper[[0, 2]] - 0.2
            )
            if clear and inside:
                break
        boxes.append([*centre, *half, rng.uniform(-0.8, 0.8), rng.uniform(0.2, 0.9)])
    light = np.array([rng.uniform(-0.5, 0.5), rng.uniform(0.6, 0.9), rng.uniform(-0.5, 0.5)])
    return RoomGeometry(
        lower=lower,
        upper=upper,
        boxes=np.array(boxes),
        light=light / norm3(light),
        texture=RigTexture(wall_albedo=wall_albedo, waves=waves, posters=np.array(posters)),
        seed=seed,
    )


def cast_rig_rays(
    room: RoomGeometry, origin, directions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Ray-cast the room from a point of the rig: distance and shaded intensity along each ray.

    :func:`~refsynth.scenes.room.cast_rays` with the rays normalised and
    culled per box (``cull=True``), the intensity clipped to [0, 1].

    Parameters
    ----------
    room : RoomGeometry
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

    Examples
    --------
    The directions need not be unit vectors: straight down, the floor is the
    camera height away.

    >>> room = rig_room(0)
    >>> distance, intensity = cast_rig_rays(room, [0.0, 0.0, 0.0], np.array([[0.0, -2.0, 0.0]]))
    >>> bool(distance[0] == room.camera_height), bool(0 <= intensity[0] <= 1)
    (True, True)
    """
    origin = np.asarray(origin, dtype=np.float64)
    rays = np.asarray(directions, dtype=np.float64)
    rays = rays / norm3(rays)[..., None]
    hits = cast_rays(room, rays, origin=origin, cull=True)
    return hits.distance, np.clip(hits.albedo * hits.shading, 0.0, 1.0)


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

    Examples
    --------
    ``r`` is the distance from the laser's centre, ``delta_y`` below the
    camera, to ``points``, plus the range noise (5 mm):

    >>> scan = laser_scan(rig_room(0), phi_range=(0.0, 0.1), theta_range=(1.5, 1.6), stripes=None)
    >>> scan.r.shape, scan.points.shape
    ((17, 33), (17, 33, 3))
    >>> laser = np.array([0.0, -scan.delta_y, 0.0])
    >>> bool(np.abs(scan.r - np.linalg.norm(scan.points - laser, axis=-1)).max() < 0.03)
    True
    """

    r: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    points: np.ndarray
    delta_y: float
    pan_offset: float


def laser_scan(
    room: RoomGeometry,
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
    room : RoomGeometry
        From :func:`rig_room`.
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
        Draws the range noise.

    Returns
    -------
    LaserScan
        ``r`` of shape ``(n_phi, n_theta)``, NaN on the skipped slices.

    Examples
    --------
    Ten slices, two scanned then three skipped, over a narrow band of mirror
    angles:

    >>> scan = laser_scan(rig_room(0), phi_range=(0.0, 9 * LASER_PAN_STEP),
    ...                   theta_range=(1.5, 1.52), stripes=(2, 3))
    >>> np.isfinite(scan.r[:, 0]).astype(int).tolist()
    [1, 1, 0, 0, 0, 1, 1, 0, 0, 0]
    """
    delta_y = check_real("delta_y", delta_y)
    pan_step = check_real("pan_step", pan_step, positive=True)
    theta_step = check_real("theta_step", theta_step, positive=True)
    pan_offset = check_real("pan_offset", pan_offset)
    noise = check_real("noise", noise, minimum=0.0)
    phi = np.arange(phi_range[0], phi_range[1] + pan_step / 2, pan_step)
    theta = np.arange(theta_range[0], theta_range[1] + theta_step / 2, theta_step)
    if phi.size < 2 or theta.size < 2:
        raise ValueError("The parameters `phi_range` and `theta_range` must span 2 steps or more")
    world = phi[:, None] + pan_offset
    sin_theta, cos_theta = portable_sin(theta), portable_cos(theta)
    directions = np.stack(
        np.broadcast_arrays(
            sin_theta * portable_sin(world), cos_theta, sin_theta * portable_cos(world)
        ),
        axis=-1,
    )
    origin = np.array([0.0, -delta_y, 0.0])
    distance, _ = cast_rig_rays(room, origin, directions)
    rng = np.random.default_rng(seed)
    r = distance + rng.normal(0.0, noise, distance.shape)
    if stripes is not None:
        rw, xw = (check_int("stripes", s, 0) for s in stripes)
        if rw < 1:
            raise ValueError(f"The parameter `stripes` must scan >= 1 slice per run, got {rw}")
        scanned = np.arange(phi.size) % (rw + xw) < rw
        r[~scanned] = np.nan
    points = origin + directions * distance[..., None]
    return LaserScan(r=r, theta=theta, phi=phi, points=points, delta_y=delta_y,
                     pan_offset=pan_offset)
