"""The acquisition rig (§3.1, §4): serial drivers, a simulated rig, scans that lose nothing.

- :mod:`refsynth.acquisition.protocol`: both wire protocols as pure functions on
  bytes (``refsynth/rig/PROTOCOL.md`` is the adapter writer's page).
- :class:`PanUnit`, :class:`Rangefinder`: pyserial drivers with deadlines,
  validation, retries and reconnection.
- :class:`RigSimulator`: both devices on pseudo-terminals, backed by a
  ray-cast of the synthetic room, with fault injection; :class:`RoomRig`
  is its physics without ports.
- :func:`run_scan`, :func:`plan_slices`, :func:`load_scan`: partial scans
  (all / every n-th / stripes / distance-driven, Fig. 2), saved slice by
  slice, resumable, assembled as spherical samples (r, θ, φ).
- :mod:`refsynth.acquisition.geometry`: pan and mirror angles, the camera model.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.1 and §4, doi:10.1007/s11263-007-0108-2.
"""

from refsynth.acquisition.errors import (
    DeviceError,
    DeviceTimeout,
    PortLost,
    ReplyError,
    RetriesExhausted,
    RigError,
)
from refsynth.acquisition.pan_unit import PanInfo, PanUnit
from refsynth.acquisition.rangefinder import Rangefinder
from refsynth.acquisition.scan import (
    STRATEGIES,
    CameraImage,
    Scan,
    ScanSettings,
    ScanSummary,
    load_scan,
    plan_slices,
    read_slice,
    run_scan,
)
from refsynth.acquisition.simulator import Faults, RigSimulator, RoomRig

__all__ = [
    "PanUnit",
    "PanInfo",
    "Rangefinder",
    "RigSimulator",
    "RoomRig",
    "Faults",
    "ScanSettings",
    "ScanSummary",
    "Scan",
    "CameraImage",
    "STRATEGIES",
    "plan_slices",
    "run_scan",
    "load_scan",
    "read_slice",
    "RigError",
    "DeviceError",
    "ReplyError",
    "DeviceTimeout",
    "PortLost",
    "RetriesExhausted",
]
