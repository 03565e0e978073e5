r"""A scan position's model against the simulated room's truth: the targets of stage 3 (#12).

The simulated rig (:mod:`refsynth.acquisition.simulator`) scans a room whose
geometry is known exactly (:func:`refsynth.scenes.room_geometry`: walls,
floor, ceiling and boxes), so the model of stage 3 can be measured against
it. Three measures, each from the position's own pose:

- :func:`true_range`: the ray caster's range along each pixel's ray of the
  registered panorama (its :class:`~refsynth.model.CylindricalCamera`),
  from the pose — the ground truth of the range image and of MAR (Eq. 13).
- **Points**: a vertex ``v`` of pixel ``p`` is off the true surface by
  ``| ‖v‖ − r_true(p) |``, measured along its ray; relative to
  ``r_true(p)``, reported for measured and synthesized points apart
  (:func:`point_errors`). Along the ray is an upper bound of the distance
  to the nearest true surface.
- **Triangles**: a triangle *bridges a true depth discontinuity* when
  (1) the true range jumps between its pixels, ``max r_true > (1 + jump) ·
  min r_true`` with ``jump = 0.1``, and (2) its centre hangs off every true
  surface by more than ``off = 2.5 %`` of its range
  (:func:`surface_distance`, the exact Euclidean distance to the room's
  planes and boxes). Condition (1) alone also counts the triangles at a
  silhouette whose pixels' true ranges jump but whose vertices all lie on
  one surface (a measured range registered a pixel beside the edge makes
  the foreground a pixel wider); those are counted apart, as
  *silhouette* triangles (:func:`triangle_checks`). A triangle across a
  jump of 10 % or more has its centre a third of the jump or more off both
  surfaces; one on a single plane (or across a crease) stays within the
  noise and a pixel's footprint of it.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §1 (stage 3), Eq. 13,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth.model import Model, Pose
from refsynth.scenes import RoomGeometry, cast_rays
from refsynth.scenes.portable import norm3, portable_cos, portable_sin, rotate3

__all__ = ["true_range", "surface_distance", "point_errors", "triangle_checks",
           "TRUE_JUMP", "OFF_SURFACE"]

#: A relative jump of the true range between a triangle's pixels above which it crosses an edge.
TRUE_JUMP = 0.1
#: A triangle's centre this far off every true surface (fraction of its range) hangs in the air.
OFF_SURFACE = 0.025


def true_range(room: RoomGeometry, camera, shape, pose: Pose) -> np.ndarray:
    """The ray caster's range (m) along each pixel's ray of ``camera``, cast from ``pose``.

    Parameters
    ----------
    room : RoomGeometry
    camera : refsynth.model.CylindricalCamera or PinholeCamera
        Its :meth:`directions` in the scanner's frame.
    shape : pair of int
    pose : refsynth.model.Pose
        The scanner's pose in the room's frame.

    Returns
    -------
    ndarray of shape ``shape``
        Euclidean distance (inf where a ray leaves through an open side).
    """
    matrix = pose.matrix()
    rays = rotate3(matrix[:3, :3], camera.directions(shape))
    return cast_rays(room, rays, origin=matrix[:3, 3]).distance


def surface_distance(room: RoomGeometry, points) -> np.ndarray:
    """The Euclidean distance of points inside the room to its nearest true surface.

    The room's faces are planes (an infinite bound is an open side and has
    none); a box's distance is that of its signed distance function,
    ``‖max(e, 0)‖ + min(max e, 0)`` with ``e = |R(yaw)ᵀ (p − c)| − half``,
    taken in absolute value (so a point inside a box is measured to its
    nearest face too).

    Parameters
    ----------
    room : RoomGeometry
    points : array_like of shape (N, 3)
        In the room's frame.

    Returns
    -------
    ndarray of shape (N,)

    Examples
    --------
    >>> from refsynth.scenes import room_geometry
    >>> room = room_geometry(0)
    >>> d = surface_distance(room, [[0.0, 0.0, room.back - 0.5]])
    >>> bool(d[0] <= 0.5)
    True
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    distance = np.full(len(points), np.inf)
    for axis in range(3):
        for bound in (room.lower[axis], room.upper[axis]):
            if np.isfinite(bound):
                distance = np.minimum(distance, np.abs(points[:, axis] - bound))
    for box in room.boxes:
        c, s = portable_cos(box[6]), portable_sin(box[6])
        rel = points - box[:3]
        local = np.stack([c * rel[:, 0] - s * rel[:, 2], rel[:, 1], s * rel[:, 0] + c * rel[:, 2]],
                         axis=1)  # R(yaw)ᵀ (p − c), as refsynth.scenes.ray_box
        excess = np.abs(local) - box[3:6]
        outside = norm3(np.maximum(excess, 0.0))
        distance = np.minimum(distance, np.abs(outside + np.minimum(excess.max(axis=1), 0.0)))
    return distance


def _pixel_index(model: Model, shape) -> np.ndarray:
    return model.pixels[:, 0] * shape[1] + model.pixels[:, 1]


def point_errors(model: Model, truth: np.ndarray) -> np.ndarray:
    """Each vertex's distance from the true surface along its ray, relative to the true range.

    ``| ‖v‖ − r_true(p) | / r_true(p)`` for the vertex ``v`` of pixel ``p``
    (``model`` in the scanner's frame, as :func:`refsynth.model.build_model`
    returns it; ``truth`` from :func:`true_range`).
    """
    r = truth.ravel()[_pixel_index(model, truth.shape)]
    return np.abs(norm3(model.vertices) - r) / r


def triangle_checks(model: Model, truth: np.ndarray, room: RoomGeometry, pose: Pose, *,
                    jump: float = TRUE_JUMP, off: float = OFF_SURFACE) -> dict:
    """Which triangles cross a true depth edge, and which of those bridge it (module docstring).

    Parameters
    ----------
    model : refsynth.model.Model
        One position's model, in its scanner's frame.
    truth : ndarray
        :func:`true_range` of its pixels.
    room : RoomGeometry
    pose : refsynth.model.Pose
    jump, off : float
        :data:`TRUE_JUMP` and :data:`OFF_SURFACE`.

    Returns
    -------
    dict of ndarray of bool, one entry per face
        ``crossing`` (the true range jumps between its pixels), ``bridging``
        (crossing, and its centre off every true surface), ``measured``
        (all three vertices measured).
    """
    corners = _pixel_index(model, truth.shape)[model.faces]
    ranges = truth.ravel()[corners]
    crossing = ranges.max(axis=1) > (1.0 + jump) * ranges.min(axis=1)
    centre = model.vertices[model.faces].mean(axis=1)
    reach = norm3(centre)
    hanging = surface_distance(room, pose.apply(centre)) > off * reach
    return {"crossing": crossing, "bridging": crossing & hanging,
            "measured": ~model.synthesized[model.faces].any(axis=1)}
