"""Scans that lose nothing: choose the slices (§3.1.1, Fig. 2), acquire, assemble (r, θ, φ).

The paper scans only part of the 500 slices of a pose, "approximately 30
to 50 % of total range" (§4), chosen by a sampling strategy; Fig. 2's rule
samples densely where the scene is far. :func:`plan_slices` gives the
strategies on the 500-slice pan axis:

- ``"all"``: every slice (the paper's complete scans, for ground truth);
- ``"every"``: every ``step``-th slice;
- ``"stripes"``: stripes of ``stripe_width`` consecutive slices with gaps
  sized for the requested fraction (:func:`refsynth.acquisition.sampling.x_stripes_for_fraction`);
- ``"distance"``: a coarse first pass (every ``coarse_step``-th slice),
  then :func:`refsynth.acquisition.sampling.distance_driven` on its per-slice median
  range, the union sized to the requested fraction.

:func:`run_scan` acquires a plan with the drivers. Each validated slice is
written at once (temporary file, then ``os.replace``) to
``slices/pan-<index>.slice``, whose bytes depend only on the data, and
``manifest.json`` is rewritten the same way after every slice and picture.
The slice files are the truth: a scan interrupted at any point (even by
SIGKILL) is resumed with ``resume=True``, which re-reads and checks them and
acquires only what is missing. When the plan is complete the scan is
assembled into ``scan.npz`` (spherical samples, see :func:`load_scan`).

Output folder::

    manifest.json        settings, plan, devices, slices, pictures, sessions
    slices/pan-0250.slice
    images/pan-0025.png  the camera's pictures (every 18°)
    scan.npz             r, theta, phi, amplitude, pan_index, encoder

References
----------
Torres-Méndez & Dudek (2008), §3.1.1 (Fig. 2) and §4,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import io
import json
import os
import re
import time
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from refsynth.acquisition.errors import RigError
from refsynth.acquisition.geometry import (
    CAMERA_EVERY,
    CAMERA_FIRST,
    ENCODER_POSITIONS,
    ENCODER_STEP_DEG,
    FOCAL_PX,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    PAN_CENTRE,
    PAN_SLICES,
    PAN_STEP_DEG,
    SLICE_AVERAGE,
    SLICE_COUNT,
    SLICE_START,
    camera_indices,
    image_name,
    pan_angle,
    polar_angle,
)
from refsynth.acquisition.protocol import (
    LINE_WIDTH,
    PAN_RESOLUTION,
    ProtocolError,
    crc16,
    decode_samples,
    encode_samples,
)
from refsynth.acquisition.sampling import distance_driven, x_stripes_for_fraction

__all__ = [
    "STRATEGIES",
    "ScanSettings",
    "ScanSummary",
    "SliceRecord",
    "Scan",
    "CameraImage",
    "plan_slices",
    "coarse_slices",
    "slice_bytes",
    "read_slice",
    "slice_name",
    "run_scan",
    "load_scan",
]

#: The sampling strategies of :func:`plan_slices`.
STRATEGIES = ("all", "every", "stripes", "distance")
#: The manifest's format tag.
FORMAT = "refsynth-scan/1"
_SLICE_MAGIC = b"refsynth-slice 1\n"
_SLICE_NAME = re.compile(r"pan-(\d{4})\.slice")


# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class ScanSettings:
    """How a scan chooses and requests its slices.

    Parameters
    ----------
    strategy : {"stripes", "every", "distance", "all"}
    fraction : float, default 0.4
        Fraction of the 500 slices to scan, in (0, 1] (the paper: 0.3–0.5);
        ignored by ``"all"``, and by ``"every"`` when ``step`` is given.
    step : int, optional
        ``"every"``: scan every ``step``-th slice; default ``1 / fraction``
        rounded half up (0.4 → every 3rd).
    stripe_width : int, default 4
        ``"stripes"``: consecutive slices per stripe (the ``rw`` of §3.3).
    coarse_step : int, default 10
        ``"distance"``: the first pass scans every ``coarse_step``-th slice.
    seq, count, average : int
        The GS window: first encoder position, positions per slice, samples
        averaged (defaults: 379, 243 and 10, see :mod:`refsynth.acquisition.geometry`).
    camera : bool, default True
        Take the ten pictures (``C`` at pan indices 25, 75, …, 475).
    """

    strategy: str = "stripes"
    fraction: float = 0.4
    step: int | None = None
    stripe_width: int = 4
    coarse_step: int = 10
    seq: int = SLICE_START
    count: int = SLICE_COUNT
    average: int = SLICE_AVERAGE
    camera: bool = True

    def __post_init__(self) -> None:
        if self.strategy not in STRATEGIES:
            raise ValueError(f"The parameter `strategy` must be one of {', '.join(STRATEGIES)}, "
                             f"got {self.strategy!r}")
        if isinstance(self.fraction, bool) or not isinstance(self.fraction, (int, float)) or not (
            0.0 < self.fraction <= 1.0
        ):
            raise ValueError(f"The parameter `fraction` must be in (0, 1], got {self.fraction!r}")
        for name, low, high in (("stripe_width", 1, PAN_SLICES), ("coarse_step", 2, PAN_SLICES),
                                ("seq", 0, ENCODER_POSITIONS - 1), ("count", 1, ENCODER_POSITIONS),
                                ("average", 1, 99)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise ValueError(f"The parameter `{name}` must be an integer in [{low}, {high}], "
                                 f"got {value!r}")
        if self.step is not None and (
            isinstance(self.step, bool) or not isinstance(self.step, int)
            or not 1 <= self.step <= PAN_SLICES
        ):
            raise ValueError(f"The parameter `step` must be an integer in [1, {PAN_SLICES}], "
                             f"got {self.step!r}")
        if self.seq + self.count > ENCODER_POSITIONS:
            raise ValueError(f"The parameters `seq` + `count` must be <= {ENCODER_POSITIONS}, "
                             f"got {self.seq + self.count}")
        if not isinstance(self.camera, bool):
            raise TypeError(f"The parameter `camera` must be a bool, got {self.camera!r}")

    def as_dict(self) -> dict:
        """The settings as a JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, values: dict) -> ScanSettings:
        """Inverse of :meth:`as_dict` (unknown keys are an error)."""
        known = {f.name for f in fields(cls)}
        unknown = set(values) - known
        if unknown:
            raise ValueError(f"unknown scan settings {sorted(unknown)}")
        return cls(**values)


def coarse_slices(settings: ScanSettings) -> np.ndarray:
    """The first pass of the ``"distance"`` strategy: every ``coarse_step``-th slice from 0."""
    return np.arange(0, PAN_SLICES, settings.coarse_step)


def plan_slices(settings: ScanSettings, coarse_range: np.ndarray | None = None) -> np.ndarray:
    """The pan indices a scan acquires, ascending (§3.1.1, Fig. 2).

    Parameters
    ----------
    settings : ScanSettings
    coarse_range : ndarray of shape (500,), optional
        ``"distance"`` only (and required there): a representative range
        (metres) per slice, NaN where the first pass did not scan; in
        between it is interpolated (:func:`refsynth.acquisition.sampling.column_range_profile`).

    Returns
    -------
    ndarray of int
        Sorted, unique pan indices in ``0 … 499``. For ``"distance"`` it
        contains :func:`coarse_slices`, and its size is the one closest to
        ``fraction · 500`` that the rule reaches.

    Examples
    --------
    >>> plan = plan_slices(ScanSettings("stripes", 0.4))
    >>> len(plan), plan[:6].tolist()
    (200, [0, 1, 2, 3, 10, 11])
    >>> plan_slices(ScanSettings("every", step=100)).tolist()
    [0, 100, 200, 300, 400]
    """
    if not isinstance(settings, ScanSettings):
        raise TypeError(f"The parameter `settings` must be a ScanSettings, got {settings!r}")
    if settings.strategy == "all" or (settings.strategy != "every" and settings.fraction >= 1.0):
        return np.arange(PAN_SLICES)
    if settings.strategy == "every":
        step = settings.step or max(1, int(1.0 / settings.fraction + 0.5))
        return np.arange(0, PAN_SLICES, step)
    if settings.strategy == "stripes":
        mask = x_stripes_for_fraction((1, PAN_SLICES), 1.0 - settings.fraction,
                                      rw=settings.stripe_width)
        return np.flatnonzero(mask[0])
    # distance-driven (Fig. 2), laid out around the coarse pass
    if coarse_range is None:
        raise ValueError("The `distance` strategy needs `coarse_range` from a first pass")
    profile = np.asarray(coarse_range, dtype=np.float64)
    if profile.shape != (PAN_SLICES,):
        raise ValueError(f"The parameter `coarse_range` must have shape ({PAN_SLICES},), "
                         f"got {profile.shape}")
    coarse = np.zeros(PAN_SLICES, dtype=bool)
    coarse[coarse_slices(settings)] = True
    target = settings.fraction * PAN_SLICES
    if coarse.sum() >= target:
        return np.flatnonzero(coarse)

    def union(known_fraction: float) -> np.ndarray:
        return coarse | distance_driven(profile, known_fraction, height=1)[0]

    # the union grows with the rule's own fraction: bisect for the size closest to the target
    low, high = 1.0 / PAN_SLICES, min(settings.fraction, 1.0 - 1.0 / PAN_SLICES)
    best = union(high)
    for _ in range(30):
        middle = 0.5 * (low + high)
        candidate = union(middle)
        if abs(int(candidate.sum()) - target) < abs(int(best.sum()) - target):
            best = candidate
        if candidate.sum() < target:
            low = middle
        else:
            high = middle
    return np.flatnonzero(best)


# ----------------------------------------------------------------------------- slice files


@dataclass(frozen=True, eq=False)
class SliceRecord:
    """One saved slice.

    Attributes
    ----------
    pan_index, seq, count, average : int
    range_mm : ndarray of shape (count,), uint16
        0 = no return.
    amplitude : ndarray of shape (count,), uint8
    """

    pan_index: int
    seq: int
    count: int
    average: int
    range_mm: np.ndarray
    amplitude: np.ndarray


def slice_name(pan_index: int) -> str:
    """``pan-0250.slice``."""
    return f"pan-{int(pan_index):04d}.slice"


def slice_bytes(record: SliceRecord) -> bytes:
    """The slice file's bytes: a header, the samples as on the wire, a CRC line.

    ::

        refsynth-slice 1
        pan 250
        seq 379
        count 243
        average 10

        <the GS data lines: 6 hex digits per sample, 64 characters a line>
        =<CRC-16 of the data lines, LF included>

    Nothing in it but the data: the same slice always gives the same bytes.
    """
    payload = encode_samples(record.range_mm, record.amplitude)
    lines = [payload[i : i + LINE_WIDTH] for i in range(0, len(payload), LINE_WIDTH)]
    block = b"".join(line + b"\n" for line in lines)
    header = (f"pan {record.pan_index}\nseq {record.seq}\ncount {record.count}\n"
              f"average {record.average}\n\n").encode("ascii")
    return _SLICE_MAGIC + header + block + f"={crc16(block):04X}\n".encode("ascii")


def read_slice(path: str | os.PathLike) -> SliceRecord:
    """Read and check a slice file (header, CRC, sample count).

    Raises
    ------
    ValueError
        If the file is not a valid slice file (the message names it).
    FileNotFoundError
        If it does not exist.
    """
    path = Path(path)
    data = path.read_bytes()
    try:
        if not data.startswith(_SLICE_MAGIC):
            raise ProtocolError("not a slice file")
        header, sep, rest = data[len(_SLICE_MAGIC):].partition(b"\n\n")
        if not sep:
            raise ProtocolError("no blank line after the header")
        values = {}
        for line in header.split(b"\n"):
            key, _, value = line.partition(b" ")
            if not value.isdigit():
                raise ProtocolError(f"bad header line {line[:30]!r}")
            values[key.decode("ascii", "replace")] = int(value)
        if set(values) != {"pan", "seq", "count", "average"}:
            raise ProtocolError(f"header keys {sorted(values)}")
        block, _, crc_line = rest.rpartition(b"=")
        if not (crc_line.endswith(b"\n") and len(crc_line) == 5) or (
            int(crc_line[:4], 16) != crc16(block)
        ):
            raise ProtocolError("CRC mismatch")
        range_mm, amplitude = decode_samples(block.replace(b"\n", b""), values["count"])
    except (ProtocolError, ValueError) as error:
        raise ValueError(f"'{path}' is not a valid slice file: {error}") from None
    return SliceRecord(values["pan"], values["seq"], values["count"], values["average"],
                       range_mm, amplitude)


def _write_atomic(path: Path, data: bytes) -> None:
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(data)
    os.replace(temporary, path)


def _write_json(path: Path, value: dict) -> None:
    _write_atomic(path, (json.dumps(value, indent=1, sort_keys=True) + "\n").encode("utf-8"))


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """An ``.npz`` whose bytes depend only on the arrays (fixed zip timestamps)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as archive:
        for name, array in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(array), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.create_system = 3
            info.external_attr = 0o644 << 16
            archive.writestr(info, member.getvalue())
    _write_atomic(path, buffer.getvalue())


# ----------------------------------------------------------------------------- the scan


@dataclass
class ScanSummary:
    """What one :func:`run_scan` session did.

    Attributes
    ----------
    folder : Path
    planned : int
        Slices in the plan.
    acquired : int
        Slices acquired in this session.
    already : int
        Valid slices found on disk when the session started.
    images : int
        Pictures taken in this session.
    retries, faults, reconnects : int
        Summed over both devices (see :class:`refsynth.acquisition.link.DeviceStats`);
        ``faults`` counts every failure met and recovered from.
    seconds : float
    complete : bool
        Whether the plan is complete and ``scan.npz`` written.
    """

    folder: Path
    planned: int = 0
    acquired: int = 0
    already: int = 0
    images: int = 0
    retries: int = 0
    faults: int = 0
    reconnects: int = 0
    seconds: float = 0.0
    complete: bool = False

    def __str__(self) -> str:
        return (
            f"{self.acquired + self.already}/{self.planned} slices "
            f"({100 * self.planned / PAN_SLICES:.1f} % of {PAN_SLICES}; {self.acquired} acquired "
            f"now, {self.already} already on disk), {self.images} pictures; retries "
            f"{self.retries}, faults recovered {self.faults} ({self.reconnects} reconnects); "
            f"{self.seconds:.1f} s"
        )


def _existing_slices(folder: Path, settings: ScanSettings) -> dict[int, SliceRecord]:
    """The valid slice files in ``folder/slices``; invalid or stray files are removed."""
    found: dict[int, SliceRecord] = {}
    for path in sorted((folder / "slices").iterdir()):
        match = _SLICE_NAME.fullmatch(path.name)
        if match is None:
            if path.name.endswith(".tmp"):
                path.unlink()  # a write cut short by a kill
            continue
        try:
            record = read_slice(path)
        except ValueError:
            path.unlink()
            continue
        window = (record.seq, record.count, record.average)
        if record.pan_index != int(match.group(1)) or window != (
            settings.seq, settings.count, settings.average
        ):
            path.unlink()
            continue
        found[record.pan_index] = record
    return found


def _coarse_profile(records: dict[int, SliceRecord], indices: np.ndarray) -> np.ndarray:
    """Median range (m) of each coarse slice's returns; NaN elsewhere."""
    profile = np.full(PAN_SLICES, np.nan)
    for index in indices:
        values = records[int(index)].range_mm
        returned = values[values > 0]
        if returned.size:
            profile[index] = np.median(returned) / 1000.0
    if not np.isfinite(profile).any():
        raise ValueError("the coarse pass saw no return at all: cannot plan by distance")
    return profile


def _check_pan(info) -> None:
    if abs(info.resolution - PAN_RESOLUTION) > 1e-3 or info.minimum > 0 or (
        info.maximum < PAN_SLICES - 1
    ):
        raise ValueError(
            f"the pan unit must step {PAN_RESOLUTION:g} arc-seconds (0.36°) over positions "
            f"0-{PAN_SLICES - 1}; it reports {info.resolution:g} over "
            f"{info.minimum}-{info.maximum}"
        )


def run_scan(
    folder: str | os.PathLike,
    pan,
    laser,
    settings: ScanSettings | None = None,
    *,
    resume: bool = False,
    source: dict | None = None,
    camera_dir_is_local: bool = True,
    progress: Callable[[int, int, int], None] | None = None,
) -> ScanSummary:
    """Acquire a scan into ``folder``, or resume one (§3.1.1, §4).

    Parameters
    ----------
    folder : str or Path
        The output folder (created if needed).
    pan : PanUnit
        An initialisable pan-unit driver (:class:`refsynth.acquisition.PanUnit`).
    laser : Rangefinder
        A rangefinder driver (:class:`refsynth.acquisition.Rangefinder`).
    settings : ScanSettings, optional
        Default ``ScanSettings()`` (stripes, 40 %). When resuming, the
        folder's own settings are used; passing different ones is an error.
    resume : bool, default False
        Continue the scan in ``folder``: keep every valid slice file, acquire
        the rest of the plan. Without it, a folder holding a scan is an
        error. With it, a folder without one starts a new scan.
    source : dict, optional
        Recorded in the manifest (e.g. ``{"simulated": True, "seed": 0}``);
        when resuming it must agree with the recorded one on ``"simulated"``
        and ``"seed"`` (the same seed gives the same slices).
    camera_dir_is_local : bool, default True
        Whether the camera writes its pictures into ``folder/images`` (the
        simulator does): then a picture counts as taken only once its file
        is there.
    progress : callable, optional
        ``progress(done, planned, pan_index)`` after every saved slice.

    Returns
    -------
    ScanSummary

    Raises
    ------
    ValueError
        On settings that disagree with the folder's scan, a folder that
        holds a scan without ``resume``, or a pan unit with another
        geometry.
    RigError
        When a device fails beyond its retries (the folder stays
        resumable).

    Notes
    -----
    The order of events: initialise both devices; for ``"distance"``,
    acquire the coarse pass and plan from it; then, in ascending pan order,
    for each missing slice: move (absolute), request the slice, confirm the
    pan position again, write ``slices/pan-<i>.slice``, rewrite the
    manifest; a picture is taken when the pan passes its index. A slice
    whose position cannot be confirmed after the request is acquired again.
    """
    started = time.perf_counter()
    folder = Path(folder)
    manifest_path = folder / "manifest.json"
    if settings is not None and not isinstance(settings, ScanSettings):
        raise TypeError(f"The parameter `settings` must be a ScanSettings, got {settings!r}")
    source = dict(source or {})

    # --- the folder: a new scan, or the one to resume ---------------------------------
    if manifest_path.exists():
        if not resume:
            raise ValueError(f"'{folder}' already holds a scan: resume it (--resume) or choose "
                             "another folder")
        try:
            manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
            if manifest.get("format") != FORMAT:
                raise ValueError(f"format {manifest.get('format')!r}")
            saved = ScanSettings.from_dict(manifest["settings"])
        except (ValueError, KeyError, TypeError) as error:
            raise ValueError(f"cannot resume '{folder}': bad manifest.json ({error})") from None
        if settings is not None and settings != saved:
            changed = [f.name for f in fields(ScanSettings)
                       if getattr(settings, f.name) != getattr(saved, f.name)]
            raise ValueError(f"cannot resume '{folder}' with other settings "
                             f"({', '.join(changed)} differ from the saved scan)")
        settings = saved
        recorded = manifest.get("source", {})
        clash = [k for k in ("simulated", "seed")
                 if k in source and k in recorded and source[k] != recorded[k]]
        if clash:
            raise ValueError(f"cannot resume '{folder}': {', '.join(sorted(clash))} differ from "
                             f"the saved scan ({', '.join(f'{k}={recorded[k]!r}' for k in clash)})")
    else:
        settings = ScanSettings() if settings is None else settings
        if folder.exists() and any(p.name not in ("slices", "images") for p in folder.iterdir()):
            raise ValueError(f"'{folder}' is not empty and holds no scan (no manifest.json)")
        manifest = {
            "format": FORMAT,
            "paper": "Torres-Mendez & Dudek (2008), IJCV 79:137-158, sections 3.1 and 4",
            "settings": settings.as_dict(),
            "source": source,
            "geometry": {
                "pan_slices": PAN_SLICES, "pan_step_deg": PAN_STEP_DEG, "pan_centre": PAN_CENTRE,
                "encoder_positions": ENCODER_POSITIONS, "encoder_step_deg": ENCODER_STEP_DEG,
                "theta": "polar angle from the upward axis = encoder * encoder_step_deg",
                "phi": "pan angle = (pan_index - pan_centre) * pan_step_deg, positive to the right",
            },
            "camera": {
                "focal_px": FOCAL_PX, "width": IMAGE_WIDTH, "height": IMAGE_HEIGHT,
                "principal_point": [IMAGE_WIDTH / 2, IMAGE_HEIGHT / 2],
                "first": CAMERA_FIRST, "every": CAMERA_EVERY,
                "model": "pinhole at the laser centre; pixel (row, col) looks along "
                         "((col + 0.5 - W/2)/f, (H/2 - row - 0.5)/f, 1) turned by phi",
            },
            "plan": None,
            "coarse": None,
            "slices": {},
            "images": {},
            "devices": {},
            "sessions": [],
            "complete": False,
        }
    (folder / "slices").mkdir(parents=True, exist_ok=True)
    (folder / "images").mkdir(parents=True, exist_ok=True)

    # --- what is on disk is the truth ---------------------------------------------------
    records = _existing_slices(folder, settings)
    session = len(manifest["sessions"]) + 1
    entries = {}
    for index, record in records.items():
        entry = manifest["slices"].get(str(index)) or {"session": max(session - 1, 1)}
        entry.update(file=f"slices/{slice_name(index)}",
                     crc=f"{crc16(slice_bytes(record)):04X}")
        entries[str(index)] = entry
    manifest["slices"] = entries
    manifest["images"] = {key: value for key, value in manifest["images"].items()
                          if not camera_dir_is_local or (folder / value["file"]).is_file()}
    summary = ScanSummary(folder=folder, already=len(records))
    record_session = {"session": session, "resumed": session > 1, "acquired": 0, "images": 0,
                      "complete": False}
    manifest["sessions"].append(record_session)
    manifest["source"] = {**manifest.get("source", {}), **source}
    _write_json(manifest_path, manifest)

    stats_before = [d.stats.as_dict() for d in (pan, laser)]

    def account() -> None:
        now = [d.stats.as_dict() for d in (pan, laser)]
        for key in ("retries", "faults", "reconnects"):
            setattr(summary, key, sum(n[key] - b[key] for n, b in zip(now, stats_before))
                    + extra[key])
        summary.seconds = time.perf_counter() - started
        record_session.update(acquired=summary.acquired, images=summary.images,
                              retries=summary.retries, faults=summary.faults,
                              reconnects=summary.reconnects, seconds=round(summary.seconds, 3))

    extra = {"retries": 0, "faults": 0, "reconnects": 0}

    # --- the devices ----------------------------------------------------------------------
    info = pan.initialise()
    _check_pan(info)
    laser_info = laser.initialise()
    manifest["devices"] = {"pan unit": {"version": info.version, "resolution": info.resolution,
                                        "minimum": info.minimum, "maximum": info.maximum},
                           "rangefinder": dict(laser_info)}

    pictures = ([int(c) for c in camera_indices() if str(int(c)) not in manifest["images"]]
                if settings.camera else [])

    def take_picture(index: int) -> None:
        pan.move_to(index)
        pan.trigger_camera(expected=index)
        name = image_name(index)
        if camera_dir_is_local and not (folder / "images" / name).is_file():
            raise RigError("pan unit", "C", f"the camera wrote no file images/{name}")
        manifest["images"][str(index)] = {
            "file": f"images/{name}", "pan_index": index,
            "pan_angle_deg": round(float(np.degrees(pan_angle(index))), 6),
            "after_slices": len(records), "session": session,
        }
        summary.images += 1

    def acquire(index: int) -> None:
        for _ in range(pan.retries + 1):
            pan.move_to(index)
            range_mm, amplitude = laser.scan_slice(settings.seq, settings.count, settings.average)
            if pan.position() == index:
                break
            extra["faults"] += 1  # the pan moved away (a reset?) while the slice was taken
            extra["retries"] += 1
        else:
            raise RigError("pan unit", f"PP{index}", "the position kept changing during the slice")
        record = SliceRecord(index, settings.seq, settings.count, settings.average,
                             range_mm, amplitude)
        data = slice_bytes(record)
        _write_atomic(folder / "slices" / slice_name(index), data)
        records[index] = record
        manifest["slices"][str(index)] = {"file": f"slices/{slice_name(index)}",
                                          "crc": f"{crc16(data):04X}", "session": session}
        summary.acquired += 1

    def run(indices: np.ndarray, total: int, last_picture: int) -> None:
        events = sorted([(int(i), 0) for i in indices if int(i) not in records]
                        + [(c, 1) for c in pictures if c <= last_picture])
        for index, kind in events:
            if kind == 0:
                acquire(index)
                if progress is not None:
                    progress(len([i for i in plan_so_far if i in records]), total, index)
            else:
                take_picture(index)
                pictures.remove(index)
            account()
            _write_json(manifest_path, manifest)

    try:
        if settings.strategy == "distance" and manifest["plan"] is None:
            coarse = coarse_slices(settings)
            plan_so_far = set(int(i) for i in coarse)
            manifest["coarse"] = coarse.tolist()
            run(coarse, len(coarse), int(coarse.max()))
            plan = plan_slices(settings, _coarse_profile(records, coarse))
            manifest["plan"] = plan.tolist()
            _write_json(manifest_path, manifest)
        elif manifest["plan"] is None:
            manifest["plan"] = plan_slices(settings).tolist()
        plan = np.asarray(manifest["plan"], dtype=np.int64)
        plan_so_far = set(plan.tolist())
        summary.planned = len(plan)
        run(plan, len(plan), PAN_SLICES - 1)
        missing = [i for i in plan.tolist() if i not in records]
        if missing:  # cannot happen unless a slice file vanished under us
            raise RigError("scan", "check", f"{len(missing)} planned slices missing")
        # the assembled scan, ready for registration (App. A.2)
        _write_npz(folder / "scan.npz", _assemble(records, plan, settings))
        manifest["complete"] = record_session["complete"] = summary.complete = True
    finally:
        summary.planned = summary.planned or len(manifest["plan"] or [])
        account()
        _write_json(manifest_path, manifest)
    return summary


# ----------------------------------------------------------------------------- assembled scan


def _assemble(records: dict[int, SliceRecord], indices, settings: ScanSettings) -> dict:
    indices = np.asarray(sorted(int(i) for i in indices), dtype=np.int64)
    encoder = np.arange(settings.seq, settings.seq + settings.count, dtype=np.int64)
    if indices.size:
        range_mm = np.stack([records[int(i)].range_mm for i in indices])
        amplitude = np.stack([records[int(i)].amplitude for i in indices])
    else:
        range_mm = np.zeros((0, encoder.size), dtype=np.uint16)
        amplitude = np.zeros((0, encoder.size), dtype=np.uint8)
    r = np.where(range_mm > 0, range_mm / 1000.0, np.nan)
    theta, phi = np.broadcast_arrays(polar_angle(encoder)[None, :], pan_angle(indices)[:, None])
    return {"r": r, "theta": np.array(theta), "phi": np.array(phi),
            "amplitude": amplitude.astype(np.uint8), "pan_index": indices, "encoder": encoder}


@dataclass(frozen=True)
class CameraImage:
    """A picture of the scan.

    Attributes
    ----------
    path : Path
    pan_index : int
    pan_angle : float
        Radians (``φ`` of the optical axis).
    """

    path: Path
    pan_index: int
    pan_angle: float


@dataclass(frozen=True, eq=False)
class Scan:
    """A scan as spherical samples, ready for registration (App. A.2, Eq. 19).

    Attributes
    ----------
    r : ndarray of shape (S, N), float64
        Range in metres; NaN where there was no return. One row per scanned
        slice, one column per encoder position.
    theta : ndarray of shape (S, N), float64
        Polar angle from the upward axis, radians (Eq. 19's θ; π/2 is
        horizontal).
    phi : ndarray of shape (S, N), float64
        Pan (azimuth) angle, radians, positive to the right.
    amplitude : ndarray of shape (S, N), uint8
        0 where there was no return.
    pan_index : ndarray of shape (S,), int64
    encoder : ndarray of shape (N,), int64
    images : tuple of CameraImage
    settings : ScanSettings
    complete : bool
        Whether every planned slice is there.
    focal : float
        The camera's focal length in pixels (300).
    """

    r: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    amplitude: np.ndarray
    pan_index: np.ndarray
    encoder: np.ndarray
    images: tuple[CameraImage, ...]
    settings: ScanSettings
    complete: bool
    focal: float = FOCAL_PX

    @property
    def theta_axis(self) -> np.ndarray:
        """(N,) polar angles of the encoder positions (the columns of ``r``)."""
        return polar_angle(self.encoder)

    @property
    def phi_axis(self) -> np.ndarray:
        """(S,) pan angles of the scanned slices (the rows of ``r``)."""
        return pan_angle(self.pan_index)

    @property
    def known_slices(self) -> np.ndarray:
        """Boolean (500,): ``True`` for the scanned pan indices."""
        known = np.zeros(PAN_SLICES, dtype=bool)
        known[self.pan_index] = True
        return known

    def range_image(self) -> np.ndarray:
        """The partial range as an (N, 500) image: rows are encoder positions (top = up),
        columns pan indices; NaN where not scanned or no return."""
        image = np.full((self.encoder.size, PAN_SLICES), np.nan)
        image[:, self.pan_index] = self.r.T
        return image

    def points(self) -> np.ndarray:
        """The returns as (M, 3) points in metres (x right, y up, z forward)."""
        valid = np.isfinite(self.r)
        r, theta, phi = self.r[valid], self.theta[valid], self.phi[valid]
        return np.stack([r * np.sin(theta) * np.sin(phi), r * np.cos(theta),
                         r * np.sin(theta) * np.cos(phi)], axis=-1)


def load_scan(folder: str | os.PathLike) -> Scan:
    """Load a scan folder written by :func:`run_scan`.

    A complete scan is read from ``scan.npz``; an incomplete one is
    assembled from its slice files (``complete=False``).

    Raises
    ------
    FileNotFoundError
        If the folder holds no ``manifest.json``.
    ValueError
        If the manifest or a file is invalid.

    Examples
    --------
    >>> scan = load_scan("my-scan")            # doctest: +SKIP
    >>> scan.r.shape, scan.range_image().shape  # doctest: +SKIP
    ((200, 243), (243, 500))
    """
    folder = Path(folder)
    manifest_path = folder / "manifest.json"
    if not manifest_path.is_file():
        raise FileNotFoundError(f"No scan in '{folder}': no manifest.json")
    try:
        manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        settings = ScanSettings.from_dict(manifest["settings"])
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(f"'{manifest_path}' is not a valid scan manifest: {error}") from None
    npz = folder / "scan.npz"
    if manifest.get("complete") and npz.is_file():
        with np.load(npz, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
        complete = True
    else:
        records = {}
        for path in sorted((folder / "slices").glob("pan-*.slice")):
            record = read_slice(path)
            records[record.pan_index] = record
        arrays = _assemble(records, list(records), settings)
        complete = False
    images = tuple(
        CameraImage(folder / entry["file"], int(entry["pan_index"]),
                    float(np.radians(entry["pan_angle_deg"])))
        for _, entry in sorted(manifest.get("images", {}).items(), key=lambda kv: int(kv[0]))
    )
    return Scan(r=arrays["r"], theta=arrays["theta"], phi=arrays["phi"],
                amplitude=arrays["amplitude"], pan_index=arrays["pan_index"],
                encoder=arrays["encoder"], images=images, settings=settings, complete=complete)
