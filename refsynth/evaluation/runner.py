"""The experiment runner: fill and score each case, here, in local processes or on Dask (§3.3).

:func:`score` fills a scene's unknown range with one method and scores it with
the measures of :mod:`refsynth.evaluation.metrics` (MAR of Eq. 13, RMSE,
bad > 1, bad > 3) over the pixels that were unknown and have ground truth;
:func:`run_case` does that for a :class:`~refsynth.evaluation.cases.Case`.
Cases are independent, so :func:`run_cases` runs a grid of them in parallel:
local processes (``jobs=N``) or an existing Dask cluster (``scheduler=ADDRESS``,
with ``dask.distributed`` installed), through the same
:class:`concurrent.futures.Executor` interface. Every case is a pure function
of its specification, so the results are bit-identical across runs, whatever
runs them; only ``seconds`` (wall time) varies.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3.1, Eq. 13, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Sequence

import numpy as np

from refsynth._checks import check_int
from refsynth.acquisition.sampling import unknown_fraction
from refsynth.evaluation.baselines import BASELINES
from refsynth.evaluation.cases import (
    SYNTHESIS_METHODS,
    Case,
    known_mask,
    load_scene,
    parse_method,
    scene_label,
    size_tuple,
)
from refsynth.evaluation.metrics import evaluate
from refsynth.synthesis.api import synthesize
from refsynth.synthesis.readings import split_options

__all__ = ["ProgressCallback", "score", "run_case", "case_cost", "run_cases"]

#: ``progress(done, total, case, result, elapsed_seconds)``, called after each case.
ProgressCallback = Callable[[int, int, Case, dict, float], None]


def score(scene, known: np.ndarray, method: str, seed: int = 0) -> dict:
    """Fill the scene's range outside ``known`` with a method and score it (Eq. 13 and more).

    Parameters
    ----------
    scene : refsynth.scenes.Scene
        Intensity, ground-truth range (NaN or inf where there is none) and units.
    known : ndarray of shape (H, W), bool
        The pixels whose range the method is given.
    method : str
        A name of :func:`refsynth.evaluation.cases.method_names`.
    seed : int
        The synthesis seed (unused by deterministic methods).

    Returns
    -------
    dict
        ``mar``, ``rmse``, ``bad1``, ``bad3``, ``evaluated`` (the number of
        unknown pixels with ground truth), ``known`` (the number of known
        pixels), ``unknown_percent`` (of the image) and ``seconds`` (wall
        time of the fill alone).

    Examples
    --------
    >>> from refsynth.evaluation.cases import known_mask
    >>> from refsynth.scenes import synthetic_room
    >>> scene = synthetic_room(shape=(16, 16))
    >>> result = score(scene, known_mask(scene, "x20"), "nearest")
    >>> result["evaluated"], round(result["mar"], 4)
    (64, 0.2914)
    """
    method = parse_method(method)
    partial = np.where(known, scene.range, np.nan)
    start = time.perf_counter()
    if method in BASELINES:
        estimate = BASELINES[method](scene.intensity, partial)
    else:
        keywords, readings = split_options(SYNTHESIS_METHODS[method])
        estimate = synthesize(scene.intensity, partial, seed=seed, **keywords,
                              readings=readings).range
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

    Fill the scene's range outside the sampling's mask and score it (Eq. 13, §3.3.1).

    Parameters
    ----------
    case : Case
        The scene, size, sampling, method and seed to run.

    Returns
    -------
    dict
        The case's fields, the scene's name and units, and :func:`score`'s.

    Examples
    --------
    >>> result = run_case(Case("synthetic-0", "16x16", "x20", "nearest", 0))
    >>> result["scene"], result["units"], round(result["mar"], 4)
    ('synthetic-room-0', 'm', 0.2914)
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
        label = f"{scene_label(case.scene)} {case.size} {case.sampling}"
        if not known.any():
            raise ValueError(f"{label}: the sampling leaves no known range")
        if not (~known & scene.has_truth).any():
            raise ValueError(f"{label}: the sampling leaves nothing to evaluate")


def case_cost(case: Case) -> float:
    """A rough relative cost of a case (pixels × a method factor), to start the longest first.

    Parameters
    ----------
    case : Case
        The case to cost (nothing is run).

    Returns
    -------
    float
        Comparable between cases only.

    Examples
    --------
    >>> case_cost(Case("synthetic-0", "16x16", "x20", "np", 0)) > case_cost(
    ...     Case("synthetic-0", "16x16", "x20", "nearest", 0))
    True
    """
    dims = size_tuple(case.size) or (741, 500)
    factor = {"bp": 2.0, "bp-noedges": 2.0, "bp-fig6": 2.0, "bp-copy": 2.0, "bp-obs-np": 3.0,
              "np-onion": 0.5}.get(case.method, 1.0)
    if case.method not in SYNTHESIS_METHODS:
        factor = 0.2
    return dims[0] * dims[1] * factor


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
            max_workers=jobs, mp_context=multiprocessing.get_context("spawn"),
            initializer=_exit_with_parent,
        )
        return pool, lambda cancel: pool.shutdown(wait=True, cancel_futures=cancel)
    return None, None


def _exit_with_parent() -> None:
    """A worker's initializer: end the worker when the process that spawned it ends.

    A worker computing a case would otherwise outlive a parent killed by a signal
    (``kill``, ``pkill``: no ``finally`` runs there) and keep computing, an orphan.
    A daemon thread waits on the parent's sentinel, which the operating system
    signals when the parent ends, however it ends.
    """
    parent = multiprocessing.parent_process()
    if parent is None:  # not a multiprocessing child
        return

    def watch() -> None:
        parent.join()
        os._exit(1)

    threading.Thread(target=watch, name="refsynth-exit-with-parent", daemon=True).start()


def run_cases(
    cases: Sequence[Case],
    *,
    jobs: int = 1,
    scheduler: str | None = None,
    progress: ProgressCallback | None = None,
) -> list[dict]:
    """Run cases, in this process, in local processes or on a Dask cluster.

    Each case is scored with the MAR of Eq. 13 (§3.3.1) and more (:func:`score`).

    Parameters
    ----------
    cases : sequence of Case
        The runs (:func:`refsynth.evaluation.cases.build_cases`).
    jobs : int, default 1
        Local worker processes (spawned); 1 runs every case in this process.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); the cases then run
        on its workers through ``Client(scheduler).get_executor()``, and
        ``jobs`` is ignored. The workers need refsynth (and scikit-image for
        the Motorcycle) installed, and any path-pair files at the same paths.
    progress : callable, optional
        Called as ``progress(done, total, case, result, elapsed_seconds)``
        after each case (:data:`ProgressCallback`).

    Returns
    -------
    list of dict
        :func:`run_case`'s results, in the order of ``cases`` (whatever order
        they finished in).

    Examples
    --------
    >>> cases = [Case("synthetic-0", "16x16", sampling, "nearest", 0)
    ...          for sampling in ("x20", "x40")]
    >>> [row["sampling"] for row in run_cases(cases)]
    ['x20', 'x40']
    """
    jobs = check_int("jobs", jobs, minimum=1)
    cases = list(cases)
    _check_cases(cases)
    results: list[dict | None] = [None] * len(cases)
    start = time.perf_counter()
    # the longest first; sorted is stable, so ties keep their order
    order = sorted(range(len(cases)), key=lambda i: -case_cost(cases[i]))
    executor, close = _executor(jobs, scheduler)
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

