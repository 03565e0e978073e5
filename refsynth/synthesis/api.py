"""The front door: :func:`synthesize` (§3.2).

Validates the inputs, normalises the intensity, detects intensity edges
(Canny, σ = 0.8) and dispatches to the range-synthesis method: NP
(:mod:`refsynth.synthesis.nonparametric`) or BP (:mod:`refsynth.synthesis.belief`).
Every other part of refsynth (the command line, the tutorials, the
benchmarks, a faster port checking itself against this one) calls this
function.

The paper's parameters are keywords; the readings of the paper — the paper as
printed, or refsynth's measured departures (the default) — travel together as
``readings=`` (:mod:`refsynth.synthesis.readings`). A few keywords belong to
one method (:data:`NP_OPTIONS`, :data:`BP_OPTIONS`, checked in
:mod:`refsynth.synthesis.options`): they default to ``None``, which means the
method's default, and giving one to the other method raises ``ValueError``
unless it is that option's default.

The intensity convention
------------------------
Before Canny and Eq. 2 the intensity is brought to its own span: ``q =
rint(2**16 (I − min I) / (max I − min I))``, over all pixels and channels
(:func:`refsynth.numeric.quantise_intensity`). Eq. 2 uses ``q`` (or, with
``colour=False``, the grey level of ``q`` brought to its span the same way),
and Canny runs on that grey level as a float image in [0, 1], so Canny's
thresholds are fractions of the image's grey-level span. Any positive affine
change of the intensity — an offset, a scale, ``uint8`` against the same
values as floats in 0–255 or in 0–1 — therefore gives the *same* result, bit
for bit (up to a value landing within an ulp of a rounding boundary of the
2**-16 grid, which integer images never do).

The limits of every parameter — where the arithmetic stays finite, what the
image can use, the memory a run needs — are :mod:`refsynth.synthesis.limits`.

References
----------
Torres-Méndez & Dudek (2008), §3.2 (the paper's full reference is in
:mod:`refsynth.synthesis`), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from refsynth._checks import check_bool, check_choice, check_real
from refsynth.numeric import INTENSITY_BITS, quantise_grey, quantise_intensity
from refsynth.synthesis.belief.fill import BPResult, bp_fill
from refsynth.synthesis.belief.observation import np_observation, observation_fill
from refsynth.synthesis.belief.proposals import np_proposals
from refsynth.synthesis.canny import canny
from refsynth.synthesis.gap_readings import gap_gate
from refsynth.synthesis.limits import (
    check_canny_sigma,
    check_memory,
    normalise_intensity,
    search_radius,
    validate_inputs,
)
from refsynth.synthesis.median_pass import median_pass
from refsynth.synthesis.nonparametric import np_fill
from refsynth.synthesis.options import (
    BP_OPTIONS,
    METHODS,
    NP_OPTIONS,
    at_least,
    check_method_options,
    random_source,
)
from refsynth.synthesis.progress import StagedProgress
from refsynth.synthesis.range_copy import default_offset_tolerance
from refsynth.synthesis.readings import DEFAULT_PRESET, Readings, resolve_readings
from refsynth.synthesis.uncertainty import uncertainty_map
from refsynth.synthesis.window_reading import choose_neighbourhood

__all__ = [
    "SynthesisResult",
    "synthesize",
    "validate_inputs",
    "synthesis_edges",
    "normalise_intensity",
    "Readings",
    "NP_OPTIONS",
    "BP_OPTIONS",
    "OBSERVATION_SHARE",
    "NP_OBSERVATION_SHARE",
]

#: The observations' fill's share of BP's work with ``observation="colorization"`` (BP's
#: progress reports, :mod:`refsynth.synthesis.progress`): its share of the CPU time on the
#: Motorcycle, x-stripes 78 %, at 450×375 and 900×750, which
#: ``python benchmarks/bench_speed.py --bp-stages`` prints.
OBSERVATION_SHARE = 0.10
#: The same with ``observation="np"``, NP's fill first: NP's wall time over that of BP on
#: NP's fill at 450×375 and 900×750, which ``python benchmarks/bench_speed.py`` prints.
NP_OBSERVATION_SHARE = 0.67

@dataclass(frozen=True)
class SynthesisResult:
    """What :func:`synthesize` returns.

    Attributes
    ----------
    range : ndarray of shape (H, W), float64
        The dense range, finite everywhere; measured pixels are unchanged. With the
        reading ``gaps="gate"`` (the default) a column scan's gaps are the fill after
        :func:`refsynth.synthesis.gap_readings.gap_gate`, and with ``median=3`` (the
        default) each synthesized pixel then takes the median of its 3 × 3 window
        (:func:`refsynth.synthesis.median_pass.median_pass`); ``bp.range`` keeps BP's MAP
        labels as filled.
    confidence : ndarray of shape (H, W), float64
        In [0, 1]: 1 where the range was measured; for NP the confidence the
        pixel received when it was synthesized (Eq. 11, see
        :mod:`refsynth.synthesis.priority`); for BP the normalised belief (Eq. 8) of the
        chosen range, pooled over the candidates that propose it (see
        :mod:`refsynth.synthesis.belief`).
    order : ndarray of shape (N, 2), int64
        The synthesized pixels as (row, col): NP's fill order; for BP, which
        decides all pixels together, raster order.
    edges : ndarray of shape (H, W), bool
        The Canny edge map used (all False when ``use_edges=False``).
    method : str
        ``"np"`` or ``"bp"``.
    params : dict
        The parameters of the run, for provenance.
    iterations : int
        BP's message-passing sweeps (0 for NP).
    candidate_values : ndarray of shape (N, k) or None
        BP: the centre range of each pixel's ``k`` candidates (rows in
        ``order``), to judge candidate generation apart from inference.
    bp : BPResult or None
        BP: the whole model and its solution — candidates, unary terms, pairs,
        ``log Ψ``, the final messages and beliefs (see
        :class:`refsynth.synthesis.belief.fill.BPResult`); None for NP.
    uncertainty : ndarray of shape (H, W), float64, or None
        Each pixel's expected absolute error in the range's unit: 0 where
        measured, finite and > 0 on every synthesized pixel
        (:func:`refsynth.synthesis.uncertainty.uncertainty_map` of ``range``).

    Examples
    --------
    >>> import numpy as np, refsynth
    >>> image = np.tile(np.linspace(0, 1, 8), (8, 1))
    >>> partial = np.full((8, 8), np.nan); partial[:, ::3] = 2.0
    >>> result = refsynth.synthesize(image, partial)
    >>> result.method, result.range.shape, len(result.order) == int(np.isnan(partial).sum())
    ('np', (8, 8), True)
    >>> bool(np.all(result.confidence[~np.isnan(partial)] == 1.0)), result.bp is None
    (True, True)
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    edges: np.ndarray
    method: str
    params: dict = field(default_factory=dict)
    iterations: int = 0
    candidate_values: np.ndarray | None = None
    bp: BPResult | None = None
    uncertainty: np.ndarray | None = None


def synthesis_edges(image: np.ndarray, sigma: float = 0.8) -> np.ndarray:
    """The edges :func:`synthesize` detects (§3.2): Canny on the grey level of the quantised
    intensity, brought to [0, 1] (the intensity convention: the thresholds are fractions of
    the grey span).

    Parameters
    ----------
    image : ndarray of shape (H, W, C), real
        The intensity as :func:`synthesize` hands it on (:func:`validate_inputs`; any offset
        and scale: :func:`~refsynth.numeric.quantise_intensity` brings it to its span).
    sigma : float, default 0.8
        Canny's σ (``canny_sigma``).

    Returns
    -------
    ndarray of shape (H, W), bool

    Examples
    --------
    >>> image = np.zeros((9, 9, 1)); image[:, 5:] = 1.0
    >>> bool(synthesis_edges(image)[:, 4:6].any()), bool(synthesis_edges(image)[:, :3].any())
    (True, False)
    """
    levels = quantise_grey(quantise_intensity(image)) * 2.0**-INTENSITY_BITS
    return canny(levels, sigma=sigma)


def _after_fill(filled: np.ndarray, range_values: np.ndarray, edges: np.ndarray,
                chosen: dict) -> np.ndarray:
    """The readings ``gaps`` (as filled, or :func:`gap_gate` with the edges), then ``median``
    (:func:`median_pass`)."""
    gated = (filled if chosen["gaps"] == "copy"
             else gap_gate(filled, range_values, edges=edges))
    return median_pass(gated, range_values, chosen["median"]) if chosen["median"] else gated


def synthesize(
    intensity: np.ndarray,
    partial_range: np.ndarray,
    *,
    method: str = "np",
    seed: int | np.random.Generator | None = 0,
    neighbourhood: int | None = None,
    radius: float = 10.0,
    epsilon: float | None = None,
    iterations: int | None = None,
    candidates: int | None = None,
    canny_sigma: float = 0.8,
    edges: np.ndarray | None = None,
    use_edges: bool = True,
    use_isophotes: bool | None = None,
    ordering: str | None = None,
    readings: str | Readings | Mapping = DEFAULT_PRESET,
    progress: Callable[[int, int], None] | None = None,
) -> SynthesisResult:
    """Infer the missing range from intensity and partial range (§3.2).

    Everything after ``partial_range`` is keyword-only. The options of one
    method (``epsilon``, ``use_isophotes``, ``ordering`` for NP; ``candidates``,
    ``iterations`` for BP) default to ``None``, the method's default; giving one
    to the other method raises ``ValueError``, unless it is that option's
    default. The readings of the paper travel together in ``readings``.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The registered intensity image, grey or colour, of any real dtype,
        offset and scale: it is brought to its own span before Canny and Eq. 2
        (see the intensity convention under Notes). A masked array only with
        nothing masked.
    partial_range : ndarray of shape (H, W), floating
        The measured range, NaN where unknown (and, in a masked array, where
        masked), in any length unit; the result comes back in the same unit.
    method : {"np", "bp"}
        Non-parametric sampling (§3.2.2, Eqs. 2–5) or belief propagation
        (§3.2.3, Eqs. 6–9, Fig. 6).
    seed : int, numpy.random.Generator or None, default 0
        Source of every random choice of NP (the draw from the Eq. 5 set,
        ties in the fill order). The same seed gives bit-identical output.
        BP draws through NP's fill when NP completes its observations (the
        default preset's ``observation="np"``) or proposes labels
        (``proposals``); otherwise BP makes no random choice and the seed does
        not matter.
    neighbourhood : int, optional
        Odd side ``n`` of the n×n MRF neighbourhood (§3.2.1). Without it, the
        reading ``window`` chooses: 5 (§3.3's "windows of 5 × 5 pixels"), or
        3 on a column scan whose typical gap is at most 5 columns wide
        (:mod:`refsynth.synthesis.window_reading`; ``readings="paper"``: 5).
        ``params["neighbourhood"]`` records the side used.
    radius : float, default 10
        Search radius ``r`` of Eq. 3 (NP) and of BP's training set, in
        pixels, at least 1. A radius beyond the image's diagonal,
        ``ceil(hypot(H − 1, W − 1))``, searches the whole image, as the
        diagonal does: BP runs it as the next power of two at or above the
        diagonal (bit for bit the given radius's result; its prior keeps the
        scale ``r``, and with ``proximity=0`` the result is the diagonal's
        too); NP's tie-break permutation is drawn over the frame padded by
        ``r`` (as the literal reference draws it), so its result can differ
        from the diagonal's, and a radius whose padded frame does not fit in
        memory is refused (see :mod:`refsynth.synthesis.limits`).
    epsilon : float, NP only, default 0.1
        Tolerance ε of Eq. 5, in ``[0, 1e100]``.
    iterations : int, BP only, default 50
        At most this many message-passing sweeps (the paper's 50).
    candidates : int, BP only, default 8
        ``k``, the candidates (labels) per unknown pixel (Ψ holds ``k²``
        numbers per pair of neighbours: a ``k`` beyond memory is refused).
    canny_sigma : float, default 0.8
        σ of the Canny edge detector's Gaussian (the paper's setting), in
        ``[0, max(H, W)]``. Canny runs on the grey level brought to [0, 1]
        (see Notes), with thresholds 0.1 and 0.2 of that span.
    edges : ndarray of shape (H, W), bool, optional
        A precomputed edge map; overrides the Canny detector.
    use_edges : bool, default True
        NP: use the edge count of Eq. 10 and (with the reading ``edges_last``)
        fill edge pixels last. BP: the edge-constraint rule (the reading
        ``edge_rule``). ``False`` is the paper's no-edge ablation (Fig. 13,
        Table 3).
    use_isophotes : bool, NP only, default True
        Use the isophote data term of Eq. 12. ``False`` sets D = 1 (Fig. 16).
    ordering : {"priority", "onion"}, NP only, default "priority"
        The paper's information-driven order (Eqs. 10–12) or the onion-peel
        order it compares against (Fig. 7).
    readings : str, Readings or mapping, default "refsynth"
        The readings of the paper (:class:`~refsynth.synthesis.readings.Readings`,
        whose docstring lists every field with the paper's text, both presets
        and the evidence): ``"refsynth"``, refsynth's measured readings (the
        default); ``"paper"``, the paper as printed (Eq. 2 as written, Eq. 5's
        value copy, Fig. 6's BP); a mapping of overrides on the default
        preset, e.g. ``{"range_copy": "value"}`` to turn one departure off;
        or a ``Readings``, e.g. ``Readings.paper().replace(range_copy="offset")``.
        An unknown name raises ``ValueError`` listing the valid ones; in a
        mapping, a reading the method does not use raises ``ValueError``
        unless it is the default's value.
    progress : callable, optional
        Called as ``progress(done, total)``: NP in pixels, every few hundred
        pixels; BP in per mille of its estimated work, as the observations'
        fill sweeps, the candidates are searched and the messages are sent
        (:data:`refsynth.synthesis.belief.fill.BP_STAGES`, :data:`OBSERVATION_SHARE`),
        so that no stage runs long without a report.

    Returns
    -------
    SynthesisResult
        ``params`` records the run's keywords and the readings the method used.

    Raises
    ------
    TypeError, ValueError
        On bad input, naming the argument, before any work starts: a real
        parameter outside the range where the arithmetic stays finite
        (:data:`refsynth.synthesis.limits.PARAMETER_BOUNDS`, the ranges given
        above), and a run whose estimated memory exceeds the machine's
        physical memory (the message says how much it would need); and
        ``ValueError`` for an option or reading the chosen method does not
        use.

    Notes
    -----
    The keywords, by the method that uses them. The options of one method
    default to ``None``, which stands for the default in the last column:

    =======================  ===========  ===========  ================================
    option                   NP           BP           default
    =======================  ===========  ===========  ================================
    ``seed``                 yes          (NP first)   0
    ``neighbourhood``        yes          yes          5 or 3 (``window``)
    ``radius``               yes          yes          10
    ``epsilon``              Eq. 5        —            0.1
    ``iterations``           —            Eq. 9        50
    ``candidates``           —            ``k``        8
    ``canny_sigma``          yes          yes          0.8
    ``edges``                yes          yes          Canny's
    ``use_edges``            Eq. 10       edge rule    True
    ``use_isophotes``        Eq. 12       —            True
    ``ordering``             §3.2.4       —            ``"priority"``
    ``readings``             yes          yes          ``"refsynth"``
    ``progress``             yes          yes          none
    =======================  ===========  ===========  ================================

    An option marked "—" raises ``ValueError`` for that method unless it is
    ``None`` or its default, e.g. ``method="bp", ordering="onion"``: "The
    parameter `ordering` applies to method='np' only; method='bp' does not use
    it". NP uses the readings :data:`~refsynth.synthesis.readings.NP_READINGS`,
    BP :data:`~refsynth.synthesis.readings.BP_READINGS`.

    **The intensity convention.** The intensity (any real dtype) is brought
    to its own span before anything else: ``q = rint(2**16 (I − min I) /
    (max I − min I))`` over all pixels and channels. Eq. 2 compares ``q``
    (``colour=True``) or its grey level ``quantise(0.2125 R + 0.7154 G +
    0.0721 B)`` (``colour=False``); Canny runs on that grey level divided by
    ``2**16``, a float image spanning [0, 1], so its thresholds (0.1 and 0.2)
    are fractions of the image's grey-level span. So ``uint8`` input, the same
    values as floats in 0–255, the same divided by 255, or any of them plus an
    offset give bit-identical results; so does a positive scale of
    ``partial_range`` (the result scales with it). A precomputed ``edges`` map
    is used as given.

    **Reproducibility.** Every decision runs on exact numbers (the numeric
    contract of :mod:`refsynth.numeric`), so the same call gives the same bits
    whatever the BLAS library, its kernel and thread count, or the CPU's SIMD
    width, and the same as the literal references
    (:mod:`refsynth.synthesis.nonparametric.reference` for NP under
    ``readings="paper"``, :mod:`refsynth.synthesis.reference` under every
    reading).

    Examples
    --------
    >>> import numpy as np, refsynth
    >>> image = np.tile(np.linspace(0, 1, 8), (8, 1))
    >>> partial = np.full((8, 8), np.nan); partial[:, ::3] = 2.0
    >>> result = refsynth.synthesize(image, partial, seed=0)
    >>> bool(np.all(result.range == 2.0))
    True
    >>> paper = refsynth.synthesize(image, partial, readings="paper")
    >>> paper.params["range_copy"], paper.params["missing_range"]
    ('value', 'ignore')
    >>> refsynth.synthesize(image, partial, readings={"range_copy": "value"}).params["range_copy"]
    'value'
    >>> refsynth.synthesize(image, partial, method="bp", ordering="onion")
    Traceback (most recent call last):
    ...
    ValueError: The parameter `ordering` applies to method='np' only; method='bp' does not use it
    """
    image, range_values = validate_inputs(intensity, partial_range)
    method = check_choice("method", method, METHODS)
    options = check_method_options(method, dict(
        epsilon=epsilon, use_isophotes=use_isophotes, ordering=ordering,
        candidates=candidates, iterations=iterations))
    chosen = resolve_readings(readings, method).for_method(method)
    if method == "bp" and chosen["offset_tolerance"] is None:  # by the observation
        chosen["offset_tolerance"] = default_offset_tolerance(chosen["observation"])
    if neighbourhood is None:  # the reading `window` (synthesis.window_reading)
        neighbourhood = choose_neighbourhood(range_values, chosen["window"])
    neighbourhood = at_least("neighbourhood", neighbourhood, 1)
    if neighbourhood % 2 == 0:
        raise ValueError(f"The parameter `neighbourhood` must be odd, got {neighbourhood}")
    radius = check_real("radius", radius)
    if radius <= 0:
        raise ValueError(f"The parameter `radius` must be finite and > 0, got {radius}")
    if radius < 1:
        raise ValueError(f"The parameter `radius` must be >= 1 pixel, got {radius}")
    canny_sigma = check_canny_sigma(canny_sigma, range_values.shape)
    use_edges = check_bool("use_edges", use_edges)
    if edges is not None:
        try:
            edges = np.asarray(edges)
        except (ValueError, TypeError):  # ragged lists: numpy's words name no argument
            raise ValueError(
                f"The parameter `edges` must be a boolean array of shape {range_values.shape}, "
                "got ragged nested lists (rows of different lengths)"
            ) from None
        if edges.shape != range_values.shape:
            raise ValueError(
                f"The parameter `edges` must have shape {range_values.shape}, got {edges.shape}"
            )
        if edges.dtype != np.bool_:
            raise TypeError(f"The parameter `edges` must be a boolean array, got {edges.dtype}")
    if progress is not None and not callable(progress):
        raise TypeError("The parameter `progress` must be callable or None")
    rng = random_source(seed)
    proposal_runs = chosen.pop("proposal_runs", 1)
    proposals = chosen.pop("proposals", None)
    colour = chosen["colour"]
    # beyond the image's diagonal the radius means the whole image (bit for bit); the gap's
    # discs (r plus each node's depth) are cut one by one (belief.gap_radius)
    cut_radius, cut_proximity = search_radius(method, radius, chosen.get("proximity", 0.0),
                                              range_values.shape)
    run_radius, proximity = cut_radius, cut_proximity
    if chosen.get("training_radius") == "gap":
        run_radius, proximity = radius, chosen["proximity"]
    extra_labels = proposal_runs if proposals is not None else 0
    np_first = proposals is not None or chosen.get("observation") == "np"
    if np_first:  # NP runs first, at its own radius
        np_radius = search_radius("np", radius, 0.0, range_values.shape)[0]
        check_memory("np", image, range_values, neighbourhood=neighbourhood, radius=np_radius,
                     colour=colour, before="proposals" if proposals else "observation")
    check_memory(method, image, range_values, neighbourhood=neighbourhood, radius=cut_radius,
                 candidates=options.get("candidates", 8) + extra_labels, colour=colour)

    if edges is None:
        # the intensity convention: Canny on the grey level brought to [0, 1]
        edge_map = synthesis_edges(image, sigma=canny_sigma) if use_edges else None
    else:
        edge_map = edges.copy()
    if edge_map is None or not use_edges:
        edge_map = np.zeros(range_values.shape, dtype=bool)

    params = dict(method=method, neighbourhood=neighbourhood, radius=radius,
                  canny_sigma=canny_sigma, use_edges=use_edges, **options, **chosen)
    if proposals is not None:
        params.update(proposals=proposals, proposal_runs=proposal_runs)
    common = dict(neighbourhood=neighbourhood, radius=run_radius, use_edges=use_edges,
                  range_weight=chosen["range_weight"], missing_range=chosen["missing_range"],
                  colour=colour, channels=chosen["channels"], progress=progress)
    if method == "np":
        filled, confidence, order = np_fill(
            image, range_values, edge_map, rng, **common, **options,
            range_copy=chosen["range_copy"], confidence_update=chosen["confidence_update"],
            edges_last=chosen["edges_last"])
        gated = _after_fill(filled, range_values, edge_map, chosen)
        return SynthesisResult(range=gated, confidence=confidence, order=order,
                               edges=edge_map, method=method, params=params,
                               uncertainty=uncertainty_map(range_values, gated, raw=filled))
    bp_options = dict(k=options["candidates"], iterations=options["iterations"],
                      proximity=proximity, sigma_i=chosen["sigma_i"], sigma_s=chosen["sigma_s"],
                      tolerance=chosen["tolerance"], product=chosen["product"],
                      edge_rule=chosen["edge_rule"], range_copy=chosen["range_copy"],
                      offset_tolerance=chosen["offset_tolerance"],
                      compatibility=chosen["compatibility"],
                      training_radius=chosen["training_radius"])
    if proposals is not None:  # the departure: NP's fills as more labels (belief.proposals)
        bp_options["proposals"] = np_proposals(
            image, range_values, edge_map, rng, runs=proposal_runs,
            **{**common, "radius": np_radius, "progress": None})
        bp_options["proposal_phi"] = "match"
        bp_options["proposal_completed"] = proposals == "np-completed"
    observation = chosen["observation"]
    share = {"measured": 0.0, "np": NP_OBSERVATION_SHARE}.get(observation, OBSERVATION_SHARE)
    stages = StagedProgress(progress, [share, 1.0 - share])
    if observation == "np":  # the departure: NP's fill completes them
        if proposals is not None:  # NP has run already: its first fill
            filled = bp_options["proposals"][0]
        else:
            filled = np_fill(image, range_values, edge_map, rng,
                             **{**common, "radius": np_radius, "progress": stages.stage(0)})[0]
        bp_options["observation"] = np_observation(filled, range_values)
    elif observation != "measured":  # the departure: completed by the colorization fill
        bp_options["observation"] = observation_fill(image, range_values, observation,
                                                     colour=colour, progress=stages.stage(0))
        bp_options["observation_completed"] = observation.endswith("-completed")
    bp = bp_fill(image, range_values, edge_map, **bp_options,
                 **{**common, "progress": stages.stage(1)})
    gated = _after_fill(bp.range, range_values, edge_map, chosen)
    return SynthesisResult(range=gated, confidence=bp.confidence, order=bp.order,
                           edges=edge_map, method=method, params=params,
                           iterations=bp.iterations, candidate_values=bp.candidate_values,
                           bp=bp, uncertainty=uncertainty_map(
                               range_values, gated, method="bp", raw=bp.range,
                               candidate_values=bp.candidate_values))
