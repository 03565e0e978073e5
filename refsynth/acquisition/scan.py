"""Running a scan, and resuming one: the order of events on the rig (§3.1.1, §4).

:func:`run_scan` acquires a slice plan (:mod:`refsynth.acquisition.slice_plan`)
with the two drivers: in ascending pan order, move (absolute), request the
slice, confirm the position, save the slice file at once, rewrite the
manifest (:mod:`refsynth.acquisition.scan_folder`); a picture is taken as the
pan passes its index. For the distance-driven strategy (Fig. 2) the coarse
pass comes first and the plan is made from its ranges; for the active
strategy (§5) a sparse first pass, then rounds chosen by
:func:`refsynth.acquisition.next_slices` on what was measured so far
(:mod:`refsynth.acquisition.active_scan`), each recorded in the manifest
before it is acquired. A failure beyond the
drivers' retries leaves the folder resumable: ``resume=True`` keeps every
valid slice on disk and acquires only the rest. The complete scan is
assembled into ``scan.npz`` (:mod:`refsynth.acquisition.assembly`).

What a resumed session trusts is :mod:`refsynth.acquisition.resume`: the
manifest is checked in full, every slice file against its own CRC and the
one the manifest recorded, every picture for being whole; what fails is set
aside into ``rejected/`` and acquired again, never deleted or overwritten.
A folder whose ``manifest.json`` is gone is resumed only with the scan's
settings given, its manifest rebuilt from the slice files.

References
----------
Torres-Méndez & Dudek (2008), §3.1.1 (Fig. 2: the distance-driven plan) and §4
(the acquisition: slices across 180°, a picture every 18°), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from refsynth.acquisition.active_scan import choose_round, read_pictures
from refsynth.acquisition.assembly import assemble
from refsynth.acquisition.errors import RigError
from refsynth.acquisition.geometry import PAN_SLICES, camera_indices, image_name, pan_angle
from refsynth.acquisition.manifest import image_entry_file, slice_entry_file
from refsynth.acquisition.pan_protocol import PAN_RESOLUTION
from refsynth.acquisition.pan_unit import PanUnit
from refsynth.acquisition.pose import RigPose
from refsynth.acquisition.rangefinder import Rangefinder
from refsynth.acquisition.resume import (
    finish_temporary,
    prepare_folder,
    trusted_images,
    trusted_slices,
)
from refsynth.acquisition.scan_folder import (
    SliceRecord,
    lock_folder,
    png_is_complete,
    read_regular,
    set_aside,
    slice_bytes,
    slice_crc,
    slice_name,
    write_json,
    write_new,
    write_npz,
)
from refsynth.acquisition.simulator import RigSimulator
from refsynth.acquisition.slice_plan import (
    ScanSettings,
    active_first_pass,
    active_round_sizes,
    coarse_profile,
    coarse_slices,
    plan_slices,
)

__all__ = ["ScanSummary", "run_scan", "simulate_scan"]


@dataclass
class ScanSummary:
    """What one :func:`run_scan` session did (the acquisition of §3.1.1, §4).

    Attributes
    ----------
    folder : Path
    planned : int
        Slices in the plan.
    acquired : int
        Slices acquired in this session.
    already : int
        Valid slices of the plan found on disk when the session started.
    images : int
        Pictures taken in this session.
    retries, faults, reconnects : int
        Summed over both devices (see :class:`refsynth.acquisition.link.DeviceStats`);
        ``faults`` counts every failure met and recovered from.
    seconds : float
    complete : bool
        Whether the plan is complete and ``scan.npz`` written.
    rejected : list of Path
        Files set aside into ``rejected/`` (invalid, or not what the
        manifest recorded) and acquired again.
    rebuilt : int
        The slice files a missing manifest was rebuilt from.

    Examples
    --------
    See :func:`run_scan` and :func:`simulate_scan`.
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
    rejected: list = field(default_factory=list)
    rebuilt: int = 0

    def __str__(self) -> str:
        notes = ""
        if self.rebuilt:
            notes += f"; manifest.json rebuilt from {self.rebuilt} slice files"
        if self.rejected:
            count = len(self.rejected)
            notes += (f"; {count} file{'s' if count != 1 else ''} not trusted, set aside in "
                      f"{self.folder / 'rejected'}")
        return (
            f"{self.acquired + self.already}/{self.planned} slices "
            f"({100 * self.planned / PAN_SLICES:.1f} % of {PAN_SLICES}; {self.acquired} acquired "
            f"now, {self.already} already on disk), {self.images} pictures; retries "
            f"{self.retries}, faults recovered {self.faults} ({self.reconnects} reconnects); "
            f"{self.seconds:.1f} s{notes}"
        )


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
        Continue the scan in ``folder``: check its manifest, keep every slice
        file that is valid and matches the CRC the manifest recorded, set
        aside into ``rejected/`` any other (and any damaged picture), and
        acquire the rest of the plan. Without it, a folder holding a scan
        (or slice files) is an error. With it, an empty folder starts a new
        scan, and a folder with slice files but no ``manifest.json`` is
        resumed only if ``settings`` are given and every slice belongs to
        them: the manifest is rebuilt from the slice files.
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
        On settings that disagree with the folder's scan, an invalid
        manifest, a folder that holds a scan without ``resume``, slice files
        without a manifest that cannot be resumed (see ``resume``), a
        ``manifest.json``, ``slices/``, ``images/`` or ``rejected/`` that is
        a symbolic link, a folder another scan holds locked, or a pan unit
        with another geometry. Nothing in the folder is changed then.
    RigError
        When a device fails beyond its retries (the folder stays
        resumable).

    Notes
    -----
    The session holds the folder's lock throughout
    (:func:`~refsynth.acquisition.scan_folder.lock_folder`). What a killed
    session left behind is dealt with first
    (:func:`~refsynth.acquisition.resume.finish_temporary`): a slice
    written but not yet in the manifest is checked and kept, a temporary
    file finished or removed, a symbolic link set aside, never followed.
    The order of events: initialise both devices; for ``"distance"``,
    acquire the coarse pass and plan from it; for ``"active"``, acquire the
    first pass (with every picture), then round after round: choose the
    round's slices from exactly the slices of the rounds before
    (:func:`~refsynth.acquisition.active_scan.choose_round`), record them in
    the manifest's ``rounds``, acquire them; a resumed scan acquires what its
    recorded rounds lack and chooses the next rounds the same way, so it ends
    with the slices of an uninterrupted scan. Then, in ascending pan order,
    for each missing slice: move (absolute), request the slice, confirm the
    pan position again, write ``slices/pan-<i>.slice``, rewrite the
    manifest; a picture is taken when the pan passes its index. A slice
    whose position cannot be confirmed after the request is acquired again.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from refsynth.acquisition import PanUnit, Rangefinder, RigSimulator, ScanSettings, run_scan
    >>> folder = Path(tempfile.mkdtemp())
    >>> with RigSimulator(seed=0) as rig:
    ...     with PanUnit(rig.pan_port) as pan, Rangefinder(rig.laser_port) as laser:
    ...         settings = ScanSettings("every", step=100, count=8, camera=False)
    ...         summary = run_scan(folder, pan, laser, settings)
    >>> print(summary)  # doctest: +ELLIPSIS
    5/5 slices (1.0 % of 500; 5 acquired now, 0 already on disk), 0 pictures; ...
    >>> sorted(path.name for path in folder.iterdir())
    ['images', 'manifest.json', 'scan.npz', 'slices']
    """
    started = time.perf_counter()
    folder = Path(folder)
    if settings is not None and not isinstance(settings, ScanSettings):
        raise TypeError(f"The parameter `settings` must be a ScanSettings, got {settings!r}")
    if settings is not None and settings.strategy == "active" and not camera_dir_is_local:
        raise ValueError("The strategy `active` needs the pictures in the scan folder "
                         "(`camera_dir_is_local=True`): its rounds are chosen from them")
    if os.path.lexists(folder) and not folder.is_dir():
        raise ValueError(f"'{folder}' is not a folder: a scan needs a folder of its own")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OSError(error.errno, f"cannot create the scan folder '{folder}': "
                      f"{error.strerror}") from None
    with lock_folder(folder):  # one session at a time
        return _session(folder, pan, laser, settings, resume=resume, source=dict(source or {}),
                        camera_dir_is_local=camera_dir_is_local, progress=progress,
                        started=started)


def _session(folder: Path, pan, laser, settings: ScanSettings | None, *, resume: bool,
             source: dict, camera_dir_is_local: bool, progress, started: float) -> ScanSummary:
    """:func:`run_scan` in ``folder``, whose lock this process holds."""
    manifest_path = folder / "manifest.json"

    # --- the folder: a new scan, or the one to resume ---------------------------------
    manifest, settings, rebuilt = prepare_folder(folder, settings, source, resume)

    # --- what is on disk, checked, is the truth --------------------------------------
    stale = finish_temporary(folder)
    decisions = trusted_slices(folder, manifest, settings)
    records = decisions.records
    if manifest["plan"] is None and settings.strategy not in ("distance", "active"):
        manifest["plan"] = plan_slices(settings).tolist()
    session = len(manifest["sessions"]) + 1
    entries = {}
    for index in records:
        entry = manifest["slices"].get(str(index)) or {
            "session": 0 if rebuilt else max(session - 1, 1)}
        entry.update(file=slice_entry_file(index), crc=decisions.crcs[index])
        entries[str(index)] = entry
    manifest["slices"] = entries
    damaged = trusted_images(folder, manifest, camera_dir_is_local, bool(rebuilt))
    summary = ScanSummary(folder=folder, rebuilt=rebuilt)
    summary.rejected = [set_aside(folder, path)
                        for path in stale + decisions.set_aside + damaged]
    on_disk = set(records)
    record_session = {"session": session, "resumed": session > 1 or bool(rebuilt),
                      "acquired": 0, "images": 0, "complete": False}
    if rebuilt:
        record_session["rebuilt_from"] = rebuilt
    if summary.rejected:
        record_session["rejected"] = [str(p.relative_to(folder)) for p in summary.rejected]
    manifest["sessions"].append(record_session)
    manifest["source"] = {**manifest.get("source", {}), **source}
    write_json(manifest_path, manifest)

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
        if camera_dir_is_local and not png_is_complete(folder / "images" / name):
            raise RigError("pan unit", "C", f"the camera wrote no whole picture images/{name}")
        manifest["images"][str(index)] = {
            "file": image_entry_file(index), "pan_index": index,
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
        path = folder / "slices" / slice_name(index)
        try:
            write_new(path, data)  # never over another file
        except FileExistsError:  # put there behind this session's back: keep it if it is
            if read_regular(path) != data:  # this very slice, else set it aside
                summary.rejected.append(set_aside(folder, path))
                write_new(path, data)
        records[index] = record
        manifest["slices"][str(index)] = {"file": slice_entry_file(index),
                                          "crc": slice_crc(data), "session": session}
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
            write_json(manifest_path, manifest)

    refused = []

    def check_plan_of_rebuilt(plan: list[int]) -> None:
        off = sorted(on_disk - set(plan))
        if rebuilt and off:  # the settings given are not the scan's: undo the new manifest
            refused.append(off)
            raise ValueError(
                f"cannot resume '{folder}' with these settings: {len(off)} of its slice files "
                f"(pan {', '.join(map(str, off[:5]))}) are not in their plan; give the "
                "settings the scan was taken with")

    def active_rounds() -> None:
        """The first pass, then the rounds (§5): each chosen from the rounds before it."""
        sizes = active_round_sizes(settings)
        rounds = manifest.setdefault("rounds", [])
        if not rounds:
            rounds.append(active_first_pass(settings).tolist())
            write_json(manifest_path, manifest)
        while True:
            so_far = sorted(set().union(*rounds))
            plan_so_far.clear()
            plan_so_far.update(so_far)
            summary.planned = sum(sizes)
            run(np.asarray(so_far), sum(sizes), PAN_SLICES - 1)  # the pictures come first
            if len(rounds) == len(sizes):
                break
            chosen = choose_round({i: records[i] for i in so_far}, read_pictures(folder),
                                  settings, sizes[len(rounds)])
            rounds.append(chosen)
            record_session["rounds_chosen"] = record_session.get("rounds_chosen", 0) + 1
            write_json(manifest_path, manifest)
        manifest["plan"] = so_far

    plan_so_far: set[int] = set()
    try:
        if settings.strategy == "active" and manifest["plan"] is None:
            if not camera_dir_is_local:
                raise ValueError("The strategy `active` needs the pictures in the scan folder "
                                 "(`camera_dir_is_local=True`): its rounds are chosen from them")
            active_rounds()
            write_json(manifest_path, manifest)
        if settings.strategy == "distance" and manifest["plan"] is None:
            coarse = coarse_slices(settings)
            plan_so_far.update(int(i) for i in coarse)
            summary.already = len(on_disk & plan_so_far)
            manifest["coarse"] = coarse.tolist()
            run(coarse, len(coarse), int(coarse.max()))
            profile = coarse_profile({int(i): records[int(i)].range_mm for i in coarse}, coarse)
            manifest["plan"] = plan_slices(settings, profile).tolist()
            write_json(manifest_path, manifest)
        plan = np.asarray(manifest["plan"], dtype=np.int64)
        check_plan_of_rebuilt(manifest["plan"])
        plan_so_far.clear()
        plan_so_far.update(plan.tolist())
        summary.planned = len(plan)
        summary.already = len(on_disk & plan_so_far)
        run(plan, len(plan), PAN_SLICES - 1)
        missing = [i for i in plan.tolist() if i not in records]
        if missing:  # cannot happen unless a slice file vanished under us
            raise RigError("scan", "check", f"{len(missing)} planned slices missing")
        # the assembled scan, ready for registration (App. A.2)
        write_npz(folder / "scan.npz", assemble(records, plan, settings))
        manifest["complete"] = record_session["complete"] = summary.complete = True
    finally:
        summary.planned = summary.planned or len(manifest["plan"] or [])
        account()
        if refused:
            manifest_path.unlink()  # this session wrote it, from nothing
        else:
            write_json(manifest_path, manifest)
    return summary


def simulate_scan(
    folder: str | os.PathLike,
    settings: ScanSettings | None = None,
    *,
    seed: int = 0,
    faults=None,
    pose: RigPose | None = None,
    resume: bool = False,
    progress: Callable[[int, int, int], None] | None = None,
) -> ScanSummary:
    """Acquire a scan into ``folder`` on the simulated rig (§3.1.1, §4).

    :func:`run_scan` with both drivers at their defaults on a
    :class:`~refsynth.acquisition.simulator.RigSimulator` whose camera writes
    into ``folder/images``; the manifest records the source as
    ``{"simulated": True, "seed": seed, "faults": str(faults)}`` (and
    ``"pose"`` when one is given).

    Parameters
    ----------
    folder : str or Path
        The output folder (see :func:`run_scan`).
    settings : ScanSettings, optional
        See :func:`run_scan`.
    seed : int, default 0
        The simulated room and its noise (see
        :class:`~refsynth.acquisition.simulator.RigSimulator`).
    faults : Faults or str, optional
        What goes wrong on the wire (default none).
    pose : RigPose, optional
        Where the rig stands (default the room's centre, facing z).
    resume, progress
        See :func:`run_scan`.

    Returns
    -------
    ScanSummary

    Examples
    --------
    >>> import tempfile
    >>> summary = simulate_scan(tempfile.mkdtemp(), ScanSettings("every", step=100, count=8))
    >>> summary.planned, summary.acquired, summary.images, summary.complete
    (5, 5, 10, True)
    """
    with RigSimulator(seed=seed, faults=faults, camera_dir=Path(folder) / "images",
                      pose=pose) as rig, \
            PanUnit(rig.pan_port) as pan, Rangefinder(rig.laser_port) as laser:
        source = {"simulated": True, "seed": rig.seed, "faults": str(rig.faults)}
        if pose is not None:
            source["pose"] = pose.as_dict()
        return run_scan(folder, pan, laser, settings, resume=resume, source=source,
                        progress=progress)
