"""Whole NP and BP runs of the literal reference, with their step traces, as flat arrays.

:func:`run_outputs` runs :func:`refsynth.synthesis.reference.np_reference` or
:func:`~refsynth.synthesis.reference.bp_reference` on a case and returns every array the
oracle stores: the contract's prepared inputs (quantised intensity and range, the integer
window, the tie permutation and the Eq. 5 draws), the outputs, and the step trace.

NP's trace has one row per step; the ragged candidate lists are in CSR form
(``cand_start[s] : cand_start[s + 1]`` are step ``s``'s rows of ``cand_*``). BP's trace is
the messages after each sweep (all of them up to 32×32; sweeps 1, 2, 5, 10 and the last
beyond, listed in ``sweeps``).
"""

from __future__ import annotations

import math

import numpy as np

from refsynth.numeric import quantise_grey, quantise_intensity, quantise_range, window_weights
from refsynth.synthesis import reference as ref
from refsynth.synthesis.api import normalise_intensity
from refsynth.synthesis.gap_readings import gap_gate
from refsynth.synthesis.median_pass import median_pass

__all__ = ["run_outputs", "np_trace", "prepared_arrays", "KEPT_SWEEPS", "ALL_SWEEPS_UP_TO"]

#: BP runs larger than this many pixels keep only some sweeps' messages in the trace.
ALL_SWEEPS_UP_TO = 32 * 32
#: The sweeps kept beyond that (1-based), with the last one.
KEPT_SWEEPS = (1, 2, 5, 10)


def prepared_arrays(inputs: dict, options: dict) -> dict:
    """The contract's intermediates of a run: what a port can check its own preparation on.

    ``q_intensity`` (H, W, C) int64 is the quantised intensity that Eq. 2 uses (with
    ``colour=False``, the quantised grey level, C = 1); ``q_range`` (H, W) int64, −1 where
    unknown; ``window`` (n, n) int64, Eq. 2's integer Gaussian.
    """
    image = normalise_intensity(inputs["intensity"])
    q = quantise_intensity(image)
    if not options.get("colour", True):
        q = quantise_grey(q)[:, :, None]
    return dict(q_intensity=q, q_range=quantise_range(inputs["partial_range"])[0],
                window=window_weights(options["neighbourhood"]))


def _random_numbers(seed: int, shape, options: dict, unknown: int) -> dict:
    """NP's random numbers, replayed in the order the reference draws them.

    ``tie`` (H, W): the inner part of the padded frame's permutation (Eq. 10's tie-break);
    ``draws`` (N,): one uniform number per step (Eq. 5's draw); with the onion order,
    ``onion_tie`` (N,): the permutation that orders the unknown pixels (raster order) within
    a layer.
    """
    H, W = shape
    pad = max(int(math.ceil(options["radius"])), options["neighbourhood"] // 2 + 1)
    rng = np.random.default_rng(seed)
    tie = rng.permutation((H + 2 * pad) * (W + 2 * pad)).reshape(H + 2 * pad, W + 2 * pad)
    out = dict(tie=tie[pad : pad + H, pad : pad + W].copy(), draws=rng.random(unknown))
    if options.get("ordering", "priority") == "onion":
        out["onion_tie"] = rng.permutation(unknown)
    return out


def np_trace(steps: list, edges: np.ndarray, tie: np.ndarray, values: np.ndarray,
             tiered: bool) -> dict:
    """The per-step trace of a reference NP run as flat arrays (ragged parts in CSR form).

    ``edges`` and ``tiered`` give each step's tier (1: an edge pixel filled in the second
    tier), ``tie`` its tie-break key, ``values`` (the result) the range it received.
    """
    start = np.cumsum([0] + [len(s["candidates"]) for s in steps]).astype(np.int64)
    terms = np.array([s["terms"] if s["terms"] else (np.nan,) * 4 for s in steps],
                     dtype=np.float64).reshape(-1, 4)
    gamma = np.zeros(int(start[-1]), dtype=bool)
    for s, first in zip(steps, start[:-1]):
        gamma[first + np.array(s["members"], dtype=np.int64)] = True
    pixel = np.array([s["pixel"] for s in steps], np.int64).reshape(-1, 2)
    rows, cols = pixel[:, 0], pixel[:, 1]
    return dict(
        step_pixel=pixel,
        step_tier=(edges[rows, cols] & tiered).astype(np.int64),
        step_tie=tie[rows, cols].astype(np.int64),
        step_C=terms[:, 0], step_D=terms[:, 1], step_E=terms[:, 2], step_P=terms[:, 3],
        cand_start=start,
        cand_pixel=np.array([q for s in steps for q in s["candidates"]],
                            np.int64).reshape(-1, 2),
        cand_distance=np.array([d for s in steps for d in s["distances"]], np.float64),
        cand_in_gamma=gamma,
        step_best=np.array([s["best"] for s in steps], np.int64),
        step_draw=np.array([s["draw"] for s in steps], np.float64),
        step_source=np.array([s["source"] for s in steps], np.int64).reshape(-1, 2),
        step_value=values[rows, cols].astype(np.float64),
        step_confidence=np.array([s["confidence"] for s in steps], np.float64),
    )


def _np_run(inputs: dict, options: dict, seed: int, reference) -> dict:
    image = normalise_intensity(inputs["intensity"])
    partial = inputs["partial_range"]
    edges = inputs["edges"] & bool(options["use_edges"])
    run = reference.np_reference(image, partial, edges, np.random.default_rng(seed),
                                 trace=True, **options)
    numbers = _random_numbers(seed, partial.shape, options, int(np.isnan(partial).sum()))
    tiered = bool(options["use_edges"]) and bool(options.get("edges_last", True)) and (
        options.get("ordering", "priority") == "priority")
    return dict(numbers, range=run.range, confidence=run.confidence, order=run.order,
                **np_trace(run.trace, edges, numbers["tie"], run.range, tiered))


def _bp_run(inputs: dict, options: dict, seed, reference) -> dict:
    image = normalise_intensity(inputs["intensity"])
    partial = inputs["partial_range"]
    edges = inputs["edges"] & bool(options["use_edges"])
    settings = dict(options)
    k = settings["k"] = settings.pop("candidates")
    numbers = {}
    if settings.get("observation", "np") == "np":  # NP's fill first (BP's default): it draws
        settings["rng"] = np.random.default_rng(seed)
        numbers = _random_numbers(seed, partial.shape, {**options, "ordering": "priority"},
                                  int(np.isnan(partial).sum()))
    run = reference.bp_reference(image, partial, edges, trace=True, **settings)
    done = len(run.trace)
    if partial.size <= ALL_SWEEPS_UP_TO:
        kept = list(range(1, done + 1))
    else:
        kept = sorted({s for s in KEPT_SWEEPS if s <= done} | ({done} if done else set()))
    sweeps = (np.stack([run.trace[s - 1][0] for s in kept]) if kept
              else np.zeros((0, 2 * len(run.pairs), k)))
    return dict(numbers, q_observation=run.observed, range=run.range,
                confidence=run.confidence,
                order=run.order, labels=run.labels, candidates=run.candidates,
                candidate_values=run.candidate_values, unary=run.unary, pairs=run.pairs,
                log_psi=run.log_psi, messages=run.messages, beliefs=run.beliefs,
                iterations=np.array(run.iterations, dtype=np.int64),
                sweeps=np.array(kept, dtype=np.int64), sweep_messages=sweeps,
                sweep_change=np.array([run.trace[s - 1][1] for s in kept], np.float64))


def run_outputs(kind: str, inputs: dict, options: dict, seed, *, reference=None) -> dict:
    """Prepared arrays, outputs and trace of a whole run (``kind`` "np" or "bp").

    With ``options["gaps"] == "gate"`` the output ``range`` is the fill's after
    :func:`~refsynth.synthesis.gap_readings.gap_gate` (the reading ``gaps``, a post-pass with
    the case's edges), and with ``options["median"]`` not 0 after
    :func:`~refsynth.synthesis.median_pass.median_pass` too; the trace stays the fill's.
    ``reference`` is the module whose ``np_reference`` / ``bp_reference`` runs (default
    :mod:`refsynth.synthesis.reference`): a Python port written in its image, or a
    deliberately perturbed copy, gets its trace in the oracle's layout this way.
    """
    reference = ref if reference is None else reference
    options = dict(options)
    gaps = options.pop("gaps", "copy")
    median = options.pop("median", 0)
    prepared = prepared_arrays(inputs, options)
    run = (_np_run if kind == "np" else _bp_run)(inputs, dict(options, gaps="copy", median=0),
                                                 seed, reference)
    if gaps == "gate":  # the readings after the fill: the trace is the fill's
        edges = inputs["edges"] & bool(options["use_edges"])
        run["range"] = gap_gate(run["range"], inputs["partial_range"], edges=edges)
    if median:
        run["range"] = median_pass(run["range"], inputs["partial_range"], median)
    return dict(prepared, **run)
