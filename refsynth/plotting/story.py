r"""The paper's story end to end: two scan positions → registration → NP and BP → one 3-D model.

:func:`run_pipeline_demo` is what ``python -m refsynth demo`` runs (its
default; :mod:`refsynth.cli.demo` prints the results). The three stages of
the paper (§1), on the simulated rig's room:

1. **Acquisition and registration** (§3.1, §4, Appendix A). The simulated
   rig (:func:`~refsynth.acquisition.simulate_scan`: the
   :class:`~refsynth.acquisition.RigSimulator` on pseudo-terminals, driven
   by the real drivers) scans the room from each pose of
   :data:`DEMO_POSES` — 40 % of the 500 slices in stripes, a picture every
   18° — into ``scan/`` and ``scan-2/``. The pictures and the partial scan
   are registered (:func:`refsynth.registration.register_scan`: the
   cylindrical mosaic, Eqs. 14–18; the scan on the cylinder, Eq. 19; the
   warp, Eq. 21).
2. **Depth inference** (§3.2). To fit the demo's two minutes, every second
   row and column of the registered panorama is kept (``shrink = 2``:
   228 × 961 → 114 × 481 pixels; the camera's steps double with it). NP
   (§3.2.1, §3.2.2) and BP (§3.2.3) fill the missing range, and the
   nearest-neighbour and colorization fills run beside them; each is
   scored by MAR (Eq. 13) against the simulator's ground truth, the ray
   caster's range along each pixel's ray from the true pose
   (:func:`refsynth.plotting.story_truth.true_range`).
3. **The model** (§1's stage 3, :mod:`refsynth.model`). Each position's
   dense range becomes a model (:func:`~refsynth.model.build_model`, the
   camera of the registration's warp,
   :meth:`~refsynth.model.CylindricalCamera.from_warp`); the positions'
   odometry is made wrong by 10 cm (in a direction drawn from the seed)
   and 2° (:data:`ODOMETRY_ERROR`), refined by point-to-plane ICP on the
   measured points (:func:`~refsynth.model.refine_poses`; the synthesized
   ones carry stage 2's errors) and the models merged
   (:func:`~refsynth.model.merge_models`) into ``room.ply``, drawn
   obliquely from behind the scan positions, coloured by intensity and by
   confidence (:func:`refsynth.plotting.model_view.model_view_figure`), the
   positions marked. What no position saw has no triangles and shows blank,
   as the figure's caption says: in seed 0's room, the floor and the wall
   behind the boxes, whose tops are just below the scanners' height.

Along the way the targets of stage 3 are measured against the truth
(:mod:`refsynth.plotting.story_truth`): the model's points' distance to the
true surface, measured and NP- and BP-synthesized apart; triangles that
bridge a true depth discontinuity; the refined poses' alignment error.

Files written into ``out`` (:data:`STORY_FILES`, the scan folders apart):
``scan/``, ``scan-2/`` (the rig's scans; reused when already there, for
the same seed and pose), ``position-1.ply``, ``position-2.ply`` (each
position's model in its scanner's frame), ``odometry.json`` and
``poses.json`` (the noisy and the refined poses, in the format of
``python -m refsynth model --poses``), ``room.ply`` (the merged model,
byte for byte what ``python -m refsynth model --merge position-1.ply
position-2.ply --poses poses.json --out room.ply`` writes),
``model_view.png``, ``pipeline_np.png``, ``pipeline_bp.png`` (the paper's
layout, position 1) and ``story.json`` (the table and the targets).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §1, §3.1, §3.2, §4, Eq. 13 and
Appendix A, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from refsynth._files import write_atomic
from refsynth.acquisition import RigPose, ScanSettings, load_scan, simulate_scan
from refsynth.acquisition.manifest import saved_manifest
from refsynth.evaluation.baselines import BASELINES
from refsynth.evaluation.metrics import evaluate
from refsynth.io import read_array
from refsynth.model import (
    CylindricalCamera,
    Pose,
    alignment_error,
    build_model,
    merge_models,
    read_ply,
    refine_poses,
    write_ply,
)
from refsynth.plotting.layouts import result_figure, save_figure
from refsynth.plotting.model_view import model_view_figure, oblique_eye
from refsynth.plotting.story_truth import point_errors, triangle_checks, true_range
from refsynth.registration import register_scan
from refsynth.scenes import room_geometry
from refsynth.scenes.portable import portable_cos, portable_sin
from refsynth.synthesis.api import synthesize

__all__ = ["DEMO_POSES", "ODOMETRY_ERROR", "STORY_FILES", "STORY_BASELINES", "StoryProgress",
           "run_pipeline_demo"]

#: The rig's two scan positions: the room's centre facing z, and 1 m to the right, 0.8 m
#: forward, turned 20° to the left (the convention of :class:`refsynth.model.Pose`).
DEMO_POSES = (RigPose(), RigPose(x=1.0, z=0.8, heading=math.radians(-20.0)))
#: Odometry's error: (heading in radians, distance in metres): 2° and 10 cm.
ODOMETRY_ERROR = (math.radians(2.0), 0.10)
#: The baselines beside NP and BP in the table.
STORY_BASELINES = ("nearest", "colorization")
#: The files :func:`run_pipeline_demo` writes besides the scan folders, in order.
STORY_FILES = ("position-1.ply", "position-2.ply", "odometry.json", "poses.json", "room.ply",
               "model_view.png", "pipeline_np.png", "pipeline_bp.png", "story.json")
#: The focal length of the rig's camera, pixels (App. A.2), the cylinder's radius.
_FOCAL = 300.0
#: The model's view: cut above this height over the scanner (the ceiling hides the room).
_CLIP_ABOVE = 0.3
#: The model's view: from behind the scan positions (azimuth 0), 30° up, at the model's
#: diagonal (:func:`~refsynth.plotting.model_view.oblique_eye`): the scan positions in
#: front, the boxes and the far wall behind them.
_VIEW = (0.0, math.radians(30.0), 1.0)
#: What a blank region inside the model view is (the figure's caption).
_VIEW_NOTE = ("Blank inside the room: surfaces that neither scan position (▼) saw, such as "
              f"the floor and wall behind the boxes. The model is cut {_CLIP_ABOVE:g} m above "
              "the scanners to show the inside.")

#: ``progress(stage, fraction)``: called as each stage starts and during each fill, with
#: the stage's label and the fraction (0 … 1) of the demo's expected work done.
StoryProgress = Callable[[str, float], None]

#: Expected seconds of each stage on two cores (weights of the progress fraction).
_COST = {"scan": 3.0, "register": 4.0, "np": 8.0, "bp": 10.0, "baselines": 1.0,
         "model": 3.0, "figures": 6.0}


@dataclass
class _Work:
    """The progress fraction: stages weighted by their expected cost."""

    total: float
    report: StoryProgress | None
    done: float = 0.0
    seconds: dict = field(default_factory=dict)
    _stage: tuple = ("", 0.0, 0.0)

    def start(self, label: str, cost: float) -> None:
        self.finish()
        self._stage = (label, cost, time.perf_counter())
        if self.report is not None:
            self.report(label, min(self.done / self.total, 1.0))

    def within(self, done: int, total: int) -> None:
        label, cost, _ = self._stage
        if self.report is not None and total:
            self.report(label, min((self.done + cost * done / total) / self.total, 1.0))

    def finish(self) -> None:
        label, cost, started = self._stage
        if label:
            self.seconds[label] = time.perf_counter() - started
            self.done += cost
        self._stage = ("", 0.0, 0.0)


@dataclass
class ScanPosition:
    """One scan position through the stages."""

    number: int
    pose: RigPose
    folder: Path
    intensity: np.ndarray = None
    partial: np.ndarray = None
    truth: np.ndarray = None
    camera: CylindricalCamera = None
    registration: object = None
    results: dict = field(default_factory=dict)

    @property
    def model_pose(self) -> Pose:
        return Pose(x=self.pose.x, z=self.pose.z, heading=self.pose.heading)

    @property
    def known(self) -> np.ndarray:
        return np.isfinite(self.partial)


# ----------------------------------------------------------------------------- stage 1


def acquire_position(folder: Path, seed: int, pose: RigPose, settings: ScanSettings) -> None:
    """Scan from ``pose`` into ``folder`` with ``settings``, or keep the scan there if it is
    this one."""
    manifest = saved_manifest(folder)  # {} without a manifest.json
    if manifest:
        recorded = manifest.get("source", {})
        if ((recorded.get("seed"), recorded.get("pose", RigPose().as_dict())) != (seed,
                                                                                pose.as_dict())
                or ScanSettings.from_dict(manifest["settings"]) != settings):
            raise ValueError(f"{folder} holds another scan (seed {recorded.get('seed')}, pose "
                             f"{recorded.get('pose')}, or other settings): choose another --out")
        if (folder / "scan.npz").is_file():
            return
    # the source recorded: {"simulated": True, "seed": seed, "faults": "none", "pose": ...}
    simulate_scan(folder, settings, seed=seed, pose=pose, resume=True)


def register_position(position: ScanPosition, shrink: int) -> None:
    """Appendix A, then every ``shrink``-th row and column with the camera to match."""
    scan = load_scan(position.folder)
    images = [read_array(picture.path) for picture in scan.images]
    angles = [picture.pan_angle for picture in scan.images]
    intensity, partial, info = register_scan(images, angles, _FOCAL,
                                             (scan.r, scan.theta, scan.phi),
                                             slice_step=scan.slice_step)
    camera = CylindricalCamera.from_warp(info.warp, _FOCAL, origin=(info.crop[0], info.crop[2]))
    position.registration = info
    position.intensity = intensity[::shrink, ::shrink]
    position.partial = partial[::shrink, ::shrink]
    position.camera = CylindricalCamera(camera.focal, cx=camera.cx / shrink,
                                        cy=camera.cy / shrink, phi_step=camera.phi_step * shrink,
                                        h_step=camera.h_step * shrink)


# ----------------------------------------------------------------------------- stage 2


def _fill(position: ScanPosition, methods, baselines, seed: int, work: _Work) -> list[dict]:
    """NP / BP and the baselines on one position; the table's rows (MAR against the truth)."""
    rows = []
    known, truth = position.known, position.truth
    for method in [*methods, *baselines]:
        label = f"position {position.number}: {method.upper() if method in methods else method}"
        work.start(label, _COST.get(method, _COST["baselines"] / max(len(baselines), 1)))
        start = time.perf_counter()
        if method in methods:
            result = synthesize(position.intensity, position.partial, method=method, seed=seed,
                                progress=work.within)
            position.results[method] = result
            estimate = result.range
        else:
            estimate = BASELINES[method](position.intensity, position.partial)
        seconds = time.perf_counter() - start
        unknown = ~known & np.isfinite(truth)
        relative = np.abs(estimate - truth)[unknown] / truth[unknown]
        rows.append(dict(position=position.number, method=method.upper() if method in methods
                         else method, unknown=100 * float(np.mean(~known)), seconds=seconds,
                         median_percent=100 * float(np.median(relative)),
                         **evaluate(estimate, truth, known)))
    return rows


# ----------------------------------------------------------------------------- stage 3


def _models(position: ScanPosition) -> dict:
    return {method: build_model(result.range, position.camera, intensity=position.intensity,
                                confidence=result.confidence, measured=position.known)
            for method, result in position.results.items()}


def _position_targets(position: ScanPosition, models: dict, room) -> dict:
    """Points off the true surface and bridging triangles, for one position (story_truth)."""
    pose = position.model_pose
    points, triangles = {}, {}
    for method, model in models.items():
        errors = point_errors(model, position.truth)
        checks = triangle_checks(model, position.truth, room, pose)
        measured, synthesized = checks["measured"], ~checks["measured"]
        if not points:  # the measured points and triangles are the same in every model
            points["measured"] = 100 * float(np.median(errors[~model.synthesized]))
            triangles["measured"] = {
                "triangles": int(measured.sum()),
                "bridging": int(np.sum(checks["bridging"] & measured)),
                "silhouette": int(np.sum(checks["crossing"] & ~checks["bridging"] & measured))}
        points[method.upper()] = 100 * float(np.median(errors[model.synthesized]))
        triangles[method.upper()] = {
            "triangles": int(synthesized.sum()),
            "bridging": int(np.sum(checks["bridging"] & synthesized)),
            "silhouette": int(np.sum(checks["crossing"] & ~checks["bridging"] & synthesized))}
    return {"points_percent": points, "triangles": triangles}


def _odometry(poses: Sequence[Pose], seed: int, error: tuple[float, float]) -> list[Pose]:
    """The poses as odometry knows them: each after the first off by ``error`` (seeded)."""
    heading, distance = error
    rng = np.random.default_rng([seed, 0x0D0])
    noisy = [poses[0]]
    for pose in poses[1:]:
        direction = rng.uniform(0.0, 2 * math.pi)
        sign = 1.0 if rng.random() < 0.5 else -1.0
        noisy.append(Pose(x=pose.x + distance * float(portable_cos(direction)),
                          z=pose.z + distance * float(portable_sin(direction)),
                          heading=pose.heading + sign * heading, y=pose.y))
    return noisy


def _write_json(path: Path, data) -> Path:
    return write_atomic(path, (json.dumps(data, indent=1) + "\n").encode("utf-8"))


def _pose_entry(pose: Pose) -> dict:
    return {"x": pose.x, "z": pose.z, "heading": round(math.degrees(pose.heading), 9),
            "y": pose.y}


def _merge(positions, models, seed, error, out: Path, files: list) -> tuple:
    """Odometry → ICP → merged PLY; returns the merged model and the alignment figures."""
    true = [p.model_pose for p in positions]
    odometry = _odometry(true, seed, error)
    # ICP on the laser's own points: the synthesized ones carry stage 2's errors (0.5 % of
    # range), which leave the refined pose about 1.1 cm off on seeds 1 and 2 (median
    # alignment error), where the measured points alone give 4-6 mm
    refined, reports = refine_poses([m.subset(~m.synthesized) for m in models], odometry)
    alignment = []
    for k in range(1, len(models)):
        before = alignment_error(models[k].vertices, odometry[k].matrix(), true[k].matrix())
        after = alignment_error(models[k].vertices, refined[k], true[k].matrix())
        alignment.append({"position": k + 1, "odometry_cm": 100 * float(np.median(before)),
                          "refined_cm": 100 * float(np.median(after)),
                          "icp_iterations": reports[k].iterations,
                          "converged": bool(reports[k].converged)})
    for k, model in enumerate(models):
        files.append(write_ply(out / f"position-{k + 1}.ply", model,
                               comments=[f"refsynth demo: scan position {k + 1}, scanner frame"]))
    files.append(_write_json(out / "odometry.json", [_pose_entry(p) for p in odometry]))
    files.append(_write_json(out / "poses.json",
                             [{"matrix": np.asarray(m).tolist()} for m in refined]))
    # merged from the files (their confidence is float32), so that ``python -m refsynth model
    # --merge position-*.ply --poses poses.json`` writes room.ply again, byte for byte
    world = merge_models([read_ply(path) for path in files[-len(models) - 2:-2]], refined)
    files.append(write_ply(out / "room.ply", world,
                           comments=[f"merged from {len(models)} scans"]))
    return world, alignment


# ----------------------------------------------------------------------------- the story


def run_pipeline_demo(out: Path, seed: int = 0, methods: Sequence[str] = ("np", "bp"), *,
                      poses: Sequence[RigPose] = DEMO_POSES, fraction: float = 0.4,
                      shrink: int = 2, odometry_error: tuple[float, float] = ODOMETRY_ERROR,
                      progress: StoryProgress | None = None) -> dict:
    """The paper's three stages on the simulated rig's room, from several scan positions.

    See the module's docstring for the stages and the files written.

    Parameters
    ----------
    out : Path
        The output folder (created if missing).
    seed : int, default 0
        The room, the rig's noise, the synthesis and the odometry's error.
    methods : sequence of {"np", "bp"}, default ("np", "bp")
        The fills of :func:`refsynth.synthesize`. The merged model is BP's
        (the first method's without BP). Empty: stop after the
        registration (scans and panoramas only).
    poses : sequence of RigPose, default :data:`DEMO_POSES`
        The scan positions (at least two for the model; the first defines
        the world frame). The first's scan goes into ``scan/``, the k-th
        into ``scan-k/``.
    fraction : float, default 0.4
        Of the 500 slices (stripes).
    shrink : int, default 2
        Keep every ``shrink``-th row and column of the registered panorama.
    odometry_error : (float, float), default :data:`ODOMETRY_ERROR`
        Heading (radians) and distance (metres) odometry is off by.
    progress : callable, optional
        A :data:`StoryProgress`.

    Returns
    -------
    dict
        ``panorama`` (position 1's registered shape, before ``shrink``),
        ``known`` (its fraction with range), ``warp`` (its ``a, b, alpha,
        beta``), ``positions`` (per position: pose, panorama shape, known
        fraction, warp), ``rows`` (the table: position, method, unknown %,
        MAR and the other scores of :func:`refsynth.evaluation.metrics.evaluate`,
        ``median_percent``, the median of ``|error| / true range`` over the
        filled pixels in %, and seconds), ``targets`` (``points_percent`` and
        ``triangles`` per position, ``alignment`` per refined position),
        ``files`` (every path written, in order) and ``seconds`` (per
        stage).

    Examples
    --------
    Stage 1 alone (no fill, so no model): one position scanned and registered,
    a few seconds:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     summary = run_pipeline_demo(Path(folder), methods=(), poses=DEMO_POSES[:1])
    >>> summary["panorama"], round(summary["known"], 2), summary["rows"]
    ((228, 961), 0.39, [])
    """
    out = Path(out)
    methods = [str(m).lower() for m in methods]
    poses = list(poses)
    if not all(isinstance(p, RigPose) for p in poses) or not poses:
        raise TypeError("The parameter `poses` must be a non-empty sequence of RigPose")
    if methods and len(poses) < 2:
        raise ValueError("The parameter `poses` must hold two positions or more for the model")
    positions = [ScanPosition(k + 1, pose, out / ("scan" if k == 0 else f"scan-{k + 1}"))
                 for k, pose in enumerate(poses)]
    per_position = _COST["scan"] + _COST["register"]
    if methods:
        per_position += sum(_COST.get(m, 0.0) for m in methods) + _COST["baselines"]
    work = _Work(per_position * len(poses) + (_COST["model"] + _COST["figures"]) * bool(methods),
                 progress)
    room = room_geometry(seed)
    rows, files = [], []
    out.mkdir(parents=True, exist_ok=True)
    for position in positions:
        work.start(f"position {position.number}: scan", _COST["scan"])
        acquire_position(position.folder, seed, position.pose,
                         ScanSettings("stripes", fraction=fraction))
        work.start(f"position {position.number}: registration", _COST["register"])
        register_position(position, shrink)
        position.truth = true_range(room, position.camera, position.partial.shape,
                                    position.model_pose)
        if methods:
            rows += _fill(position, methods, STORY_BASELINES, seed, work)
    first = positions[0].registration
    summary = dict(
        panorama=first.intensity.shape, known=float(np.isfinite(first.partial_range).mean()),
        warp=tuple(float(v) for v in first.warp),
        positions=[dict(pose=p.pose.as_dict(), panorama=p.registration.intensity.shape,
                        known=float(np.isfinite(p.registration.partial_range).mean()),
                        warp=tuple(float(v) for v in p.registration.warp), scan=str(p.folder))
                   for p in positions],
        rows=rows, targets={}, files=[p.folder for p in positions], seconds=work.seconds)
    if not methods:
        work.finish()
        return summary

    work.start("the model: build, refine, merge", _COST["model"])
    merged_method = "bp" if "bp" in methods else methods[0]
    models = [_models(p) for p in positions]
    targets = {"positions": [_position_targets(p, m, room) for p, m in zip(positions, models)]}
    world, targets["alignment"] = _merge(positions, [m[merged_method] for m in models], seed,
                                         odometry_error, out, files)
    targets["merged"] = {"method": merged_method.upper(), "vertices": world.n_vertices,
                         "triangles": world.n_faces,
                         "fused_away": sum(m[merged_method].n_vertices for m in models)
                         - world.n_vertices}
    work.start("figures", _COST["figures"])
    kept = world.faces[(world.vertices[world.faces, 1] <= _CLIP_ABOVE).all(axis=1)]
    azimuth, elevation, distance = _VIEW
    eye, target = oblique_eye(world.vertices[np.unique(kept)], azimuth=azimuth,
                              elevation=elevation, distance=distance)
    scanners = {f"scan {p.number}": p.model_pose.apply(np.zeros(3)) for p in positions}
    fig = model_view_figure(world, colours=("intensity", "confidence"), clip_above=_CLIP_ABOVE,
                            eye=eye, target=target, markers=scanners, note=_VIEW_NOTE,
                            title=f"{len(positions)} scan positions merged ({merged_method.upper()}"
                            f", ICP-refined odometry): stage 3")
    save_figure(fig, out / "model_view.png", dpi=100)
    files.append(out / "model_view.png")
    first = positions[0]
    for method, result in first.results.items():
        fig = result_figure(first.intensity, result.edges, first.partial, result.range,
                            first.truth, units="m",
                            title=f"simulated rig, position 1, registered panorama: "
                            f"{method.upper()}")
        save_figure(fig, out / f"pipeline_{method}.png", dpi=110)
        files.append(out / f"pipeline_{method}.png")
    work.finish()
    summary["targets"] = targets
    record = {key: summary[key] for key in ("positions", "rows", "targets")}
    record.update(seed=seed, shrink=shrink, fraction=fraction,
                  odometry_error={"heading_deg": math.degrees(odometry_error[0]),
                                  "distance_m": odometry_error[1]},
                  seconds=work.seconds)
    files.append(_write_json(out / "story.json", record))
    summary["files"] = [p.folder for p in positions] + files
    if progress is not None:
        progress("done", 1.0)
    return summary
