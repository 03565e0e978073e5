"""The demos: the quick comparison on the synthetic room, and the paper's story end to end.

:func:`run_demo` fills the synthetic room's range on two samplings of the
paper's experiments (Tables 1 and 4) with NP, two of its ablations (Table 3,
Fig. 7), BP and the baselines, scores each fill with MAR (Eq. 13) and RMSE,
and writes three figures; it returns the table's rows: ``python -m refsynth
demo --quick`` (:mod:`refsynth.cli.demo` prints the table), and ``python -m
refsynth figures`` writes its figures too. :func:`run_pipeline_demo` (in
:mod:`refsynth.plotting.story`, re-exported here) is the default ``demo``:
the simulated rig scans from two positions (§3.1, §4), registration
(Appendix A), NP and BP, and the merged 3-D model (stage 3).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 (Tables 1, 3, 4, Fig. 7), §4 and
Appendix A, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from refsynth.acquisition.sampling import stripes, unknown_fraction, x_stripes_for_fraction
from refsynth.evaluation.baselines import BASELINES
from refsynth.evaluation.metrics import evaluate
from refsynth.plotting.layouts import (
    comparison_figure,
    methods_figure,
    result_figure,
    save_figure,
)
from refsynth.plotting.story import run_pipeline_demo
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

    Examples
    --------
    The smallest room (16 × 16; a few seconds, most of it drawing the figures):

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     rows = run_demo(Path(folder), size=16)
    ...     written = sorted(path.name for path in Path(folder).iterdir())
    >>> written == sorted(DEMO_FIGURES), len(rows)  # 2 samplings × (4 methods + 5 baselines)
    (True, 18)
    >>> rows[0]["sampling"], rows[0]["method"], round(rows[0]["mar"], 3)
    ('grid 5/25', 'NP', 0.797)
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
                        units=scene.units, title=f"{scene.name}: NP, {sampling}",
                        uncertainty=res.uncertainty)
    save_figure(fig, out / DEMO_FIGURES[0], dpi=110)
    fig = methods_figure(
        scene.range, partials[sampling],
        {m: (full[(sampling, m)].range, full[(sampling, m)].confidence,
             full[(sampling, m)].uncertainty) for m in ("NP", "BP")},
        units=scene.units, title=f"{scene.name}, {sampling}: NP and BP",
    )
    save_figure(fig, out / DEMO_FIGURES[1], dpi=110)
    fig = comparison_figure(scene.range, partials, results, units=scene.units,
                            title=f"{scene.name}, seed {seed}: MAR (Eq. 13) per method")
    save_figure(fig, out / DEMO_FIGURES[2], dpi=110)
    return rows
