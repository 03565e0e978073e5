"""A scan's folder on disk: slice files, ``manifest.json``, ``scan.npz`` (§4).

Scans that lose nothing: each validated slice is written at once
(temporary file, then ``os.replace``) to ``slices/pan-<index>.slice``, whose
bytes depend only on the data, and ``manifest.json`` is rewritten the same
way after every slice and picture. The slice files are the truth: a scan
interrupted at any point (even by SIGKILL) is resumed by re-reading and
checking them (:func:`existing_slices`) and acquiring only what is missing.
When the plan is complete the scan is assembled into ``scan.npz``
(:func:`write_npz`, whose bytes depend only on the arrays).

Output folder::

    manifest.json        settings, plan, devices, slices, pictures, sessions
    slices/pan-0250.slice
    images/pan-0025.png  the camera's pictures (every 18°)
    scan.npz             r, theta, phi, amplitude, pan_index, encoder

:func:`prepare_folder` opens the folder for a session: a new scan (its
manifest), or the one to resume, checked against the settings and source
asked for.

References
----------
Torres-Méndez & Dudek (2008), §4, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import io
import json
import os
import re
import zipfile
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from refsynth.acquisition.errors import ProtocolError
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
)
from refsynth.acquisition.rangefinder_protocol import (
    LINE_WIDTH,
    crc16,
    decode_samples,
    encode_samples,
)
from refsynth.acquisition.slice_plan import ScanSettings

__all__ = [
    "FORMAT",
    "SliceRecord",
    "slice_name",
    "slice_bytes",
    "read_slice",
    "existing_slices",
    "write_atomic",
    "write_json",
    "write_npz",
    "prepare_folder",
    "saved_manifest",
]

#: The manifest's format tag.
FORMAT = "refsynth-scan/1"
_SLICE_MAGIC = b"refsynth-slice 1\n"
_SLICE_NAME = re.compile(r"pan-(\d{4})\.slice")


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


def existing_slices(folder: Path, settings: ScanSettings) -> dict[int, SliceRecord]:
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


# ----------------------------------------------------------------------------- writing


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and ``os.replace``: all or nothing."""
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_bytes(data)
    os.replace(temporary, path)


def write_json(path: Path, value: dict) -> None:
    """:func:`write_atomic` of ``value`` as indented JSON with sorted keys."""
    write_atomic(path, (json.dumps(value, indent=1, sort_keys=True) + "\n").encode("utf-8"))


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
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
    write_atomic(path, buffer.getvalue())


# ----------------------------------------------------------------------------- the manifest


def prepare_folder(
    folder: Path, settings: ScanSettings | None, source: dict, resume: bool
) -> tuple[dict, ScanSettings]:
    """Open ``folder`` for a session of :func:`refsynth.acquisition.scan.run_scan`.

    Returns the manifest (read from the folder, or a new one) and the
    settings of its scan; creates ``slices/`` and ``images/``. Nothing else
    is written.

    Raises
    ------
    ValueError
        If the folder holds a scan and ``resume`` is false; if the scan to
        resume has a bad manifest, other settings, or another ``source``
        (``"simulated"``, ``"seed"``); if the folder is not empty and holds
        no scan.
    """
    manifest_path = folder / "manifest.json"
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
        manifest = _new_manifest(settings, source)
    (folder / "slices").mkdir(parents=True, exist_ok=True)
    (folder / "images").mkdir(parents=True, exist_ok=True)
    return manifest, settings


def _new_manifest(settings: ScanSettings, source: dict) -> dict:
    """The manifest of a new scan: what the scan is, before any slice."""
    return {
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


def saved_manifest(folder: str | os.PathLike) -> dict:
    """The manifest of the scan in ``folder``; ``{}`` if there is none or it is unreadable."""
    try:
        return json.loads((Path(folder) / "manifest.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
