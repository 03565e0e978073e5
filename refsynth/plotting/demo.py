"""The demos: the main job on the synthetic room, and the paper's pipeline end to end.

:func:`run_demo` fills the synthetic room's range on two samplings of the
paper's experiments (Tables 1 and 4) with NP, two of its ablations (Table 3,
Fig. 7), BP and the baselines, scores each fill with MAR (Eq. 13) and RMSE,
and writes three figures; it returns the table's rows. :func:`run_pipeline_demo`
acquires with the simulated rig (§3.1, §4), registers the pictures and the
partial scan (Appendix A) and fills the panorama's missing range. Both are
what ``python -m refsynth demo`` runs (:mod:`refsynth.cli.demo` prints the
table); ``python -m refsynth figures`` writes the first demo's figures too.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 (Tables 1, 3, 4, Fig. 7), §4 and
Appendix A, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from refsynth.acquisition import (
    PanUnit,
    Rangefinder,
    RigSimulator,
    ScanSettings,
    load_scan,
    run_scan,
)
from refsynth.acquisition.sampling import stripes, unknown_fraction, x_stripes_for_fraction
from refsynth.evaluation.baselines import BASELINES
from refsynth.evaluation.metrics import evaluate
from refsynth.io import read_array
from refsynth.plotting.layouts import comparison_figure, methods_figure, result_figure
from refsynth.registration import register_scan
from refsynth.scenes import synthetic_room
from refsynth.synthesis.api import synthesize

__all__ = ["DEMO_METHODS", "DEMO_FIGURES", "ProgressFactory", "run_demo", "run_pipeline_demo"]

#: The demo's methods: NP, its two ablations of Table 3 / Fig. 7, and BP.
DEMO_METHODS = {
    "NP": {},
    "NP, no edges": {"use_edges": False},
    "NP, onion order": {"ordering": "onion"},
    "BP": {"method": "bp"},
}

#: The files :func:`run_demo` writes, in order.
DEMO_FIGURES = ("demo_result.png", "demo_np_bp.png", "demo_comparison.png")

#: ``progress(label)``: called before each synthesis with a label such as
#: ``"grid 5/25, NP"``; what it returns (``None`` or a ``callback(done, total)``)
#: is passed to :func:`refsynth.synthesize` as its ``progress``.
ProgressFactory = Callable[[str], Callable[[int, int], None] | None]


def _no_progress(label: str) -> None:
    return None


def run_demo(out: Path, size: int = 128, seed: int = 0, *,
             progress: ProgressFactory | None = None) -> list[dict]:
    """The main job on the bundled synthetic room; returns the table's rows.

    Two samplings (grid stripes rw/xw = 5/25, about 61 % unknown, as in Table 1;
    vertical x-stripes at 78 % unknown, as in Table 4) × NP with priority order,
    NP without edges, NP with onion-peel order, BP, and the baselines of
    :data:`refsynth.evaluation.baselines.BASELINES`. Writes ``demo_result.png``
    (the paper's layout, NP on the grid sampling), ``demo_np_bp.png`` (NP's and
    BP's results, residuals and confidence maps) and ``demo_comparison.png``
    (every sampling × method) into ``out``.

    Parameters
    ----------
    out : Path
        The folder for the figures (created if missing).
    size : int, default 128
        The room's side in pixels.
    seed : int, default 0
        The room's seed and NP's.
    progress : callable, optional
        A :data:`ProgressFactory`, for progress reports during each synthesis.

    Returns
    -------
    list of dict
        One row per sampling × method: ``sampling``, ``unknown`` (% of the
        image), ``method``, ``seconds`` (wall time of the fill) and the scores
        of :func:`refsynth.evaluation.metrics.evaluate` (``mar``, ``rmse``,
        ``bad1``, ``bad3``, ``n``).
    """
    progress = progress or _no_progress
    scene = synthetic_room((size, size), seed=seed)
    shape = scene.range.shape
    samplings = {
        "grid 5/25": stripes(shape, 5, 25, axes="xy"),
        "x-stripes 78%": x_stripes_for_fraction(shape, 0.78),
    }
    rows, partials, results = [], {}, {}
    full: dict = {}
    for sampling, known in samplings.items():
        partial = np.where(known, scene.range, np.nan)
        partials[sampling] = partial
        for method, kwargs in [*DEMO_METHODS.items(), *((name, None) for name in BASELINES)]:
            start = time.perf_counter()
            if kwargs is None:
                estimate = BASELINES[method](scene.intensity, partial)
            else:
                res = synthesize(
                    scene.intensity, partial, seed=seed,
                    progress=progress(f"{sampling}, {method}"), **kwargs,
                )
                estimate = res.range
                full[(sampling, method)] = res
            seconds = time.perf_counter() - start
            results[(sampling, method)] = estimate
            scores = evaluate(estimate, scene.range, known)
            rows.append(dict(sampling=sampling, unknown=100 * unknown_fraction(known),
                             method=method, seconds=seconds, **scores))
    out.mkdir(parents=True, exist_ok=True)
    sampling = next(iter(samplings))
    res = full[(sampling, "NP")]
    fig = result_figure(scene.intensity, res.edges, partials[sampling], res.range, scene.range,
                        units=scene.units, title=f"{scene.name}: NP, {sampling}")
    fig.savefig(out / DEMO_FIGURES[0], dpi=110)
    fig = methods_figure(
        scene.range, partials[sampling],
        {m: (full[(sampling, m)].range, full[(sampling, m)].confidence) for m in ("NP", "BP")},
        units=scene.units, title=f"{scene.name}, {sampling}: NP and BP",
    )
    fig.savefig(out / DEMO_FIGURES[1], dpi=110)
    fig = comparison_figure(scene.range, partials, results, units=scene.units,
                            title=f"{scene.name}, seed {seed}: MAR (Eq. 13) per method")
    fig.savefig(out / DEMO_FIGURES[2], dpi=110)
    return rows


def run_pipeline_demo(out: Path, seed: int = 0, methods: Sequence[str] = ("np", "bp"), *,
                      progress: ProgressFactory | None = None) -> dict:
    """Acquire (simulated) → register → synthesize: the paper's pipeline end to end.

    Scans the simulated rig's room (40 % of the 500 slices, stripes; pictures
    every 18°) into ``out/scan`` unless a scan is already there, registers the
    pictures and the partial scan (Appendix A), fills the panorama's missing
    range with each method and writes ``pipeline_<method>.png``.

    Parameters
    ----------
    out : Path
        The folder for the scan and the figures.
    seed : int, default 0
        The simulator's seed and NP's.
    methods : sequence of str, default ("np", "bp")
        The ``method`` of each :func:`refsynth.synthesize` run.
    progress : callable, optional
        A :data:`ProgressFactory`, for progress reports during each synthesis.

    Returns
    -------
    dict
        ``panorama`` (its shape), ``known`` (the fraction with range), ``warp``
        (the registration's ``a, b, alpha, beta``) and ``seconds`` (method →
        wall time of the fill).
    """
    progress = progress or _no_progress
    scan_dir = out / "scan"
    if not (scan_dir / "scan.npz").is_file():
        with RigSimulator(seed=seed, camera_dir=scan_dir / "images") as sim, \
                PanUnit(sim.pan_port) as pan, Rangefinder(sim.laser_port) as laser:
            run_scan(scan_dir, pan, laser, ScanSettings("stripes", fraction=0.4))
    scan = load_scan(scan_dir)
    images = [read_array(picture.path) for picture in scan.images]
    angles = [picture.pan_angle for picture in scan.images]
    intensity, partial, info = register_scan(images, angles, 300.0, (scan.r, scan.theta, scan.phi))
    summary = dict(panorama=intensity.shape, known=float(np.isfinite(partial).mean()),
                   warp=tuple(float(v) for v in info.warp), seconds={})
    out.mkdir(parents=True, exist_ok=True)
    for method in methods:
        start = time.perf_counter()
        result = synthesize(intensity, partial, method=method, seed=seed,
                            progress=progress(f"pipeline, {method}"))
        summary["seconds"][method] = time.perf_counter() - start
        fig = result_figure(intensity, result.edges, partial, result.range, units="m",
                            title=f"simulated rig, registered panorama: {method.upper()}")
        fig.savefig(out / f"pipeline_{method}.png", dpi=110)
    return summary
