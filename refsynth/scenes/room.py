r"""One room model and one ray caster for every synthetic scene (§3.3, §4, §4.1).

refsynth's synthetic scenes are one kind of room seen from one point: a box
(walls, floor, ceiling; one side may be open) with furniture standing in it —
boxes turned about the vertical — lit by a distant light. Two layouts are
drawn into this model:

- :func:`refsynth.scenes.synthetic.room_geometry`: the single forward view
  of :func:`~refsynth.scenes.synthetic.synthetic_room`, also what the
  simulated rig of :mod:`refsynth.acquisition` scans and photographs;
- :func:`refsynth.scenes.rig.rig_room`: the room around the registration
  test rig, walls 5–8 m away all round (§4.1).

This module holds what they share:

- :class:`RoomGeometry`: the room box, the furniture, the light, and the
  room's :class:`Texture` (its albedo, which each layout brings);
- :func:`intersect`: rays from a point against the room and the furniture;
  which surface each ray hits first, how far, and its normal;
- :func:`cast_rays`: :func:`intersect`, then the texture's albedo and the
  Lambertian shading

  .. math:: I = \rho\,\bigl(a + (1 - a)\max(0, \mathbf n \cdot \mathbf l)\bigr),
            \qquad a = 0.35

  (``ρ`` the albedo, ``n`` the surface normal, ``l`` the direction towards
  the light; no shadows, no inter-reflections).

World frame: metres, x to the right, y up, z forward (the direction of pan
angle 0 and, before its yaw, of the synthetic camera's optical axis).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3, §4 and §4.1,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from refsynth.scenes.portable import dot3, norm3, portable_cos, portable_sin, rotate3

__all__ = [
    "RoomGeometry",
    "Texture",
    "Intersections",
    "RayHits",
    "intersect",
    "ray_box",
    "cast_rays",
    "shading",
    "AMBIENT",
]

#: The ambient term ``a`` of the Lambertian shading.
AMBIENT = 0.35


# ----------------------------------------------------------------------------- the model


class Texture(Protocol):
    """A room's surface albedo: what a layout adds to the shared geometry.

    Any object with this ``albedo`` method will do:
    :class:`~refsynth.scenes.synthetic.SyntheticTexture` and
    :class:`~refsynth.scenes.rig.RigTexture` are the two layouts' own.

    Examples
    --------
    A uniform grey, in an empty 4 m cube:

    >>> class Grey:
    ...     def albedo(self, room, rays, origin, hits):
    ...         return np.full(rays.shape[:-1], 0.5)
    >>> cube = RoomGeometry(lower=np.full(3, -2.0), upper=np.full(3, 2.0),
    ...                     boxes=np.zeros((0, 8)), light=np.array([0.0, 1.0, 0.0]),
    ...                     texture=Grey())
    >>> cast_rays(cube, np.array([[0.0, 0.0, 1.0]])).albedo
    array([0.5])
    """

    def albedo(
        self, room: RoomGeometry, rays: np.ndarray, origin: np.ndarray, hits: Intersections
    ) -> np.ndarray:
        """The albedo, shape ``rays.shape[:-1]``, of the surface each ray hits."""


@dataclass(frozen=True, eq=False)
class RoomGeometry:
    """A room: its box, its furniture, its light and its texture.

    Drawn by :func:`refsynth.scenes.synthetic.room_geometry` (the synthetic
    scenes) or :func:`refsynth.scenes.rig.rig_room` (the registration rig);
    ray-cast with :func:`cast_rays`.

    Attributes
    ----------
    lower, upper : ndarray of shape (3,)
        The room box, ``lower <= p <= upper`` (side walls along x, floor and
        ceiling along y, back and front walls along z). An infinite bound is
        an open side: the synthetic room has ``lower[2] = -inf``, nothing
        behind its camera.
    boxes : ndarray of shape (K, 8)
        The furniture, one box per row: centre (3), half-extents along the
        box's own axes (3), yaw about the vertical (y) axis (rad), albedo.
    light : ndarray of shape (3,)
        Unit vector towards the distant light.
    texture : Texture
        The layout's surface albedo
        (:class:`~refsynth.scenes.synthetic.SyntheticTexture`,
        :class:`~refsynth.scenes.rig.RigTexture`).
    yaw : float, default 0
        The heading of the scene's camera, radians: the yaw of
        :func:`~refsynth.scenes.synthetic.synthetic_room`'s camera; 0 for the
        rig, whose pan angle 0 looks along z. Not used by :func:`cast_rays`.
    seed : int or None, default None
        The seed the room was drawn from (None: a Generator, or fresh
        entropy).

    Examples
    --------
    >>> from refsynth.scenes import room_geometry
    >>> room = room_geometry(0)
    >>> room.boxes.shape[1], bool(1.3 <= room.camera_height <= 1.6), room.seed
    (8, True, 0)
    """

    lower: np.ndarray
    upper: np.ndarray
    boxes: np.ndarray
    light: np.ndarray
    texture: Texture
    yaw: float = 0.0
    seed: int | None = None

    @property
    def camera_height(self) -> float:
        """The height of the origin (the camera) above the floor, ``-lower[1]``."""
        return -self.lower[1]

    @property
    def ceiling(self) -> float:
        """The height of the ceiling above the origin, ``upper[1]``."""
        return self.upper[1]

    @property
    def back(self) -> float:
        """The distance along z to the wall ahead (the back wall), ``upper[2]``."""
        return self.upper[2]


class Intersections(NamedTuple):
    """Which surface each ray hits first (:func:`intersect`).

    Attributes
    ----------
    distance : ndarray of shape (...)
        Distance along the ray (the ray's length as unit) to the nearest
        surface; inf where the ray leaves through an open side.
    normal : ndarray of shape (..., 3)
        World-frame unit normal of that surface, facing the ray.
    box : ndarray of shape (...), int
        The row of :attr:`RoomGeometry.boxes` hit, or -1 for the room's own
        surfaces.
    axis : ndarray of shape (...), int
        The room face the ray leaves the room box through (behind any box
        it hits): 0 a side wall, 1 floor or ceiling, 2 back or front wall.
    sign : ndarray of shape (...), float
        The sign of the ray's component along ``axis``: -1 the lower face
        (−x wall, floor, front), +1 the upper one; 0 for a ray that never
        leaves.
    exit : ndarray of shape (..., 3)
        The point where the ray leaves the room box (NaN components on a ray
        through an open side).

    Examples
    --------
    Straight down from the camera: the floor (axis 1, the lower face), no box.

    >>> from refsynth.scenes import rig_room
    >>> room = rig_room(0)
    >>> down = intersect(room, np.array([[0.0, -1.0, 0.0]]), np.zeros(3))
    >>> int(down.axis[0]), float(down.sign[0]), int(down.box[0])
    (1, -1.0, -1)
    >>> bool(down.distance[0] == room.camera_height)
    True
    """

    distance: np.ndarray
    normal: np.ndarray
    box: np.ndarray
    axis: np.ndarray
    sign: np.ndarray
    exit: np.ndarray


@dataclass(frozen=True, eq=False)
class RayHits:
    """What :func:`cast_rays` finds along each ray.

    Attributes
    ----------
    distance : ndarray of shape (...), float64
        Euclidean distance in metres from the origin to the first surface
        hit (inf for a ray that leaves through an open side, such as the one
        behind the synthetic room's camera).
    normal : ndarray of shape (..., 3), float64
        World-frame unit normal of the surface hit.
    albedo : ndarray of shape (...), float64
        Its albedo (texture included).
    shading : ndarray of shape (...), float64
        Lambertian shading ``a + (1 − a) max(0, n·l)`` with ``a = 0.35``; the
        noise-free intensity is ``albedo * shading``.

    Examples
    --------
    The rig room's ceiling (albedo 0.85) faces away from the light above it,
    so only the ambient term lights it:

    >>> from refsynth.scenes import rig_room
    >>> up = cast_rays(rig_room(0), np.array([[0.0, 1.0, 0.0]]))
    >>> up.albedo.tolist(), up.shading.tolist()
    ([0.85], [0.35])
    """

    distance: np.ndarray
    normal: np.ndarray
    albedo: np.ndarray
    shading: np.ndarray


# ----------------------------------------------------------------------------- intersection


def _slab(rays: np.ndarray, offset: np.ndarray, half: np.ndarray, to_local: np.ndarray):
    """The slab method on every ray given: hit distance (inf on a miss) and world normal.

    The products with ``to_local`` are explicit 3-term sums (:func:`~refsynth.scenes.
    portable.rotate3`), not BLAS: the same bits on every machine.
    """
    start = rotate3(to_local, -offset)  # the rays' origin in the box's frame
    local = rotate3(to_local, rays)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - start) / local
        t2 = (half - start) / local
    near = np.fmin(t1, t2)
    far = np.fmax(t1, t2)
    t_enter = near.max(axis=-1)
    t_exit = far.min(axis=-1)
    hit = (t_enter <= t_exit) & (t_enter > 0)
    axis = near.argmax(axis=-1)
    component = np.take_along_axis(local, axis[..., None], axis=-1)[..., 0]
    face = np.zeros_like(local)
    np.put_along_axis(face, axis[..., None], -np.sign(component)[..., None], axis=-1)
    return np.where(hit, t_enter, np.inf), rotate3(to_local.T, face)  # R · n


def ray_box(
    origin: np.ndarray,
    rays: np.ndarray,
    centre: np.ndarray,
    half: np.ndarray,
    yaw: float,
    *,
    cull: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Ray–box intersection by the slab method, for all rays from ``origin`` at once.

    The box is ``|R(yaw)ᵀ (p − centre)| <= half`` per axis, ``R`` a rotation
    about the vertical (y) axis.

    Parameters
    ----------
    origin : ndarray of shape (3,)
    rays : ndarray of shape (..., 3)
        Directions.
    centre, half : ndarray of shape (3,)
    yaw : float
    cull : bool, default False
        Intersect only the rays that pass through the box's bounding sphere
        (the rest miss); faster with many boxes. The registration rig culls,
        the synthetic scenes do not.

    Returns
    -------
    distance : ndarray of shape (...)
        To the first hit along the ray (inf on a miss).
    normal : ndarray of shape (..., 3)
        World-frame unit normal of the face hit (zero on a culled ray).

    Examples
    --------
    A 2 m cube 5 m ahead: the ray along z meets its near face at 4 m, the
    ray straight up misses.

    >>> rays = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    >>> distance, normal = ray_box(np.zeros(3), rays, np.array([0.0, 0.0, 5.0]), np.ones(3), 0.0)
    >>> distance.tolist(), normal[0].tolist()
    ([4.0, inf], [0.0, 0.0, -1.0])
    """
    cos, sin = portable_cos(yaw), portable_sin(yaw)
    to_local = np.array([[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]])  # Rᵀ
    offset = centre - origin
    if not cull:
        return _slab(rays, offset, half, to_local)
    distance = np.full(rays.shape[:-1], np.inf)
    normal = np.zeros(rays.shape)
    reach = float(norm3(half))
    gap = float(norm3(offset))
    if gap > reach:
        along = dot3(rays, offset / gap)
        ratio = reach / gap
        candidate = along > np.sqrt(1.0 - ratio * ratio)
    else:
        candidate = np.ones(rays.shape[:-1], dtype=bool)
    if candidate.any():
        distance[candidate], normal[candidate] = _slab(rays[candidate], offset, half, to_local)
    return distance, normal


def intersect(
    room: RoomGeometry, rays: np.ndarray, origin: np.ndarray, *, cull: bool = False
) -> Intersections:
    """The first surface along each ray from ``origin``: the room or a box, nearest wins.

    Each ray is intersected with the room box (the face it leaves through:
    the nearest of ``(upper − origin) / ray`` and ``(lower − origin) / ray``
    per axis) and with every box (:func:`ray_box`), as array operations over
    all rays.

    Parameters
    ----------
    room : RoomGeometry
    rays : ndarray of shape (..., 3), float64
        Directions (distances come in units of their length).
    origin : ndarray of shape (3,), float64
        Inside the room.
    cull : bool, default False
        Passed to :func:`ray_box`.

    Returns
    -------
    Intersections
        Arrays of shape ``rays.shape[:-1]`` (``normal`` and ``exit``:
        ``rays.shape``).

    Examples
    --------
    In the rig room of seed 0, box 7 stands in front of box 1: the ray aimed
    at box 1's centre hits box 7 first.

    >>> from refsynth.scenes import rig_room
    >>> room = rig_room(0)
    >>> intersect(room, room.boxes[[1, 7], :3], np.zeros(3)).box.tolist()
    [7, 7]
    """
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
    with np.errstate(invalid="ignore"):  # 0 · inf for a ray leaving through an open side
        exit_point = origin + rays * distance[..., None]
    box = np.full(rays.shape[:-1], -1)
    for index, row in enumerate(room.boxes):
        hit, hit_normal = ray_box(origin, rays, row[:3], row[3:6], row[6], cull=cull)
        closer = hit < distance
        distance = np.where(closer, hit, distance)
        normal[closer] = hit_normal[closer]
        box[closer] = index
    return Intersections(distance, normal, box, axis, sign, exit_point)


# ----------------------------------------------------------------------------- casting


def shading(room: RoomGeometry, normal: np.ndarray) -> np.ndarray:
    """Lambertian shading under the room's light, ``a + (1 − a) max(0, n·l)``, ``a = 0.35``.

    The shading term of the synthetic intensity (§3.3, §4): surface
    orientation shows as intensity, so creases and occluding boundaries are
    intensity edges.

    Parameters
    ----------
    room : RoomGeometry
        Its ``light``, a unit vector of shape (3,) towards the distant light.
    normal : ndarray of shape (..., 3), float64
        World-frame unit surface normals.

    Returns
    -------
    ndarray of shape (...), float64
        In ``[a, 1]``: :data:`AMBIENT` where the surface faces away from the
        light, 1 where it faces it squarely.

    Examples
    --------
    >>> from refsynth.scenes import rig_room
    >>> room = rig_room(0)
    >>> shading(room, np.stack([room.light, -room.light])).tolist()
    [1.0, 0.35]
    """
    return AMBIENT + (1 - AMBIENT) * np.clip(dot3(normal, room.light), 0.0, None)


def cast_rays(
    room: RoomGeometry, rays: np.ndarray, *, origin=None, cull: bool = False
) -> RayHits:
    """Intersect rays with the room; the nearest surface wins (§3.3, §4).

    Parameters
    ----------
    room : RoomGeometry
        From :func:`~refsynth.scenes.synthetic.room_geometry` or
        :func:`~refsynth.scenes.rig.rig_room`.
    rays : ndarray of shape (..., 3)
        Unit direction vectors in the world frame (x right, y up, z
        forward).
    origin : array_like of shape (3,), optional
        Where the rays start, inside the room. Default: the origin (the
        camera and laser centre of the synthetic room).
    cull : bool, default False
        Skip, per box, the rays that miss its bounding sphere
        (:func:`ray_box`).

    Returns
    -------
    RayHits
        Distance, normal, albedo and shading per ray, arrays of shape
        ``rays.shape[:-1]`` (normal: ``rays.shape``).

    Notes
    -----
    :func:`intersect` finds the surface; the room's :class:`Texture` gives
    its albedo (for the synthetic room: floor tiles, the framed painting on
    the back wall, the door on a side wall, the wood grain of one box; for
    the rig: textured walls, posters, doors, a tiled floor, wood grain on
    every box); :func:`shading` its Lambertian shading.

    Examples
    --------
    Ahead, to the right and down from the synthetic room's camera; the floor
    is ``camera_height`` below it.

    >>> from refsynth.scenes import room_geometry
    >>> room = room_geometry(0)
    >>> hits = cast_rays(room, np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))
    >>> hits.normal.shape, bool(hits.distance[2] == room.camera_height)
    ((3, 3), True)
    """
    if not isinstance(room, RoomGeometry):
        raise TypeError(f"The parameter `room` must be a RoomGeometry, got {type(room).__name__}")
    if not isinstance(rays, np.ndarray) or rays.ndim < 1 or rays.shape[-1] != 3:
        got = rays.shape if isinstance(rays, np.ndarray) else type(rays).__name__
        raise ValueError(f"The parameter `rays` must be an array of shape (..., 3), got {got}")
    rays = rays.astype(np.float64, copy=False)
    origin = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    if origin.shape != (3,):
        raise ValueError(f"The parameter `origin` must have shape (3,), got {origin.shape}")
    hits = intersect(room, rays, origin, cull=cull)
    albedo = room.texture.albedo(room, rays, origin, hits)
    return RayHits(
        distance=hits.distance, normal=hits.normal, albedo=albedo,
        shading=shading(room, hits.normal),
    )
