"""The synthetic room: a ray-cast indoor scene with registered intensity and range (§3.3, §4).

- :func:`synthetic_room`: the scene, a single forward view in metres, the
  stand-in for the USF range database and the authors' own lab scans
  (§3.3, §4.2).
- :func:`room_geometry`: that room's layout for a seed, a
  :class:`~refsynth.scenes.room.RoomGeometry` to ray-cast at will with
  :func:`~refsynth.scenes.room.cast_rays` (what the simulated rig of
  :mod:`refsynth.acquisition` measures and photographs, from the same
  centre).
- :class:`SyntheticTexture`: its surfaces' albedo (floor tiles, a framed
  painting, a door, wood grain).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.2, §3.3 and §4,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_seed, is_int
from refsynth.scenes.portable import (
    hypot2,
    norm3,
    portable_cos,
    portable_sin,
    portable_tan,
    rotate3,
)
from refsynth.scenes.room import Intersections, RoomGeometry, cast_rays
from refsynth.scenes.scene import Scene

__all__ = ["SyntheticTexture", "room_geometry", "synthetic_room"]

#: tan 30° (half the camera's 60° field of view) = √3 / 3: two correctly rounded IEEE
#: operations, the same bits everywhere (and those of ``np.tan(np.radians(30))`` here).
_TAN_30 = float(np.sqrt(3.0)) / 3.0


# ----------------------------------------------------------------------------- texture


@dataclass(frozen=True, eq=False)
class SyntheticTexture:
    """The albedo of :func:`synthetic_room`'s surfaces (a :class:`~refsynth.scenes.room.Texture`).

    Attributes
    ----------
    wall_albedo : float
        The walls' (and the divider's) albedo; the ceiling's is 0.85.
    tile : float
        Floor tile size, metres.
    tile_albedo : ndarray of shape (8, 8)
        Per-tile albedo variation of the checkerboard floor (0.6 / 0.38).
    painting_x, painting_y, horizon : float
        The painting on the back wall: centre x, centre y, and the height of
        its horizon (fraction of the half-height).
    painting_half : ndarray of shape (2,)
        Its half-width and half-height.
    door_wall : float
        ``-1`` or ``+1``: the side wall with the door.
    door_z : float
        The door's centre along z.
    grain : int, default 1
        The box (row of :attr:`RoomGeometry.boxes`) with a wood-grain
        albedo: the first piece of furniture, after the divider.

    Examples
    --------
    Each seed draws its own; the floor's tiles are 0.5–0.7 m.

    >>> texture = room_geometry(2).texture
    >>> isinstance(texture, SyntheticTexture), bool(0.5 <= texture.tile <= 0.7)
    (True, True)
    """

    wall_albedo: float
    tile: float
    tile_albedo: np.ndarray
    painting_x: float
    painting_half: np.ndarray
    painting_y: float
    horizon: float
    door_wall: float
    door_z: float
    grain: int = 1

    def albedo(
        self, room: RoomGeometry, rays: np.ndarray, origin: np.ndarray, hits: Intersections
    ) -> np.ndarray:
        """The albedo of the surface each ray hits, shape ``rays.shape[:-1]``."""
        grid = rays.shape[:-1]
        axis, sign = hits.axis, hits.sign
        x, y, z = hits.exit[..., 0], hits.exit[..., 1], hits.exit[..., 2]
        albedo = np.full(grid, self.wall_albedo)
        floor = (axis == 1) & (sign < 0)
        albedo[(axis == 1) & (sign > 0)] = 0.85  # ceiling
        # floor tiles: a checkerboard with a little per-tile variation
        with np.errstate(invalid="ignore"):
            i = np.floor(np.nan_to_num(x / self.tile)).astype(int)
            j = np.floor(np.nan_to_num(z / self.tile)).astype(int)
        tiles = np.where((i + j) % 2 == 0, 0.6, 0.38) + self.tile_albedo[i % 8, j % 8]
        albedo[floor] = tiles[floor]
        # a framed painting on the back wall: bright sky over dark ground
        px, py = np.abs(x - self.painting_x), np.abs(y - self.painting_y)
        painting_half = self.painting_half
        on_back = axis == 2
        frame = on_back & (px <= painting_half[0]) & (py <= painting_half[1])
        canvas = on_back & (px <= painting_half[0] - 0.05) & (py <= painting_half[1] - 0.05)
        albedo[frame] = 0.15
        sky = (y - self.painting_y) / painting_half[1] > self.horizon
        albedo[canvas] = np.where(sky, 0.9, 0.3)[canvas]
        # a door on one side wall
        door = (
            (axis == 0)
            & (np.sign(x) == self.door_wall)
            & (np.abs(z - self.door_z) <= 0.45)
            & (y <= room.lower[1] + 2.0)
        )
        albedo[door] = 0.3
        # the boxes: plain, but for the wood grain of one
        for index, box in enumerate(room.boxes):
            on = hits.box == index
            value = np.full(grid, box[7])
            if index == self.grain:
                # wood grain along the box's own x axis, slightly wavy with height
                offset = origin + rays * np.where(on, hits.distance, 0.0)[..., None] - box[:3]
                cos, sin = portable_cos(box[6]), portable_sin(box[6])
                along = offset[..., 0] * cos - offset[..., 2] * sin
                along = along + 0.03 * portable_sin(2 * np.pi * offset[..., 1] / 0.4)
                value = value * (0.8 + 0.2 * portable_sin(2 * np.pi * along / 0.12))
            albedo[on] = value[on]
        return albedo


# ----------------------------------------------------------------------------- layout


def _draw_room(rng: np.random.Generator, seed) -> RoomGeometry:
    """Draw the layout; the draws and their order are those of :func:`synthetic_room`."""
    half_width = rng.uniform(2.6, 3.4)  # room: x in [-half_width, half_width]
    camera_height = rng.uniform(1.3, 1.6)  # floor at y = -camera_height
    ceiling = rng.uniform(2.6, 3.0) - camera_height
    back = rng.uniform(7.0, 8.0)  # back wall at z = back
    yaw = rng.uniform(-0.1, 0.1)
    wall_albedo = rng.uniform(0.6, 0.8)
    light = np.array([rng.uniform(-0.5, -0.2), rng.uniform(0.6, 0.9), rng.uniform(-0.7, -0.4)])
    light /= norm3(light)
    side = rng.choice([-1.0, 1.0])  # the divider on this side, the painting on the other

    # the divider: a thin panel parallel to the back wall, with its albedo
    divider_width = rng.uniform(0.8, 1.2)
    divider_height = rng.uniform(1.9, 2.3)
    divider_x = side * rng.uniform(0.4, 1.4)
    divider_z = back - rng.uniform(1.0, 2.0)
    centre = [divider_x, -camera_height + divider_height / 2, divider_z]
    boxes = [[*centre, divider_width / 2, divider_height / 2, 0.02, 0.0, wall_albedo]]
    # the furniture: boxes on the floor, kept clear of the divider's columns
    for _ in range(int(rng.integers(3, 6))):
        half = np.array([rng.uniform(0.2, 0.6), 0.0, rng.uniform(0.2, 0.6)])
        half[1] = rng.uniform(0.2, 0.75)
        radius = hypot2(half[0], half[2])
        for _ in range(100):
            z = rng.uniform(2.5, back - 1.0)
            reach = min(half_width - radius, z * portable_tan(np.radians(28)))
            x = rng.uniform(-reach, reach)
            if abs(x - divider_x) > divider_width / 2 + radius + 0.2:
                break
        angle = rng.uniform(-0.6, 0.6)
        albedo = rng.uniform(0.25, 0.9)
        boxes.append([x, -camera_height + half[1], z, *half, angle, albedo])
    tile = rng.uniform(0.5, 0.7)
    tile_albedo = rng.uniform(-0.04, 0.04, size=(8, 8))
    painting_x = -side * rng.uniform(1.0, 1.8)
    painting_half = np.array([rng.uniform(0.5, 0.8), rng.uniform(0.35, 0.5)])
    painting_y = rng.uniform(0.0, 0.4)
    horizon = rng.uniform(-0.3, 0.3)
    door_wall = rng.choice([-1.0, 1.0])
    door_z = rng.uniform(3.5, back - 1.5)
    texture = SyntheticTexture(
        wall_albedo=wall_albedo,
        tile=tile,
        tile_albedo=tile_albedo,
        painting_x=painting_x,
        painting_half=painting_half,
        painting_y=painting_y,
        horizon=horizon,
        door_wall=door_wall,
        door_z=door_z,
    )
    return RoomGeometry(
        lower=np.array([-half_width, -camera_height, -np.inf]),
        upper=np.array([half_width, ceiling, back]),
        boxes=np.array(boxes, dtype=np.float64),
        light=light,
        texture=texture,
        yaw=yaw,
        seed=int(seed) if is_int(seed) else None,
    )


def room_geometry(seed=0) -> RoomGeometry:
    """The layout of :func:`synthetic_room`'s room for a seed, to ray-cast at will (§4).

    World frame: metres, origin at the camera (and laser) centre, x to the
    right, y up, z forward (the camera's optical axis before its yaw). The
    room spans ``lower <= p <= upper``: side walls at ``x = ±upper[0]``, the
    floor at ``y = -camera_height``, the ceiling at ``y = ceiling``, the back
    wall at ``z = back``; it is open behind the camera (``lower[2] = -inf``),
    so any ray with a horizontal component sideways or forward hits a wall.
    ``boxes[0]`` is the divider, the furniture follows.

    Parameters
    ----------
    seed : int, numpy.random.Generator or None, default 0
        The same int gives the same room as ``synthetic_room(shape, seed)``
        for every ``shape``.

    Returns
    -------
    RoomGeometry
        With a :class:`SyntheticTexture` and ``yaw`` the camera's.

    See Also
    --------
    refsynth.scenes.room.cast_rays : intersect any set of rays with the room.

    Examples
    --------
    >>> room = room_geometry(1)
    >>> hits = cast_rays(room, np.array([[0.0, 0.0, 1.0]]))
    >>> bool(hits.distance[0] <= room.back)
    True
    """
    return _draw_room(np.random.default_rng(check_seed(seed)), seed)


# ----------------------------------------------------------------------------- the scene


def synthetic_room(shape: tuple[int, int] = (128, 128), seed=0) -> Scene:
    """A ray-cast indoor scene in metres with registered grey intensity (§3.3, §4).

    A pinhole camera (60° horizontal field of view, square pixels, 1.3–1.6 m
    above the floor, yawed by up to ±6°) looks into a room 5.2–6.8 m wide,
    2.6–3 m high, whose back wall stands 7–8 m away. In the room stand 3–5
    boxes (furniture, 0.4–1.5 m high) on the floor, their centres between
    2.5 m from the camera and 1 m before the back wall, turned about the
    vertical, and a thin panel (a room divider, 1.9–2.3 m high, 4 cm thick)
    1–2 m in front of the back wall; the boxes are placed clear of the
    divider's x-range (up to 100 draws each), and the divider, taller than
    the camera, usually rises above them in the image. The layout, sizes, albedos and the
    light direction are drawn from ``seed``.

    The intensity follows the geometry as in real indoor images, with the
    cases the paper discusses (§3.2): Lambertian shading by surface
    orientation under a distant light, ``I = albedo · (a + (1 − a)
    max(0, n·l))`` with ambient ``a = 0.35``, so creases and occluding
    boundaries show as intensity edges; albedo edges that are *not* depth
    edges (floor tiles, a framed painting on the back wall, a door on a side
    wall, wood grain on one box); and a depth edge that is nearly invisible
    in intensity: the divider has the back wall's albedo and orientation, so
    its outline against the wall is a 1–2 m jump in range with no step in
    intensity (an "object that blends in with its background"; only its
    edge-on side face may show as a line about a pixel wide). Gaussian
    noise of standard deviation 0.01 is added and the result clipped to
    [0, 1]. There are no cast shadows and no inter-reflections.

    Parameters
    ----------
    shape : pair of int, default (128, 128)
        ``(H, W)``, each >= 16. The horizontal field of view stays 60°; the
        vertical one follows from ``H / W``.
    seed : int, numpy.random.Generator or None, default 0
        The same int gives bit-identical scenes.

    Returns
    -------
    Scene
        ``intensity`` (H, W) float64 in [0, 1]; ``range`` (H, W) float64,
        the Euclidean distance in metres from the camera centre to the
        surface seen through each pixel centre (what a laser rangefinder at
        the camera centre measures, not the z-depth), finite everywhere;
        ``units="m"``; ``name="synthetic-room-<seed>"``.

    Notes
    -----
    The layout is :func:`room_geometry`'s for the same seed and each pixel's
    ray goes through :func:`~refsynth.scenes.room.cast_rays` (the room box
    and every box by the slab method, as array operations over all pixels;
    the nearest hit wins), so other sensors (the simulated rig of
    :mod:`refsynth.acquisition`) can see the same room from the same centre.

    Examples
    --------
    >>> scene = synthetic_room((32, 32), seed=1)
    >>> scene.shape, scene.units
    ((32, 32), 'm')
    """
    if (
        not isinstance(shape, (tuple, list))
        or len(shape) != 2
        or not all(is_int(n) and n >= 16 for n in shape)
    ):
        raise ValueError(
            f"The parameter `shape` must be a pair of integers >= 16 (H, W), got {shape!r}"
        )
    height, width = int(shape[0]), int(shape[1])
    rng = np.random.default_rng(check_seed(seed))
    room = _draw_room(rng, seed)  # the layout, all drawn before any pixel work
    noise = rng.normal(0.0, 0.01, size=(height, width))

    # --- the rays --------------------------------------------------------------------
    focal = (width / 2) / _TAN_30
    u = (np.arange(width) + 0.5 - width / 2) / focal
    v = (height / 2 - (np.arange(height) + 0.5)) / focal
    camera = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 1.0), axis=-1)
    cos, sin = portable_cos(room.yaw), portable_sin(room.yaw)
    # camera @ R, as explicit 3-term sums (no BLAS: the same bits everywhere)
    rays = rotate3(np.array([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]]), camera)
    rays /= norm3(rays)[..., None]

    hits = cast_rays(room, rays)
    intensity = np.clip(hits.albedo * hits.shading + noise, 0.0, 1.0)
    name = f"synthetic-room-{seed}" if is_int(seed) else "synthetic-room"
    return Scene(intensity=intensity, range=hits.distance, units="m", name=name)
