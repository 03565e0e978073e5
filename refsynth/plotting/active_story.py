r"""Active scanning on the simulated rig beside the fixed strategies: ``demo --active`` (§5).

:func:`run_active_demo` is what ``python -m refsynth demo --active`` runs. From
the story's first position (:data:`~refsynth.plotting.story.DEMO_POSES`), the
simulated rig scans its room three ways, each measuring ``fraction`` of the 500
slices (default 40 %: 200 slices each; the stripes' pattern reaches some
other fractions only to within a stripe):

``stripes``
    Table 4's vertical stripes, the story's own scan;
``distance``
    Fig. 2's distance-driven slices, laid out after a coarse pass (§3.1.1);
``active``
    an evenly spread first pass of 20 %, then rounds of 5 % of the slices, each
    chosen by :func:`refsynth.acquisition.next_slices` with BP from what the scan
    has measured so far (§5; :mod:`refsynth.acquisition.active_scan`).

Each scan is registered to its pictures (Appendix A), every second row and
column kept as in the story, and filled by BP (§3.2.3) and by the linear and
colorization fills; each fill is scored by MAR (Eq. 13) against the
simulator's ground truth. ``active_scan.png`` shows where each strategy
looked, on the pan axis (the active scan's rounds in colour), BP's error on
each registered panorama, and the MAR of each strategy and fill.

Files written into ``out`` (:data:`ACTIVE_FILES`, besides the scan folders
``scan-stripes/``, ``scan-distance/`` and ``scan-active/``, reused when
already there for the same seed and settings): ``active_scan.png`` and
``active.json`` (the table, the rounds and the ratio).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.1.1 (Fig. 2), §3.3 (Table 4, Eq. 13), §4,
§5 (active sensing) and Appendix A, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from refsynth._checks import check_choice, check_int, check_real
from refsynth._files import write_atomic
from refsynth.acquisition import ScanSettings
from refsynth.acquisition.geometry import PAN_SLICES
from refsynth.acquisition.manifest import saved_manifest
from refsynth.evaluation.baselines import BASELINES
from refsynth.evaluation.metrics import evaluate
from refsynth.plotting.layouts import save_figure
from refsynth.plotting.story import DEMO_POSES, ScanPosition, acquire_position, register_position
from refsynth.plotting.story_truth import true_range
from refsynth.scenes import room_geometry
from refsynth.synthesis.api import synthesize

__all__ = ["ACTIVE_FILES", "ACTIVE_STRATEGIES", "ACTIVE_FILLS", "run_active_demo"]

#: The strategies compared, in the table's order: the fixed ones, then the active scan.
ACTIVE_STRATEGIES = ("stripes", "distance", "active")
#: The fills beside BP (§3.2.3): the classical ones that do best on column scans.
ACTIVE_FILLS = ("linear", "colorization")
#: The files :func:`run_active_demo` writes besides the scan folders.
ACTIVE_FILES = ("active_scan.png", "active.json")

#: ``progress(stage, fraction)``: as :data:`refsynth.plotting.story.StoryProgress`.
ActiveProgress = Callable[[str, float], None]


def _rounds(folder: Path) -> list[list[int]]:
    """The active scan's rounds as its manifest records them (the first pass first)."""
    return [[int(i) for i in chosen] for chosen in saved_manifest(folder)["rounds"]]


def _scanned(folder: Path) -> list[int]:
    """The slices a scan measured (its manifest's plan), ascending."""
    return sorted(int(i) for i in saved_manifest(folder)["plan"])


def run_active_demo(out: Path, seed: int = 0, fraction: float = 0.4, *, shrink: int = 2,
                    strategies: Sequence[str] = ACTIVE_STRATEGIES,
                    progress: ActiveProgress | None = None) -> dict:
    """Active scanning against the fixed strategies on the simulated rig, one position (§5).

    See the module's docstring for the strategies, the fills and the files.

    Parameters
    ----------
    out : Path
        The output folder (created if missing).
    seed : int, default 0
        The room, the rig's noise and the synthesis.
    fraction : float, default 0.4
        Of the 500 slices, for every strategy; the active scan starts from 20 %
        and adds 5 % a round, so ``fraction`` is above 0.2.
    shrink : int, default 2
        Keep every ``shrink``-th row and column of each registered panorama.
    strategies : sequence of str, default :data:`ACTIVE_STRATEGIES`
        Which of them to run, in the table's order; ``"active"`` and at least
        one fixed strategy, each once.
    progress : callable, optional
        ``progress(stage, fraction_done)`` as each stage starts.

    Returns
    -------
    dict
        ``rows`` (per strategy and fill: ``strategy``, ``slices``, ``method``,
        ``unknown`` %, the scores of :func:`refsynth.evaluation.metrics.evaluate`
        and ``seconds``), ``rounds`` (the active scan's, first pass first),
        ``slices`` (each strategy's, ascending), ``ratio`` (active BP's MAR over
        the best MAR of a fixed strategy, BP or a classical fill: below 1 where the
        active scan gained) and ``files``.
    """
    out = Path(out)
    fraction = check_real("fraction", fraction, maximum=1.0)
    if fraction <= 0.2:
        raise ValueError(f"The parameter `fraction` must be in (0.2, 1], got {fraction!r}")
    seed = check_int("seed", seed, minimum=0)
    shrink = check_int("shrink", shrink, minimum=1)
    if isinstance(strategies, str):
        raise TypeError(f"The parameter `strategies` must be a sequence of names, got "
                        f"{strategies!r}")
    strategies = [check_choice("strategies", s, ACTIVE_STRATEGIES) for s in strategies]
    if "active" not in strategies or len(strategies) < 2 or len(set(strategies)) < len(
            strategies):
        raise ValueError("The parameter `strategies` must hold 'active' and a fixed strategy, "
                         f"each once, got {strategies!r}")
    out.mkdir(parents=True, exist_ok=True)
    room = room_geometry(seed)
    pose = DEMO_POSES[0]
    stages = 3 * len(strategies) + 1
    rows, positions, slices, done = [], {}, {}, 0

    def stage(label: str) -> None:
        nonlocal done
        if progress is not None:
            progress(label, done / stages)
        done += 1

    for strategy in strategies:
        folder = out / f"scan-{strategy}"
        stage(f"{strategy}: scan")
        acquire_position(folder, seed, pose, ScanSettings(strategy, fraction=fraction))
        slices[strategy] = _scanned(folder)
        stage(f"{strategy}: registration")
        position = ScanPosition(1, pose, folder)
        register_position(position, shrink)
        position.truth = true_range(room, position.camera, position.partial.shape,
                                    position.model_pose)
        positions[strategy] = position
        stage(f"{strategy}: BP and the classical fills")
        rows += _fills(strategy, len(slices[strategy]), position, seed)
    stage("figure")
    rounds = _rounds(out / "scan-active")
    fixed = [r["mar"] for r in rows if r["strategy"] != "active"]
    active_bp = next(r["mar"] for r in rows if (r["strategy"], r["method"]) == ("active", "BP"))
    ratio = active_bp / min(fixed)
    files = [out / f"scan-{s}" for s in strategies]
    fig = active_figure(positions, rows, slices, rounds)
    save_figure(fig, out / "active_scan.png", dpi=100)
    files.append(out / "active_scan.png")
    record = dict(seed=seed, fraction=fraction, shrink=shrink, rows=rows, rounds=rounds,
                  slices=slices, ratio=ratio)
    files.append(write_atomic(out / "active.json",
                              (json.dumps(record, indent=1) + "\n").encode("utf-8")))
    if progress is not None:
        progress("done", 1.0)
    return dict(rows=rows, rounds=rounds, slices=slices, ratio=ratio, files=files)


def _fills(strategy: str, count: int, position: ScanPosition, seed: int) -> list[dict]:
    """BP and :data:`ACTIVE_FILLS` on one registered scan: the table's rows."""
    rows = []
    for method in ("bp", *ACTIVE_FILLS):
        start = time.perf_counter()
        if method == "bp":
            result = synthesize(position.intensity, position.partial, method="bp", seed=seed)
            position.results["bp"] = result
            estimate = result.range
        else:
            estimate = BASELINES[method](position.intensity, position.partial)
        rows.append(dict(strategy=strategy, slices=count,
                         method="BP" if method == "bp" else method,
                         unknown=100 * float(np.mean(~position.known)),
                         seconds=time.perf_counter() - start,
                         **evaluate(estimate, position.truth, position.known)))
    return rows


def active_figure(positions: dict, rows: list[dict], slices: dict, rounds: list[list[int]]):
    """Where each strategy looked, BP's error on each panorama, and each one's MAR.

    Parameters
    ----------
    positions : dict of str to story position
        Per strategy: the registered panorama (``intensity``, ``partial``,
        ``truth``) and BP's result (``results["bp"]``).
    rows : list of dict
        :func:`run_active_demo`'s table.
    slices : dict of str to list of int
        Each strategy's slices (pan indices, 0 … 499).
    rounds : list of list of int
        The active scan's rounds, first pass first.

    Returns
    -------
    matplotlib.figure.Figure
    """
    strategies = list(positions)
    fig = Figure(figsize=(11.0, 2.2 + 1.9 * len(strategies)), layout="constrained")
    grid = fig.add_gridspec(1 + len(strategies), 4, height_ratios=[1.1] + [1.6] * len(strategies))
    # where each strategy looked: one row of the 500 slices each, the active scan by round
    ax = fig.add_subplot(grid[0, :])
    code = np.full((len(strategies), PAN_SLICES), np.nan)
    for k, strategy in enumerate(strategies):
        if strategy == "active":
            for number, chosen in enumerate(rounds):
                code[k, chosen] = number
        else:
            code[k, slices[strategy]] = 0
    colours = ["0.55", "tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple",
               "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]
    cmap = ListedColormap(colours[:max(len(rounds), 1)])
    ax.imshow(code, aspect="auto", interpolation="nearest", cmap=cmap, vmin=-0.5,
              vmax=max(len(rounds), 1) - 0.5)
    ax.set_yticks(range(len(strategies)), [f"{s} ({len(slices[s])})" for s in strategies])
    ax.set_xlabel("slice (pan position, 0 … 499 over 180°)")
    ax.set_title("Where each strategy measured: the active scan's first pass grey, its rounds "
                 "in colour (blue first)", fontsize=9)
    errors = {s: np.abs(p.results["bp"].range - p.truth) for s, p in positions.items()}
    top = float(np.nanpercentile(np.concatenate([e[~positions[s].known].ravel()
                                                 for s, e in errors.items()]), 99))
    cmap_error = colormaps["magma"].with_extremes(bad="0.8")
    images = []
    for k, strategy in enumerate(strategies, start=1):
        position = positions[strategy]
        image = fig.add_subplot(grid[k, :3])
        error = np.where(position.known, np.nan, errors[strategy])
        shown = image.imshow(error, cmap=cmap_error, vmin=0.0, vmax=top, interpolation="nearest")
        image.set_axis_off()
        mar = next(r["mar"] for r in rows if (r["strategy"], r["method"]) == (strategy, "BP"))
        image.set_title(f"{strategy}: BP's |error| where not measured (measured: grey), "
                        f"MAR {mar:.4f} m",
                        fontsize=9)
        images.append(image)
    fig.colorbar(shown, ax=images, location="bottom", label="BP's |error| (m)", extend="max",
                 shrink=0.5, aspect=40)
    bars = fig.add_subplot(grid[1:, 3])
    methods = list(dict.fromkeys(r["method"] for r in rows))
    width = 0.8 / len(methods)
    for m, method in enumerate(methods):
        values = [next(r["mar"] for r in rows if (r["strategy"], r["method"]) == (s, method))
                  for s in strategies]
        bars.bar(np.arange(len(strategies)) + (m - (len(methods) - 1) / 2) * width, values,
                 width, label=method)
    bars.set_xticks(range(len(strategies)), strategies, rotation=30)
    bars.set_ylabel("MAR (m), Eq. 13")
    bars.legend(fontsize=8)
    bars.set_title("MAR, same slices", fontsize=9)
    return fig
