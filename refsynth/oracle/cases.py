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
both confidence updates, Eq. 2 on grey and with the channel mean, sum-product, both edge
rules, the proximity prior on; BP's observations completed by NP's fill (the default: those
cases carry NP's random numbers too, and ``q_observation`` is NP's result on the quantised
grid) and by the colorization fill (``observation="colorization"``, the prepared
``q_observation``), the training disc widened by the gap's depth and shifted labels
(``range_copy="offset"``), and Fig. 6 as printed (``observation="measured"``,
``training_radius="fixed"``, ``range_copy="value"``) beside them; ``bp-10x12-k8`` has all
eight labels (the default ``k``), where numpy's pairwise sum of the confidence's eight
weights differs from the contract's sum left to right (:mod:`refsynth.oracle.contract`);
the ``*-planes`` cases are a column scan, where the reading ``gaps`` acts: with
``gaps="copy"`` they check the fill as copied, ``*-planes-gaps`` the default gate after it
(:func:`refsynth.synthesis.gap_readings.gap_gate`). Every run checks the fill with
``median=0``, since a median could hide a one-pixel difference, except the ``*-median``
cases: the default 3 × 3 median (:func:`refsynth.synthesis.median_pass.median_pass`) after
the gate on the column scan, and alone on a scattered sample. A run's options hold every
option the method takes, its default filled in (:data:`NP_DEFAULTS`, :data:`BP_DEFAULTS`), so
a port reads them all from the case.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field

import numpy as np

from refsynth.oracle.equations import KINDS, equation_cases, equation_outputs
from refsynth.oracle.runs import run_outputs

__all__ = ["Case", "CASE_SET_VERSION", "NP_DEFAULTS", "BP_DEFAULTS", "build_cases",
           "expected_outputs", "select_cases", "with_defaults"]

#: The version of the case set (inputs and options); the format's is in files.py.
CASE_SET_VERSION = 9

#: Every option of :func:`refsynth.synthesize` that NP takes, with its default: a NP case's
#: options are these, updated by the case's own.
NP_DEFAULTS = dict(neighbourhood=5, radius=10.0, range_weight=1.0, missing_range="mean",
                   colour=True, channels="sum", use_edges=True, epsilon=0.1,
                   use_isophotes=True, ordering="priority", confidence_update="best",
                   edges_last=True, range_copy="offset", gaps="gate", median=3)
#: The same for BP; ``offset_tolerance`` follows the observation (``2**-3`` with
#: ``observation="np"``, else ``2**-7``) unless the case sets it.
BP_DEFAULTS = dict(neighbourhood=5, radius=10.0, range_weight=1.0, missing_range="mean",
                   colour=True, channels="sum", use_edges=True, candidates=8, sigma_i=0.1,
                   sigma_s=0.2, iterations=50, tolerance=1e-4, product="max",
                   edge_rule="silent", proximity=0.0, observation="np",
                   training_radius="gap", range_copy="offset", offset_tolerance=None,
                   gaps="gate", median=3)


def with_defaults(kind: str, options: dict) -> dict:
    """A run's options with every default filled in (``kind`` "np" or "bp").

    >>> with_defaults("bp", dict(observation="measured"))["offset_tolerance"] == 2.0**-7
    True
    """
    out = dict(NP_DEFAULTS if kind == "np" else BP_DEFAULTS, **options)
    if kind == "bp" and out["offset_tolerance"] is None:
        out["offset_tolerance"] = 2.0**-3 if out["observation"] == "np" else 2.0**-7
    return out


@dataclass
class Case:
    """One golden case: what to call (``kind``, ``options``, ``seed``) and on which arrays.

    Its :attr:`tolerance` is the loosest comparison the case needs:
    ``"exact"`` for the kinds under the numeric contract (the synthesis
    stage), ``"float64"`` for Eq. 13 and the registration stage (Eqs. 14–21).

    Attributes
    ----------
    name : str
        A file-name-safe identifier (``"np-8x8-noise"``, ``"eq7"``).
    kind : str
        A key of :data:`~refsynth.oracle.equations.KINDS`: ``"np"`` or
        ``"bp"`` for a whole run (§3.2.2, §3.2.3), ``"eq2"`` … ``"eq21"`` or
        ``"canny"`` for a per-equation batch.
    inputs : dict of str to ndarray
        What the function under test receives. A whole run: ``intensity``
        (H, W) or (H, W, 3) float in [0, 1], ``partial_range`` (H, W) float
        (NaN unknown) and ``edges`` (H, W) bool; an equation: its batch
        (Eq. 7's ``distances`` (B, K), Eq. 13's ``estimate``, ``truth``,
        ``known`` (H, W) …).
    options : dict, default {}
        Keyword arguments: :func:`refsynth.synthesize`'s for a run, the
        equation's parameters otherwise (Eq. 7's ``sigma_i`` …).
    seed : int or None, default None
        The run's seed; None for the equation cases.

    Examples
    --------
    >>> known = np.array([[True, False], [False, True]])
    >>> case = Case("mar", "eq13", dict(estimate=np.ones((2, 2)), truth=np.zeros((2, 2)),
    ...                                 known=known))
    >>> case.tolerance   # Eq. 13 is not under the numeric contract
    'float64'
    """

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


def _planes_scene(seed: int, shape):
    """Two slanted planes meeting at a depth step, textured intensity, x-stripes known."""
    g = np.random.default_rng(seed)
    H, W = shape
    rows, cols = np.mgrid[:H, :W]
    right = cols > W // 2 + rows // 4
    image = np.where(right, 0.7, 0.2)[..., None] + 0.2 * g.random((H, W, 3))
    truth = np.where(right, 5.0 - 0.07 * rows, 2.0 + 0.04 * cols + 0.02 * rows)
    known = cols % 6 < 2
    known[g.random((H, W)) < 0.1] = False
    edges = g.random((H, W)) < 0.1
    return dict(intensity=image, partial_range=np.where(known, truth, np.nan), edges=edges)


#: BP's observations completed by the colorization fill, which most BP cases ask for (NP's
#: fill, the default, completes them in the cases that do not).
COLORIZATION = dict(observation="colorization")


def _run_cases(large: bool) -> list[Case]:
    cases = []
    shapes = [(8, 8), (12, 10), (16, 16)]
    plans = [
        ("noise", 1, dict(), dict(), 0.5),
        ("levels", 3, dict(epsilon=0.5, use_isophotes=False),
         dict(edge_rule="deaf"), 0.4),
        ("ramp", 1, dict(ordering="onion", missing_range="ignore"),
         dict(product="sum", proximity=1.0), 0.3),
    ]
    for i, shape in enumerate(shapes):
        for j, (kind, channels, np_extra, bp_extra, fraction) in enumerate(plans):
            seed = 100 * i + j
            scene = _scene(seed, shape, channels, kind, fraction)
            common = dict(neighbourhood=5 if min(shape) >= 12 else 3, radius=4.0,
                          use_edges=bool(j != 1))
            tag = f"{shape[0]}x{shape[1]}-{kind}"
            # the product rule and Eq. 5's value copy here (a port's first steps, tutorial 6),
            # the paper's C(best) and the offset copy (the defaults) in the cases below; BP's
            # labels' values here too, shifted (the default) below
            np_options = dict(common, confidence_update="product", range_copy="value",
                              **np_extra)
            cases.append(Case(f"np-{tag}", "np", scene, np_options, seed))
            bp = dict(common, candidates=3, iterations=8, range_copy="value", **bp_extra,
                      **COLORIZATION)
            cases.append(Case(f"bp-{tag}", "bp", scene, bp, seed))
    # the options a port must get right, one case each
    colour = _scene(11, (10, 12), 3, "noise", 0.5)
    cases += [
        Case("np-10x12-best-grey", "np", colour,
             dict(neighbourhood=3, radius=3.0, use_edges=True, confidence_update="best",
                  colour=False, edges_last=False), 11),
        Case("np-10x12-channel-mean", "np", colour,
             dict(neighbourhood=3, radius=3.0, use_edges=True, channels="mean"), 11),
        Case("bp-10x12-channel-mean", "bp", colour,
             dict(neighbourhood=3, radius=2.5, use_edges=False, candidates=4, iterations=8,
                  channels="mean", **COLORIZATION), 11),
        Case("np-12x12-widened", "np", _scene(12, (12, 12), 1, "noise", 0.2),
             dict(neighbourhood=3, radius=1.0, use_edges=False, epsilon=0.0), 12),
        Case("bp-10x12-grey-k5", "bp", colour,
             dict(neighbourhood=3, radius=2.5, use_edges=True, candidates=5, iterations=12,
                  colour=False, sigma_i=0.5, range_weight=4.0, **COLORIZATION), 11),
    ]
    # all eight labels (the default k): BP's confidence sums eight weights, where a pairwise
    # sum (numpy's, from eight terms on) rounds differently from the contract's left to right
    eight = _scene(0, (10, 12), 3, "noise", 0.3)
    cases.append(Case("bp-10x12-k8", "bp", eight,
                      dict(neighbourhood=3, radius=3.0, use_edges=True, candidates=8,
                           iterations=8, **COLORIZATION), 0))
    # BP as Fig. 6 prints it (the observations' measured range, the fixed disc), and the
    # training patches completed too, beside the defaults above
    sparse = _scene(13, (16, 16), 1, "noise", 0.3)
    cases += [
        Case("bp-16x16-fig6", "bp", sparse,
             dict(neighbourhood=3, radius=2.0, use_edges=True, candidates=4, iterations=10,
                  observation="measured", training_radius="fixed", range_copy="value"), 13),
        Case("bp-16x16-completed-prior", "bp", sparse,
             dict(neighbourhood=3, radius=2.0, use_edges=True, candidates=4, iterations=10,
                  observation="colorization-completed", proximity=1.0), 13),
        Case("bp-16x16-fig6-gap", "bp", sparse,
             dict(neighbourhood=3, radius=2.0, use_edges=True, candidates=4, iterations=10,
                  observation="measured"), 13),
    ]
    # NP and BP on slanted planes, where the offset copy (the default) shifts most values,
    # and the value copy (Eq. 5, Fig. 6's labels) on the same scene: the fill as copied
    # (gaps="copy"), then the default gap reading on it (a column scan: the gate acts)
    planes = _planes_scene(14, (14, 18))
    copy = dict(gaps="copy")
    cases += [
        Case("np-14x18-planes", "np", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, **copy), 14),
        Case("np-14x18-planes-value-copy", "np", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, range_copy="value", **copy), 14),
        Case("bp-14x18-planes", "bp", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=4, iterations=10,
                  **COLORIZATION, **copy), 14),
        Case("bp-14x18-planes-value-copy", "bp", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=4, iterations=10,
                  range_copy="value", **COLORIZATION, **copy), 14),
        # BP's default observations: NP's fill (drawing on the case's seed; the case
        # carries NP's random numbers) completes them, the labels shift within 2**-3
        Case("bp-14x18-planes-np-fill", "bp", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=4, iterations=10,
                  **copy), 14),
        Case("np-14x18-planes-gaps", "np", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True), 14),
        Case("bp-14x18-planes-gaps", "bp", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=4, iterations=10),
             14),
        Case("bp-16x16-np-fill-tolerance", "bp", sparse,
             dict(neighbourhood=3, radius=2.0, use_edges=True, candidates=4, iterations=10,
                  offset_tolerance=2.0**-7), 13),
        # the defaults whole: the gate, then the 3x3 median; the median alone off a column scan
        Case("np-14x18-planes-median", "np", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, median=3), 14),
        Case("bp-14x18-planes-median", "bp", planes,
             dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=4, iterations=10,
                  median=3), 14),
        Case("np-16x16-median", "np", sparse,
             dict(neighbourhood=3, radius=2.0, use_edges=True, median=3), 13),
    ]
    # larger: 32×32 with the priority order, 64×64 onion (the reference is slow beyond)
    big = _scene(32, (32, 32), 1, "noise", 0.75)
    cases.append(Case("np-32x32-noise", "np", big,
                      dict(neighbourhood=5, radius=3.0, use_edges=True), 32))
    cases.append(Case("bp-32x32-noise", "bp", big,
                      dict(neighbourhood=5, radius=3.0, use_edges=True, candidates=3,
                           iterations=10, **COLORIZATION), 32))
    huge = _scene(64, (64, 64), 3, "levels", 0.6)
    cases.append(Case("np-64x64-levels-onion", "np", huge,
                      dict(neighbourhood=3, radius=2.0, use_edges=False, ordering="onion"), 64))
    cases.append(Case("bp-64x64-levels", "bp", huge,
                      dict(neighbourhood=3, radius=2.0, use_edges=True, candidates=2,
                           iterations=12, **COLORIZATION), 64))
    if large:
        wide = _scene(65, (48, 64), 1, "ramp", 0.5)
        cases.append(Case("np-48x64-ramp", "np", wide,
                          dict(neighbourhood=5, radius=4.0, use_edges=True), 65))
    return cases


def build_cases(*, large: bool = False) -> list[Case]:
    """The versioned case set: whole runs from 8×8 to 64×64, then the per-equation batches.

    Only the inputs and options are built here (in milliseconds); the
    expected values come from :func:`expected_outputs`.

    Parameters
    ----------
    large : bool, default False
        Add a 48×64 NP run with the priority order (about a minute in the
        reference).

    Returns
    -------
    list of Case
        Version :data:`CASE_SET_VERSION`: the NP and BP runs first, then one
        or more cases per equation (:data:`~refsynth.oracle.equations.KINDS`).

    Examples
    --------
    >>> cases = build_cases()
    >>> cases[0].name, cases[0].inputs["intensity"].shape, cases[0].seed
    ('np-8x8-noise', (8, 8), 0)
    >>> [case.name for case in cases if case.kind == "eq6"]
    ['eq6-h', 'eq6-v']
    """
    # the fill's checks without the median (which could hide a one-pixel difference)
    cases = [Case(c.name, c.kind, c.inputs, with_defaults(c.kind, {"median": 0, **c.options}),
                  c.seed) for c in _run_cases(large)]
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
    """Run the reference on ``case``: prepared arrays, outputs and (NP, BP) the step trace.

    Parameters
    ----------
    case : Case
        A whole run (``kind`` "np" or "bp") or a per-equation batch.

    Returns
    -------
    dict of str to ndarray
        A whole run: the prepared arrays (``q_intensity`` (H, W, C) and
        ``q_range`` (H, W) on the contract's grids, the integer ``window``
        (n, n), NP's ``tie`` (H, W) and Eq. 5 ``draws`` (M,)), the outputs
        ``range`` and ``confidence`` (H, W) and ``order`` (M, 2) (the M
        unknown pixels in synthesis order), then the trace (NP's per-step
        ``step_*`` and per-candidate ``cand_*`` rows; BP's candidates, unary
        terms, compatibilities, messages and beliefs, and ``sweep_messages``).
        An equation case: its outputs (the table of
        :mod:`refsynth.oracle.equations`).

    Examples
    --------
    The smallest NP run (§3.2.2), 8×8: every unknown pixel is filled once.

    >>> run = build_cases()[0]
    >>> out = expected_outputs(run)
    >>> out["range"].shape, len(out["order"]) == int(np.isnan(run.inputs["partial_range"]).sum())
    ((8, 8), True)
    """
    if case.kind in ("np", "bp"):
        return run_outputs(case.kind, case.inputs, case.options, case.seed)
    return equation_outputs(case.kind, case.inputs, case.options)
