"""An in-process rig for scan tests: the simulator's physics without ports or threads.

``fake_scan`` runs :func:`refsynth.acquisition.run_scan` with drivers that answer from
:class:`refsynth.acquisition.RoomRig` directly: the same slice and picture bytes as the pty
simulator of the same seed without faults, in a fraction of the time.
"""

from pathlib import Path

from refsynth.acquisition import PanInfo, RoomRig, run_scan
from refsynth.acquisition.geometry import image_name


class _Stats:
    def as_dict(self):
        return {"retries": 0, "faults": 0, "reconnects": 0}


class FakePan:
    """The simulated pan unit without a port: what run_scan asks of a driver."""

    retries = 0

    def __init__(self, rig: RoomRig, camera_dir: Path):
        self.rig, self.camera_dir, self.at, self.stats = rig, camera_dir, 0, _Stats()
        self.pictures = 0

    def initialise(self):
        return PanInfo("fake pan unit", 1296.0, 0, 499, 0)

    def move_to(self, index):
        self.at = index

    def position(self):
        return self.at

    def trigger_camera(self, expected=None):
        self.camera_dir.mkdir(parents=True, exist_ok=True)
        (self.camera_dir / image_name(self.at)).write_bytes(self.rig.picture_png(self.at))
        self.pictures += 1
        return self.at


class FakeLaser:
    def __init__(self, rig: RoomRig, pan: FakePan):
        self.rig, self.pan, self.stats, self.slices = rig, pan, _Stats(), 0

    def initialise(self):
        return {"VEND": "fake"}

    def scan_slice(self, seq, count, average):
        self.slices += 1
        return self.rig.measure(self.pan.at, seq, count, average)


#: The simulated room of seed 0, as the pty simulator's.
RIG = RoomRig(0)


def fake_scan(folder, settings=None, *, resume=False, source=None, progress=None):
    pan = FakePan(RIG, Path(folder) / "images")
    laser = FakeLaser(RIG, pan)
    summary = run_scan(folder, pan, laser, settings, resume=resume,
                       source=source or {"simulated": True, "seed": 0}, progress=progress)
    return summary, laser.slices, pan.pictures
