"""Registration (Appendix A): the issue's target figures on the synthetic rig and real texture.

Prints, as Markdown tables:

1. translation recovered between consecutive views (Eqs. 15–17), RMS error in
   pixels over all pairs, on the synthetic rig (camera every 18°, f = 300 px,
   vertical jitter ±1.5 px, pan error ±0.4°, cos⁴ vignetting, noise) and on
   views cut out of real photographs (scikit-image) wrapped on the cylinder,
   at 10 %, 20 % and 30 % overlap — refsynth's defaults, and Eqs. 15–17 as
   the paper writes them (no whole-pixel search, no photometric terms);
2. the mosaic's seam error: RMS intensity difference between consecutive
   views where they overlap in the mosaic, with the recovered placements and
   with the true ones;
3. the warp of Eq. 21 fitted to noisy correspondences (20 points over 180°,
   Gaussian noise of 0.5 and 1 px, 500 draws): errors of a, b (relative) and
   α, β (px), mean and 95th percentile;
4. laser–camera registration on the rig (f = 300 px, ΔY = 5 cm, walls
   5–8 m, furniture 1.5–4.5 m, 40 % of the slices scanned): edge misalignment
   (the error along the normal of each depth edge, against the ground truth)
   with the rig's nominal geometry, after the global warp (Eq. 21), after the
   local stretch, and with the exact Eq. 20 (ΔY known) for comparison; the
   mean 2-D error over all scanned samples; time per registration.

Run::

    python benchmarks/bench_registration.py            # about 2–3 minutes on 2 cores
    python benchmarks/bench_registration.py --quick    # fewer seeds
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from refsynth.registration import (
    Warp,
    align_translation,
    blend,
    cylindrical_warp,
    fit_warp,
    intensity_edges,
    match_edges,
    mosaic,
    range_edges,
    register,
)
from refsynth.registration import warp_forward as _forward
from refsynth.registration.scoring import registration_errors
from refsynth.scenes import FOCAL, laser_scan, render_views, rig_room, texture_views

TEXTURES = ("stereo_motorcycle", "coffee", "rocket", "astronaut", "camera", "chelsea")


def _pair_errors(views, **options) -> tuple[np.ndarray, int]:
    """Errors of the aligned translations of consecutive views; failures counted apart."""
    cylinders = [cylindrical_warp(view, views.focal) for view in views.images]
    errors, failures = [], 0
    for k in range(len(cylinders) - 1):
        initial = (views.focal * (views.pan_angles[k + 1] - views.pan_angles[k]), 0.0)
        try:
            found = align_translation(cylinders[k], cylinders[k + 1], initial, **options)
        except ValueError:
            failures += 1
            continue
        errors.append(found - views.translations[k])
    return np.array(errors).reshape(-1, 2), failures


def _rms(errors: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(errors**2, axis=1)))) if errors.size else float("nan")


def _textures():
    try:
        from skimage import data
    except ImportError:
        return []
    out = []
    for name in TEXTURES:
        image = getattr(data, name)()
        out.append((name, image[0] if isinstance(image, tuple) else image))
    return out


LITERAL = {"search": (0, 0), "photometric": False}


def translation_table(seeds: list[int]) -> None:
    print("### 1. Translation between consecutive views (Eqs. 15–17), RMS error (px)\n")
    print("| views | overlap | pairs | refsynth (search + photometric) | max | "
          "Eqs. 15–17 as written | failed |")
    print("|---|---|---|---|---|---|---|")
    textures = _textures()
    for overlap in (0.1, 0.2, 0.3):
        ours, literal, failed = [], [], 0
        for seed in seeds:
            views = render_views(rig_room(seed), overlap=overlap, seed=seed)
            ours.append(_pair_errors(views)[0])
            errors, fails = _pair_errors(views, **LITERAL)
            literal.append(errors)
            failed += fails
        ours, literal = np.vstack(ours), np.vstack(literal)
        print(f"| synthetic rig | {overlap:.0%} | {len(ours)} | {_rms(ours):.3f} | "
              f"{np.abs(ours).max():.3f} | {_rms(literal):.3f} | {failed} |")
    for overlap in (0.1, 0.2, 0.3):
        if not textures:
            print(f"| real texture | {overlap:.0%} | — | (scikit-image not installed) | | | |")
            continue
        ours, literal, failed = [], [], 0
        for _, image in textures:
            for seed in seeds[:2]:
                views = texture_views(image, overlap=overlap, seed=seed, noise=0.005,
                                      vignetting=1.0)
                ours.append(_pair_errors(views)[0])
                errors, fails = _pair_errors(views, **LITERAL)
                literal.append(errors)
                failed += fails
        ours, literal = np.vstack(ours), np.vstack(literal)
        print(f"| real texture ({len(textures)} photos) | {overlap:.0%} | {len(ours)} | "
              f"{_rms(ours):.3f} | {np.abs(ours).max():.3f} | {_rms(literal):.3f} | {failed} |")
    print("\n(Literal Eqs. 15–17: RMS over the pairs that did not fail; a failure is an "
          "iteration that ran out of overlap.)\n")


def _seam_rms(views, offsets) -> float:
    shape = None
    layers = []
    for view, offset in zip(views.images, offsets):
        layer, _ = blend([view], [offset], focal=views.focal, shape=shape or _shape(views, offsets))
        layers.append(layer)
    squares, count = 0.0, 0
    for first, second in zip(layers[:-1], layers[1:]):
        both = np.isfinite(first) & np.isfinite(second)
        squares += float(np.sum((first - second)[both] ** 2))
        count += int(both.sum())
    return math.sqrt(squares / count)


def _shape(views, offsets):
    height, width = views.images.shape[1:]
    return (int(np.ceil(offsets[:, 1].max() + height)), int(np.ceil(offsets[:, 0].max() + width)))


def seam_table(seeds: list[int]) -> None:
    print("### 2. Mosaic seam error: RMS intensity difference in the overlaps (intensity 0–1)\n")
    print("| views | overlap | recovered placements | true placements | no vignetting, no noise |")
    print("|---|---|---|---|---|")
    for overlap in (0.1, 0.3):
        found, truth, clean = [], [], []
        for seed in seeds[:3]:
            room = rig_room(seed)
            views = render_views(room, overlap=overlap, seed=seed)
            result = mosaic(views.images, views.focal, np.diff(views.pan_angles))
            true_offsets = np.vstack([[0.0, 0.0], np.cumsum(views.translations, axis=0)])
            true_offsets -= true_offsets.min(axis=0)
            found.append(_seam_rms(views, result.offsets))
            truth.append(_seam_rms(views, true_offsets))
            plain = render_views(room, overlap=overlap, seed=seed, noise=0.0, vignetting=0.0)
            clean.append(_seam_rms(plain, true_offsets))
        print(f"| synthetic rig | {overlap:.0%} | {np.mean(found):.4f} | {np.mean(truth):.4f} | "
              f"{np.mean(clean):.4f} |")
    print("\n(The seams are dominated by vignetting, which Eq. 18's hat weights blend away in "
          "the mosaic but which makes two views differ where they overlap; with neither "
          "vignetting nor noise, what is left is interpolation.)\n")


def warp_table(draws: int) -> None:
    print("### 3. Eq. 21 fitted to noisy correspondences (20 points over 180°)\n")
    print("| noise (px) | draws | a: mean / 95 % (rel.) | b: mean / 95 % (rel.) | "
          "α: mean / 95 % (px) | β: mean / 95 % (px) |")
    print("|---|---|---|---|---|---|")
    truth = Warp(FOCAL, -1.0, 480.0, 120.0)
    rng = np.random.default_rng(0)
    for noise in (0.5, 1.0):
        errors = []
        for _ in range(draws):
            laser = np.column_stack([rng.uniform(-np.pi / 2, np.pi / 2, 20),
                                     rng.uniform(-100, 100, 20)])
            camera = np.column_stack(truth.apply(laser[:, 0], laser[:, 1]))
            fitted = fit_warp(laser, camera + rng.normal(0, noise, camera.shape))
            errors.append([abs(fitted.a / truth.a - 1), abs(fitted.b / truth.b - 1),
                           abs(fitted.alpha - truth.alpha), abs(fitted.beta - truth.beta)])
        errors = np.array(errors)
        cells = [f"{errors[:, k].mean():.4f} / {np.percentile(errors[:, k], 95):.4f}"
                 for k in range(4)]
        print(f"| {noise} | {draws} | " + " | ".join(cells) + " |")
    print("\n(α is the mosaic column of φ = 0, the middle of the panorama here; it is as "
          "well determined as the mean of the points.)\n")


def _eq20_mapping(registration, delta_y):
    """The exact Eq. 20 with the rig's ΔY: v = b h + v0 + f ΔY / ρ, v0 from the edge matches."""
    warp, focal = registration.warp, registration.cylinder.focal
    found = range_edges(registration.cylinder)
    positions = _forward(warp, None, found.phi, found.h)
    edges = intensity_edges(registration.mosaic.image)
    offset = match_edges(positions, found.axis, *edges, 3)
    use = np.isfinite(offset) & (found.axis == 1)
    rho = found.r[use] * focal / np.hypot(focal, found.h[use])
    v0 = float(np.median(positions[use, 1] + offset[use] - warp.b * found.h[use]
                         - focal * delta_y / rho))

    def mapping(phi, h, r):
        rho = r * focal / np.hypot(focal, h)
        return np.column_stack([warp.a * phi + warp.alpha, warp.b * h + v0 + focal * delta_y / rho])

    return mapping


def laser_table(seeds: list[int]) -> None:
    print("### 4. Laser–camera registration on the rig (f = 300 px, ΔY = 5 cm, walls 5–8 m)\n")
    print("Edge misalignment: mean |error| along the normal of each depth edge, px "
          "(vertical edges: u; horizontal edges: v).\n")
    print("| seed | depth edges (vert./horiz.) | nominal | global Eq. 21 | + local stretch | "
          "exact Eq. 20 (ΔY known) | horiz. edges: global → local | all samples (2-D): global → "
          "local / Eq. 20 | seconds |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for seed in seeds:
        room = rig_room(seed)
        views = render_views(room, seed=seed)
        scan = laser_scan(room, seed=seed)
        start = time.perf_counter()
        result = register(views.images, views.pan_angles, views.focal,
                          (scan.r, scan.theta, scan.phi))
        seconds = time.perf_counter() - start
        errors = registration_errors(result, scan, views,
                                     stages={"eq20": _eq20_mapping(result, scan.delta_y)})
        row = [errors[k]["mean"] for k in ("nominal", "global", "local", "eq20")]
        row += [errors["global"]["mean_v"], errors["local"]["mean_v"],
                errors["global"]["samples"], errors["local"]["samples"],
                errors["eq20"]["samples"], seconds]
        rows.append(row)
        print(f"| {seed} | {errors['n_u']} / {errors['n_v']} | {row[0]:.2f} | {row[1]:.2f} | "
              f"{row[2]:.2f} | {row[3]:.2f} | {row[4]:.2f} → {row[5]:.2f} | "
              f"{row[6]:.2f} → {row[7]:.2f} / {row[8]:.2f} | {row[9]:.1f} |")
    mean = np.mean(rows, axis=0)
    print(f"| **mean** | | **{mean[0]:.2f}** | **{mean[1]:.2f}** | **{mean[2]:.2f}** | "
          f"{mean[3]:.2f} | {mean[4]:.2f} → {mean[5]:.2f} | {mean[6]:.2f} → {mean[7]:.2f} / "
          f"{mean[8]:.2f} | {mean[9]:.1f} |")
    print("\n(Nominal: a = f, b = −1, the laser's azimuth 0 at the camera's pan angle 0, the "
          "horizon at view 0's centre row — the paper's 'initial estimate', 5–7 px off. Global: "
          "chamfer search and edge-matched least squares of α and β. Local: the stretch at "
          "matched depth-edge segments. All samples: every scanned sample, edge or not; the "
          "stretch only moves range near depth edges, so walls keep the global warp's error, "
          "which Eq. 21's single β cannot remove: it is fitted to the depth edges, mostly tops "
          "of furniture 1.5–4.5 m away, whose parallax f ΔY / ρ is 3–10 px against 2–3 px for "
          "the walls.)\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer seeds and draws")
    args = parser.parse_args(argv)
    seeds = list(range(2 if args.quick else 5))
    start = time.perf_counter()
    translation_table(seeds)
    seam_table(seeds)
    warp_table(100 if args.quick else 500)
    laser_table(list(range(3 if args.quick else 8)))
    print(f"(total {time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
