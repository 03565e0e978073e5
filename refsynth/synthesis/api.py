"""The front door: :func:`synthesize` (§3.2).

Validates the inputs, normalises the intensity, detects intensity edges
(Canny, σ = 0.8) and dispatches to the range-synthesis method: NP
(:mod:`refsynth.synthesis.nonparametric`) or BP (:mod:`refsynth.synthesis.bp`).
Every other part of refsynth (the command line, the tutorials, the
benchmarks, a faster port checking itself against this one) calls this
function.

Each method has options of its own (:data:`NP_OPTIONS`, :data:`BP_OPTIONS`,
checked in :mod:`refsynth.synthesis.options`): they default to ``None``, which
means the method's default, and giving one to the other method raises
``ValueError`` unless it is that option's default.

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

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from refsynth._checks import check_bool, check_choice, check_real
from refsynth.numeric import INTENSITY_BITS, quantise_grey, quantise_intensity
from refsynth.synthesis.bp import BPResult, bp_fill
from refsynth.synthesis.bp_observation import np_observation, observation_fill
from refsynth.synthesis.bp_proposals import np_proposals
from refsynth.synthesis.canny import canny
from refsynth.synthesis.limits import (
    check_canny_sigma,
    check_memory,
    normalise_intensity,
    search_radius,
    validate_inputs,
)
from refsynth.synthesis.nonparametric import np_fill
from refsynth.synthesis.options import (
    BP_DEPARTURES,
    BP_OPTIONS,
    METHODS,
    NP_OPTIONS,
    at_least,
    bounded,
    check_bp_departures,
    check_method_options,
    check_proposals,
    random_source,
)
from refsynth.synthesis.progress import StagedProgress
from refsynth.synthesis.range_copy import default_offset_tolerance
from refsynth.synthesis.similarity import CHANNELS, MISSING_RANGE

__all__ = [
    "SynthesisResult",
    "synthesize",
    "validate_inputs",
    "normalise_intensity",
    "NP_OPTIONS",
    "BP_OPTIONS",
    "BP_DEPARTURES",
    "OBSERVATION_SHARE",
]

#: The observations' fill's share of BP's work with ``observation="colorization"`` (BP's
#: progress reports, :mod:`refsynth.synthesis.progress`): CPU time on the Motorcycle,
#: x-stripes 78 % (``python benchmarks/bench_speed.py --bp-stages``: 9 % at 450×375 and 10 % at
#: 900×750 since 0.7's cascade; 0.6's Gauss–Seidel alone took about a quarter).
OBSERVATION_SHARE = 0.10
#: The same with ``observation="np"``, NP's fill first: NP's wall time over BP-on-NP's, 0.55
#: at 450×375 and 0.59 at 900×750 in 0.8's run, 0.59 and 0.60 in 0.9's, 0.67 and 0.69 in
#: 0.9.3's (``python benchmarks/bench_speed.py``; 0.55 until 0.9.2).
NP_OBSERVATION_SHARE = 0.67

@dataclass(frozen=True)
class SynthesisResult:
    """What :func:`synthesize` returns.

    Attributes
    ----------
    range : ndarray of shape (H, W), float64
        The dense range, finite everywhere; measured pixels are unchanged.
    confidence : ndarray of shape (H, W), float64
        In [0, 1]: 1 where the range was measured; for NP the confidence the
        pixel received when it was synthesized (Eq. 11, see
        :mod:`refsynth.synthesis.priority`); for BP the normalised belief (Eq. 8) of the
        chosen range, pooled over the candidates that propose it (see
        :mod:`refsynth.synthesis.bp`).
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
        :class:`refsynth.synthesis.bp.BPResult`); None for NP.

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


def synthesize(
    intensity: np.ndarray,
    partial_range: np.ndarray,
    *,
    method: str = "np",
    seed: int | np.random.Generator | None = 0,
    neighbourhood: int = 5,
    radius: float = 10.0,
    range_weight: float = 1.0,
    missing_range: str = "mean",
    colour: bool = True,
    channels: str = "sum",
    canny_sigma: float = 0.8,
    edges: np.ndarray | None = None,
    use_edges: bool = True,
    progress: Callable[[int, int], None] | None = None,
    epsilon: float | None = None,
    use_isophotes: bool | None = None,
    ordering: str | None = None,
    candidates: int | None = None,
    proximity: float | None = None,
    sigma_i: float | None = None,
    sigma_s: float | None = None,
    iterations: int | None = None,
    tolerance: float | None = None,
    product: str | None = None,
    confidence_update: str | None = None,
    edges_last: bool | None = None,
    range_copy: str | None = None,
    offset_tolerance: float | None = None,
    edge_rule: str | None = None,
    proposals: str | None = None,
    proposal_runs: int | None = None,
    observation: str | None = None,
    compatibility: str | None = None,
    training_radius: str | None = None,
) -> SynthesisResult:
    """Infer the missing range from intensity and partial range (§3.2).

    Everything after ``partial_range`` is keyword-only. The options of one
    method (NP or BP only, see the table under Notes) default to ``None``,
    the method's default; giving one to the other method raises
    ``ValueError``, unless it is that option's default.

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
        BP draws through NP's fill, which completes its observations by default
        (``observation="np"``, since 0.9), so its output depends on the seed too;
        with another ``observation`` and no ``proposals`` BP makes no random
        choice and the seed does not matter.
    neighbourhood : int, default 5
        Odd side ``n`` of the n×n MRF neighbourhood (§3.2.1).
    radius : float, default 10
        Search radius ``r`` of Eq. 3 (NP) and of BP's training set, in
        pixels, at least 1. A radius beyond the image's diagonal,
        ``ceil(hypot(H − 1, W − 1))``, searches the whole image, as the
        diagonal does: BP runs it as the next power of two at or above the
        diagonal (bit for bit the given radius's result; its prior keeps the
        scale ``r``, and with ``proximity=0`` the result is the diagonal's
        too); NP's tie-break
        permutation is drawn over the frame padded by ``r`` (as the literal
        reference draws it), so its result can differ from the diagonal's, and
        a radius whose padded frame does not fit in memory is refused (see
        :mod:`refsynth.synthesis.limits`).
    range_weight : float, default 1
        Weight λ of the range term of Eq. 2 against the intensity term,
        both normalised (see :mod:`refsynth.synthesis.similarity`); in
        ``[0, 1e100]``.
    missing_range : {"mean", "ignore"}
        How Eq. 2's range term treats window offsets where the target has range
        and a candidate has none: ``"mean"`` charges them the mean discrepancy
        of the offsets both have; ``"ignore"`` drops them, the literal Eq. 2
        (see :mod:`refsynth.synthesis.similarity` for why refsynth
        departs from it). BP ranks its candidates with the same distance.
    colour : bool, default True
        Eq. 2's intensity term on the colour channels; ``False`` uses the grey
        level (BT.709 luminance, brought to its span). No effect on a grey
        image.
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's intensity term over the colour channels: their sum, the
        paper's Eq. 2 (each channel's squared difference weighs as much as
        the range's), or their mean (refsynth before 0.3, which weighs the
        range term C times more). On the Motorcycle the sum wins for NP at
        every fraction (the README's audit). No effect on grey.
    canny_sigma : float, default 0.8
        σ of the Canny edge detector's Gaussian (the paper's setting), in
        ``[0, max(H, W)]``. Canny runs on the grey level brought to [0, 1]
        (see Notes), with thresholds 0.1 and 0.2 of that span.
    edges : ndarray of shape (H, W), bool, optional
        A precomputed edge map; overrides the Canny detector.
    use_edges : bool, default True
        NP: use the edge count of Eq. 10 and (with ``edges_last``) fill edge
        pixels last. BP: the edge-constraint rule (``edge_rule``). ``False``
        is the paper's no-edge ablation (Fig. 13, Table 3).
    progress : callable, optional
        Called as ``progress(done, total)``: NP in pixels, every few hundred
        pixels; BP in per mille of its estimated work, as the observations'
        fill sweeps, the candidates are searched and the messages are sent
        (:data:`refsynth.synthesis.bp.BP_STAGES`, :data:`OBSERVATION_SHARE`),
        so that no stage runs long without a report.
    epsilon : float, NP only, default 0.1
        Tolerance ε of Eq. 5, in ``[0, 1e100]``.
    use_isophotes : bool, NP only, default True
        Use the isophote data term of Eq. 12. ``False`` sets D = 1 (Fig. 16).
    ordering : {"priority", "onion"}, NP only, default "priority"
        The paper's information-driven order (Eqs. 10–12) or the onion-peel
        order it compares against (Fig. 7).
    confidence_update : {"best", "product"}, NP only, default "best"
        The confidence a synthesized pixel receives (Eq. 11): ``"best"``,
        ``C(N_best)``, the confidence of the neighbourhood it matched best
        (the text after Eq. 11 read literally; chosen on the Motorcycle, see
        the README's audit), or ``"product"``, ``C(p) · C(N_best)`` (refsynth's
        reading before 0.2, which drives synthesized confidence towards 0).
    range_copy : {"offset", "value"}, default "offset"
        What a pixel gets from the neighbourhood Eq. 5 drew (NP) or from its
        MAP label (BP, Eq. 8): ``"value"``, its centre range (the paper, Efros
        & Leung's copy; Fig. 6's labels); ``"offset"`` (**a departure, the
        default since 0.5 for NP and 0.6 for BP**: it won on the Motorcycle at
        every fraction and size, see the README's audit), that value shifted by
        the consistent difference in range between the two windows, so that a
        slanted surface fills as a surface, not a staircase of copies
        (:mod:`refsynth.synthesis.range_copy`). BP shifts every label against
        its node's observation (measured or completed range) and compares the
        shifted patches in Eq. 6.
    offset_tolerance : float, BP only, default by ``observation``
        How closely the two windows' range differences must agree for BP's
        labels to be shifted (``range_copy="offset"``), as a fraction of the
        measured span: a power of two from ``2**-16`` to 1. None: ``2**-3``
        with ``observation="np"``, the default (0.8.4, chosen on the
        Motorcycle: with NP's dense fill as the observation a looser agreement
        shifts more labels and wins), else ``2**-7``, NP's own agreement (a
        looser one loses with the colorization fill's observations). See
        :mod:`refsynth.synthesis.range_copy`.
    edges_last : bool, NP only, default True
        With ``use_edges``: pixels on an edge form a second tier, filled only
        when no other pixel is left on the front. ``False`` keeps only Eq. 10's
        ``1 / (1 + E)`` term.
    candidates : int, BP only, default 8
        ``k``, the candidates (labels) per unknown pixel (Ψ holds ``k²``
        numbers per pair of neighbours: a ``k`` beyond memory is refused).
    proximity : float, BP only, default 0
        μ, the weight of a spatial prior ``μ (|p − q| / r)²`` added to
        Eq. 2 when ranking candidates and in Φ (a departure from the paper,
        see :mod:`refsynth.synthesis.bp`); 0, the default, ranks by Eq. 2
        alone as Fig. 6 does (μ = 1 was the default before 0.3; on the
        Motorcycle it loses at every fraction). In ``[0, 1e100]``.
    sigma_i : float, BP only, default 0.1
        σ_i of Eq. 7, in units of the Eq. 2 distance's square root; in
        ``[1e-50, 1e50]``.
    sigma_s : float, BP only, default 0.2
        σ_s of Eq. 6, in units of the known range's span; in ``[1e-50, 1e50]``.
    iterations : int, BP only, default 50
        At most this many message-passing sweeps (the paper's 50).
    tolerance : float, BP only, default 1e-4
        Stop when no (log) message changes by more than this.
    product : {"max", "sum"}, BP only, default "max"
        Max-product (MAP) or sum-product messages.
    edge_rule : {"silent", "paper"}, BP only, default "silent"
        With ``use_edges``, how edges stop messages (§3.2.3). ``"silent"``: a
        node on an edge sends nothing — an unknown one no message, a measured
        one no Ψ term on its unknown neighbours — but still receives.
        ``"paper"``: no message crosses an edge — a node on an edge neither
        sends nor receives (no message, no measured neighbour's term), so its
        belief is its own evidence Φ.
    proposals : {None, "np", "np-completed"}, BP only, default None
        **A departure from Fig. 6** (issue #10;
        :mod:`refsynth.synthesis.bp_proposals`). None: the paper's candidates,
        bit for bit. ``"np"``: NP (§3.2.2, its default options, seeded from
        ``seed``) first fills the range; each unknown pixel gets, after its
        ``candidates`` training patches, one more label per fill — the patch
        of NP's result centred on it, so Ψ (Eq. 6) and the measured
        neighbours' terms see synthesized range — whose Φ (Eq. 7) is that of
        the best training candidate proposing the same range (within 1 % of
        the known span), or of the worst candidate when none does.
        ``"np-completed"``: the same, and the training patches' unknown range
        is NP's too. BP then depends on ``seed``; NP's own options
        (``epsilon`` …) stay refused, NP runs at its defaults. The
        candidates' ceiling drops at every fraction; the measured gain in MAR
        (and where it loses) is in :mod:`refsynth.synthesis.bp_proposals`.
    proposal_runs : int, BP with ``proposals`` only, default 1
        How many NP fills propose (each a label per pixel; the seeds follow one
        another from ``seed``'s generator).
    observation : {None, "colorization", "measured", "colorization-completed", "np"}, BP only
        Fig. 6, step 2's observations ``y_i`` (issue #10;
        :mod:`refsynth.synthesis.bp_observation`). None or ``"np"`` (the
        default since 0.9, **a departure from Fig. 6** that won on real data):
        NP's fill (at NP's defaults, the result ``method="np"`` gives with the
        same ``seed``; with ``proposals`` their first fill) completes every
        observation (:func:`refsynth.synthesis.bp_observation.np_observation`),
        so Eq. 2 ranks the candidates with a range term deep in a gap too; BP
        then depends on ``seed`` and takes NP's time on top of its own (its
        measured gain and cost are in :mod:`refsynth.synthesis.bp_observation`).
        ``"colorization"`` (0.4–0.8's default, a departure): the colorization
        fill of the measured range
        (:func:`refsynth.synthesis.bp_observation.observation_fill`: the
        portable solve, the same bits on every machine, of the quantised range
        guided by the quantised intensity, so the intensity convention below
        holds for it too) completes them instead: cheaper, no seed, less
        accurate. ``"colorization-completed"``: the training patches' range in
        Eq. 2 is completed by it as well. ``"measured"``: the observations hold
        the measured range only, as printed.
    compatibility : {None, "overlap", "overlap-centres"}, BP only
        **A departure in Eq. 6** (:mod:`refsynth.synthesis.bp_centres`). None
        or ``"overlap"``: the mean square over the shared measured pixels, Ψ = 1
        with none. ``"overlap-centres"``: the two labels' centre ranges count as
        one more shared pixel.
    training_radius : {None, "gap", "fixed"}, BP only
        Fig. 6, step 2's training disc (:mod:`refsynth.synthesis.bp_gap_radius`).
        None or ``"gap"`` (the default, **a departure** that won on real data
        together with the completed observations): within ``radius`` plus the
        node's distance to the nearest measured pixel (floored), so a node
        deep in a gap searches as far past its edge as one beside it.
        ``"fixed"``: the measured pixels within ``radius``, as printed.
        ``observation="measured", training_radius="fixed", range_copy="value"``
        is Fig. 6's BP.

    Returns
    -------
    SynthesisResult

    Raises
    ------
    TypeError, ValueError
        On bad input, naming the argument, before any work starts: a real
        parameter outside the range where the arithmetic stays finite
        (:data:`refsynth.synthesis.limits.PARAMETER_BOUNDS`, the ranges given
        above), and a run whose estimated memory exceeds the machine's
        physical memory (the message says how much it would need); and
        ``ValueError`` for an option the chosen method does not use.

    Notes
    -----
    The options, by the method that uses them. The options of one method
    default to ``None``, which stands for the default in the last column:

    =======================  ===========  ===========  ================================
    option                   NP           BP           default
    =======================  ===========  ===========  ================================
    ``seed``                 yes          (NP first)   0
    ``neighbourhood``        yes          yes          5
    ``radius``               yes          yes          10
    ``range_weight``         yes          yes          1
    ``missing_range``        yes          yes          ``"mean"``
    ``colour``               Eq. 2        Eq. 2        True
    ``channels``             Eq. 2        Eq. 2        ``"sum"``
    ``canny_sigma``          yes          yes          0.8
    ``edges``                yes          yes          Canny's
    ``use_edges``            Eq. 10       edge rule    True
    ``progress``             yes          yes          none
    ``epsilon``              Eq. 5        —            0.1
    ``use_isophotes``        Eq. 12       —            True
    ``ordering``             §3.2.4       —            ``"priority"``
    ``confidence_update``    Eq. 11       —            ``"best"``
    ``edges_last``           Eq. 10       —            True
    ``range_copy``           Eq. 5        Eq. 8        ``"offset"`` (departure)
    ``offset_tolerance``     —            Eq. 8        ``2**-3``; ``2**-7`` on colorization
    ``candidates``           —            ``k``        8
    ``proximity``            —            μ            0
    ``sigma_i``              —            Eq. 7        0.1
    ``sigma_s``              —            Eq. 6        0.2
    ``iterations``           —            Eq. 9        50
    ``tolerance``            —            Eq. 9        1e-4
    ``product``              —            Eq. 9        ``"max"``
    ``edge_rule``            —            §3.2.3       ``"silent"``
    ``proposals``            —            departure    None
    ``proposal_runs``        —            departure    1
    ``observation``          —            step 2       ``"np"`` (departure)
    ``compatibility``        —            Eq. 6        ``"overlap"``
    ``training_radius``      —            step 2       ``"gap"`` (departure)
    =======================  ===========  ===========  ================================

    An option marked "—" raises ``ValueError`` for that method unless it is
    ``None`` or its default, e.g. ``method="bp", ordering="onion"``: "The
    parameter `ordering` applies to method='np' only; method='bp' does not use
    it".

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
    width, and the same as the literal reference
    :mod:`refsynth.synthesis.reference`.

    Examples
    --------
    >>> import numpy as np, refsynth
    >>> image = np.tile(np.linspace(0, 1, 8), (8, 1))
    >>> partial = np.full((8, 8), np.nan); partial[:, ::3] = 2.0
    >>> result = refsynth.synthesize(image, partial, seed=0)
    >>> bool(np.all(result.range == 2.0))
    True
    >>> refsynth.synthesize(image, partial, method="bp", ordering="onion")
    Traceback (most recent call last):
    ...
    ValueError: The parameter `ordering` applies to method='np' only; method='bp' does not use it
    """
    image, range_values = validate_inputs(intensity, partial_range)
    method = check_choice("method", method, METHODS)
    options = check_method_options(method, dict(
        epsilon=epsilon, use_isophotes=use_isophotes, ordering=ordering,
        candidates=candidates, proximity=proximity, sigma_i=sigma_i, sigma_s=sigma_s,
        iterations=iterations, tolerance=tolerance, product=product,
        confidence_update=confidence_update, edges_last=edges_last, edge_rule=edge_rule,
        range_copy=range_copy, offset_tolerance=offset_tolerance,
    ))
    proposal_options = check_proposals(method, proposals, proposal_runs)
    departures = check_bp_departures(method, observation, compatibility, training_radius)
    if method == "bp" and options["offset_tolerance"] is None:  # by the observation
        options["offset_tolerance"] = default_offset_tolerance(departures["observation"])
    neighbourhood = at_least("neighbourhood", neighbourhood, 1)
    if neighbourhood % 2 == 0:
        raise ValueError(f"The parameter `neighbourhood` must be odd, got {neighbourhood}")
    radius = check_real("radius", radius)
    if radius <= 0:
        raise ValueError(f"The parameter `radius` must be finite and > 0, got {radius}")
    if radius < 1:
        raise ValueError(f"The parameter `radius` must be >= 1 pixel, got {radius}")
    canny_sigma = check_canny_sigma(canny_sigma, range_values.shape)
    range_weight = bounded("range_weight")(range_weight)
    missing_range = check_choice("missing_range", missing_range, MISSING_RANGE)
    colour = check_bool("colour", colour)
    channels = check_choice("channels", channels, CHANNELS)
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
    # beyond the image's diagonal the radius means the whole image (bit for bit); the gap's
    # discs (r plus each node's depth) are cut one by one (bp_gap_radius)
    cut_radius, cut_proximity = search_radius(method, radius, options.get("proximity", 0.0),
                                              range_values.shape)
    run_radius, proximity = cut_radius, cut_proximity
    if departures.get("training_radius") == "gap":
        run_radius, proximity = radius, options.get("proximity", 0.0)
    extra_labels = proposal_options.get("proposal_runs", 0)
    np_first = bool(proposal_options) or departures.get("observation") == "np"
    if np_first:  # NP runs first, at its own radius
        np_radius = search_radius("np", radius, 0.0, range_values.shape)[0]
        check_memory("np", image, range_values, neighbourhood=neighbourhood, radius=np_radius,
                     colour=colour, before="proposals" if proposal_options else "observation")
    check_memory(method, image, range_values, neighbourhood=neighbourhood, radius=cut_radius,
                 candidates=options.get("candidates", 8) + extra_labels, colour=colour)

    if edges is None:
        # the intensity convention: Canny on the grey level brought to [0, 1]
        levels = quantise_grey(quantise_intensity(image)) * 2.0**-INTENSITY_BITS
        edge_map = canny(levels, sigma=canny_sigma) if use_edges else None
        del levels
    else:
        edge_map = edges.copy()
    if edge_map is None or not use_edges:
        edge_map = np.zeros(range_values.shape, dtype=bool)

    params = dict(method=method, neighbourhood=neighbourhood, radius=radius,
                  canny_sigma=canny_sigma, use_edges=use_edges, range_weight=range_weight,
                  missing_range=missing_range, colour=colour, channels=channels, **options,
                  **proposal_options, **departures)
    common = dict(neighbourhood=neighbourhood, radius=run_radius, use_edges=use_edges,
                  range_weight=range_weight, missing_range=missing_range, colour=colour,
                  channels=channels, progress=progress)
    if method == "bp":
        options["k"] = options.pop("candidates")  # bp_fill's name for it
        options["proximity"] = proximity
        if proposal_options:  # the departure: NP's fills as more labels (bp_proposals)
            options["proposals"] = np_proposals(
                image, range_values, edge_map, rng, runs=proposal_options["proposal_runs"],
                **{**common, "radius": np_radius, "progress": None})
            options["proposal_phi"] = "match"
            options["proposal_completed"] = proposal_options["proposals"] == "np-completed"
        observation = departures["observation"]
        share = {"measured": 0.0, "np": NP_OBSERVATION_SHARE}.get(observation,
                                                                 OBSERVATION_SHARE)
        stages = StagedProgress(progress, [share, 1.0 - share])
        if observation == "np":  # the departure: NP's fill completes them
            if proposal_options:  # NP has run already: its first fill
                filled = options["proposals"][0]
            else:
                filled = np_fill(image, range_values, edge_map, rng,
                                 **{**common, "radius": np_radius, "progress": stages.stage(0)})[0]
            options["observation"] = np_observation(filled, range_values)
        elif observation != "measured":  # the default: completed by the colorization fill
            options["observation"] = observation_fill(image, range_values, observation,
                                                      colour=colour, progress=stages.stage(0))
            options["observation_completed"] = observation.endswith("-completed")
        options["compatibility"] = departures["compatibility"]
        options["training_radius"] = departures["training_radius"]
        bp = bp_fill(image, range_values, edge_map, **options,
                     **{**common, "progress": stages.stage(1)})
        return SynthesisResult(range=bp.range, confidence=bp.confidence, order=bp.order,
                               edges=edge_map, method=method, params=params,
                               iterations=bp.iterations, candidate_values=bp.candidate_values,
                               bp=bp)
    filled, confidence, order = np_fill(image, range_values, edge_map, rng, **options, **common)
    return SynthesisResult(range=filled, confidence=confidence, order=order, edges=edge_map,
                           method=method, params=params)
