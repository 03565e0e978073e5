"""Opening a scan folder for a session: what a new or resumed scan trusts on disk (§4).

A scan is resumed from its folder, and nothing in the folder is trusted
until it is checked; nothing the session cannot trust is deleted or
overwritten (it is set aside into ``rejected/``,
:func:`refsynth.acquisition.scan_folder.set_aside`):

- :func:`prepare_folder`: a new scan, or the one to resume, with its
  manifest checked in full (:func:`refsynth.acquisition.manifest.read_manifest`)
  and against the settings and source asked for. A folder that holds slice
  files but no ``manifest.json`` is resumed only with the scan's settings
  given: its manifest is then rebuilt from the slice files, whose headers
  hold their pan index and GS window (but not the sampling strategy); every
  slice must belong to those settings, else nothing is touched.
- :func:`trusted_slices`: the slice files a session keeps. A slice is kept
  if its file is valid on its own (header, CRC, the bytes a slice file of its
  data has), is the slice its name says, matches the CRC the manifest
  recorded for it, and was taken with the scan's GS window; one that fails
  is set aside and acquired again. A slice the manifest vouches for (its
  CRC matches) but that does not fit the settings means the manifest
  contradicts itself: the resume is refused.
- :func:`trusted_images`: the pictures kept; a missing or damaged one
  (not a whole PNG) is taken again.

References
----------
Torres-Méndez & Dudek (2008), §4 (a complete scan of 500 slices takes about 20
minutes: a session cut short is worth resuming, not repeating), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from refsynth.acquisition.geometry import camera_indices, image_name, pan_angle
from refsynth.acquisition.manifest import (
    check_plan,
    image_entry_file,
    new_manifest,
    read_manifest,
)
from refsynth.acquisition.scan_folder import (
    LOCK_NAME,
    SliceRecord,
    check_subfolder,
    odd_slice_entries,
    parse_slice,
    png_is_complete,
    read_regular,
    slice_bytes,
    slice_crc,
    slice_files,
    slice_name,
    temporary_target,
)
from refsynth.acquisition.slice_plan import ScanSettings, coarse_profile, plan_slices

__all__ = ["SliceDecisions", "prepare_folder", "read_slice_files", "resumed_manifest",
           "slice_window", "finish_temporary", "trusted_slices", "trusted_images"]

#: Entries a folder without a manifest may hold when its scan is rebuilt.
_REBUILD_ENTRIES = ("slices", "images", "scan.npz", "rejected", LOCK_NAME)


def _window(thing) -> tuple[int, int, int]:
    return thing.seq, thing.count, thing.average


def _describe(window: tuple[int, int, int]) -> str:
    return "seq {}, count {}, average {}".format(*window)


def read_slice_files(folder: Path) -> tuple[dict[int, tuple[SliceRecord, bytes]], list[Path]]:
    """Every slice file of ``folder`` that is valid on its own, and the others.

    Returns
    -------
    valid : dict of int to (SliceRecord, bytes)
        By pan index: files that parse, are the bytes :func:`slice_bytes`
        gives for their data, and whose header names the pan index of the
        file name.
    invalid : list of Path
        The rest of the ``slices/pan-<i>.slice`` files.
    """
    valid, invalid = {}, []
    for index, path in slice_files(folder).items():
        data = read_regular(path)
        if data is None:  # replaced by a link since it was listed
            invalid.append(path)
            continue
        try:
            record = parse_slice(data, path)
        except ValueError:
            invalid.append(path)
            continue
        if record.pan_index != index or slice_bytes(record) != data:
            invalid.append(path)
            continue
        valid[index] = (record, data)
    return valid, invalid


def slice_window(folder: str | os.PathLike) -> dict | None:
    """The GS window (``seq``, ``count``, ``average``) all valid slice files of ``folder``
    share, or None if there are none or they differ."""
    valid, _ = read_slice_files(Path(folder))
    windows = {_window(record) for record, _ in valid.values()}
    if len(windows) != 1:
        return None
    return dict(zip(("seq", "count", "average"), windows.pop()))


def _unexpected(folder: Path, allowed: tuple[str, ...]) -> list[str]:
    """Entries of ``folder`` other than ``allowed`` and cut-short temporary files."""
    if not folder.exists():
        return []
    return sorted(p.name for p in folder.iterdir() if p.name not in allowed
                  and not (p.name.startswith(".") and p.name.endswith(".tmp")))


def _has_files(directory: Path) -> bool:
    return directory.is_dir() and any(not (p.name.startswith(".") and p.name.endswith(".tmp"))
                                      for p in directory.iterdir())


def _check_rebuild(folder: Path, settings: ScanSettings | None) -> int:
    """Whether the slice files of ``folder`` (no manifest) can be resumed with ``settings``.

    Returns the number of valid slice files; raises ValueError (touching
    nothing) if they cannot.
    """
    valid, _ = read_slice_files(folder)
    indices = sorted(valid)
    windows = sorted({_window(record) for record, _ in valid.values()})
    found = (f"its {len(indices)} valid slice files (pan {indices[0]}-{indices[-1]}; "
             f"{' or '.join(map(_describe, windows))})" if indices else "its slice files")
    if settings is None:
        raise ValueError(
            f"cannot resume '{folder}': it has no manifest.json, and {found} do not record "
            "which slices the scan planned; give the scan's settings (--strategy, --fraction "
            "or --step, --stripe-width, --average) with --resume to rebuild manifest.json "
            "from them")
    other = [w for w in windows if w != _window(settings)]
    if other:
        raise ValueError(
            f"cannot resume '{folder}' with these settings: {found} were not taken with "
            f"{_describe(_window(settings))}")
    if settings.strategy not in ("distance", "active"):  # their plan is made while scanning
        off = sorted(set(indices) - set(plan_slices(settings).tolist()))
        if off:
            shown = ", ".join(map(str, off[:5])) + (", ..." if len(off) > 5 else "")
            raise ValueError(
                f"cannot resume '{folder}' with these settings: {len(off)} of {found} are not "
                f"in their plan (pan {shown}); give the settings the scan was taken with")
    unexpected = _unexpected(folder, _REBUILD_ENTRIES)
    if unexpected:
        raise ValueError(f"cannot resume '{folder}': it has no manifest.json and holds "
                         f"{', '.join(unexpected[:3])}, which a scan does not write")
    return len(valid)


def resumed_manifest(folder: str | os.PathLike) -> tuple[dict, ScanSettings | None]:
    """The checked manifest of the scan to resume in ``folder`` and its settings;
    ``({}, None)`` if the folder has no ``manifest.json``.

    Raises
    ------
    ValueError
        ``cannot resume: '<folder>/manifest.json' is not a valid scan
        manifest: <what> (...)`` if it is not valid.
    """
    path = Path(folder) / "manifest.json"
    if not os.path.lexists(path):
        return {}, None
    if path.is_symlink():
        raise ValueError(f"cannot resume: '{path}' is a symbolic link, not a scan's manifest "
                         "(move it away and resume with the scan's settings to rebuild it from "
                         "the slice files)")
    try:
        return read_manifest(path)
    except ValueError as error:
        raise ValueError(f"cannot resume: {error} (move it away and resume with the scan's "
                         "settings to rebuild it from the slice files)") from None


def prepare_folder(
    folder: Path, settings: ScanSettings | None, source: dict, resume: bool
) -> tuple[dict, ScanSettings, int]:
    """Open ``folder`` for a session of :func:`refsynth.acquisition.scan.run_scan`.

    Returns
    -------
    manifest : dict
        Read from the folder and checked, or a new one.
    settings : ScanSettings
        The settings of its scan.
    rebuilt : int
        The number of slice files a missing manifest is rebuilt from (0
        when the folder has a manifest or holds no slice).

    Creates ``slices/`` and ``images/``; nothing else is written or moved.

    Raises
    ------
    ValueError
        If the folder holds a scan and ``resume`` is false; if the scan to
        resume has an invalid manifest, other settings, or another
        ``source`` (``"simulated"``, ``"seed"``); if it has slice files but
        no manifest and ``resume`` is false, no settings are given, or the
        slices do not belong to them; if the folder holds anything else.
    """
    manifest_path = folder / "manifest.json"
    rebuilt = 0
    for name in ("slices", "images", "rejected"):
        check_subfolder(folder, name)
    if os.path.lexists(manifest_path):
        if not resume:
            raise ValueError(f"'{folder}' already holds a scan: resume it (--resume) or choose "
                             "another folder")
        manifest, saved = resumed_manifest(folder)
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
    elif resume and slice_files(folder):
        rebuilt = _check_rebuild(folder, settings)
        manifest = new_manifest(settings, source)
    else:
        if slice_files(folder):
            raise ValueError(f"'{folder}' holds slice files but no manifest.json: resume it "
                             "(--resume, with the scan's settings) or choose another folder")
        settings = ScanSettings() if settings is None else settings
        if (_unexpected(folder, ("slices", "images", LOCK_NAME)) or _has_files(folder / "slices")
                or _has_files(folder / "images")):
            raise ValueError(f"'{folder}' is not empty and holds no scan (no manifest.json)")
        manifest = new_manifest(settings, source)
    (folder / "slices").mkdir(parents=True, exist_ok=True)
    (folder / "images").mkdir(parents=True, exist_ok=True)
    return manifest, settings, rebuilt


#: The files refsynth writes, by subfolder of a scan folder: a temporary file for one of them
#: (:func:`~refsynth.acquisition.scan_folder.temporary_target`) is a write a kill cut short.
_WRITTEN = {"": re.compile(r"manifest\.json|scan\.npz"), "slices": re.compile(r"pan-\d{4}\.slice"),
            "images": re.compile(r"pan-\d{4}\.png")}


def finish_temporary(folder: Path) -> list[Path]:
    """Deal with the temporary files of writes a kill cut short, writing through none of them.

    Every entry of ``folder``, ``slices/`` and ``images/`` named like a
    temporary file of a file a scan writes (``.<name>.<random>.tmp``, or
    ``.<name>.tmp``; ``<name>`` being ``manifest.json``, ``scan.npz``, a
    slice or a picture):

    - a symbolic link, or anything but a regular file, is never read nor
      followed: it is returned, to be set aside;
    - in ``slices/``, a whole slice file of the pan index its name says
      (killed between its write and its link into place) is linked into
      place if nothing is there, so it is checked like any other slice;
      removed if the same bytes are in place; returned, to be set aside, if
      other bytes are (or it is a whole slice of another pan index);
    - any other (a write cut short, never a complete file; or a manifest,
      ``scan.npz`` or picture the session writes again) is removed.

    Returns
    -------
    list of Path
        The entries to set aside (:func:`~refsynth.acquisition.scan_folder.set_aside`).
    """
    odd = []
    for sub, names in _WRITTEN.items():
        directory = folder / sub if sub else folder
        if directory.is_symlink() or not directory.is_dir():
            continue
        for path in sorted(directory.iterdir()):
            target = temporary_target(path.name)
            if target is None or not names.fullmatch(target):
                continue  # not a file of ours
            data = read_regular(path)
            if data is None:
                odd.append(path)
                continue
            index = _whole_slice(data, path) if sub == "slices" else None
            if index is not None:
                final = directory / target
                if index == int(target[4:8]) and not os.path.lexists(final):
                    os.link(path, final, follow_symlinks=False)
                elif index != int(target[4:8]) or read_regular(final) != data:
                    odd.append(path)  # a whole slice, not the one in place: kept
                    continue
            path.unlink()
    return odd


def _whole_slice(data: bytes, path: Path) -> int | None:
    """The pan index of ``data`` if it is a whole slice file, else None."""
    try:
        record = parse_slice(data, path)
    except ValueError:
        return None
    return record.pan_index if slice_bytes(record) == data else None


@dataclass
class SliceDecisions:
    """What :func:`trusted_slices` decided; nothing is moved until the caller does.

    Attributes
    ----------
    records : dict of int to SliceRecord
        The slices kept, by pan index.
    crcs : dict of int to str
        Their CRCs (:func:`~refsynth.acquisition.scan_folder.slice_crc`).
    set_aside : list of Path
        The files to set aside (and acquire again).
    """

    records: dict
    crcs: dict
    set_aside: list


def trusted_slices(folder: Path, manifest: dict, settings: ScanSettings) -> SliceDecisions:
    """Decide which slice files of ``folder`` a session keeps (see the module's docstring).

    For ``"distance"`` with a plan, when every coarse slice is kept, the plan
    is checked against the one their ranges give.

    Raises
    ------
    ValueError
        If the manifest vouches for a slice (its CRC matches) that does not
        fit the settings, or its distance plan is not the coarse pass's.
    """
    valid, invalid = read_slice_files(folder)
    entries = manifest["slices"]
    decisions = SliceDecisions({}, {}, [*invalid, *odd_slice_entries(folder)])
    for index, (record, data) in valid.items():
        entry = entries.get(str(index))
        crc = slice_crc(data)
        path = folder / "slices" / slice_name(index)
        if entry is not None and entry["crc"] != crc:
            decisions.set_aside.append(path)  # not the file the scan saved
            continue
        if _window(record) != _window(settings):
            if entry is not None:
                raise ValueError(
                    f"cannot resume '{folder}': manifest.json records {entry['file']} (CRC "
                    f"{crc}), taken with {_describe(_window(record))}, but its settings say "
                    f"{_describe(_window(settings))}")
            decisions.set_aside.append(path)
            continue
        decisions.records[index] = record
        decisions.crcs[index] = crc
    decisions.set_aside.sort()
    coarse, plan = manifest.get("coarse"), manifest["plan"]
    if settings.strategy == "distance" and plan is not None and all(
        i in decisions.records for i in coarse
    ):
        profile = coarse_profile({i: decisions.records[i].range_mm for i in coarse}, coarse)
        try:
            check_plan(plan, coarse, settings, profile)
        except ValueError as error:
            raise ValueError(f"cannot resume '{folder}': manifest.json: {error}") from None
    return decisions


def trusted_images(folder: Path, manifest: dict, camera_dir_is_local: bool,
                   rebuilt: bool) -> list[Path]:
    """Keep the pictures of ``manifest["images"]`` that are whole; return those to set aside.

    With ``camera_dir_is_local`` (the camera writes into ``folder/images``),
    an entry whose file is missing or not a whole PNG is dropped (the
    picture is taken again) and a damaged file is to be set aside; with
    ``rebuilt``, the whole pictures already in ``images/`` get entries.
    Without it the pictures are elsewhere and every entry is kept.
    """
    if not camera_dir_is_local:
        return []
    damaged, kept = [], {}
    images = manifest["images"]
    if rebuilt:
        images = {str(i): {"file": image_entry_file(i), "pan_index": i,
                           "pan_angle_deg": round(float(np.degrees(pan_angle(i))), 6),
                           "session": 0}
                  for i in map(int, camera_indices())
                  if (folder / "images" / image_name(i)).exists()}
    for key, entry in images.items():
        path = folder / entry["file"]
        if path.is_symlink():  # never read through: set aside, taken again
            damaged.append(path)
            continue
        if not path.is_file():
            continue
        if not png_is_complete(path):
            damaged.append(path)
            continue
        kept[key] = entry
    manifest["images"] = kept
    return damaged
