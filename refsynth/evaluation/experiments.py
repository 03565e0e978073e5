"""The paper's experiments as code: scenes × samplings × methods → tables (§3.3).

``python -m refsynth evaluate`` runs a grid of *cases* — a scene at a size,
a sampling of its range, a method, and (for NP, which draws at random) a
seed — scores each with the measures of :mod:`refsynth.evaluation.metrics` (MAR of
Eq. 13, RMSE, bad > 1, bad > 3) over the pixels that were unknown and have
ground truth, and aggregates the seeds of each scene × sampling × method
into one row (mean and spread). Cases are independent, so the grid runs in
parallel: local processes (``--jobs N``) or an existing Dask cluster
(``--scheduler ADDRESS``, with ``dask.distributed`` installed), through the
same :class:`concurrent.futures.Executor` interface. Every case is a pure
function of its specification, so the tables are bit-identical across runs,
whatever runs them; only the ``seconds`` column (wall time) varies.

Cases are named compactly, as on the command line:

- scenes: ``synthetic`` (the synthetic room of seed 0; ``synthetic-N`` for
  seed N), ``motorcycle`` (the Middlebury 2014 pair of scikit-image), or a
  path pair ``IMAGE:DISPARITY`` (PNG/PFM/NPY, see
  :func:`refsynth.scenes.datasets.load_middlebury`);
- sizes: ``128`` (square), ``450x375`` (width × height, as the paper
  writes it), or ``native`` (a path pair or the Motorcycle as stored);
- samplings: ``gRW_XW`` (the paper's grid stripes, known width RW, unknown
  width XW, Table 1), ``xNN`` (vertical stripes, NN % unknown, Table 4),
  ``distance`` or ``distanceNN`` (Fig. 2's distance-driven columns, 60 % or
  NN % unknown);
- methods: ``np``, ``np-noedges``, ``np-noisophotes``, ``np-onion``, ``bp``,
  ``bp-noedges``, and the baselines of :mod:`refsynth.evaluation.baselines` by name
  (``nearest``, ``linear``, ``harmonic``, ``colorization``,
  ``joint-bilateral``).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 (Tables 1–4, Figs. 7, 11, 13, 16,
17), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import functools
import json
import math
import multiprocessing
import re
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "Case",
    "SYNTHESIS_METHODS",
    "DEFAULT_SAMPLINGS",
    "DEFAULT_GRID",
    "QUICK_GRID",
    "TIMING_FIELDS",
    "PAPER",
    "method_names",
    "parse_scene",
    "parse_size",
    "parse_sampling",
    "parse_method",
    "parse_list",
    "build_cases",
    "grid_cases",
    "load_scene",
    "known_mask",
    "score",
    "run_case",
    "run_cases",
    "aggregate",
    "without_timing",
    "findings",
    "format_results",
    "format_pivot",
    "format_runtimes",
    "format_findings",
    "format_winners",
    "format_paper_comparison",
    "write_json",
    "read_json",
    "write_csv",
    "add_evaluate_parser",
]

#: The synthesis variants: keyword arguments of :func:`refsynth.synthesize`.
SYNTHESIS_METHODS: dict[str, dict] = {
    "np": {},
    "np-noedges": {"use_edges": False},
    "np-noisophotes": {"use_isophotes": False},
    "np-onion": {"ordering": "onion"},
    "bp": {"method": "bp"},
    "bp-noedges": {"method": "bp", "use_edges": False},
}

#: Every sampling of the paper's experiments: Table 1's grids, Table 4's
#: x-stripes and Fig. 2's distance-driven columns.
DEFAULT_SAMPLINGS = ("g24_80", "g10_20", "g5_25", "g3_28", "x63", "x78", "x85", "distance")

#: Known fraction of Fig. 2's sampling when the spec gives none: §4 scans
#: 30–50 % of the slices.
DISTANCE_KNOWN_FRACTION = 0.4

#: Row fields that hold wall time: they differ between runs and are left
#: out of every identity check (:func:`without_timing`, ``--no-timing``).
TIMING_FIELDS = ("seconds",)


def method_names() -> tuple[str, ...]:
    """Every method name: the synthesis variants, then the baselines."""
    from refsynth.evaluation.baselines import BASELINES

    return (*SYNTHESIS_METHODS, *BASELINES)


def _all_methods() -> str:
    return ",".join(method_names())


#: The default grid, as blocks of (scenes, size, samplings, methods); ``None``
#: for the methods means all of them. Block 1 is Tables 1, 3 and 4 on 128×128
#: scenes; block 2 adds three more rooms at Table 2/3's sampling; block 3 is
#: Table 4 at the paper's Middlebury size.
DEFAULT_GRID: tuple[tuple[str, str, str, str | None], ...] = (
    ("synthetic,motorcycle", "128", ",".join(DEFAULT_SAMPLINGS), None),
    ("synthetic-1,synthetic-2,synthetic-3", "128", "g5_25", "np,np-noedges,bp"),
    ("motorcycle", "450x375", "x63,x78,x85", None),
)

#: A grid of seconds, for smoke tests: a 32×32 room.
QUICK_GRID: tuple[tuple[str, str, str, str | None], ...] = (
    ("synthetic", "32", "g3_8,x78", "np,np-noedges,np-onion,bp,nearest,colorization"),
)


# ----------------------------------------------------------------------------- specs


@dataclass(frozen=True)
class Case:
    """One run: a scene at a size, a sampling, a method and a seed, all as spec strings.

    Attributes
    ----------
    scene : str
        ``synthetic``, ``synthetic-N``, ``motorcycle`` or ``IMAGE:DISPARITY``
        (absolute paths).
    size : str
        ``WxH`` or ``native``.
    sampling : str
        ``gRW_XW``, ``xNN``, ``distance`` or ``distanceNN``.
    method : str
        A name of :func:`method_names`.
    seed : int
        The synthesis seed (0 for deterministic methods).
    """

    scene: str
    size: str
    sampling: str
    method: str
    seed: int

    @property
    def label(self) -> str:
        """A one-line description for progress reports."""
        return (f"{_scene_label(self.scene)} {self.size} {self.sampling} {self.method} "
                f"seed {self.seed}")


def _scene_label(scene: str) -> str:
    if ":" in scene:
        image, disparity = _split_pair(scene)
        return f"{Path(image).name}:{Path(disparity).name}"
    return scene


def _split_pair(text: str) -> tuple[str, str]:
    """Split ``IMAGE:DISPARITY``; with several colons, at the one whose halves exist."""
    parts = text.split(":")
    if len(parts) == 2:
        return parts[0], parts[1]
    for i in range(1, len(parts)):
        image, disparity = ":".join(parts[:i]), ":".join(parts[i:])
        if Path(image).is_file() and Path(disparity).is_file():
            return image, disparity
    raise ValueError(f"scene {text!r}: cannot tell IMAGE from DISPARITY at its colons")


def parse_scene(text: str) -> str:
    """Validate a scene spec and return it in canonical form.

    Parameters
    ----------
    text : str
        ``synthetic`` (room of seed 0), ``synthetic-N``, ``motorcycle``, or
        ``IMAGE:DISPARITY`` (two existing files).

    Returns
    -------
    str
        ``synthetic-N``, ``motorcycle`` or ``IMAGE:DISPARITY`` with absolute
        paths (so that workers elsewhere on the machine find them).

    Raises
    ------
    ValueError
        If the spec is none of these.
    OSError
        If a file of a path pair does not exist.

    Examples
    --------
    >>> parse_scene("synthetic"), parse_scene("synthetic-3"), parse_scene("motorcycle")
    ('synthetic-0', 'synthetic-3', 'motorcycle')
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"scene must be a non-empty string, got {text!r}")
    text = text.strip()
    if text == "synthetic":
        return "synthetic-0"
    match = re.fullmatch(r"synthetic-(\d+)", text)
    if match:
        return f"synthetic-{int(match.group(1))}"
    if text == "motorcycle":
        return text
    if ":" in text:
        image, disparity = _split_pair(text)
        for what, path in (("image", image), ("disparity", disparity)):
            if not path:
                raise ValueError(f"scene {text!r}: the {what} path is empty")
            if not Path(path).is_file():
                raise FileNotFoundError(f"scene {text!r}: {what} file not found: {path}")
        return f"{Path(image).resolve()}:{Path(disparity).resolve()}"
    raise ValueError(
        f"unknown scene {text!r}: expected synthetic, synthetic-N, motorcycle or IMAGE:DISPARITY"
    )


def parse_size(text: str) -> str:
    """Validate a size spec: ``128`` (square), ``450x375`` (W×H) or ``native``.

    Returns
    -------
    str
        ``WxH`` or ``native``.

    Examples
    --------
    >>> parse_size("128"), parse_size("450x375"), parse_size("native")
    ('128x128', '450x375', 'native')
    """
    if not isinstance(text, str):
        raise ValueError(f"size must be a string, got {text!r}")
    text = text.strip().lower()
    if text == "native":
        return text
    match = re.fullmatch(r"(\d+)(?:x(\d+))?", text)
    if not match:
        raise ValueError(f"bad size {text!r}: expected N (square), WxH such as 450x375, or native")
    width = int(match.group(1))
    height = int(match.group(2)) if match.group(2) else width
    if width < 16 or height < 16:
        raise ValueError(f"bad size {text!r}: width and height must be at least 16 pixels")
    return f"{width}x{height}"


def _size_tuple(size: str) -> tuple[int, int] | None:
    """``"450x375"`` → ``(450, 375)`` (width, height); ``"native"`` → None."""
    if size == "native":
        return None
    width, height = size.split("x")
    return int(width), int(height)


def parse_sampling(text: str) -> str:
    """Validate a sampling spec: ``gRW_XW``, ``xNN``, ``distance`` or ``distanceNN``.

    Returns
    -------
    str
        The spec in canonical form (no leading zeros).

    Raises
    ------
    ValueError
        If the spec is malformed or out of range: RW, XW >= 1; NN in 1 … 99.

    Examples
    --------
    >>> parse_sampling("g5_25"), parse_sampling("x078"), parse_sampling("distance")
    ('g5_25', 'x78', 'distance')
    """
    if not isinstance(text, str):
        raise ValueError(f"sampling must be a string, got {text!r}")
    text = text.strip().lower()
    match = re.fullmatch(r"g(\d+)_(\d+)", text)
    if match:
        rw, xw = int(match.group(1)), int(match.group(2))
        if rw < 1 or xw < 1:
            raise ValueError(f"bad sampling {text!r}: gRW_XW needs RW >= 1 and XW >= 1")
        return f"g{rw}_{xw}"
    match = re.fullmatch(r"(x|distance)(\d+)", text)
    if match:
        percent = int(match.group(2))
        if not 1 <= percent <= 99:
            raise ValueError(f"bad sampling {text!r}: the unknown percentage must be in 1..99")
        return f"{match.group(1)}{percent}"
    if text == "distance":
        return text
    raise ValueError(
        f"unknown sampling {text!r}: expected gRW_XW (grid stripes, e.g. g5_25), "
        "xNN (x-stripes, NN % unknown, e.g. x78), distance or distanceNN"
    )


def parse_method(text: str) -> str:
    """Validate a method name (see :func:`method_names`).

    Examples
    --------
    >>> parse_method("np-onion"), parse_method("colorization")
    ('np-onion', 'colorization')
    """
    if not isinstance(text, str) or text.strip().lower() not in method_names():
        raise ValueError(f"unknown method {text!r}: choose from {', '.join(method_names())}")
    return text.strip().lower()


def parse_list(text: str, parse: Callable[[str], str], what: str) -> list[str]:
    """Parse a comma-separated list with ``parse``, dropping duplicates, keeping order.

    Raises
    ------
    ValueError
        If the list or one of its items is empty, or an item does not parse.

    Examples
    --------
    >>> parse_list("x78,g5_25,x78", parse_sampling, "sampling")
    ['x78', 'g5_25']
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"empty {what} list")
    items = [item.strip() for item in text.split(",")]
    if any(not item for item in items):
        raise ValueError(f"empty item in the {what} list {text!r}")
    return list(dict.fromkeys(parse(item) for item in items))


def _is_stochastic(method: str) -> bool:
    """NP draws from the Eq. 5 set; BP and the baselines are deterministic."""
    return method.startswith("np")


def build_cases(
    scenes: Sequence[str],
    sizes: Sequence[str],
    samplings: Sequence[str],
    methods: Sequence[str],
    seeds: int = 3,
) -> list[Case]:
    """The product scenes × sizes × samplings × methods (× seeds for NP), in that order.

    Parameters
    ----------
    scenes, sizes, samplings, methods : sequence of str
        Specs, parsed with :func:`parse_scene` etc.
    seeds : int, default 3
        NP variants run with seeds ``0 … seeds − 1``; the others once (seed 0).

    Returns
    -------
    list of Case
    """
    if isinstance(seeds, bool) or not isinstance(seeds, (int, np.integer)) or seeds < 1:
        raise ValueError(f"seeds must be a positive integer, got {seeds!r}")
    scenes = [parse_scene(s) for s in scenes]
    sizes = [parse_size(s) for s in sizes]
    samplings = [parse_sampling(s) for s in samplings]
    methods = [parse_method(m) for m in methods]
    cases = []
    for scene in scenes:
        for size in sizes:
            if size == "native" and scene.startswith("synthetic"):
                raise ValueError(f"scene {scene!r} has no native size: give --size, e.g. 128")
            for sampling in samplings:
                for method in methods:
                    for seed in range(int(seeds) if _is_stochastic(method) else 1):
                        cases.append(Case(scene, size, sampling, method, seed))
    return cases


def grid_cases(
    blocks: Iterable[tuple[str, str, str, str | None]], seeds: int = 3,
    methods: str | None = None,
) -> list[Case]:
    """The cases of a grid given as blocks ``(scenes, sizes, samplings, methods)`` of lists.

    ``methods`` (a comma-separated list) replaces every block's methods.
    """
    cases: list[Case] = []
    for scenes, sizes, samplings, block_methods in blocks:
        chosen = methods or block_methods or _all_methods()
        cases += build_cases(
            parse_list(scenes, parse_scene, "scene"), parse_list(sizes, parse_size, "size"),
            parse_list(samplings, parse_sampling, "sampling"),
            parse_list(chosen, parse_method, "method"), seeds,
        )
    return list(dict.fromkeys(cases))


# ----------------------------------------------------------------------------- one case


@functools.lru_cache(maxsize=8)
def load_scene(scene: str, size: str):
    """Load a scene spec at a size spec (cached per process).

    Returns
    -------
    refsynth.scenes.datasets.Scene
    """
    from refsynth.scenes.datasets import load_middlebury, motorcycle, synthetic_room

    dims = _size_tuple(size)
    if scene.startswith("synthetic-"):
        if dims is None:
            raise ValueError(f"scene {scene!r} has no native size: give a size, e.g. 128")
        return synthetic_room((dims[1], dims[0]), seed=int(scene.split("-")[1]))
    if scene == "motorcycle":
        return motorcycle(dims if dims is not None else (741, 500))
    image, disparity = _split_pair(scene)
    return load_middlebury(image, disparity, size=dims)


def known_mask(scene, sampling: str) -> np.ndarray:
    """The known-range mask of a sampling spec on a scene, without pixels that lack truth.

    Pixels without ground truth are never given to the synthesis (there is
    no range to give) and never scored (:func:`refsynth.evaluation.metrics.evaluate`
    skips them).

    Parameters
    ----------
    scene : refsynth.scenes.datasets.Scene
    sampling : str
        A spec of :func:`parse_sampling`.

    Returns
    -------
    ndarray of shape (H, W), bool
        ``True`` where the range is known.

    Notes
    -----
    ``distance`` uses the ground truth's per-column median as the coarse
    range of Fig. 2 (for disparity, its inverse, which grows with
    distance), standing in for the rig's coarse pass.
    """
    from refsynth.acquisition.sampling import distance_driven, stripes, x_stripes_for_fraction

    sampling = parse_sampling(sampling)
    shape = scene.range.shape
    if sampling.startswith("g"):
        rw, xw = (int(v) for v in sampling[1:].split("_"))
        mask = stripes(shape, rw, xw, axes="xy")
    elif sampling.startswith("x"):
        mask = x_stripes_for_fraction(shape, int(sampling[1:]) / 100.0)
    else:
        percent = sampling[len("distance"):]
        known_fraction = 1.0 - int(percent) / 100.0 if percent else DISTANCE_KNOWN_FRACTION
        truth = scene.range
        if scene.units.startswith("disparity"):
            with np.errstate(divide="ignore"):
                truth = np.where(truth > 0, 1.0 / truth, np.nan)
        mask = distance_driven(truth, known_fraction=known_fraction)
    return mask & scene.has_truth


def score(scene, known: np.ndarray, method: str, seed: int = 0) -> dict:
    """Fill the scene's range outside ``known`` with a method and score it (Eq. 13 and more).

    Parameters
    ----------
    scene : refsynth.scenes.datasets.Scene
    known : ndarray of shape (H, W), bool
        The pixels whose range the method is given.
    method : str
        A name of :func:`method_names`.
    seed : int
        The synthesis seed (unused by deterministic methods).

    Returns
    -------
    dict
        ``mar``, ``rmse``, ``bad1``, ``bad3``, ``evaluated`` (the number of
        unknown pixels with ground truth), ``known`` (the number of known
        pixels), ``unknown_percent`` (of the image) and ``seconds`` (wall
        time of the fill alone).
    """
    from refsynth import synthesize
    from refsynth.acquisition.sampling import unknown_fraction
    from refsynth.evaluation.baselines import BASELINES
    from refsynth.evaluation.metrics import evaluate

    method = parse_method(method)
    partial = np.where(known, scene.range, np.nan)
    start = time.perf_counter()
    if method in BASELINES:
        estimate = BASELINES[method](scene.intensity, partial)
    else:
        estimate = synthesize(scene.intensity, partial, seed=seed,
                              **SYNTHESIS_METHODS[method]).range
    seconds = time.perf_counter() - start
    scores = evaluate(estimate, scene.range, known)
    return dict(
        unknown_percent=100.0 * unknown_fraction(known),
        known=int(np.count_nonzero(known)),
        evaluated=scores["n"],
        mar=scores["mar"],
        rmse=scores["rmse"],
        bad1=scores["bad1"],
        bad3=scores["bad3"],
        seconds=seconds,
    )


def run_case(case: Case) -> dict:
    """Run one case; the result is a pure function of ``case`` apart from ``seconds``.

    Returns
    -------
    dict
        The case's fields, the scene's name and units, and :func:`score`'s.
    """
    scene = load_scene(case.scene, case.size)
    known = known_mask(scene, case.sampling)
    height, width = scene.range.shape
    return dict(
        scene=scene.name,
        scene_spec=case.scene,
        size=f"{width}x{height}",
        units=scene.units,
        sampling=case.sampling,
        method=case.method,
        seed=case.seed,
        **score(scene, known, case.method, case.seed),
    )


def _check_cases(cases: Sequence[Case]) -> None:
    """Load every scene and sampling once, so that user errors surface before any work."""
    seen = set()
    for case in cases:
        key = (case.scene, case.size, case.sampling)
        if key in seen:
            continue
        seen.add(key)
        scene = load_scene(case.scene, case.size)
        known = known_mask(scene, case.sampling)
        label = f"{_scene_label(case.scene)} {case.size} {case.sampling}"
        if not known.any():
            raise ValueError(f"{label}: the sampling leaves no known range")
        if not (~known & scene.has_truth).any():
            raise ValueError(f"{label}: the sampling leaves nothing to evaluate")


def _cost(case: Case) -> float:
    """A rough relative cost, to start the longest cases first."""
    dims = _size_tuple(case.size) or (741, 500)
    factor = {"bp": 2.0, "bp-noedges": 2.0, "np-onion": 0.5}.get(case.method, 1.0)
    if case.method not in SYNTHESIS_METHODS:
        factor = 0.2
    return dims[0] * dims[1] * factor


ProgressCallback = Callable[[int, int, Case, dict, float], None]


def _executor(jobs: int, scheduler: str | None):
    """An executor and a function that closes it (None, None: run in this process)."""
    if scheduler is not None:
        try:
            from dask.distributed import Client
        except ImportError as error:
            raise ImportError(
                "--scheduler needs dask.distributed: pip install 'dask[distributed]' "
                "(or refsynth[dask])"
            ) from error
        try:
            client = Client(scheduler, timeout="10s")
        except OSError as error:
            message = " ".join(str(error).split())
            raise OSError(f"cannot reach the Dask scheduler at {scheduler}: {message}") from None
        executor = client.get_executor(pure=False)

        def close(cancel: bool) -> None:
            executor.shutdown(wait=not cancel)  # wait=False cancels what is left
            client.close()

        return executor, close
    if jobs > 1:
        # spawn, not fork: a forked child of a process with threads (BLAS, Dask) can deadlock
        pool = concurrent.futures.ProcessPoolExecutor(
            max_workers=jobs, mp_context=multiprocessing.get_context("spawn")
        )
        return pool, lambda cancel: pool.shutdown(wait=True, cancel_futures=cancel)
    return None, None


def run_cases(
    cases: Sequence[Case],
    *,
    jobs: int = 1,
    scheduler: str | None = None,
    progress: ProgressCallback | None = None,
) -> list[dict]:
    """Run cases, in this process, in local processes or on a Dask cluster.

    Parameters
    ----------
    cases : sequence of Case
    jobs : int, default 1
        Local worker processes (spawned); 1 runs every case in this process.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); the cases then run
        on its workers through ``Client(scheduler).get_executor()``, and
        ``jobs`` is ignored. The workers need refsynth (and scikit-image for
        the Motorcycle) installed, and any path-pair files at the same paths.
    progress : callable, optional
        Called as ``progress(done, total, case, result, elapsed_seconds)``
        after each case.

    Returns
    -------
    list of dict
        :func:`run_case`'s results, in the order of ``cases`` (whatever order
        they finished in).
    """
    if isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)) or jobs < 1:
        raise ValueError(f"jobs must be a positive integer, got {jobs!r}")
    cases = list(cases)
    _check_cases(cases)
    results: list[dict | None] = [None] * len(cases)
    start = time.perf_counter()
    order = sorted(range(len(cases)), key=lambda i: -_cost(cases[i]))  # stable: ties keep order
    executor, close = _executor(int(jobs), scheduler)
    done = 0
    if executor is None:
        for i in range(len(cases)):
            results[i] = run_case(cases[i])
            done += 1
            if progress is not None:
                progress(done, len(cases), cases[i], results[i], time.perf_counter() - start)
        return results  # type: ignore[return-value]
    finished = False
    try:
        futures = {executor.submit(run_case, cases[i]): i for i in order}
        for future in concurrent.futures.as_completed(futures):
            i = futures[future]
            results[i] = future.result()
            done += 1
            if progress is not None:
                progress(done, len(cases), cases[i], results[i], time.perf_counter() - start)
        finished = True
    finally:
        close(not finished)  # on an error or Ctrl-C, drop the cases not yet started
    return results  # type: ignore[return-value]


# ----------------------------------------------------------------------------- aggregation


def _mean(values: Sequence[float]) -> float:
    return float(math.fsum(values) / len(values))


def aggregate(runs: Sequence[dict]) -> list[dict]:
    """One row per scene × size × sampling × method: the mean and spread over seeds.

    Parameters
    ----------
    runs : sequence of dict
        :func:`run_case` results.

    Returns
    -------
    list of dict
        In order of first appearance. Fields: ``scene``, ``scene_spec``,
        ``size``, ``units``, ``sampling``, ``unknown_percent``, ``known``,
        ``evaluated``, ``method``, ``seeds`` (the list), ``mar`` (mean over
        seeds), ``mar_sd`` (sample standard deviation, ``None`` for one
        seed), ``mar_min``, ``mar_max``, ``mar_per_seed``, ``rmse``, ``bad1``,
        ``bad3`` (means) and ``seconds`` (mean wall time of the fill, the
        only field that differs between runs).

    Examples
    --------
    >>> runs = [dict(scene="s", scene_spec="s", size="8x8", units="m", sampling="x78",
    ...              unknown_percent=75.0, known=16, evaluated=48, method="np", seed=s,
    ...              mar=m, rmse=m, bad1=0.0, bad3=0.0, seconds=1.0)
    ...         for s, m in enumerate([1.0, 2.0, 3.0])]
    >>> row = aggregate(runs)[0]
    >>> row["mar"], row["mar_sd"], row["seeds"]
    (2.0, 1.0, [0, 1, 2])
    """
    groups: dict[tuple, list[dict]] = {}
    for run in runs:
        key = (run["scene_spec"], run["size"], run["sampling"], run["method"])
        groups.setdefault(key, []).append(run)
    rows = []
    for members in groups.values():
        members = sorted(members, key=lambda r: r["seed"])
        first = members[0]
        mars = [m["mar"] for m in members]
        rows.append(dict(
            scene=first["scene"],
            scene_spec=first["scene_spec"],
            size=first["size"],
            units=first["units"],
            sampling=first["sampling"],
            unknown_percent=first["unknown_percent"],
            known=first["known"],
            evaluated=first["evaluated"],
            method=first["method"],
            seeds=[m["seed"] for m in members],
            mar=_mean(mars),
            mar_sd=float(np.std(mars, ddof=1)) if len(mars) > 1 else None,
            mar_min=min(mars),
            mar_max=max(mars),
            mar_per_seed=mars,
            rmse=_mean([m["rmse"] for m in members]),
            bad1=_mean([m["bad1"] for m in members]),
            bad3=_mean([m["bad3"] for m in members]),
            seconds=_mean([m["seconds"] for m in members]),
        ))
    return rows


def without_timing(rows: Sequence[dict]) -> list[dict]:
    """The rows without their :data:`TIMING_FIELDS`: what must be identical across runs."""
    return [{k: v for k, v in row.items() if k not in TIMING_FIELDS} for row in rows]


# ----------------------------------------------------------------------------- findings


#: The paper's relative findings, as (name, better method, worse method, source).
PAIRWISE_FINDINGS = (
    ("BP < NP", "bp", "np", "Tables 1–4"),
    ("NP < NP without edges", "np", "np-noedges", "Table 3, Fig. 13"),
    ("BP < NP without edges", "bp", "np-noedges", "Table 3, Fig. 13"),
    ("priority order < onion order", "np", "np-onion", "Fig. 7"),
    ("isophotes help: NP < NP without isophotes", "np", "np-noisophotes", "Fig. 16"),
)


def _spread(row: dict) -> float:
    return row["mar_sd"] or 0.0


def findings(rows: Sequence[dict]) -> list[dict]:
    """Check the paper's relative findings on aggregated rows.

    For each scene × sampling where both methods of a pairwise finding ran,
    the finding *holds* when the first method's mean MAR is lower; it is a
    *tie* when the difference is within the sum of the two standard
    deviations over seeds (a deterministic method has none). "Error grows
    with the unknown fraction" is checked per scene × method over the
    x-stripe samplings, which differ only in their fraction.

    Returns
    -------
    list of dict
        ``finding``, ``source``, ``scene``, ``sampling``, ``better`` (the MAR
        of the method the paper finds better, or the sequence of MARs),
        ``worse`` and ``verdict`` (``"holds"``, ``"tie"`` or ``"fails"``).
    """
    index = {(r["scene"], r["sampling"], r["method"]): r for r in rows}
    out = []
    scenes_samplings = list(dict.fromkeys((r["scene"], r["sampling"]) for r in rows))
    for name, better, worse, source in PAIRWISE_FINDINGS:
        for scene, sampling in scenes_samplings:
            a, b = index.get((scene, sampling, better)), index.get((scene, sampling, worse))
            if a is None or b is None:
                continue
            difference = b["mar"] - a["mar"]
            if abs(difference) <= _spread(a) + _spread(b):
                verdict = "tie"
            else:
                verdict = "holds" if difference > 0 else "fails"
            out.append(dict(finding=name, source=source, scene=scene, sampling=sampling,
                            better=a["mar"], worse=b["mar"], verdict=verdict))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for method in methods:
            series = sorted(
                (r for r in rows if r["scene"] == scene and r["method"] == method
                 and r["sampling"].startswith("x")),
                key=lambda r: r["unknown_percent"],
            )
            if len(series) < 2:
                continue
            mars = [r["mar"] for r in series]
            grows = all(b > a for a, b in zip(mars, mars[1:]))
            out.append(dict(finding=f"error grows with the unknown fraction ({method})",
                            source="Tables 1, 4", scene=scene,
                            sampling=",".join(r["sampling"] for r in series),
                            better=mars, worse=None, verdict="holds" if grows else "fails"))
    return out


# ----------------------------------------------------------------------------- tables


def _fmt_mar(row: dict) -> str:
    text = f"{row['mar']:.3f}"
    if row["mar_sd"] is not None:
        text += f" ± {row['mar_sd']:.3f}"
    return text


def format_results(rows: Sequence[dict], *, timing: bool = True) -> str:
    """Markdown tables, one per scene, of the aggregated rows.

    Columns: sampling, unknown %, method, seeds, MAR (mean ± sd over seeds),
    RMSE, bad > 1 and bad > 3 (% of the evaluated pixels, in the scene's
    units), and, with ``timing``, the mean wall time of one fill.
    """
    blocks = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        members = [r for r in rows if r["scene"] == scene]
        units = members[0]["units"]
        header = ["sampling", "unknown", "method", "seeds", f"MAR ({units})", "RMSE",
                  "bad>1", "bad>3"] + (["seconds"] if timing else [])
        lines = [f"### {scene} ({units})", "", "| " + " | ".join(header) + " |",
                 "|" + "---|" * len(header)]
        for r in members:
            cells = [r["sampling"], f"{r['unknown_percent']:.1f} %", r["method"],
                     str(len(r["seeds"])), _fmt_mar(r), f"{r['rmse']:.3f}",
                     f"{100 * r['bad1']:.1f} %", f"{100 * r['bad3']:.1f} %"]
            if timing:
                cells.append(f"{r['seconds']:.2f}")
            lines.append("| " + " | ".join(cells) + " |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def format_pivot(rows: Sequence[dict]) -> str:
    """Markdown: one table per scene, a row per sampling, a column per method (mean MAR ± sd
    over seeds), in the scene's units."""
    blocks = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        members = [r for r in rows if r["scene"] == scene]
        methods = list(dict.fromkeys(r["method"] for r in members))
        index = {(r["sampling"], r["method"]): r for r in members}
        lines = [f"MAR, {scene} ({members[0]['units']})", "",
                 "| sampling | unknown | " + " | ".join(methods) + " |",
                 "|---|---|" + "---|" * len(methods)]
        for sampling in dict.fromkeys(r["sampling"] for r in members):
            first = next(r for r in members if r["sampling"] == sampling)
            cells = [_fmt_mar(index[sampling, m]) if (sampling, m) in index else "–"
                     for m in methods]
            lines.append(f"| {sampling} | {first['unknown_percent']:.1f} % | "
                         + " | ".join(cells) + " |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def format_runtimes(rows: Sequence[dict]) -> str:
    """Markdown: mean wall time of one fill per scene size × method (over samplings and
    seeds), from the rows' ``seconds``."""
    timed = [r for r in rows if r.get("seconds") is not None]
    if not timed:
        return ""
    sizes = list(dict.fromkeys(r["size"] for r in timed))
    methods = list(dict.fromkeys(r["method"] for r in timed))
    lines = ["| method | " + " | ".join(sizes) + " |", "|---|" + "---|" * len(sizes)]
    for method in methods:
        cells = []
        for size in sizes:
            runs = [(r["seconds"], len(r["seeds"])) for r in timed
                    if r["method"] == method and r["size"] == size]
            total = sum(n for _, n in runs)
            cells.append(f"{sum(t * n for t, n in runs) / total:.2f} s" if total else "–")
        lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _finding_group(item: dict) -> str:
    """The finding's name without the method of a growth check."""
    return item["finding"].split(" (")[0] if item["worse"] is None else item["finding"]


def format_findings(items: Sequence[dict], *, detail: bool = True) -> str:
    """Markdown: a summary (finding × scene: holds / ties / fails), then, with ``detail``,
    one line per check."""
    if not items:
        return "(no finding can be checked: the grid lacks the methods to compare)"
    scenes = list(dict.fromkeys(f["scene"] for f in items))
    groups = list(dict.fromkeys(_finding_group(f) for f in items))
    sources = {_finding_group(f): f["source"] for f in items}

    def counts(members: list[dict]) -> str:
        if not members:
            return "–"
        verdicts = [m["verdict"] for m in members]
        return " / ".join(str(verdicts.count(v)) for v in ("holds", "tie", "fails"))

    lines = ["Each cell: holds / ties / fails (a tie: the difference is within the sum of the "
             "two standard deviations over seeds).", "",
             "| finding (paper) | " + " | ".join(scenes) + " | all |",
             "|---|" + "---|" * (len(scenes) + 1)]
    for group in groups:
        members = [f for f in items if _finding_group(f) == group]
        cells = [counts([m for m in members if m["scene"] == scene]) for scene in scenes]
        lines.append(f"| {group} ({sources[group]}) | " + " | ".join(cells)
                     + f" | {counts(members)} |")
    if detail:
        lines += ["", "| finding (paper) | scene | sampling | MAR (first vs second) | verdict |",
                  "|---|---|---|---|---|"]
        for f in items:
            if f["worse"] is None:
                mar = " → ".join(f"{m:.3f}" for m in f["better"])
            else:
                mar = f"{f['better']:.3f} vs {f['worse']:.3f}"
            lines.append(f"| {f['finding']} ({f['source']}) | {f['scene']} | {f['sampling']} "
                         f"| {mar} | {f['verdict']} |")
    return "\n".join(lines)


def _best(group: Sequence[dict]) -> str:
    row = min(group, key=lambda r: r["mar"])
    return f"{row['method']} {_fmt_mar(row)}"


def format_winners(rows: Sequence[dict]) -> str:
    """Markdown: per scene × sampling, the best method by mean MAR, NP and BP with the
    paper's defaults, the best of refsynth's variants, the best baseline and the nearest
    fill — where refsynth wins and where it loses."""
    from refsynth.evaluation.baselines import BASELINES

    lines = ["| scene | sampling | best | np | bp | best refsynth variant | best baseline "
             "| nearest |", "|---|---|---|---|---|---|---|---|"]
    for scene, sampling in dict.fromkeys((r["scene"], r["sampling"]) for r in rows):
        members = {r["method"]: r for r in rows
                   if r["scene"] == scene and r["sampling"] == sampling}
        ours = [r for m, r in members.items() if m in SYNTHESIS_METHODS]
        theirs = [r for m, r in members.items() if m in BASELINES]
        if not ours or not theirs:
            continue
        cells = [_fmt_mar(members[m]) if m in members else "–" for m in ("np", "bp")]
        nearest = _fmt_mar(members["nearest"]) if "nearest" in members else "–"
        lines.append(f"| {scene} | {sampling} | {_best(list(members.values()))} | "
                     f"{cells[0]} | {cells[1]} | {_best(ours)} | {_best(theirs)} | {nearest} |")
    return "\n".join(lines) if len(lines) > 2 else ""


#: The paper's MARs (cm for USF, the units of its range images for
#: Middlebury), as read in shared/paper/EQUATIONS.md: table → row → method → MAR.
PAPER: dict[str, dict[str, dict[str, float]]] = {
    "Table 1 (USF 128×128, cm)": {
        "g24_80": {"np": 36.36, "bp": 4.23}, "g10_20": {"np": 5.76, "bp": 1.33},
        "g5_25": {"np": 8.86, "bp": 1.85}, "g3_28": {"np": 9.99, "bp": 2.76},
    },
    "Table 2 (USF 128×128, mean of 32 images at 61 %, cm)": {"mean": {"np": 4.27, "bp": 2.65}},
    "Table 3 (USF 128×128, 61 %, cm)": {
        "image 1": {"np-noedges": 8.58, "np": 3.77, "bp": 2.58},
        "image 2": {"np-noedges": 13.48, "np": 3.03, "bp": 1.63},
        "image 3": {"np-noedges": 11.39, "np": 2.99, "bp": 2.03},
        "image 4": {"np-noedges": 7.12, "np": 2.20, "bp": 1.36},
    },
    "Table 4 (Middlebury 450×375)": {
        "x63": {"np": 6.42, "bp": 3.90}, "x78": {"np": 6.45, "bp": 3.90},
        "x85": {"np": 7.98, "bp": 4.80},
    },
    "Fig. 16 (Middlebury, 65 % / 62 %)": {
        "65 %": {"np-noisophotes": 10.5, "np": 6.5}, "62 %": {"np-noisophotes": 12.2, "np": 7.3},
    },
}


def _ratio(a: float, b: float) -> str:
    return f"{a / b:.2f}" if b else "–"


def format_paper_comparison(rows: Sequence[dict]) -> str:
    """The paper's Tables 1, 3, 4 and Fig. 16 beside our analogues, where the grid has them.

    Table 1 ↔ the synthetic room 128×128 on the grid samplings; Table 3 ↔
    the rooms at g5_25 (no edges / NP / BP); Table 4 ↔ the Motorcycle
    450×375 on x-stripes; Fig. 16 ↔ the Motorcycle 450×375 at x63 (no
    isophotes / NP). The paper's scenes and units differ from ours, so
    compare the orderings, not the numbers.
    """
    index = {(r["scene"], r["sampling"], r["method"]): r for r in rows}

    def ours(scene: str, sampling: str, method: str) -> str:
        row = index.get((scene, sampling, method))
        return _fmt_mar(row) if row else "–"

    def ours_ratio(scene: str, sampling: str) -> str:
        bp, np_row = index.get((scene, sampling, "bp")), index.get((scene, sampling, "np"))
        return _ratio(bp["mar"], np_row["mar"]) if bp and np_row else "–"

    blocks = []
    table1 = PAPER["Table 1 (USF 128×128, cm)"]
    if any(("synthetic-room-0", s, "np") in index for s in table1):
        lines = ["Table 1 analogue: synthetic room 0, 128×128 (m) — paper: USF images (cm)", "",
                 "| rw/xw | unknown (ours) | paper NP | paper BP | paper BP/NP | ours NP | ours BP "
                 "| ours BP/NP |", "|---|---|---|---|---|---|---|---|"]
        for sampling, paper in table1.items():
            row = index.get(("synthetic-room-0", sampling, "np"))
            unknown = f"{row['unknown_percent']:.1f} %" if row else "–"
            lines.append(f"| {sampling[1:].replace('_', '/')} | {unknown} | {paper['np']:.2f} | "
                         f"{paper['bp']:.2f} | {_ratio(paper['bp'], paper['np'])} | "
                         f"{ours('synthetic-room-0', sampling, 'np')} | "
                         f"{ours('synthetic-room-0', sampling, 'bp')} | "
                         f"{ours_ratio('synthetic-room-0', sampling)} |")
        blocks.append("\n".join(lines))
    rooms = sorted({r["scene"] for r in rows if r["scene"].startswith("synthetic-room-")
                    and r["sampling"] == "g5_25" and r["size"] == "128x128"})
    if rooms:
        lines = ["Table 3 analogue: rooms at g5_25, 128×128 (m) — paper: four USF images at "
                 "61 % (cm)", "",
                 "| paper image | paper no-edge / NP / BP | our scene | ours no-edge | ours NP "
                 "| ours BP |", "|---|---|---|---|---|---|"]
        for (label, paper), scene in zip(PAPER["Table 3 (USF 128×128, 61 %, cm)"].items(),
                                         rooms):
            lines.append(f"| {label} | {paper['np-noedges']:.2f} / {paper['np']:.2f} / "
                         f"{paper['bp']:.2f} | "
                         f"{scene} | {ours(scene, 'g5_25', 'np-noedges')} | "
                         f"{ours(scene, 'g5_25', 'np')} | {ours(scene, 'g5_25', 'bp')} |")
        means = []
        for method in ("np-noedges", "np", "bp"):
            found = [index[scene, "g5_25", method]["mar"] for scene in rooms
                     if (scene, "g5_25", method) in index]
            means.append(f"{_mean(found):.3f}" if found else "–")
        table2 = PAPER["Table 2 (USF 128×128, mean of 32 images at 61 %, cm)"]["mean"]
        lines.append(f"| Table 2: mean of 32 | – / {table2['np']:.2f} / {table2['bp']:.2f} | "
                     f"mean of {len(rooms)} rooms | " + " | ".join(means) + " |")
        blocks.append("\n".join(lines))
    moto = "motorcycle-450x375"
    if any((moto, s, "np") in index for s in ("x63", "x78", "x85")):
        lines = ["Table 4 analogue: Motorcycle 450×375, x-stripes (disparity px) — paper: "
                 "Middlebury images (its range units)", "",
                 "| unknown (paper / ours) | paper NP | paper BP | paper BP/NP | ours NP | ours BP "
                 "| ours BP/NP |", "|---|---|---|---|---|---|---|"]
        for sampling, paper in PAPER["Table 4 (Middlebury 450×375)"].items():
            row = index.get((moto, sampling, "np"))
            unknown = f"{sampling[1:]} % / {row['unknown_percent']:.1f} %" if row else "–"
            lines.append(f"| {unknown} | {paper['np']:.2f} | {paper['bp']:.2f} | "
                         f"{_ratio(paper['bp'], paper['np'])} | {ours(moto, sampling, 'np')} | "
                         f"{ours(moto, sampling, 'bp')} | {ours_ratio(moto, sampling)} |")
        blocks.append("\n".join(lines))
        if (moto, "x63", "np-noisophotes") in index:
            lines = ["Fig. 16 analogue: isophotes off / on — paper: 10.5 → 6.5 (65 %) and "
                     "12.2 → 7.3 (62 %)", "",
                     "| sampling | ours without isophotes | ours with |", "|---|---|---|"]
            for sampling in ("x63", "x78", "x85"):
                lines.append(f"| {sampling} | {ours(moto, sampling, 'np-noisophotes')} | "
                             f"{ours(moto, sampling, 'np')} |")
            blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


# ----------------------------------------------------------------------------- files


def _json_value(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str | Path, rows: Sequence[dict]) -> None:
    """Write the rows as a JSON list (one object per scene × sampling × method)."""
    clean = [{k: _json_value(v) for k, v in row.items()} for row in rows]
    Path(path).write_text(json.dumps(clean, indent=1, ensure_ascii=False) + "\n",
                          encoding="utf-8")


#: CSV columns, in order (lists are joined with spaces).
CSV_FIELDS = ("scene", "size", "units", "sampling", "unknown_percent", "known", "evaluated",
              "method", "seeds", "mar", "mar_sd", "mar_min", "mar_max", "mar_per_seed",
              "rmse", "bad1", "bad3", "seconds")


def write_csv(path: str | Path, rows: Sequence[dict]) -> None:
    """Write the rows as CSV, one line per scene × sampling × method."""
    fields = [f for f in CSV_FIELDS if not rows or f in rows[0]]
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(fields)
        for row in rows:
            cells = []
            for field in fields:
                value = row[field]
                if isinstance(value, list):
                    value = " ".join(repr(v) for v in value)
                elif value is None:
                    value = ""
                elif isinstance(value, float):
                    value = repr(value)
                cells.append(value)
            writer.writerow(cells)


# ----------------------------------------------------------------------------- command line


def _progress_printer(cases: Sequence[Case]) -> ProgressCallback:
    """A progress callback printing one line per finished case on stderr.

    The time left is estimated from the share of the grid's :func:`_cost`
    done so far (the longest cases start first, so a count would mislead).
    """
    total_cost = sum(_cost(c) for c in cases)
    done_cost = 0.0

    def report(done: int, total: int, case: Case, result: dict, elapsed: float) -> None:
        nonlocal done_cost
        done_cost += _cost(case)
        minutes, seconds = divmod(int(elapsed), 60)
        eta = ""
        if done < total:
            left = int(elapsed * (total_cost - done_cost) / done_cost)
            eta = f", ~{left // 60}:{left % 60:02d} left"
        print(f"[{done:>{len(str(total))}}/{total} {minutes}:{seconds:02d}{eta}] {case.label}: "
              f"MAR {result['mar']:.4f} ({result['seconds']:.1f} s)", file=sys.stderr,
              flush=True)

    return report


def _cases_from_args(args) -> list[Case]:
    if args.seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {args.seeds}")
    methods = None if args.methods is None else ",".join(
        parse_list(args.methods, parse_method, "method"))
    if args.scene is None and args.size is None and args.sampling is None:
        blocks = QUICK_GRID if args.grid == "quick" else DEFAULT_GRID
        return grid_cases(blocks, args.seeds, methods)
    scenes = parse_list(args.scene or "synthetic,motorcycle", parse_scene, "scene")
    samplings = args.sampling or ",".join(DEFAULT_SAMPLINGS)
    cases: list[Case] = []
    for scene in scenes:
        sizes = args.size or ("native" if ":" in scene else "128")
        cases += grid_cases([(scene, sizes, samplings, methods or _all_methods())], args.seeds)
    return list(dict.fromkeys(cases))


def read_json(path: str | Path) -> list[dict]:
    """Read rows written by :func:`write_json` (``--json``).

    Raises
    ------
    OSError
        If the file cannot be read.
    ValueError
        If it is not a JSON list of rows.
    """
    try:
        rows = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON: {error}") from None
    needed = {"scene", "sampling", "method", "mar", "mar_sd", "seeds", "units"}
    if not isinstance(rows, list) or not all(
        isinstance(r, dict) and needed <= r.keys() for r in rows
    ):
        raise ValueError(f"{path} is not a list of rows written by `evaluate --json`")
    return rows


def _cmd_evaluate(args) -> int:
    if args.jobs < 1:
        raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
    wall = None
    if args.load:
        if args.scene or args.size or args.sampling or args.methods or args.scheduler:
            raise ValueError("--load prints saved rows: it takes no --scene, --size, "
                             "--sampling, --methods or --scheduler")
        rows = read_json(args.load)
        where = args.load
        cases: list[Case] = []
    else:
        cases = _cases_from_args(args)
        where = (f"Dask scheduler {args.scheduler}" if args.scheduler else
                 f"{args.jobs} local process{'es' if args.jobs > 1 else ''}")
        if not args.quiet:
            print(f"refsynth evaluate: {len(cases)} cases on {where}", file=sys.stderr,
                  flush=True)
        start = time.perf_counter()
        runs = run_cases(cases, jobs=args.jobs, scheduler=args.scheduler,
                         progress=None if args.quiet else _progress_printer(cases))
        wall = time.perf_counter() - start
        rows = aggregate(runs)
    timing = not args.no_timing and all("seconds" in r for r in rows)
    kept = rows if timing else without_timing(rows)
    print(format_results(rows, timing=timing))
    print("\n### MAR by method\n")
    print(format_pivot(rows))
    if timing:
        print("\n### Mean wall time of one fill\n")
        print(format_runtimes(rows))
    if not args.no_findings:
        print("\n### The paper's relative findings on these cases\n")
        print(format_findings(findings(rows)))
        winners = format_winners(rows)
        if winners:
            print("\n### Where refsynth wins and where it loses (mean MAR)\n")
            print(winners)
        comparison = format_paper_comparison(rows)
        if comparison:
            print("\n### The paper's numbers beside ours\n")
            print(comparison)
    if args.json:
        write_json(args.json, kept)
    if args.csv:
        write_csv(args.csv, kept)
    if not args.quiet and wall is not None:
        minutes, seconds = divmod(wall, 60)
        print(f"refsynth evaluate: {len(cases)} cases in {int(minutes)} min {seconds:.0f} s "
              f"on {where}", file=sys.stderr)
    return 0


def add_evaluate_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``evaluate`` subcommand to an argparse subparsers object.

    The handler (``args.func``) returns 0; user errors raise ``ValueError``,
    ``TypeError``, ``OSError`` (or ``ImportError`` for ``--scheduler``
    without dask) with a one-line message.
    """
    parser = subparsers.add_parser(
        "evaluate",
        help="the paper's experiments and the baselines, side by side",
        description="Run scenes × samplings × methods and print MAR (Eq. 13), RMSE, bad>1, "
        "bad>3 and seconds. Without --scene/--size/--sampling: the default grid (synthetic "
        "room and Motorcycle at 128x128, every sampling and method; rooms 1-3 at g5_25; "
        "Motorcycle 450x375 on x-stripes).",
    )
    parser.add_argument("--scene", help="comma-separated: synthetic, synthetic-N, motorcycle, "
                        "IMAGE:DISPARITY (default: synthetic,motorcycle)")
    parser.add_argument("--size", help="comma-separated: N (square), WxH (e.g. 450x375) or "
                        "native (default: 128; native for IMAGE:DISPARITY)")
    parser.add_argument("--sampling", help="comma-separated: gRW_XW, xNN, distance, distanceNN "
                        f"(default: {','.join(DEFAULT_SAMPLINGS)})")
    parser.add_argument("--methods", help=f"comma-separated (default: all): {_all_methods()}")
    parser.add_argument("--seeds", type=int, default=3,
                        help="seeds per NP case, reported as mean ± sd (default 3)")
    parser.add_argument("--grid", choices=["default", "quick"], default="default",
                        help="the grid when no --scene/--size/--sampling is given")
    parser.add_argument("--jobs", type=int, default=1, help="local worker processes (default 1)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on this Dask scheduler (needs dask.distributed)")
    parser.add_argument("--json", metavar="FILE", help="write the rows as JSON")
    parser.add_argument("--csv", metavar="FILE", help="write the rows as CSV")
    parser.add_argument("--load", metavar="FILE",
                        help="print the tables of a previous --json file instead of running")
    parser.add_argument("--no-timing", action="store_true",
                        help="leave wall times out of the table and files (for identical output)")
    parser.add_argument("--no-findings", action="store_true",
                        help="print only the results tables")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    parser.set_defaults(func=_cmd_evaluate)
    return parser
