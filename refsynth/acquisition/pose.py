"""Where the rig stands: a scan position in the room, for scans from several places (§1, §4).

Large indoor spaces "cannot be entirely perceived from a single vantage
point" (the paper's footnote 1): the robot scans from several positions.
:class:`RigPose` is one, in the convention of :class:`refsynth.model.Pose`
with ``y = 0`` (the acquisition layer does not import the model layer, so
the pose is its own small class here):

- the rig's centre is at ``(x, 0, z)`` of the room's frame (metres; x right,
  y up, z forward, :func:`refsynth.scenes.room_geometry`'s frame);
- ``heading`` (radians) turns it about the vertical axis in the pan angles'
  sense, from z towards x, so that the rig's pan angle ``φ`` looks along the
  room's azimuth ``φ + heading``.

A ray ``d`` of the rig's own frame (:func:`~refsynth.acquisition.geometry.directions`,
:func:`~refsynth.acquisition.geometry.camera_rays`) is cast from ``(x, 0, z)``
along ``R_y(heading) d``, with ``R_y`` the rotation of
:meth:`refsynth.model.Pose.matrix`; so a point ``p`` measured in the rig's
frame is ``R_y(heading) p + (x, 0, z)`` in the room's, which is
``refsynth.model.Pose(x, z, heading).apply(p)``. The origin (0, 0, 0) casts
the rays unchanged (:attr:`RigPose.is_origin`: no rotation is applied), so a
default scan is bit-identical to one from before poses existed.

A scan records its pose in ``manifest.json`` as ``source.pose = {"x": m,
"z": m, "heading": degrees}`` (:meth:`RigPose.as_dict`), the format of an
entry of ``python -m refsynth model --poses``'s ``poses.json``.

References
----------
Torres-Méndez & Dudek (2008), §1 (footnote 1) and §4, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_real
from refsynth.scenes import RoomGeometry
from refsynth.scenes.portable import portable_cos, portable_sin, rotate3

__all__ = ["RigPose", "check_pose"]


@dataclass(frozen=True)
class RigPose:
    """Where the rig stands in the room: ``(x, z)`` on the floor plan, ``heading`` about y.

    The convention of :class:`refsynth.model.Pose` with ``y = 0`` (see the
    module's docstring): metres in the room's frame (x right, y up, z
    forward), ``heading`` in radians from z towards x (a pan angle ``φ`` of
    the rig looks along the room's azimuth ``φ + heading``).

    Examples
    --------
    >>> pose = RigPose.from_dict({"x": 1.0, "z": 0.5, "heading": 90.0})
    >>> np.round(pose.to_room(np.array([0.0, 0.0, 1.0])), 12) + 0.0   # pan 0 looks along +x
    array([2. , 0. , 0.5])
    >>> pose.as_dict()
    {'x': 1.0, 'z': 0.5, 'heading': 90.0}
    """

    x: float = 0.0
    z: float = 0.0
    heading: float = 0.0

    def __post_init__(self):
        for name in ("x", "z", "heading"):
            object.__setattr__(self, name, check_real(name, getattr(self, name)))

    @property
    def is_origin(self) -> bool:
        """Whether this is the room's centre, facing z (the rays are cast unchanged)."""
        return self.x == 0.0 and self.z == 0.0 and self.heading == 0.0

    @property
    def origin(self) -> np.ndarray:
        """The rig's centre in the room's frame, ``(x, 0, z)``."""
        return np.array([self.x, 0.0, self.z])

    def rotation(self) -> np.ndarray:
        """``R_y(heading)``, 3×3: the rig's directions into the room's frame."""
        c, s = portable_cos(self.heading), portable_sin(self.heading)
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

    def to_room(self, points: np.ndarray) -> np.ndarray:
        """Points ``(..., 3)`` of the rig's frame in the room's: ``R p + (x, 0, z)``."""
        return rotate3(self.rotation(), points) + self.origin  # no BLAS: the same bits everywhere

    def rays(self, directions: np.ndarray) -> np.ndarray:
        """Directions ``(..., 3)`` of the rig's frame in the room's (unchanged at the origin)."""
        return directions if self.is_origin else rotate3(self.rotation(), directions)

    def as_dict(self) -> dict:
        """``{"x": m, "z": m, "heading": degrees}`` (rounded to 10⁻⁹°): the manifest's
        ``source.pose``, and an entry of ``python -m refsynth model --poses``'s ``poses.json``."""
        return {"x": self.x, "z": self.z, "heading": round(math.degrees(self.heading), 9)}

    @classmethod
    def from_dict(cls, entry) -> RigPose:
        """The pose of :meth:`as_dict` (``heading`` in degrees; missing keys are 0)."""
        if not isinstance(entry, dict) or set(entry) - {"x", "z", "heading"}:
            raise ValueError(f"A rig pose must be an object with x, z and heading (degrees), "
                             f"got {entry!r}")
        heading = check_real("heading", entry.get("heading", 0.0))
        return cls(x=entry.get("x", 0.0), z=entry.get("z", 0.0),
                   heading=math.radians(heading))


def check_pose(room: RoomGeometry, pose: RigPose) -> None:
    """Raise ValueError unless the rig stands inside ``room``, clear of its walls and of every
    box's footprint (by 5 cm)."""
    margin = 0.05
    inside = (room.lower[0] + margin < pose.x < room.upper[0] - margin
              and pose.z < room.upper[2] - margin and pose.z > room.lower[2] + margin)
    if not inside:
        raise ValueError(f"The pose x={pose.x:g}, z={pose.z:g} m is not inside the room "
                         f"(x within ±{room.upper[0]:.2f}, z below {room.upper[2]:.2f})")
    for box in room.boxes:
        c, s = portable_cos(box[6]), portable_sin(box[6])
        dx, dz = pose.x - box[0], pose.z - box[2]
        local = (c * dx - s * dz, s * dx + c * dz)  # R(yaw)ᵀ (p − centre), as ray_box
        if abs(local[0]) <= box[3] + margin and abs(local[1]) <= box[5] + margin:
            raise ValueError(f"The pose x={pose.x:g}, z={pose.z:g} m is inside a piece of "
                             "furniture")
