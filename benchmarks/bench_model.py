"""Stage 3, the 3-D model: build time, peak memory, points per second, PLY I/O, merging (issue #12).

Prints, as Markdown tables:

1. one scan position's model (:func:`refsynth.model.build_model`: back-projection,
   colours, confidence, the mesh without depth-jump bridges) and its PLY files,
   for the demo's panorama (961×228, cylindrical, f = 300 px, the rig's room
   ray-cast) and for a 741×500 pinhole range (the Middlebury Motorcycle's
   calibration at a quarter of its size: f = 995 px, baseline 193 mm, doffs
   31.1 px; the disparity of the rig's room converted by ``z = f B / (d +
   doffs)``, timed with the build). Target: ≤ 2 s for 741×500.
2. two 961×228 panoramas from poses 0.8 m and 20° apart, the second's
   odometry off by 2° and 10 cm: the merge (voxel fusion), the point-to-plane
   ICP refinement, and the median alignment error before and after (target
   ≤ 1 cm).

Every case runs in a fresh process that receives its input arrays ready-made,
so that its peak resident memory (``resource.getrusage``'s ``ru_maxrss``) is
the stage's own beside the process's memory before it started (interpreter,
numpy, the inputs).

Run::

    python benchmarks/bench_model.py            # about 30 s on 2 cores
    python benchmarks/bench_model.py --repeat 5 # best of 5 timings per step
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: Middlebury 2014 Motorcycle's calib.txt (2964×1988) at the 741×500 of scikit-image's copy.
MOTORCYCLE = dict(focal=3979.911 / 4, cx=1244.772 / 4, cy=1019.507 / 4, baseline=193.001,
                  doffs=124.343 / 4)


def _rss_mb() -> float:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1024.0 if sys.platform != "darwin" else rss / 1024.0**2


def _panorama(pose, shape=(228, 961), focal=300.0, seed=0):
    """The rig's room from ``pose``: range (m, 5 mm noise), intensity, confidence, measured."""
    from refsynth.model import CylindricalCamera
    from refsynth.scenes import cast_rays, rig_room

    camera = CylindricalCamera.centred(focal, shape)
    rays = camera.directions(shape) @ pose.matrix()[:3, :3].T
    hits = cast_rays(rig_room(0), rays, origin=pose.matrix()[:3, 3])
    rng = np.random.default_rng(seed)
    measured = np.broadcast_to(np.arange(shape[1]) % 5 < 2, shape).copy()  # 40 % of slices
    confidence = np.where(measured, 1.0, rng.uniform(0.3, 0.95, shape))
    intensity = np.clip(hits.albedo * hits.shading, 0.0, 1.0)
    return hits.distance + rng.normal(0.0, 0.005, shape), intensity, confidence, measured


def _pinhole():
    """The rig's room through Motorcycle's camera: disparity (px) and an RGB uint8 image."""
    from refsynth.model import PinholeCamera
    from refsynth.scenes import cast_rays, rig_room

    camera = PinholeCamera(MOTORCYCLE["focal"], MOTORCYCLE["cx"], MOTORCYCLE["cy"])
    rays = camera.directions((500, 741))
    hits = cast_rays(rig_room(0), rays / np.linalg.norm(rays, axis=-1, keepdims=True))
    depth_mm = 1000.0 * hits.distance / np.linalg.norm(rays, axis=-1)
    disparity = MOTORCYCLE["focal"] * MOTORCYCLE["baseline"] / depth_mm - MOTORCYCLE["doffs"]
    grey = np.clip(hits.albedo * hits.shading, 0.0, 1.0)
    rgb = np.rint(255 * np.stack([grey, 0.9 * grey, 0.8 * grey], axis=-1)).astype(np.uint8)
    return disparity.astype(np.float32), rgb


def _best(function, repeat: int):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return min(times), result


def _build_case(args):
    """Build one model and write / read its PLYs, in a fresh process."""
    name, arrays, repeat = args
    from refsynth.model import (
        CylindricalCamera,
        PinholeCamera,
        build_model,
        disparity_to_depth,
        read_ply,
        write_ply,
    )

    before = _rss_mb()
    if name == "pinhole":
        disparity, rgb = arrays
        camera = PinholeCamera(MOTORCYCLE["focal"], MOTORCYCLE["cx"], MOTORCYCLE["cy"])

        def build():
            depth = disparity_to_depth(disparity, MOTORCYCLE["focal"], MOTORCYCLE["baseline"],
                                       MOTORCYCLE["doffs"])
            return build_model(depth, camera, intensity=rgb)
        shape = disparity.shape
    else:
        r, intensity, confidence, measured = arrays
        camera = CylindricalCamera.centred(300.0, r.shape)

        def build():
            return build_model(r, camera, intensity=intensity, confidence=confidence,
                               measured=measured)
        shape = r.shape
    seconds, model = _best(build, repeat)
    peak_build = _rss_mb()
    with tempfile.TemporaryDirectory() as folder:
        binary, ascii = Path(folder) / "m.ply", Path(folder) / "a.ply"
        write_s, _ = _best(lambda: write_ply(binary, model), repeat)
        ascii_s, _ = _best(lambda: write_ply(ascii, model, ascii=True), 1)
        read_s, _ = _best(lambda: read_ply(binary), repeat)
        sizes = binary.stat().st_size / 2**20, ascii.stat().st_size / 2**20
    return dict(name=name, shape=shape, vertices=model.n_vertices, faces=model.n_faces,
                seconds=seconds, write=write_s, ascii=ascii_s, read=read_s, mb=sizes,
                rss_before=before, rss_build=peak_build, rss_peak=_rss_mb())


def _merge_case(args):
    """Merge two panoramas, refine the second's pose, in a fresh process."""
    scans, true_poses, odometry = args
    from refsynth.model import (
        CylindricalCamera,
        alignment_error,
        build_model,
        merge_models,
        refine_poses,
    )

    before = _rss_mb()
    camera = CylindricalCamera.centred(300.0, scans[0][0].shape)
    models = [build_model(r, camera, intensity=i, confidence=c, measured=m)
              for r, i, c, m in scans]
    start = time.perf_counter()
    refined, results = refine_poses(models, odometry)
    icp_s = time.perf_counter() - start
    start = time.perf_counter()
    merged = merge_models(models, refined)
    merge_s = time.perf_counter() - start
    points = models[1].vertices
    return dict(before=float(np.median(alignment_error(points, odometry[1], true_poses[1]))),
                after=float(np.median(alignment_error(points, refined[1], true_poses[1]))),
                iterations=results[1].iterations, icp=icp_s, merge=merge_s,
                vertices=merged.n_vertices, total=sum(m.n_vertices for m in models),
                faces=merged.n_faces, rss_before=before, rss_peak=_rss_mb())


def _inputs(task):
    """Make one case's input arrays (in a process of its own) and save them to ``folder``."""
    name, folder = task
    from refsynth.model import Pose

    if name == "pinhole":
        arrays = {"pinhole": _pinhole()}
    elif name == "cylindrical":
        arrays = {"cylindrical": _panorama(Pose())}
    else:
        true = [Pose(), Pose(x=0.8, z=-0.6, heading=math.radians(20.0))]
        arrays = {f"scan{k}": _panorama(pose, seed=k) for k, pose in enumerate(true)}
    for key, value in arrays.items():
        for index, array in enumerate(value):
            np.save(Path(folder) / f"{key}-{index}.npy", array)
    return sorted(arrays)


def _load(folder, key):
    return tuple(np.load(path) for path in sorted(Path(folder).glob(f"{key}-*.npy")))


def _build_from_files(task):
    name, folder, repeat = task
    return _build_case((name, _load(folder, name), repeat))


def _merge_from_files(task):
    folder, true, odometry = task
    return _merge_case(([_load(folder, "scan0"), _load(folder, "scan1")], true, odometry))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="best of N timings (default 3)")
    args = parser.parse_args(argv)
    ctx = mp.get_context("spawn")  # a fresh, small process per task: its ru_maxrss is its own
    with tempfile.TemporaryDirectory() as folder, ctx.Pool(1, maxtasksperchild=1) as pool:
        for name in ("cylindrical", "pinhole", "merge"):
            pool.apply(_inputs, ((name, folder),))
        print("## 1. One scan position: build_model and PLY files\n")
        print("| input | vertices | triangles | build s | points/s | write s (binary) "
              "| write s (ASCII) | read s | MB (binary / ASCII) | RSS before → build → peak MB |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        labels = {"cylindrical": "cylindrical 961×228, f = 300",
                  "pinhole": "pinhole 741×500 from disparity, f = 995"}
        for name, label in labels.items():
            row = pool.apply(_build_from_files, ((name, folder, args.repeat),))
            print(f"| {label} | {row['vertices']} | {row['faces']} | {row['seconds']:.3f} | "
                  f"{row['vertices'] / row['seconds']:,.0f} | {row['write']:.3f} | "
                  f"{row['ascii']:.2f} | {row['read']:.3f} | {row['mb'][0]:.1f} / "
                  f"{row['mb'][1]:.1f} | {row['rss_before']:.0f} → {row['rss_build']:.0f} → "
                  f"{row['rss_peak']:.0f} |")

        print("\n## 2. Two poses merged, odometry off by 2° and 10 cm, refined by ICP\n")
        true = [np.eye(4), _pose_matrix(0.8, -0.6, 20.0)]
        odometry = [true[0], _pose_matrix(0.8 + 0.0707, -0.6 - 0.0707, 22.0)]
        row = pool.apply(_merge_from_files, ((folder, true, odometry),))
    print("| alignment error before (median) | after ICP | ICP iterations | ICP s | merge s "
          "| vertices kept / both scans | triangles | RSS before → peak MB |")
    print("|---|---|---|---|---|---|---|---|")
    print(f"| {100 * row['before']:.1f} cm | {1000 * row['after']:.2f} mm | "
          f"{row['iterations']} | {row['icp']:.2f} | {row['merge']:.2f} | "
          f"{row['vertices']} / {row['total']} | {row['faces']} | "
          f"{row['rss_before']:.0f} → {row['rss_peak']:.0f} |")
    return 0


def _pose_matrix(x: float, z: float, heading_deg: float) -> np.ndarray:
    """:meth:`refsynth.model.Pose.matrix` without importing refsynth in the parent process."""
    c, s = math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))
    return np.array([[c, 0, s, x], [0, 1, 0, 0], [-s, 0, c, z], [0, 0, 0, 1.0]])


if __name__ == "__main__":
    sys.exit(main())
