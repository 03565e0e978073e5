"""Scenes with registered intensity and ground-truth range (§3.3, §4).

- :func:`synthetic_room`: a ray-cast indoor scene in metres, the stand-in
  for the USF range database and the authors' own lab scans (§3.3, §4.2).
- :func:`room_geometry` / :func:`cast_rays`: that room's layout for a seed,
  and any set of rays from its centre cast into it (what the simulated rig
  of :mod:`refsynth.acquisition` measures and photographs).
- :func:`motorcycle`: scikit-image's copy of the Middlebury 2014
  *Motorcycle* pair, resized to the paper's 450 × 375 (§3.3, Table 4).
- :func:`load_middlebury`: any Middlebury image + disparity from disk.
- :func:`resize_area` / :func:`resize_disparity`: exact area-averaging
  resizes for arbitrary (non-integer) factors.

Sizes given as ``size`` follow the paper's notation, **width × height**:
``size=(450, 375)`` gives arrays of shape ``(375, 450)``. An int gives a
square. Array shapes everywhere else are (H, W), as in the rest of
refsynth.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 and §4, doi:10.1007/s11263-007-0108-2.

D. Scharstein et al., "High-Resolution Stereo Datasets with Subpixel-Accurate
Ground Truth", GCPR 2014 (the Middlebury 2014 datasets, *Motorcycle*).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from refsynth.io import IMAGE_SUFFIXES, read_image, read_pfm

__all__ = [
    "Scene",
    "synthetic_room",
    "room_geometry",
    "cast_rays",
    "RoomGeometry",
    "RoomBox",
    "RayHits",
    "motorcycle",
    "load_middlebury",
    "resize_area",
    "resize_disparity",
]

#: A resized disparity cell is NaN unless at least this fraction of its area
#: has finite (known) source disparity.
MIN_DISPARITY_COVERAGE = 0.5

# ----------------------------------------------------------------------------- Scene


@dataclass(frozen=True, eq=False)
class Scene:
    """A registered intensity image and its ground-truth range.

    Attributes
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3), float64
        Grey or colour, in [0, 1].
    range : ndarray of shape (H, W), float64
        Ground truth in ``units``; NaN where there is none.
    units : str
        ``"m"`` for the synthetic scenes, ``"disparity (px)"`` for
        Middlebury.
    name : str
        A short identifier for tables and file names.

    Notes
    -----
    The dataclass is frozen (its fields cannot be rebound) and compares by
    identity (``eq=False``: arrays have no single truth value). The arrays
    themselves are ordinary writeable arrays; refsynth never writes to
    them.
    """

    intensity: np.ndarray
    range: np.ndarray
    units: str
    name: str

    def __post_init__(self) -> None:
        for field_name in ("intensity", "range"):
            value = getattr(self, field_name)
            if not isinstance(value, np.ndarray) or value.dtype != np.float64:
                got = value.dtype if isinstance(value, np.ndarray) else type(value).__name__
                raise TypeError(f"The field `{field_name}` must be a float64 array, got {got}")
        if self.range.ndim != 2:
            raise ValueError(f"The field `range` must be 2-D (H, W), got shape {self.range.shape}")
        if self.intensity.shape not in (self.range.shape, (*self.range.shape, 3)):
            raise ValueError(
                f"The field `intensity` must have shape {self.range.shape} or "
                f"{(*self.range.shape, 3)}, got {self.intensity.shape}"
            )
        for field_name in ("units", "name"):
            if not isinstance(getattr(self, field_name), str):
                raise TypeError(
                    f"The field `{field_name}` must be a str, "
                    f"got {type(getattr(self, field_name)).__name__}"
                )

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``."""
        return self.range.shape  # type: ignore[return-value]

    @property
    def has_truth(self) -> np.ndarray:
        """Boolean (H, W): ``True`` where the ground-truth range is finite."""
        return np.isfinite(self.range)


# ----------------------------------------------------------------------------- validation


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _check_size(size, name: str = "size") -> tuple[int, int]:
    """``(width, height)`` from an int or a pair ``(width, height)``."""
    if _is_int(size) and size > 0:
        return int(size), int(size)
    if (
        isinstance(size, (tuple, list))
        and len(size) == 2
        and all(_is_int(n) and n > 0 for n in size)
    ):
        return int(size[0]), int(size[1])
    raise ValueError(
        f"The parameter `{name}` must be a positive integer or a pair of positive integers "
        f"(width, height), got {size!r}"
    )


def _check_real_array(name: str, array, ndims: tuple[int, ...]) -> np.ndarray:
    if not isinstance(array, np.ndarray):
        raise TypeError(f"The parameter `{name}` must be a numpy array, got {type(array).__name__}")
    if (
        array.dtype == bool
        or not np.issubdtype(array.dtype, np.number)
        or np.issubdtype(array.dtype, np.complexfloating)
    ):
        raise TypeError(f"The parameter `{name}` must be a real numeric array, got {array.dtype}")
    if array.ndim not in ndims or 0 in array.shape:
        expected = " or ".join(f"{n}-D" for n in ndims)
        raise ValueError(
            f"The parameter `{name}` must be a non-empty {expected} array, got shape {array.shape}"
        )
    return array


# ----------------------------------------------------------------------------- resizing


def _area_matrix(old: int, new: int) -> np.ndarray:
    """The (new, old) matrix of exact area weights of a 1-D box resize.

    Output cell ``i`` covers ``[i · old/new, (i + 1) · old/new)`` in source
    pixel units; ``A[i, j]`` is the length of its overlap with source pixel
    ``[j, j + 1)`` divided by the cell length, so every row sums to 1 and
    every column to ``new / old``.
    """
    edges = np.arange(new + 1) * old / new
    lo, hi = edges[:-1, None], edges[1:, None]
    j = np.arange(old)[None, :]
    overlap = np.clip(np.minimum(hi, j + 1) - np.maximum(lo, j), 0.0, None)
    return overlap / (old / new)


def resize_area(image: np.ndarray, size: int | tuple[int, int]) -> np.ndarray:
    """Resize by exact area averaging, for any (non-integer) factor.

    Each output pixel is the area-weighted mean of the source pixels its
    footprint covers:

    .. math:: \\mathrm{out}_c = A_{\\mathrm{rows}}\\, \\mathrm{image}_c\\,
              A_{\\mathrm{cols}}^{\\top}

    per channel ``c``, with the 1-D area-weight matrices ``A`` (rows sum to
    1). The image mean is preserved exactly (up to rounding) for any factor,
    since every source pixel contributes the same total weight.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, C)
        Real values; NaN and inf propagate into every output pixel whose
        footprint touches them (use :func:`resize_disparity` for data with
        holes).
    size : int or pair of int
        ``(width, height)`` of the result (the paper's "450 × 375"), or an
        int for a square.

    Returns
    -------
    ndarray of shape (height, width) or (height, width, C), float64

    Examples
    --------
    >>> resize_area(np.array([[0.0, 1.0, 2.0, 3.0]]), (2, 1))
    array([[0.5, 2.5]])
    """
    image = _check_real_array("image", image, (2, 3))
    width, height = _check_size(size)
    rows = _area_matrix(image.shape[0], height)
    cols = _area_matrix(image.shape[1], width)
    values = image.astype(np.float64, copy=False)
    if values.ndim == 2:
        return rows @ values @ cols.T
    return np.stack([rows @ values[..., c] @ cols.T for c in range(values.shape[2])], axis=-1)


def resize_disparity(
    disparity: np.ndarray,
    size: int | tuple[int, int],
    *,
    min_coverage: float = MIN_DISPARITY_COVERAGE,
) -> np.ndarray:
    """Resize a disparity map by masked area averaging, rescaling its values.

    The finite values are area-averaged (:func:`resize_area`'s weights,
    normalised by the area of known source within each output cell); a cell
    whose footprint is less than ``min_coverage`` known becomes NaN.
    Disparities are horizontal pixel offsets, so the values are multiplied by
    ``new_width / old_width`` (the height ratio does not enter).

    Parameters
    ----------
    disparity : ndarray of shape (H, W)
        Non-finite (NaN, ±inf) where unknown, as in Middlebury PFMs.
    size : int or pair of int
        ``(width, height)`` of the result, or an int for a square.
    min_coverage : float, default 0.5
        Fraction of a cell's area that must have known disparity, in (0, 1].

    Returns
    -------
    ndarray of shape (height, width), float64
        NaN where unknown.

    Examples
    --------
    >>> resize_disparity(np.array([[4.0, 8.0, np.inf, np.inf]]), (2, 1))
    array([[ 3., nan]])
    """
    disparity = _check_real_array("disparity", disparity, (2,))
    width, height = _check_size(size)
    if isinstance(min_coverage, (bool, np.bool_)) or not isinstance(
        min_coverage, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"The parameter `min_coverage` must be a real number, got {min_coverage!r}")
    if not 0.0 < min_coverage <= 1.0:
        raise ValueError(f"The parameter `min_coverage` must be in (0, 1], got {min_coverage}")
    rows = _area_matrix(disparity.shape[0], height)
    cols = _area_matrix(disparity.shape[1], width)
    known = np.isfinite(disparity)
    total = rows @ np.where(known, disparity, 0.0).astype(np.float64) @ cols.T
    coverage = rows @ known.astype(np.float64) @ cols.T
    enough = coverage >= min_coverage - 1e-12
    out = np.full((height, width), np.nan)
    out[enough] = total[enough] / coverage[enough] * (width / disparity.shape[1])
    return out


# ----------------------------------------------------------------------------- synthetic


def _ray_box(
    directions: np.ndarray, centre: np.ndarray, half: np.ndarray, angle: float
) -> tuple[np.ndarray, np.ndarray]:
    """Ray–box intersection for rays from the origin (slab method), all pixels at once.

    The box is ``|R(angle)ᵀ (p − centre)| <= half`` per axis, ``R`` a
    rotation about the vertical (y) axis. Returns the distance to the first
    hit (inf on a miss) and the world-frame unit normal of the face hit.
    """
    cos, sin = np.cos(angle), np.sin(angle)
    to_local = np.array([[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]])  # Rᵀ
    origin = to_local @ (-centre)
    local = directions @ to_local.T  # (..., 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - origin) / local
        t2 = (half - origin) / local
    t_enter = np.fmin(t1, t2)
    t_exit = np.fmax(t1, t2)
    near = t_enter.max(axis=-1)
    far = t_exit.min(axis=-1)
    hit = (near <= far) & (near > 0)
    distance = np.where(hit, near, np.inf)
    axis = t_enter.argmax(axis=-1)
    normal_local = np.zeros_like(local)
    component = np.take_along_axis(local, axis[..., None], axis=-1)[..., 0]
    np.put_along_axis(normal_local, axis[..., None], -np.sign(component)[..., None], axis=-1)
    return distance, normal_local @ to_local  # R · n


def _check_seed(seed):
    if seed is None or isinstance(seed, np.random.Generator) or (_is_int(seed) and seed >= 0):
        return seed
    raise TypeError(
        "The parameter `seed` must be a non-negative integer, a numpy Generator or None, "
        f"got {seed!r}"
    )


@dataclass(frozen=True, eq=False)
class RoomBox:
    """One box in the synthetic room: furniture on the floor, or the divider.

    Attributes
    ----------
    centre : ndarray of shape (3,)
        World coordinates in metres (x right, y up, z forward; origin at the
        camera centre).
    half : ndarray of shape (3,)
        Half-extents along the box's own axes.
    angle : float
        Rotation about the vertical (y) axis, radians.
    albedo : float
    grain : bool
        Whether the box carries a wood-grain albedo texture.
    """

    centre: np.ndarray
    half: np.ndarray
    angle: float
    albedo: float
    grain: bool


@dataclass(frozen=True, eq=False)
class RoomGeometry:
    """The layout of a synthetic room, as drawn by :func:`room_geometry` (§3.3, §4).

    World frame: metres, origin at the camera (and laser) centre, x to the
    right, y up, z forward (the demo camera's optical axis before its yaw).
    The room spans ``|x| <= half_width``, ``-camera_height <= y <=
    ceiling`` and ``z <= back``; it is open behind the camera (``z -> -inf``),
    so any ray with a horizontal component sideways or forward hits a wall.

    Attributes
    ----------
    half_width, camera_height, ceiling, back : float
        The room box (see above).
    yaw : float
        The yaw of :func:`synthetic_room`'s camera, radians (not used by
        :func:`cast_rays`).
    wall_albedo : float
    light : ndarray of shape (3,)
        Unit vector towards the distant light.
    boxes : tuple of RoomBox
        The divider first, then the furniture.
    tile : float
        Floor tile size, metres.
    tile_albedo : ndarray of shape (8, 8)
        Per-tile albedo variation.
    painting_x, painting_y, horizon : float
        The painting on the back wall: centre x, centre y, and the height of
        its horizon (fraction of the half-height).
    painting_half : ndarray of shape (2,)
        Its half-width and half-height.
    door_wall : float
        ``-1`` or ``+1``: the side wall with the door.
    door_z : float
        The door's centre along z.
    """

    half_width: float
    camera_height: float
    ceiling: float
    back: float
    yaw: float
    wall_albedo: float
    light: np.ndarray
    boxes: tuple[RoomBox, ...]
    tile: float
    tile_albedo: np.ndarray
    painting_x: float
    painting_half: np.ndarray
    painting_y: float
    horizon: float
    door_wall: float
    door_z: float


@dataclass(frozen=True, eq=False)
class RayHits:
    """What :func:`cast_rays` finds along each ray.

    Attributes
    ----------
    distance : ndarray of shape (...), float64
        Euclidean distance in metres from the origin to the first surface
        hit (inf for a ray that leaves through the open side behind the
        camera).
    normal : ndarray of shape (..., 3), float64
        World-frame unit normal of the surface hit.
    albedo : ndarray of shape (...), float64
        Its albedo (texture included).
    shading : ndarray of shape (...), float64
        Lambertian shading ``a + (1 − a) max(0, n·l)`` with ``a = 0.35``; the
        noise-free intensity is ``albedo * shading``.
    """

    distance: np.ndarray
    normal: np.ndarray
    albedo: np.ndarray
    shading: np.ndarray


def _draw_room(rng: np.random.Generator) -> RoomGeometry:
    """Draw the layout; the draws and their order are those of :func:`synthetic_room`."""
    half_width = rng.uniform(2.6, 3.4)  # room: x in [-half_width, half_width]
    camera_height = rng.uniform(1.3, 1.6)  # floor at y = -camera_height
    ceiling = rng.uniform(2.6, 3.0) - camera_height
    back = rng.uniform(7.0, 8.0)  # back wall at z = back
    yaw = rng.uniform(-0.1, 0.1)
    wall_albedo = rng.uniform(0.6, 0.8)
    light = np.array([rng.uniform(-0.5, -0.2), rng.uniform(0.6, 0.9), rng.uniform(-0.7, -0.4)])
    light /= np.linalg.norm(light)
    side = rng.choice([-1.0, 1.0])  # the divider on this side, the painting on the other

    # the divider: a thin panel parallel to the back wall, with its albedo
    divider_width = rng.uniform(0.8, 1.2)
    divider_height = rng.uniform(1.9, 2.3)
    divider_x = side * rng.uniform(0.4, 1.4)
    divider_z = back - rng.uniform(1.0, 2.0)
    boxes = [
        RoomBox(
            centre=np.array([divider_x, -camera_height + divider_height / 2, divider_z]),
            half=np.array([divider_width / 2, divider_height / 2, 0.02]),
            angle=0.0,
            albedo=wall_albedo,
            grain=False,
        )
    ]
    # the furniture: boxes on the floor, kept clear of the divider's columns
    for index in range(int(rng.integers(3, 6))):
        half = np.array([rng.uniform(0.2, 0.6), 0.0, rng.uniform(0.2, 0.6)])
        half[1] = rng.uniform(0.2, 0.75)
        radius = float(np.hypot(half[0], half[2]))
        for _ in range(100):
            z = rng.uniform(2.5, back - 1.0)
            reach = min(half_width - radius, z * np.tan(np.radians(28)))
            x = rng.uniform(-reach, reach)
            if abs(x - divider_x) > divider_width / 2 + radius + 0.2:
                break
        boxes.append(
            RoomBox(
                centre=np.array([x, -camera_height + half[1], z]),
                half=half,
                angle=rng.uniform(-0.6, 0.6),
                albedo=rng.uniform(0.25, 0.9),
                grain=index == 0,
            )
        )
    tile = rng.uniform(0.5, 0.7)
    tile_albedo = rng.uniform(-0.04, 0.04, size=(8, 8))
    painting_x = -side * rng.uniform(1.0, 1.8)
    painting_half = np.array([rng.uniform(0.5, 0.8), rng.uniform(0.35, 0.5)])
    painting_y = rng.uniform(0.0, 0.4)
    horizon = rng.uniform(-0.3, 0.3)
    door_wall = rng.choice([-1.0, 1.0])
    door_z = rng.uniform(3.5, back - 1.5)
    return RoomGeometry(
        half_width=half_width,
        camera_height=camera_height,
        ceiling=ceiling,
        back=back,
        yaw=yaw,
        wall_albedo=wall_albedo,
        light=light,
        boxes=tuple(boxes),
        tile=tile,
        tile_albedo=tile_albedo,
        painting_x=painting_x,
        painting_half=painting_half,
        painting_y=painting_y,
        horizon=horizon,
        door_wall=door_wall,
        door_z=door_z,
    )


def room_geometry(seed=0) -> RoomGeometry:
    """The layout of :func:`synthetic_room`'s room for a seed, to ray-cast at will (§4).

    Parameters
    ----------
    seed : int, numpy.random.Generator or None, default 0
        The same int gives the same room as ``synthetic_room(shape, seed)``
        for every ``shape``.

    Returns
    -------
    RoomGeometry

    See Also
    --------
    cast_rays : intersect any set of rays from the origin with the room.

    Examples
    --------
    >>> room = room_geometry(1)
    >>> hits = cast_rays(room, np.array([[0.0, 0.0, 1.0]]))
    >>> bool(hits.distance[0] <= room.back)
    True
    """
    return _draw_room(np.random.default_rng(_check_seed(seed)))


def cast_rays(room: RoomGeometry, rays: np.ndarray) -> RayHits:
    """Intersect rays from the origin with the room; the nearest surface wins (§3.3, §4).

    Parameters
    ----------
    room : RoomGeometry
        From :func:`room_geometry`.
    rays : ndarray of shape (..., 3)
        Unit direction vectors in the world frame (x right, y up, z
        forward), all starting at the origin (the camera and laser centre).

    Returns
    -------
    RayHits
        Distance, normal, albedo and shading per ray, arrays of shape
        ``rays.shape[:-1]`` (normal: ``rays.shape``).

    Notes
    -----
    Each ray is intersected with the room's six planes (the exit of the
    room box) and with every box (slab method) as array operations over all
    rays; the nearest hit wins. The albedo carries the floor tiles, the
    painting and its frame on the back wall, the door on a side wall and the
    wood grain of one box.
    """
    if not isinstance(room, RoomGeometry):
        raise TypeError(f"The parameter `room` must be a RoomGeometry, got {type(room).__name__}")
    if not isinstance(rays, np.ndarray) or rays.ndim < 1 or rays.shape[-1] != 3:
        got = rays.shape if isinstance(rays, np.ndarray) else type(rays).__name__
        raise ValueError(f"The parameter `rays` must be an array of shape (..., 3), got {got}")
    rays = rays.astype(np.float64, copy=False)
    grid = rays.shape[:-1]
    camera_height, back = room.camera_height, room.back

    # --- the room: the nearest of its planes along each ray (the exit of the box) ----
    lower = np.array([-room.half_width, -camera_height, -np.inf])
    upper = np.array([room.half_width, room.ceiling, back])
    with np.errstate(divide="ignore", invalid="ignore"):
        exits = np.where(rays > 0, upper / rays, np.where(rays < 0, lower / rays, np.inf))
    axis = exits.argmin(axis=-1)  # 0: a side wall, 1: floor or ceiling, 2: back wall
    distance = np.take_along_axis(exits, axis[..., None], axis=-1)[..., 0]
    sign = np.sign(np.take_along_axis(rays, axis[..., None], axis=-1)[..., 0])
    normal = np.zeros_like(rays)
    np.put_along_axis(normal, axis[..., None], -sign[..., None], axis=-1)
    with np.errstate(invalid="ignore"):  # 0 · inf for a ray leaving behind the camera
        point = rays * distance[..., None]
    x, y, z = point[..., 0], point[..., 1], point[..., 2]

    albedo = np.full(grid, room.wall_albedo)
    floor = (axis == 1) & (sign < 0)
    albedo[(axis == 1) & (sign > 0)] = 0.85  # ceiling
    # floor tiles: a checkerboard with a little per-tile variation
    with np.errstate(invalid="ignore"):
        i = np.floor(np.nan_to_num(x / room.tile)).astype(int)
        j = np.floor(np.nan_to_num(z / room.tile)).astype(int)
    tiles = np.where((i + j) % 2 == 0, 0.6, 0.38) + room.tile_albedo[i % 8, j % 8]
    albedo[floor] = tiles[floor]
    # a framed painting on the back wall: bright sky over dark ground
    px, py = np.abs(x - room.painting_x), np.abs(y - room.painting_y)
    painting_half = room.painting_half
    on_back = axis == 2
    frame = on_back & (px <= painting_half[0]) & (py <= painting_half[1])
    canvas = on_back & (px <= painting_half[0] - 0.05) & (py <= painting_half[1] - 0.05)
    albedo[frame] = 0.15
    sky = (y - room.painting_y) / painting_half[1] > room.horizon
    albedo[canvas] = np.where(sky, 0.9, 0.3)[canvas]
    # a door on one side wall
    door = (
        (axis == 0)
        & (np.sign(x) == room.door_wall)
        & (np.abs(z - room.door_z) <= 0.45)
        & (y <= -camera_height + 2.0)
    )
    albedo[door] = 0.3

    # --- the objects: nearest hit wins ---------------------------------------------------
    for item in room.boxes:
        hit_distance, hit_normal = _ray_box(rays, item.centre, item.half, item.angle)
        closer = hit_distance < distance
        distance = np.where(closer, hit_distance, distance)
        normal[closer] = hit_normal[closer]
        value = np.full(grid, item.albedo)
        if item.grain:
            # wood grain along the box's own x axis, slightly wavy with height
            offset = rays * np.where(closer, hit_distance, 0.0)[..., None] - item.centre
            along = offset[..., 0] * np.cos(item.angle) - offset[..., 2] * np.sin(item.angle)
            along = along + 0.03 * np.sin(2 * np.pi * offset[..., 1] / 0.4)
            value = value * (0.8 + 0.2 * np.sin(2 * np.pi * along / 0.12))
        albedo[closer] = value[closer]

    shading = 0.35 + 0.65 * np.clip(normal @ room.light, 0.0, None)
    return RayHits(distance=distance, normal=normal, albedo=albedo, shading=shading)


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
    Each pixel's ray is intersected with the room's six planes (the exit of
    the room box) and with every box (slab method) as array operations over
    all pixels; the nearest hit wins. The layout is :func:`room_geometry`'s
    for the same seed and the rays go through :func:`cast_rays`, so other
    sensors (the simulated rig of :mod:`refsynth.acquisition`) can see the same room
    from the same centre.

    Examples
    --------
    >>> scene = synthetic_room((32, 32), seed=1)
    >>> scene.shape, scene.units
    ((32, 32), 'm')
    """
    if (
        not isinstance(shape, (tuple, list))
        or len(shape) != 2
        or not all(_is_int(n) and n >= 16 for n in shape)
    ):
        raise ValueError(
            f"The parameter `shape` must be a pair of integers >= 16 (H, W), got {shape!r}"
        )
    height, width = int(shape[0]), int(shape[1])
    rng = np.random.default_rng(_check_seed(seed))
    room = _draw_room(rng)  # the layout, all drawn before any pixel work
    noise = rng.normal(0.0, 0.01, size=(height, width))

    # --- the rays --------------------------------------------------------------------
    focal = (width / 2) / np.tan(np.radians(30))
    u = (np.arange(width) + 0.5 - width / 2) / focal
    v = (height / 2 - (np.arange(height) + 0.5)) / focal
    camera = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 1.0), axis=-1)
    cos, sin = np.cos(room.yaw), np.sin(room.yaw)
    rays = camera @ np.array([[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]])
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)

    hits = cast_rays(room, rays)
    intensity = np.clip(hits.albedo * hits.shading + noise, 0.0, 1.0)
    name = f"synthetic-room-{seed}" if _is_int(seed) else "synthetic-room"
    return Scene(intensity=intensity, range=hits.distance, units="m", name=name)


# ----------------------------------------------------------------------------- Middlebury


def motorcycle(size: int | tuple[int, int] = (450, 375)) -> Scene:
    """The Middlebury 2014 *Motorcycle* left view and disparity, resized (§3.3, Table 4).

    Loads scikit-image's copy (``skimage.data.stereo_motorcycle()``: left
    view (500, 741, 3) uint8, disparity (500, 741) float32 with ``inf`` where
    unknown), resizes the image with :func:`resize_area` and the disparity
    with :func:`resize_disparity` (NaN where less than half a cell is known;
    values scaled by ``new_width / 741``).

    Parameters
    ----------
    size : int or pair of int, default (450, 375)
        ``(width, height)`` as the paper writes "450 × 375", or an int for a
        square. A size whose aspect differs from 741:500 stretches the scene
        (e.g. 128 gives a 128 × 128 image squeezed horizontally); the
        disparity values follow the horizontal scale.

    Returns
    -------
    Scene
        ``intensity`` (height, width, 3) float64 in [0, 1], ``range`` the
        disparity in pixels of the resized image (NaN where unknown),
        ``units="disparity (px)"``, ``name="motorcycle-<width>x<height>"``.

    Raises
    ------
    ImportError
        If scikit-image is not installed (it is an optional test
        dependency).
    """
    width, height = _check_size(size)
    try:
        from skimage import data as skimage_data
    except ImportError as error:
        raise ImportError(
            "motorcycle() needs scikit-image: `pip install scikit-image` "
            '(or `pip install -e ".[test]"` in a refsynth checkout)'
        ) from error
    left, _, disparity = skimage_data.stereo_motorcycle()
    intensity = np.clip(resize_area(left / 255.0, (width, height)), 0.0, 1.0)
    disparity = resize_disparity(disparity.astype(np.float64), (width, height))
    return Scene(
        intensity=intensity,
        range=disparity,
        units="disparity (px)",
        name=f"motorcycle-{width}x{height}",
    )


def _read_disparity(path: Path, disparity_scale: float) -> np.ndarray:
    suffix = path.suffix.lower()
    if suffix == ".pfm":
        values = read_pfm(path).astype(np.float64)
        unknown = ~np.isfinite(values)
    elif suffix == ".npy":
        values = np.load(path, allow_pickle=False).astype(np.float64)
        unknown = ~np.isfinite(values)
    elif suffix in IMAGE_SUFFIXES:
        values = read_image(path, raw=True).astype(np.float64)
        unknown = values == 0
    else:
        raise ValueError(
            f"The parameter `disparity` must be a .pfm, .npy or image file, got '{path}'"
        )
    if values.ndim != 2:
        raise ValueError(
            f"The parameter `disparity` must hold a single-channel (H, W) map, "
            f"got shape {values.shape} from '{path}'"
        )
    return np.where(unknown, np.nan, values / disparity_scale)


def load_middlebury(
    image: str | Path,
    disparity: str | Path,
    size: int | tuple[int, int] | None = None,
    name: str | None = None,
    *,
    disparity_scale: float = 1.0,
) -> Scene:
    """A Middlebury (or similar) image with its ground-truth disparity, from disk.

    Parameters
    ----------
    image : str or Path
        The view (PNG, JPEG, PPM …), read with :func:`refsynth.io.read_image`
        as float64 in [0, 1] (alpha dropped).
    disparity : str or Path
        Its disparity map: a PFM (Middlebury 2014 ``disp0.pfm``; ``inf`` =
        unknown), a ``.npy`` (non-finite = unknown), or a single-channel
        image (PNG, PGM …) of integers where 0 = unknown and the stored value
        is ``disparity × disparity_scale``.
    size : int or pair of int, optional
        ``(width, height)`` to resize to (as :func:`motorcycle`); default:
        keep the size.
    name : str, optional
        Default: the image file's name without suffix, prefixed with its
        folder's name (``"Motorcycle-perfect/im0"``).
    disparity_scale : float, default 1.0
        The factor the stored values carry: 1 for PFM; for the PNG/PGM maps
        of the 2001–2006 datasets see each dataset's README (e.g. 4 for the
        2003 *Cones* and *Teddy* quarter-size maps).

    Returns
    -------
    Scene
        ``range`` the disparity in pixels of the returned image (NaN where
        unknown), ``units="disparity (px)"``.

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    ValueError
        If a file cannot be read, the disparity is not single-channel, or
        the image and disparity sizes differ.
    """
    image_path = Path(image) if isinstance(image, (str, Path)) else None
    disparity_path = Path(disparity) if isinstance(disparity, (str, Path)) else None
    if image_path is None:
        raise TypeError(
            f"The parameter `image` must be a str or a Path, got {type(image).__name__}"
        )
    if disparity_path is None:
        raise TypeError(
            f"The parameter `disparity` must be a str or a Path, got {type(disparity).__name__}"
        )
    if isinstance(disparity_scale, (bool, np.bool_)) or not isinstance(
        disparity_scale, (int, float, np.integer, np.floating)
    ):
        raise TypeError(
            f"The parameter `disparity_scale` must be a real number, got {disparity_scale!r}"
        )
    if not (np.isfinite(disparity_scale) and disparity_scale > 0):
        raise ValueError(
            f"The parameter `disparity_scale` must be a finite number > 0, got {disparity_scale}"
        )
    if name is not None and not isinstance(name, str):
        raise TypeError(f"The parameter `name` must be a str or None, got {type(name).__name__}")
    target = None if size is None else _check_size(size)

    intensity = read_image(image_path)
    ground_truth = _read_disparity(disparity_path, float(disparity_scale))
    if intensity.shape[:2] != ground_truth.shape:
        raise ValueError(
            f"The parameter `disparity` must match the image's size {intensity.shape[:2]}, "
            f"got {ground_truth.shape}"
        )
    if target is not None:
        intensity = np.clip(resize_area(intensity, target), 0.0, 1.0)
        ground_truth = resize_disparity(ground_truth, target)
    if name is None:
        folder = image_path.resolve().parent.name
        name = f"{folder}/{image_path.stem}" if folder else image_path.stem
    return Scene(
        intensity=intensity.astype(np.float64, copy=False),
        range=ground_truth,
        units="disparity (px)",
        name=name,
    )
