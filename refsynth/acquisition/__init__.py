"""Acquisition (§3.1, §4): which range to measure, and the rig that measures it.

**Sampling strategies** (§3.1, §3.1.1, Fig. 2; the experiments' masks, §3.3):
:mod:`refsynth.acquisition.sampling` gives the known-range masks: stripes of
known and unknown range (:func:`stripes`, :func:`x_stripes_for_fraction`),
Fig. 2's distance-driven slices (:func:`distance_driven`), and the unknown
fraction of the tables (:func:`unknown_fraction`).

**The rig** (§4): a rangefinder sweeping vertical slices, turned through
180° by a pan unit that also carries the camera.

- :mod:`~refsynth.acquisition.geometry`: pan and mirror angles, the camera model.
- The protocols, as pure functions on bytes:
  :mod:`~refsynth.acquisition.pan_protocol`,
  :mod:`~refsynth.acquisition.rangefinder_protocol`
  (``refsynth/acquisition/PROTOCOL.md`` is the adapter writer's page).
- The drivers: :class:`PanUnit`, :class:`Rangefinder` on pyserial, with
  deadlines, validation, retries and reconnection
  (:mod:`~refsynth.acquisition.link`); their exceptions
  (:mod:`~refsynth.acquisition.errors`).
- The simulator: :class:`RigSimulator`, both devices on pseudo-terminals,
  backed by a ray-cast of the synthetic room, with :class:`Faults`
  injected; :class:`RoomRig` is its physics without ports, seen from a
  :class:`RigPose` (a scan position, :mod:`~refsynth.acquisition.pose`; the
  convention of :class:`refsynth.model.Pose`).
- Scans: :func:`plan_slices` (the strategies on the pan axis: all / every
  n-th / stripes / distance-driven, Fig. 2), :func:`run_scan` (saved slice
  by slice, :mod:`~refsynth.acquisition.scan_folder`; resumable, trusting
  nothing on disk unchecked and never deleting or overwriting a slice,
  :mod:`~refsynth.acquisition.resume`; the manifest and its checks,
  :mod:`~refsynth.acquisition.manifest`), :func:`simulate_scan` (the same
  on the simulator), :func:`load_scan` (spherical samples (r, θ, φ),
  :mod:`~refsynth.acquisition.assembly`).

**Active sensing** (§5): :func:`next_slices` ranks the unmeasured columns by
the expected error their measurement removes from the line across their gap,
from one synthesis and its uncertainty map (:mod:`~refsynth.acquisition.active`).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.1 (§3.1.1, Fig. 2) and §4,
doi:10.1007/s11263-007-0108-2.
"""

from refsynth.acquisition import errors, sampling
from refsynth.acquisition.active import next_slices
from refsynth.acquisition.assembly import CameraImage, Scan, load_scan
from refsynth.acquisition.errors import *  # noqa: F403 (the names of errors.__all__)
from refsynth.acquisition.faults import Faults
from refsynth.acquisition.pan_unit import PanInfo, PanUnit
from refsynth.acquisition.pose import RigPose
from refsynth.acquisition.rangefinder import Rangefinder
from refsynth.acquisition.sampling import *  # noqa: F403 (the names of sampling.__all__)
from refsynth.acquisition.scan import ScanSummary, run_scan, simulate_scan
from refsynth.acquisition.scan_folder import read_slice
from refsynth.acquisition.simulator import RigSimulator, RoomRig
from refsynth.acquisition.slice_plan import STRATEGIES, ScanSettings, plan_slices

__all__ = [
    # sampling strategies (§3.1.1, Fig. 2; §3.3): all of refsynth.acquisition.sampling
    *sampling.__all__,
    # the rig (§4): drivers, simulator, scans
    "PanUnit",
    "PanInfo",
    "Rangefinder",
    "RigSimulator",
    "RoomRig",
    "RigPose",
    "Faults",
    "ScanSettings",
    "ScanSummary",
    "Scan",
    "CameraImage",
    "STRATEGIES",
    "plan_slices",
    "run_scan",
    "simulate_scan",
    "load_scan",
    "read_slice",
    # active sensing (§5)
    "next_slices",
    # errors: all of refsynth.acquisition.errors
    *errors.__all__,
]
