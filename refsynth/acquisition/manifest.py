"""A scan's ``manifest.json``: what the scan is, and the check that it is one (§3.1.1, §4).

The manifest records the scan's settings (:class:`ScanSettings`), its slice
plan (:func:`refsynth.acquisition.slice_plan.plan_slices`), every saved slice
with the CRC of its file, every picture with its pan angle, the devices and
the sessions. :func:`new_manifest` is the manifest of a new scan;
:func:`read_manifest` reads one back and checks all of it before anything
trusts it (:func:`check_manifest`):

- the schema and every type and range (a pan index is an integer in
  ``0 … 499``; the keys of ``slices`` and ``images`` are such indices);
- the plan against the settings (:func:`check_plan`): the plan the settings
  give, exactly — for ``"distance"`` it contains the coarse pass and, when
  the coarse slices are at hand, is the plan their ranges give; for
  ``"active"`` the ``rounds`` (:func:`check_rounds`): the first pass, then
  rounds of the settings' sizes, disjoint, and the plan their union;
- every path: a slice is ``slices/pan-<i>.slice`` and a picture
  ``images/pan-<i>.png``, so nothing outside the scan folder is ever named;
- the pictures' pan angles and the geometry against the rig's
  (:mod:`refsynth.acquisition.geometry`).

A manifest that fails raises ``ValueError`` in one line naming the file.

References
----------
Torres-Méndez & Dudek (2008), §3.1.1 (Fig. 2: the strategy a manifest records)
and §4 (partial scans of 30 to 50 % of the range), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path

import numpy as np

from refsynth._checks import is_int, is_real
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
    camera_indices,
    image_name,
    pan_angle,
)
from refsynth.acquisition.scan_folder import slice_name
from refsynth.acquisition.slice_plan import (
    ScanSettings,
    active_first_pass,
    active_round_sizes,
    coarse_slices,
    plan_slices,
)

__all__ = [
    "FORMAT",
    "new_manifest",
    "check_plan",
    "check_rounds",
    "check_manifest",
    "read_manifest",
    "saved_manifest",
    "slice_entry_file",
    "image_entry_file",
]

#: The manifest's format tag.
FORMAT = "refsynth-scan/1"
#: A manifest is a few tens of kB; anything far larger is not one.
_MAX_BYTES = 16 * 2**20
_INDEX_KEY = re.compile(r"0|[1-9][0-9]{0,2}")
_CRC = re.compile(r"[0-9A-F]{4}")
_GEOMETRY = {"pan_slices": PAN_SLICES, "pan_step_deg": PAN_STEP_DEG, "pan_centre": PAN_CENTRE,
             "encoder_positions": ENCODER_POSITIONS, "encoder_step_deg": ENCODER_STEP_DEG}


def slice_entry_file(pan_index: int) -> str:
    """The ``file`` of a slice's manifest entry: ``slices/pan-0250.slice``."""
    return f"slices/{slice_name(pan_index)}"


def image_entry_file(pan_index: int) -> str:
    """The ``file`` of a picture's manifest entry: ``images/pan-0025.png``."""
    return f"images/{image_name(pan_index)}"


def new_manifest(settings: ScanSettings, source: dict) -> dict:
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
        **({"rounds": []} if settings.strategy == "active" else {}),
        "slices": {},
        "images": {},
        "devices": {},
        "sessions": [],
        "complete": False,
    }


# ----------------------------------------------------------------------------- pieces


def _show(value) -> str:
    """``value`` for a message, cut to 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _kind(value) -> str:
    return {dict: "an object", list: "an array", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(value), "a number")


def _real(value) -> float | None:
    """``value`` as a finite float, or None (also for a bool or an int too large for a float)."""
    if not is_real(value):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


def _need(value, kind: type, where: str):
    if not isinstance(value, kind):
        expected = {dict: "an object", list: "an array", str: "a string", bool: "a boolean"}
        raise ValueError(f"{where} must be {expected[kind]}, got {_kind(value)}")
    return value


def _count(value, where: str, minimum: int = 0) -> int:
    if not is_int(value) or value < minimum:
        raise ValueError(f"{where} must be an integer >= {minimum}, got {_show(value)}")
    return value


def _index_key(key: str, where: str) -> int:
    if not _INDEX_KEY.fullmatch(key) or int(key) >= PAN_SLICES:
        raise ValueError(f"{where} has the key {_show(key)}, not a pan index 0-{PAN_SLICES - 1}")
    return int(key)


def _indices(value, where: str) -> list[int]:
    """A strictly ascending list of pan indices."""
    _need(value, list, where)
    for item in value:
        if not is_int(item):
            raise ValueError(f"{where} holds {_show(item)}, not an integer pan index")
        if not 0 <= item < PAN_SLICES:
            raise ValueError(f"{where} holds {_show(item)}, outside 0-{PAN_SLICES - 1}")
    for before, after in zip(value, value[1:]):
        if after <= before:
            what = "the duplicate" if after == before else "a descending step at"
            raise ValueError(f"{where} is not strictly ascending ({what} {after})")
    return value


def check_plan(plan, coarse, settings: ScanSettings, profile: np.ndarray | None = None) -> None:
    """Check a manifest's ``plan`` and ``coarse`` against its settings (§3.1.1, Fig. 2).

    Parameters
    ----------
    plan, coarse : list of int or None
        As recorded; ``None`` before the plan is made.
    settings : ScanSettings
    profile : ndarray of shape (500,), optional
        ``"distance"``: the coarse pass's range profile
        (:func:`refsynth.acquisition.slice_plan.coarse_profile`), if every
        coarse slice is at hand; then the plan must be the one it gives.

    Raises
    ------
    ValueError
        If ``plan`` is not the plan of ``settings`` (shortened, reordered,
        with duplicates, non-integers or indices outside 0–499), or
        ``coarse`` is not the coarse pass of ``settings``.
    """
    distance = settings.strategy == "distance"
    if coarse is not None:
        if not distance:
            raise ValueError(f"coarse is set for the strategy {settings.strategy!r}")
        if _indices(coarse, "coarse") != coarse_slices(settings).tolist():
            raise ValueError(f"coarse is not every {settings.coarse_step}th slice from 0 "
                             "(the settings' coarse pass)")
    if plan is None:
        return
    _indices(plan, "plan")
    if settings.strategy == "active":
        return  # the union of the rounds: check_rounds
    if not distance:
        expected = plan_slices(settings).tolist()
    elif coarse is None:
        raise ValueError("plan is set but coarse is not")
    elif not set(coarse) <= set(plan):
        raise ValueError("plan lacks slices of the coarse pass")
    elif profile is not None:
        expected = plan_slices(settings, profile).tolist()
    else:
        return
    if plan != expected:
        if len(plan) != len(expected):
            detail = f"{len(plan)} slices where the settings give {len(expected)}"
        else:
            first = next(p for p, e in zip(plan, expected) if p != e)
            detail = f"pan {first} where the settings' plan differs"
        raise ValueError(f"plan is not the plan of the settings ({detail})")


def check_rounds(rounds, plan, settings: ScanSettings) -> None:
    """Check an ``"active"`` manifest's ``rounds`` (and its ``plan``) against its settings (§5).

    Parameters
    ----------
    rounds : list of list of int or None
        The slices each round added, ascending within a round: the first pass
        (:func:`refsynth.acquisition.slice_plan.active_first_pass`), then what
        each call of :func:`refsynth.acquisition.next_slices` chose.
    plan : list of int or None
        The plan: set once the last round is chosen, the union of the rounds.
    settings : ScanSettings

    Raises
    ------
    ValueError
        If ``rounds`` is given for another strategy, its first round is not
        the settings' first pass, a round's size is not the settings' (the
        last round may not go beyond them), two rounds share a slice, or a
        plan is set that is not the union of all the rounds.
    """
    if settings.strategy != "active":
        if rounds is not None:
            raise ValueError(f"rounds is set for the strategy {settings.strategy!r}")
        return
    rounds = [] if rounds is None else _need(rounds, list, "rounds")
    sizes = active_round_sizes(settings)
    if len(rounds) > len(sizes):
        raise ValueError(f"rounds has {len(rounds)} rounds where the settings give "
                         f"{len(sizes)}")
    seen: set[int] = set()
    for number, (found, size) in enumerate(zip(rounds, sizes)):
        found = _indices(found, f"rounds[{number}]")
        if number == 0 and found != active_first_pass(settings).tolist():
            raise ValueError("rounds[0] is not the settings' first pass")
        if len(found) != size:
            raise ValueError(f"rounds[{number}] has {len(found)} slices where the settings "
                             f"give {size}")
        again = seen & set(found)
        if again:
            raise ValueError(f"rounds[{number}] scans pan {min(again)} again")
        seen |= set(found)
    if plan is not None and (len(rounds) != len(sizes) or plan != sorted(seen)):
        raise ValueError("plan is not the union of the settings' rounds")


def _check_slices(slices) -> None:
    for key, entry in _need(slices, dict, "slices").items():
        index = _index_key(key, "slices")
        where = f"slices[{key!r}]"
        _need(entry, dict, where)
        if entry.get("file") != slice_entry_file(index):
            raise ValueError(f"{where}.file must be {slice_entry_file(index)!r}, got "
                             f"{_show(entry.get('file'))}")
        crc = entry.get("crc")
        if not isinstance(crc, str) or not _CRC.fullmatch(crc):
            raise ValueError(f"{where}.crc must be 4 upper-case hex digits, got {_show(crc)}")
        if "session" in entry:
            _count(entry["session"], f"{where}.session")


def _check_images(images) -> None:
    cameras = set(camera_indices().tolist())
    for key, entry in _need(images, dict, "images").items():
        index = _index_key(key, "images")
        where = f"images[{key!r}]"
        if index not in cameras:
            raise ValueError(f"{where}: no picture is taken at pan {index}")
        _need(entry, dict, where)
        if entry.get("file") != image_entry_file(index):
            raise ValueError(f"{where}.file must be {image_entry_file(index)!r}, got "
                             f"{_show(entry.get('file'))}")
        if entry.get("pan_index") != index or not is_int(entry.get("pan_index")):
            raise ValueError(f"{where}.pan_index must be {index}, got "
                             f"{_show(entry.get('pan_index'))}")
        angle = _real(entry.get("pan_angle_deg"))
        expected = float(np.degrees(pan_angle(index)))
        if angle is None or abs(angle - expected) > 1e-5:
            raise ValueError(f"{where}.pan_angle_deg must be {expected:g} (pan {index}), got "
                             f"{_show(entry.get('pan_angle_deg'))}")
        for name in ("after_slices", "session"):
            if name in entry:
                _count(entry[name], f"{where}.{name}")


def _check_context(manifest: dict) -> None:
    """The optional parts: source, devices, sessions, geometry, camera."""
    for name in ("source", "devices", "geometry", "camera"):
        _need(manifest.get(name, {}), dict, name)
    source = manifest.get("source", {})
    if "simulated" in source:
        _need(source["simulated"], bool, "source.simulated")
    if "seed" in source:
        _count(source["seed"], "source.seed")
    for name, value in _need(source.get("pose", {}), dict, "source.pose").items():
        if _real(value) is None:
            raise ValueError(f"source.pose.{name} must be a finite number, got {_show(value)}")
    for number, session in enumerate(_need(manifest.get("sessions", []), list, "sessions")):
        _need(session, dict, f"sessions[{number}]")
    geometry = manifest.get("geometry", {})
    for name, value in _GEOMETRY.items():
        if name in geometry and (not is_real(geometry[name]) or geometry[name] != value):
            raise ValueError(f"geometry.{name} must be {value} (the rig's), got "
                             f"{_show(geometry[name])}")
    camera = manifest.get("camera", {})
    focal = _real(camera.get("focal_px", FOCAL_PX))
    if focal is None or not 0 < focal < 1e6:
        raise ValueError("camera.focal_px must be a focal length in pixels, got "
                         f"{_show(camera.get('focal_px'))}")
    for name in ("width", "height"):
        if name in camera:
            _count(camera[name], f"camera.{name}", minimum=1)


def check_manifest(manifest) -> ScanSettings:
    """Check a parsed manifest (see the module's docstring); return its settings.

    Raises
    ------
    ValueError
        On the first thing wrong, saying what and where (``plan``,
        ``slices['12'].file``, …).
    """
    _need(manifest, dict, "the manifest")
    if manifest.get("format") != FORMAT:
        raise ValueError(f"format is {_show(manifest.get('format'))}, not {FORMAT!r}")
    missing = [key for key in ("settings", "plan", "slices", "images", "complete")
               if key not in manifest]
    if missing:
        raise ValueError(f"it lacks the key{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(missing)}")
    values = _need(manifest["settings"], dict, "settings")
    for key, value in values.items():
        if is_int(value) and abs(value) > 2**53:
            raise ValueError(f"settings.{key} is out of range, got {_show(value)}")
    try:
        settings = ScanSettings.from_dict(values)
    except (TypeError, ValueError) as error:
        raise ValueError(f"settings: {error}") from None
    check_plan(manifest["plan"], manifest.get("coarse"), settings)
    check_rounds(manifest.get("rounds"), manifest["plan"], settings)
    _check_slices(manifest["slices"])
    _check_images(manifest["images"])
    if _need(manifest["complete"], bool, "complete") and manifest["plan"] is None:
        raise ValueError("complete is true but there is no plan")
    _check_context(manifest)
    return settings


def read_manifest(path: str | os.PathLike) -> tuple[dict, ScanSettings]:
    """Read and check ``manifest.json`` (:func:`check_manifest`).

    Returns
    -------
    manifest : dict
    settings : ScanSettings

    Raises
    ------
    ValueError
        ``'<path>' is not a valid scan manifest: <what>``.
    FileNotFoundError
        If there is no such file.
    """
    path = Path(path)
    try:
        if path.stat().st_size > _MAX_BYTES:
            raise ValueError(f"{path.stat().st_size} bytes")
        text = path.read_bytes().decode("utf-8")
        try:
            manifest = json.loads(text)
        except json.JSONDecodeError as error:
            raise ValueError(f"not JSON ({error})") from None
        settings = check_manifest(manifest)
    except FileNotFoundError:
        raise
    except UnicodeDecodeError as error:
        raise ValueError(f"'{path}' is not a valid scan manifest: not UTF-8 text "
                         f"({error.reason} at byte {error.start})") from None
    except RecursionError:
        raise ValueError(f"'{path}' is not a valid scan manifest: JSON nested too "
                         "deeply") from None
    except (ValueError, OSError) as error:
        raise ValueError(f"'{path}' is not a valid scan manifest: {error}") from None
    return manifest, settings


def saved_manifest(folder: str | os.PathLike) -> dict:
    """The checked manifest of the scan in ``folder``; ``{}`` if it has no ``manifest.json``.

    Raises
    ------
    ValueError
        If it has one that is not valid (:func:`read_manifest`).
    """
    path = Path(folder) / "manifest.json"
    if not os.path.lexists(path):
        return {}
    return read_manifest(path)[0]
