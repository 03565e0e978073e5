"""A simulated rig on pseudo-terminals, speaking the drivers' protocols (§3.1, §4).

- :class:`RoomRig`: the physics, with no port: what the rangefinder measures
  and the camera sees in :func:`refsynth.scenes.synthetic_room`'s room (the
  same seed gives the same room), by ray casting
  (:func:`refsynth.scenes.cast_rays`), from the room's centre or from any
  :class:`RigPose` in it;
- :class:`~refsynth.acquisition.pose.RigPose` (its own module): where the
  rig stands, ``(x, z, heading)``, the convention of
  :class:`refsynth.model.Pose` (its ``y`` is 0);
- :class:`~refsynth.acquisition.faults.Faults` (its own module): what goes
  wrong on the wire, parsed from ``"corrupt=0.05,drop=0.02,disconnect=1,delay=0.01"``;
  the servers below inject it.
- :class:`RigSimulator`: both devices, each on its own pseudo-terminal
  (``pty.openpty()``, raw mode) served by a background thread, reachable
  through stable symbolic links (``rig.pan_port``, ``rig.laser_port``) that
  survive a simulated disconnect, as udev's ``/dev/serial/by-id`` links do.
  A context manager: leaving it stops the threads and closes every
  descriptor.

The pose (:mod:`refsynth.acquisition.pose`): a :class:`RoomRig` at
``RigPose(x, z, heading)`` casts each ray of its own frame from ``(x, 0, z)``
along ``R_y(heading) d``, the convention of :class:`refsynth.model.Pose`; the
default pose casts them exactly as before poses existed. The noise is drawn
as at the origin: a seed's noise does not depend on the pose.

The measurement model (documented choices, not the paper's):

- range: the ray-cast distance plus Gaussian noise per sample of standard
  deviation ``2 mm + 6 mm · (1 − a/255)``, averaged over the samples that
  returned, rounded to the millimetre; no return (0) beyond 15 m (the
  AccuRange's span) or when fewer than half the samples returned;
- amplitude ``a = 255 · albedo · |cos(incidence)| / (1 + (r / 12 m)²)``,
  plus noise of 1.5 counts, clipped to 1–255;
- dropout: each sample is lost with probability ``0.002 + (6 / a)²``
  (grazing or dark surfaces return less often);
- the noise of slice ``i`` depends only on ``(seed, i, average)``, never
  on the order of requests or on retries, so a scan is reproducible
  whatever faults it met;
- pictures: ``albedo · shading`` plus Gaussian noise of 0.01 (seeded by
  ``(seed, pan index)``), 8-bit grey PNG, perspective (see
  :mod:`refsynth.acquisition.geometry`);
- the pan unit moves instantly, at any speed setting; the camera writes
  ``pan-<index>.png`` into ``camera_dir`` (:func:`refsynth._files.write_atomic`:
  an exclusive temporary file, then a rename).

References
----------
Torres-Méndez & Dudek (2008), §3.1 (Fig. 1: the laser and the camera on the
pan unit) and §4 (the devices simulated: 500 pan steps of 0.36°, slices of 10
samples, a picture every 18°), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import io
import os
import select
import shutil
import tempfile
import threading
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from refsynth._checks import is_int
from refsynth._files import write_atomic
from refsynth.acquisition.errors import ProtocolError
from refsynth.acquisition.faults import Faults
from refsynth.acquisition.geometry import (
    ENCODER_POSITIONS,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    PAN_SLICES,
    camera_rays,
    directions,
    image_name,
    pan_angle,
    polar_angle,
)
from refsynth.acquisition.pan_protocol import (
    PAN_RESOLUTION,
    format_pan_error,
    format_pan_reply,
    parse_pan_command,
)
from refsynth.acquisition.pose import RigPose, check_pose
from refsynth.acquisition.rangefinder_protocol import (
    encode_rangefinder_reply,
    encode_samples,
    parse_rangefinder_command,
)
from refsynth.scenes import RoomGeometry, cast_rays, room_geometry
from refsynth.scenes.portable import dot3

__all__ = ["RoomRig", "RigSimulator", "MAX_RANGE_M"]

#: The rangefinder's span, metres (AccuRange 4000: 0–15 m).
MAX_RANGE_M = 15.0
#: The simulated pan unit's version string.
PAN_VERSION = "refsynth simulated pan unit 1.0"
#: The simulated rangefinder's VV data lines.
RANGEFINDER_VERSION = (
    b"VEND:refsynth",
    b"PROD:AccuRange 4000 (simulated)",
    b"FIRM:1.0",
    b"PROT:refsynth-rig/1",
    b"ENCO:2000",
)


# ----------------------------------------------------------------------------- physics


class RoomRig:
    """What the rig measures in the synthetic room: slices and pictures, no ports.

    Parameters
    ----------
    seed : int, default 0
        The room (:func:`refsynth.scenes.room_geometry`) and every noise
        draw.
    pose : RigPose, optional
        Where the rig stands (default: the room's centre, facing z). It
        must be inside the room, clear of the furniture.

    Examples
    --------
    >>> rig = RoomRig(seed=0)
    >>> range_mm, amplitude = rig.measure(250, 500, 1, 10)
    >>> 1000 < int(range_mm[0]) < 9000     # straight ahead: the back wall or the divider
    True
    >>> moved = RoomRig(seed=0, pose=RigPose(z=1.0))   # a metre nearer
    >>> bool(abs(rig.truth(250, 500, 1)[0] - moved.truth(250, 500, 1)[0] - 1.0) < 1e-9)
    True
    """

    def __init__(self, seed: int = 0, pose: RigPose | None = None) -> None:
        if not is_int(seed) or seed < 0:
            raise TypeError(f"The parameter `seed` must be a non-negative integer, got {seed!r}")
        if pose is None:
            pose = RigPose()
        if not isinstance(pose, RigPose):
            raise TypeError(f"The parameter `pose` must be a RigPose, got {pose!r}")
        self.seed = int(seed)
        self.room: RoomGeometry = room_geometry(self.seed)
        check_pose(self.room, pose)
        self.pose = pose
        self._png: dict[int, bytes] = {}

    def _cast(self, rays: np.ndarray):
        """Rays of the rig's frame cast from the pose; returns ``(room rays, hits)``."""
        if self.pose.is_origin:
            return rays, cast_rays(self.room, rays)
        rays = self.pose.rays(rays)
        return rays, cast_rays(self.room, rays, origin=self.pose.origin)

    def _check(self, pan_index, seq, count, average) -> None:
        if not 0 <= pan_index < PAN_SLICES:
            raise ValueError(f"The parameter `pan_index` must be in [0, {PAN_SLICES - 1}], "
                             f"got {pan_index}")
        if not (0 <= seq and 1 <= count and seq + count <= ENCODER_POSITIONS and average >= 1):
            raise ValueError(f"Bad slice request seq={seq}, count={count}, average={average}")

    def truth(self, pan_index: int, seq: int, count: int) -> np.ndarray:
        """The noise-free distance in metres along each ray of a slice (inf: nothing hit)."""
        self._check(pan_index, seq, count, 1)
        rays = directions(polar_angle(np.arange(seq, seq + count)), pan_angle(pan_index))
        return self._cast(rays)[1].distance

    def measure(self, pan_index: int, seq: int, count: int,
                average: int) -> tuple[np.ndarray, np.ndarray]:
        """One slice as the rangefinder reports it.

        Returns
        -------
        range_mm : ndarray of shape (count,), uint16
            0 = no return.
        amplitude : ndarray of shape (count,), uint8
            0 where there is no return.
        """
        self._check(pan_index, seq, count, average)
        rays = directions(polar_angle(np.arange(seq, seq + count)), pan_angle(pan_index))
        rays, hits = self._cast(rays)
        # the noise of every encoder position, drawn for the whole revolution so that
        # a slice's values do not depend on which positions were asked for
        rng = np.random.default_rng([self.seed, 0x5CA, int(pan_index), int(average)])
        window = slice(seq, seq + count)
        noise = rng.standard_normal((ENCODER_POSITIONS, average))[window]
        keep = rng.random((ENCODER_POSITIONS, average))[window]
        amplitude_noise = rng.standard_normal(ENCODER_POSITIONS)[window]

        distance = hits.distance
        valid = np.isfinite(distance) & (distance <= MAX_RANGE_M)
        distance = np.where(valid, distance, 1.0)
        incidence = np.abs(dot3(rays, hits.normal))
        amplitude = 255.0 * hits.albedo * incidence / (1.0 + (distance / 12.0) ** 2)
        sigma = 0.002 + 0.006 * (1.0 - amplitude / 255.0)
        p_drop = np.clip(0.002 + (6.0 / np.maximum(amplitude, 1e-3)) ** 2, 0.0, 1.0)
        returned = (keep >= p_drop[:, None]) & valid[:, None]
        n = returned.sum(axis=1)
        samples = distance[:, None] + sigma[:, None] * noise
        total = np.zeros(samples.shape[0])
        for k in range(samples.shape[1]):  # left to right over the averaged samples (#11)
            total = total + np.where(returned[:, k], samples[:, k], 0.0)
        mean = total / np.maximum(n, 1)
        ok = n >= (average + 1) // 2
        range_mm = np.where(ok, np.clip(np.rint(mean * 1000.0), 1, 0xFFFF), 0)
        level = np.where(ok, np.clip(np.rint(amplitude + 1.5 * amplitude_noise), 1, 255), 0)
        return range_mm.astype(np.uint16), level.astype(np.uint8)

    def picture(self, pan_index: int) -> np.ndarray:
        """The camera's grey picture at ``pan_index``: (240, 128) uint8."""
        self._check(pan_index, 0, 1, 1)
        hits = self._cast(camera_rays(pan_index))[1]
        rng = np.random.default_rng([self.seed, 0xCA3, int(pan_index)])
        noise = rng.normal(0.0, 0.01, size=(IMAGE_HEIGHT, IMAGE_WIDTH))
        grey = np.clip(hits.albedo * hits.shading + noise, 0.0, 1.0)
        return np.rint(grey * 255.0).astype(np.uint8)

    def picture_png(self, pan_index: int) -> bytes:
        """:meth:`picture` encoded as PNG (cached)."""
        if pan_index not in self._png:
            from PIL import Image

            buffer = io.BytesIO()
            Image.fromarray(self.picture(pan_index), mode="L").save(buffer, format="PNG")
            self._png[pan_index] = buffer.getvalue()
        return self._png[pan_index]


# ----------------------------------------------------------------------------- device models


@dataclass
class _RigState:
    """What the two devices share: the pan position (the rangefinder scans where it points)."""

    pan_position: int = 0


class _PanModel:
    """The pan unit's behaviour, command by command."""

    delimiters = b" \r\n"
    default_speed = 1000

    def __init__(self, rig: RoomRig, state: _RigState, camera_dir: Path | None) -> None:
        self.rig = rig
        self.state = state
        self.camera_dir = camera_dir
        self.speed = self.default_speed

    def respond(self, token: bytes) -> bytes:
        try:
            name, value = parse_pan_command(token)
        except ProtocolError:
            return format_pan_error("Illegal command")
        if name == "PR":
            return format_pan_reply(PAN_RESOLUTION)
        if name == "PN":
            return format_pan_reply(0)
        if name == "PX":
            return format_pan_reply(PAN_SLICES - 1)
        if name == "PP":
            if value is None:
                return format_pan_reply(self.state.pan_position)
            if value > PAN_SLICES - 1:
                return format_pan_error("Maximum allowable pan position exceeded")
            if value < 0:
                return format_pan_error("Minimum allowable pan position exceeded")
            self.state.pan_position = value
            return format_pan_reply()
        if name == "PS":
            if value is None:
                return format_pan_reply(self.speed)
            if value < 1:
                return format_pan_error("Illegal command argument")
            self.speed = value
            return format_pan_reply()
        if name == "A":
            return format_pan_reply()
        if name == "R":
            self.state.pan_position = 0
            return format_pan_reply()
        if name == "V":
            return format_pan_reply(PAN_VERSION)
        # name == "C": the camera
        if self.camera_dir is None:
            return format_pan_error("No camera")
        position = self.state.pan_position
        try:
            if not self.camera_dir.is_dir():
                self.camera_dir.mkdir(parents=True)
            write_atomic(self.camera_dir / image_name(position), self.rig.picture_png(position))
        except OSError:  # the driver sees a camera that failed (and retries)
            return format_pan_error("Camera failed")
        return format_pan_reply(position)

    def refuse(self, token: bytes, draw: float) -> bytes:
        return format_pan_error("Busy")

    def reboot(self) -> None:
        self.state.pan_position = 0
        self.speed = self.default_speed


class _RangefinderModel:
    """The rangefinder's behaviour, command by command."""

    delimiters = b"\r\n"

    def __init__(self, rig: RoomRig, state: _RigState) -> None:
        self.rig = rig
        self.state = state
        self.laser_on = False

    def respond(self, line: bytes) -> bytes:
        try:
            command = parse_rangefinder_command(line)
        except ProtocolError:
            return encode_rangefinder_reply(line, 1 if line.startswith(b"GS") else 5)
        if command.name == "VV":
            return encode_rangefinder_reply(line, 0, list(RANGEFINDER_VERSION))
        if command.name == "BM":
            self.laser_on = True
            return encode_rangefinder_reply(line)
        if command.name == "QT":
            self.laser_on = False
            return encode_rangefinder_reply(line)
        seq, count, average = command.seq, command.count, command.average
        if count < 1 or average < 1 or seq + count > ENCODER_POSITIONS:
            return encode_rangefinder_reply(line, 1)
        if not self.laser_on:
            return encode_rangefinder_reply(line, 2)
        range_mm, amplitude = self.rig.measure(self.state.pan_position, seq, count, average)
        return encode_rangefinder_reply(line, 0, encode_samples(range_mm, amplitude))

    def refuse(self, line: bytes, draw: float) -> bytes:
        return encode_rangefinder_reply(line, 4 if draw < 0.5 else 3)

    def reboot(self) -> None:
        self.laser_on = False


# ----------------------------------------------------------------------------- pty server


@dataclass
class _ServerStats:
    requests: int = 0
    dropped: int = 0
    corrupted: int = 0
    refused: int = 0
    disconnects: int = 0


@dataclass
class _Server:
    """One device on a pseudo-terminal, served by one thread."""

    name: str
    model: object
    link: Path
    faults: Faults
    disconnect_at: list[int]
    rng: np.random.Generator
    stop: threading.Event
    reconnect_delay: float
    stats: _ServerStats = field(default_factory=_ServerStats)
    master: int = -1
    slave: int = -1
    wake: tuple[int, int] = (-1, -1)

    def open(self) -> None:
        import pty
        import tty

        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        temporary = self.link.with_name(f".{self.link.name}.tmp")
        if temporary.is_symlink() or temporary.exists():
            temporary.unlink()
        os.symlink(os.ttyname(self.slave), temporary)
        os.replace(temporary, self.link)

    def close_pty(self) -> None:
        if self.link.is_symlink():  # first the link, so that nobody opens a dying pty
            self.link.unlink()
        for fd in (self.master, self.slave):
            if fd >= 0:
                os.close(fd)
        self.master = self.slave = -1

    def run(self) -> None:
        wake = self.wake[0]
        buffer = b""
        while not self.stop.is_set():
            ready, _, _ = select.select([self.master, wake], [], [], 0.2)
            if wake in ready:
                os.read(wake, 64)
            if self.master not in ready:
                continue
            try:
                chunk = os.read(self.master, 4096)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:  # EIO: no client on the other side (cannot happen while we hold
                self.stop.wait(0.01)  # the slave open, but do not spin if it does)
                continue
            buffer += chunk
            while buffer and not self.stop.is_set():
                cut = [buffer.find(bytes([d])) for d in self.model.delimiters]
                cut = [c for c in cut if c >= 0]
                if not cut:
                    if len(buffer) > 4096:
                        buffer = b""
                    break
                token, buffer = buffer[: min(cut)], buffer[min(cut) + 1 :]
                if token and self.serve(token):
                    buffer = b""  # a disconnect lost whatever was pending

    def serve(self, token: bytes) -> bool:
        """Answer one command, with faults; True if the device disconnected."""
        stats, faults, rng = self.stats, self.faults, self.rng
        stats.requests += 1
        if self.disconnect_at and stats.requests == self.disconnect_at[0]:
            self.disconnect_at.pop(0)
            stats.disconnects += 1
            self.close_pty()
            self.model.reboot()
            self.stop.wait(self.reconnect_delay)
            if not self.stop.is_set():
                self.open()
            return True
        # the same draws for every request keep the fault sequence aligned
        u, kind, where, draw = rng.random(), int(rng.integers(3)), rng.random(), rng.random()
        flip = int(rng.integers(1, 256))
        garbage = rng.integers(0, 256, size=8).astype(np.uint8).tobytes()
        if u < faults.drop:
            self.model.respond(token)
            stats.dropped += 1
            return False
        if u < faults.drop + faults.error:
            reply = self.model.refuse(token, draw)
            stats.refused += 1
        else:
            reply = self.model.respond(token)
            if u < faults.drop + faults.error + faults.corrupt:
                stats.corrupted += 1
                reply = bytearray(reply)
                if kind == 0:
                    reply[int(where * len(reply))] ^= flip
                elif kind == 1:
                    reply[:0] = garbage[: 1 + int(where * 8)]
                else:
                    reply = reply[: 1 + int(where * (len(reply) - 1))]
                reply = bytes(reply)
        if faults.delay:
            self.stop.wait(faults.delay)
        self.write(reply)
        return False

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view and not self.stop.is_set() and self.master >= 0:
            _, ready, _ = select.select([], [self.master], [], 0.2)
            if not ready:
                continue
            try:
                view = view[os.write(self.master, view) :]
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                return


class RigSimulator:
    """Both devices of the rig on pseudo-terminals, each served by a background thread.

    Parameters
    ----------
    seed : int, default 0
        The room and all measurement noise (:class:`RoomRig`); the faults
        are drawn from ``seed`` too.
    faults : Faults or str, optional
        What goes wrong on the wire (:class:`Faults`, or its string form).
    camera_dir : str or Path, optional
        Where the camera writes its pictures on ``C``; without it, ``C``
        answers ``! No camera``.
    reconnect_delay : float, default 0.1
        Seconds a disconnected device stays away.
    pose : RigPose, optional
        Where the rig stands in the room (:class:`RoomRig`; default its
        centre, facing z).

    Attributes
    ----------
    pan_port, laser_port : str
        Paths to open with pyserial (symbolic links to the current
        pseudo-terminals).
    rig : RoomRig

    Examples
    --------
    >>> with RigSimulator(seed=0) as sim:                      # doctest: +SKIP
    ...     import serial
    ...     with serial.serial_for_url(sim.laser_port, timeout=1) as port:
    ...         _ = port.write(b"VV\\n")
    ...         port.read_until(b"\\n\\n")[:6]
    b'VV\\n00\\n'
    """

    def __init__(self, seed: int = 0, *, faults: Faults | str | None = None,
                 camera_dir: str | os.PathLike | None = None,
                 reconnect_delay: float = 0.1, pose: RigPose | None = None) -> None:
        if isinstance(faults, str) or faults is None:
            faults = Faults.parse(faults)
        if not isinstance(faults, Faults):
            raise TypeError(f"The parameter `faults` must be a Faults or a str, got {faults!r}")
        self.rig = RoomRig(seed, pose)
        self.seed = self.rig.seed
        self.faults = faults
        self.camera_dir = None if camera_dir is None else Path(camera_dir)
        self.reconnect_delay = float(reconnect_delay)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._servers: list[_Server] = []
        self._folder: str | None = None
        self.pan_port = ""
        self.laser_port = ""

    def start(self) -> RigSimulator:
        """Open both pseudo-terminals and start serving them."""
        try:
            import pty  # noqa: F401
            import tty  # noqa: F401
        except ImportError as error:  # pragma: no cover - Windows
            raise OSError("the simulated rig needs pseudo-terminals (the pty module), "
                          "which this platform lacks") from error
        if self._threads:
            raise RuntimeError("the simulator is already running")
        self._folder = tempfile.mkdtemp(prefix="refsynth-rig-")
        folder = Path(self._folder)
        state = _RigState()
        models = {
            "rangefinder": _RangefinderModel(self.rig, state),
            "pan unit": _PanModel(self.rig, state, self.camera_dir),
        }
        links = {"rangefinder": folder / "laser", "pan unit": folder / "pan"}
        turns = {"rangefinder": range(0, self.faults.disconnect, 2),
                 "pan unit": range(1, self.faults.disconnect, 2)}
        try:
            for code, name in enumerate(("pan unit", "rangefinder")):
                schedule = [self.faults.disconnect_after * (k + 1)
                            for k in range(len(turns[name]))]
                server = _Server(
                    name=name, model=models[name], link=links[name], faults=self.faults,
                    disconnect_at=schedule,
                    rng=np.random.default_rng([self.seed, 0xFA, code]),
                    stop=self._stop, reconnect_delay=self.reconnect_delay, wake=os.pipe(),
                )
                self._servers.append(server)
                server.open()
            for server in self._servers:
                thread = threading.Thread(target=server.run,
                                          name=f"refsynth-{server.name}", daemon=True)
                thread.start()
                self._threads.append(thread)
        except BaseException:
            self.close()
            raise
        self.pan_port, self.laser_port = str(links["pan unit"]), str(links["rangefinder"])
        return self

    def stats(self) -> dict[str, dict[str, int]]:
        """Per device: requests, replies dropped and corrupted, requests refused, disconnects."""
        return {server.name: asdict(server.stats) for server in self._servers}

    def close(self) -> None:
        """Stop the threads, close every descriptor, remove the links."""
        self._stop.set()
        for server in self._servers:
            os.write(server.wake[1], b"x")
        for thread in self._threads:
            thread.join(timeout=10)
        for server in self._servers:
            server.close_pty()
            for fd in server.wake:
                os.close(fd)
        if self._folder is not None:
            shutil.rmtree(self._folder, ignore_errors=True)
            self._folder = None
        self._threads, self._servers = [], []

    def __enter__(self) -> RigSimulator:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()
