"""The rig's geometry: pan angles, mirror (encoder) angles, the camera (§3.1, §4, App. A).

The paper's rig (§4): a laser rangefinder whose 45° mirror spins about a
horizontal shaft with a 2000-position encoder, sweeping one vertical plane
(a *slice*); a pan unit that turns it through 180° by steps of 0.36° (500
slices); and a camera on the same pan unit taking a picture every 18°. The
centres of the camera, the mirror and the pan axis are aligned (§3.1); the
simulator puts all three at the origin of :func:`refsynth.scenes.room_geometry`'s
frame (x right, y up, z forward), i.e. ``ΔY = 0`` in Eq. 20.

Conventions (the driver protocol page, ``refsynth/acquisition/PROTOCOL.md``, repeats them):

- pan index ``i`` in ``0 … 499`` (the pan unit's position), pan angle
  ``φ = (i − 250) · 0.36°`` (so ``φ`` runs from −90° to +89.64°; positive
  turns right, towards +x; Eq. 14's ``ψ = arctan(x / z)``);
- encoder position ``p`` in ``0 … 1999``, polar angle from the upward axis
  ``θ = p · 0.18°`` (``p = 500`` is horizontal; Eq. 19's ``θ``, with
  ``h = f / tan θ`` positive upwards);
- the unit direction of a sample is ``(sin θ sin φ, cos θ, sin θ cos φ)``;
- the camera: a pinhole with ``f = 300`` px (App. A.2), 128 × 240 px
  (width × height), principal point at the image centre, square pixels,
  no distortion; picture ``k`` is taken at pan index ``25 + 50 k``
  (``φ = −81° + 18° k``, ``k = 0 … 9``), so ten pictures 18° apart cover
  the 180° with 25 % overlap (the paper: 10–30 %);
- the laser window used by scans: encoder positions ``379 … 621`` (243
  positions, ``θ`` from 68.22° to 111.78°), which covers the camera's
  vertical field of view (±21.8°).

References
----------
Torres-Méndez & Dudek (2008), §3.1, §4 and Appendix A (Eqs. 14, 19–20),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth.scenes.portable import norm3, portable_cos, portable_sin, rotate3

__all__ = [
    "PAN_SLICES",
    "PAN_STEP_DEG",
    "PAN_CENTRE",
    "ENCODER_POSITIONS",
    "ENCODER_STEP_DEG",
    "ENCODER_HORIZON",
    "SLICE_START",
    "SLICE_COUNT",
    "SLICE_AVERAGE",
    "FOCAL_PX",
    "IMAGE_WIDTH",
    "IMAGE_HEIGHT",
    "CAMERA_FIRST",
    "CAMERA_EVERY",
    "pan_angle",
    "polar_angle",
    "directions",
    "camera_indices",
    "camera_rays",
    "image_name",
]

#: Slices over 180° (pan positions 0 … 499).
PAN_SLICES = 500
#: One pan step, degrees (1296 seconds of arc).
PAN_STEP_DEG = 0.36
#: The pan index whose angle is 0 (straight ahead, +z).
PAN_CENTRE = 250
#: Positions of the mirror's encoder per revolution.
ENCODER_POSITIONS = 2000
#: One encoder step, degrees.
ENCODER_STEP_DEG = 360.0 / ENCODER_POSITIONS
#: The encoder position whose ray is horizontal (θ = 90°).
ENCODER_HORIZON = 500
#: First encoder position of a slice as scans request it.
SLICE_START = 379
#: Encoder positions per slice (covers the camera's vertical field of view).
SLICE_COUNT = 243
#: Samples averaged per position (§4: "each slice is an average of 10 samples").
SLICE_AVERAGE = 10
#: The camera's focal length in pixels (App. A.2: f = 300 px).
FOCAL_PX = 300.0
#: Camera image width in pixels: 2 atan(64 / 300) = 24.1° horizontal field of view.
IMAGE_WIDTH = 128
#: Camera image height in pixels: 2 atan(120 / 300) = 43.6° vertical field of view.
IMAGE_HEIGHT = 240
#: Pan index of the first picture.
CAMERA_FIRST = 25
#: Pan steps between pictures (18°).
CAMERA_EVERY = 50


def pan_angle(pan_index) -> np.ndarray:
    """The pan angle ``φ`` in radians of pan index ``i``: ``(i − 250) · 0.36°``.

    Examples
    --------
    >>> float(np.degrees(pan_angle(25)))
    -81.0
    """
    return np.radians((np.asarray(pan_index, dtype=np.float64) - PAN_CENTRE) * PAN_STEP_DEG)


def polar_angle(encoder) -> np.ndarray:
    """The mirror's polar angle ``θ`` in radians (from the upward axis) at encoder position ``p``.

    Examples
    --------
    >>> float(np.degrees(polar_angle(ENCODER_HORIZON)))
    90.0
    """
    return np.radians(np.asarray(encoder, dtype=np.float64) * ENCODER_STEP_DEG)


def directions(theta, phi) -> np.ndarray:
    """Unit ray directions ``(sin θ sin φ, cos θ, sin θ cos φ)`` in the room's frame.

    Parameters
    ----------
    theta, phi : array_like
        Polar angle from the upward (y) axis and pan angle, radians;
        broadcast against each other.

    Returns
    -------
    ndarray of shape (..., 3)
    """
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    sin_theta = portable_sin(theta)  # the same bits on every machine
    return np.stack([sin_theta * portable_sin(phi), portable_cos(theta),
                     sin_theta * portable_cos(phi)], axis=-1)


def camera_indices() -> np.ndarray:
    """Pan indices of the ten pictures: ``25, 75, …, 475`` (every 18°, §4)."""
    return np.arange(CAMERA_FIRST, PAN_SLICES, CAMERA_EVERY)


def camera_rays(pan_index: int) -> np.ndarray:
    """Unit rays through the pixel centres of the picture taken at ``pan_index``.

    Pixel ``(row, col)`` looks along camera coordinates
    ``((col + 0.5 − W/2) / f, (H/2 − row − 0.5) / f, 1)``, rotated about the
    vertical axis by the pan angle ``φ``.

    Returns
    -------
    ndarray of shape (IMAGE_HEIGHT, IMAGE_WIDTH, 3)
    """
    phi = float(pan_angle(pan_index))
    u = (np.arange(IMAGE_WIDTH) + 0.5 - IMAGE_WIDTH / 2) / FOCAL_PX
    v = (IMAGE_HEIGHT / 2 - (np.arange(IMAGE_HEIGHT) + 0.5)) / FOCAL_PX
    camera = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 1.0), axis=-1)
    cos, sin = portable_cos(phi), portable_sin(phi)
    # columns of the rotation: camera x -> (cos φ, 0, −sin φ), camera z -> (sin φ, 0, cos φ);
    # camera @ that, as explicit 3-term sums (no BLAS: the same bits on every machine)
    rays = rotate3(np.array([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]]), camera)
    return rays / norm3(rays)[..., None]


def image_name(pan_index: int) -> str:
    """The file name of the picture taken at ``pan_index``: ``pan-0025.png``.

    Examples
    --------
    >>> image_name(25)
    'pan-0025.png'
    """
    return f"pan-{int(pan_index):04d}.png"
