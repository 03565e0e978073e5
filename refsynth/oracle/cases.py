"""The golden case set: small scenes for whole NP and BP runs, and per-equation batches.

Every expected value comes from the literal reference (:mod:`refsynth.synthesis.reference`)
for the synthesis stage, which follows the numeric contract, so the fast code and any port
must reproduce it exactly; the registration stage's and Eq. 13's come from refsynth's own
functions (:mod:`refsynth.oracle.equations`). Cases are built from fixed seeds: the same
refsynth version writes the same bytes. The set is versioned (:data:`CASE_SET_VERSION`):
a change of any case's inputs or options bumps it.

The whole runs (``kind`` "np" and "bp") span 8×8 to 64×64, with noise, few-level and ramp
intensity (exact ties in Eq. 2), grey and colour, edges on and off, and the options a port
must get right: ε, isophotes off, the onion order, ``missing_range="ignore"``, the widened
search (``r = 1``: a front pixel whose filled neighbours are diagonal has an empty ``A_p``),
both confidence updates, Eq. 2 on grey, sum-product, both edge rules, proximity off.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field

import numpy as np

from refsynth.oracle.equations import KINDS, equation_cases, equation_outputs
from refsynth.oracle.runs import run_outputs

__all__ = ["Case", "CASE_SET_VERSION", "build_cases", "expected_outputs", "select_cases"]

#: The version of the case set (inputs and options); the format's is in export.py.
CASE_SET_VERSION = 1


@dataclass
class Case:
    """One golden case: what to call (``kind``, ``options``, ``seed``) and on which arrays."""

    name: str
    kind: str                      # a key of refsynth.oracle.equations.KINDS
    inputs: dict
    options: dict = field(default_factory=dict)
    seed: int | None = None

    @property
    def tolerance(self) -> str:
        """The case's own tolerance: ``"exact"`` under the contract, else ``"float64"``."""
        return KINDS[self.kind][2]


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


def _run_cases(large: bool) -> list[Case]:
    cases = []
    shapes = [(8, 8), (12, 10), (16, 16)]
    plans = [
        ("noise", 1, dict(), dict(), 0.5),
        ("levels", 3, dict(epsilon=0.5, use_isophotes=False),
         dict(edge_rule="paper"), 0.4),
        ("ramp", 1, dict(ordering="onion", missing_range="ignore"),
         dict(product="sum", proximity=0.0), 0.3),
    ]
    for i, shape in enumerate(shapes):
        for j, (kind, channels, np_extra, bp_extra, fraction) in enumerate(plans):
            seed = 100 * i + j
            scene = _scene(seed, shape, channels, kind, fraction)
            common = dict(neighbourhood=5 if min(shape) >= 12 else 3, radius=4.0,
                          use_edges=bool(j != 1))
            tag = f"{shape[0]}x{shape[1]}-{kind}"
            # the product rule here, the paper's C(best) (the default) in the cases below
            np_options = dict(common, confidence_update="product", **np_extra)
            cases.append(Case(f"np-{tag}", "np", scene, np_options, seed))
            bp = dict(common, candidates=3, iterations=8, **bp_extra)
            cases.append(Case(f"bp-{tag}", "bp", scene, bp, seed))
    # the options a port must get right, one case each
    colour = _scene(11, (10, 12), 3, "noise", 0.5)
    cases += [
        Case("np-10x12-best-grey", "np", colour,
             dict(neighbourhood=3, radius=3.0, use_edges=True, confidence_update="best",
                  colour=False, edges_last=False), 11),
        Case("np-12x12-widened", "np", _scene(12, (12, 12), 1, "noise", 0.2),
             dict(neighbourhood=3, radius=1.0, use_edges=False, epsilon=0.0), 12),
        Case("bp-10x12-grey-k5", "bp", colour,
             dict(neighbourhood=3, radius=2.5, use_edges=True, candidates=5, iterations=12,
                  colour=False, sigma_i=0.5, range_weight=4.0), 11),
    ]
    # larger: 32×32 with the priority order, 64×64 onion (the reference is slow beyond)
    big = _scene(32, (32, 32), 1, "noise", 0.75)
    cases.append(Case("np-32x32-noise", "np", big,
                      dict(neighbourhood=5, radius=3.0, use_edges=True), 32))
    cases.append(Case("bp-32x32-noise", "bp", big,
                      dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=3,
                           iterations=10), 32))
    huge = _scene(64, (64, 64), 3, "levels", 0.6)
    cases.append(Case("np-64x64-levels-onion", "np", huge,
                      dict(neighbourhood=3, radius=2.0, use_edges=False, ordering="onion"), 64))
    cases.append(Case("bp-64x64-levels", "bp", huge,
                      dict(neighbourhood=3, radius=2.0, use_edges=True, candidates=2,
                           iterations=12), 64))
    if large:
        wide = _scene(65, (48, 64), 1, "ramp", 0.5)
        cases.append(Case("np-48x64-ramp", "np", wide,
                          dict(neighbourhood=5, radius=4.0, use_edges=True), 65))
    return cases


def build_cases(*, large: bool = False) -> list[Case]:
    """The versioned case set: whole runs from 8×8 to 64×64, then the per-equation batches.

    ``large`` adds a 48×64 NP run with the priority order (about a minute in the reference).
    """
    cases = _run_cases(large)
    cases += [Case(name, kind, inputs, options) for name, kind, inputs, options
              in equation_cases()]
    return cases


def select_cases(cases: list[Case], patterns) -> list[Case]:
    """The cases whose name matches one of the shell patterns (all of them for None)."""
    if not patterns:
        return list(cases)
    chosen = [c for c in cases if any(fnmatch.fnmatchcase(c.name, p) for p in patterns)]
    if not chosen:
        raise ValueError(f"No case matches {', '.join(patterns)}; the cases are "
                         + ", ".join(c.name for c in cases))
    return chosen


def expected_outputs(case: Case) -> dict:
    """Run the reference on ``case``: prepared arrays, outputs and (NP, BP) the step trace."""
    if case.kind in ("np", "bp"):
        return run_outputs(case.kind, case.inputs, case.options, case.seed)
    return equation_outputs(case.kind, case.inputs, case.options)
