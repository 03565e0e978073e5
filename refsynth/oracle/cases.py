"""The golden cases: small scenes and per-equation batches, and their expected outputs.

Every expected value comes from the literal reference (:mod:`refsynth.synthesis.reference`),
which follows the numeric contract, so the fast code and any port must reproduce it exactly.
Cases are built from fixed seeds: the same refsynth version writes the same bytes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from refsynth.synthesis import reference as ref
from refsynth.synthesis.api import normalise_intensity

__all__ = ["Case", "build_cases", "expected_outputs"]


@dataclass
class Case:
    """One golden case: what to call (``kind``, ``options``, ``seed``) and on which arrays."""

    name: str
    kind: str                      # "np", "bp", "eq2" or "eq5"
    inputs: dict
    options: dict = field(default_factory=dict)
    seed: int | None = None


def _scene(seed: int, shape, channels: int, kind: str, known_fraction: float):
    """A small scene: intensity (noise, few levels or ramp), range with ties, a random mask."""
    g = np.random.default_rng(seed)
    H, W = shape
    if kind == "noise":
        image = g.random((H, W, channels))
    elif kind == "levels":
        image = g.integers(0, 4, (H, W, channels)) / 3.0
    else:
        image = np.tile(np.linspace(0.0, 1.0, W)[None, :, None], (H, 1, channels))
    truth = np.round(1.0 + 4.0 * g.random((H, W)), 1)
    known = g.random((H, W)) < known_fraction
    known[0, 0], known[-1, -1] = True, False
    edges = g.random((H, W)) < 0.1
    intensity = image[:, :, 0] if channels == 1 else image
    return dict(intensity=intensity, partial_range=np.where(known, truth, np.nan), edges=edges)


def build_cases(*, large: bool = False) -> list[Case]:
    """The versioned case set: tiny (8×8) to small (16×16; 32×32 and 64×64 with ``large``)."""
    cases = []
    shapes = [(8, 8), (12, 10), (16, 16)] + ([(32, 32), (64, 64)] if large else [])
    plans = [
        ("noise", 1, dict(), 0.5),
        ("levels", 3, dict(epsilon=0.5, use_isophotes=False), 0.4),
        ("ramp", 1, dict(ordering="onion", missing_range="ignore"), 0.3),
    ]
    for i, shape in enumerate(shapes):
        for j, (kind, channels, extra, fraction) in enumerate(plans):
            seed = 100 * i + j
            scene = _scene(seed, shape, channels, kind, fraction)
            common = dict(neighbourhood=5 if min(shape) >= 12 else 3, radius=4.0,
                          use_edges=bool(j != 1))
            tag = f"{shape[0]}x{shape[1]}-{kind}"
            cases.append(Case(f"np-{tag}", "np", scene, dict(common, **extra), seed))
            bp_extra = dict(candidates=3, iterations=8, product="sum" if j == 2 else "max")
            cases.append(Case(f"bp-{tag}", "bp", scene, dict(common, **bp_extra), seed))
    g = np.random.default_rng(7)
    for n, channels in ((3, 1), (5, 3)):
        qi = g.integers(0, 2**16 + 1, (32, 2, n, n, channels))
        qr = np.where(g.random((32, 2, n, n)) < 0.6, g.integers(0, 2**16 + 1, (32, 2, n, n)),
                      ref.NO_RANGE)
        cases.append(Case(f"eq2-n{n}-c{channels}", "eq2", dict(q_intensity=qi, q_range=qr),
                          dict(range_weight=16.0)))
    distances = np.round(g.random((16, 20)), 2)   # ties on purpose
    cases.append(Case("eq5-ties", "eq5", dict(distances=distances), dict(epsilon=0.1)))
    return cases


def _np_trace(steps) -> dict:
    """The per-step trace of a reference NP run as flat arrays (ragged parts in CSR form)."""
    start = np.cumsum([0] + [len(s["candidates"]) for s in steps])
    terms = np.array([s["terms"] if s["terms"] else (np.nan,) * 4 for s in steps]).reshape(-1, 4)
    gamma = np.zeros(int(start[-1]), dtype=bool)
    for s, first in zip(steps, start[:-1]):
        gamma[first + np.array(s["members"], dtype=np.int64)] = True
    return dict(
        step_pixel=np.array([s["pixel"] for s in steps], np.int64).reshape(-1, 2),
        step_C=terms[:, 0], step_D=terms[:, 1], step_E=terms[:, 2], step_P=terms[:, 3],
        cand_start=start.astype(np.int64),
        cand_pixel=np.array([q for s in steps for q in s["candidates"]], np.int64).reshape(-1, 2),
        cand_distance=np.array([d for s in steps for d in s["distances"]], np.float64),
        cand_in_gamma=gamma,
        step_best=np.array([s["best"] for s in steps], np.int64),
        step_draw=np.array([s["draw"] for s in steps], np.float64),
        step_source=np.array([s["source"] for s in steps], np.int64).reshape(-1, 2),
        step_confidence=np.array([s["confidence"] for s in steps], np.float64),
    )


def expected_outputs(case: Case) -> dict:
    """Run the reference on ``case``: prepared arrays, outputs and (NP, BP) the step trace."""
    if case.kind == "eq2":
        qi, qr = case.inputs["q_intensity"], case.inputs["q_range"]
        window = ref.window_weights(qi.shape[2])
        out = dict(window=window)
        for rule in ("mean", "ignore"):
            out[f"distance_{rule}"] = np.array([
                ref.eq2_distance(qi[b, 0], qr[b, 0], qi[b, 1], qr[b, 1], window,
                                 case.options["range_weight"], rule) for b in range(len(qi))])
        return out
    if case.kind == "eq5":
        d, eps = case.inputs["distances"], case.options["epsilon"]
        return dict(members=np.array([[x <= (1.0 + eps) * row.min() for x in row] for row in d]))
    image = normalise_intensity(case.inputs["intensity"])
    partial, edges = case.inputs["partial_range"], case.inputs["edges"]
    options = dict(case.options)
    use_edges = options["use_edges"]
    edges = edges & use_edges
    prepared = dict(q_intensity=ref.quantise_intensity(image),
                    q_range=ref.quantise_range(partial)[0],
                    window=ref.window_weights(options["neighbourhood"]))
    if case.kind == "np":
        rng = np.random.default_rng(case.seed)
        run = ref.np_reference(image, partial, edges, rng, trace=True, **options)
        replay = np.random.default_rng(case.seed)
        H, W = partial.shape
        pad = max(int(np.ceil(options["radius"])), options["neighbourhood"] // 2 + 1)
        tie = replay.permutation((H + 2 * pad) * (W + 2 * pad)).reshape(H + 2 * pad, W + 2 * pad)
        prepared.update(tie=tie[pad : pad + H, pad : pad + W].copy(),
                        draws=replay.random(int(np.isnan(partial).sum())))
        return dict(prepared, range=run.range, confidence=run.confidence, order=run.order,
                    **_np_trace(run.trace))
    options["k"] = options.pop("candidates")
    run = ref.bp_reference(image, partial, edges, trace=True, **options)
    k = options["k"]
    sweeps = (np.stack([m for m, _ in run.trace]) if run.trace
              else np.zeros((0, 2 * len(run.pairs), k)))
    return dict(prepared, range=run.range, confidence=run.confidence, order=run.order,
                labels=run.labels, candidates=run.candidates,
                candidate_values=run.candidate_values, unary=run.unary, pairs=run.pairs,
                log_psi=run.log_psi, beliefs=run.beliefs, messages=sweeps,
                change=np.array([c for _, c in run.trace or []], np.float64),
                iterations=np.array(run.iterations))
