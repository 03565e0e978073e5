r"""Range synthesis by belief propagation (§3.2.3, Eqs. 6–9, Fig. 6).

The algorithm of Fig. 6, step by step:

1. Divide the intensity and the incomplete range image into n×n patches: the
   hidden node ``x_i`` of each pixel ``i`` whose range is unknown is the range
   patch centred there, its observation ``y_i`` the patch of intensity and of
   whatever range is already known (:func:`candidates`). Pixels with measured
   range are fixed nodes: their belief never changes, and they constrain their
   unknown neighbours through Ψ (:func:`fixed_neighbour_terms`).
2. For each ``y_i``, find the ``k`` closest patches among the local training
   set — the patches centred on measured pixels within ``r`` of ``i`` — by the
   distance of Eq. 2 (intensity, plus the range known in ``y_i``, with NP's
   mean-filled range term; :mod:`refsynth.synthesis.similarity`). Their range patches are the
   ``k`` labels of node ``i``. When fewer than ``k`` training patches lie
   within ``r`` (a gap wider than ``r``), the search radius doubles until ``k``
   are found or the whole image is searched.
3. Eq. 7, the local evidence of each label:

   .. math:: \Phi(x_i^l, y_i) = \exp\left(-\frac{|y_i^l - y_i|^2}{2\sigma_i^2}\right)

4. Eq. 6, a ``k × k`` compatibility per pair of 4-neighbours, from the range
   the two candidate patches give the pixels they share:

   .. math:: \Psi(x_k^l, x_j^m) = \exp\left(-\frac{|d_{jk}^l - d_{kj}^m|^2}{2\sigma_s^2}\right)

   ``|d − d'|²`` is the *mean* squared difference over the shared pixels
   where both patches have range (training patches are partial near unknown
   range); with no such pixel, Ψ = 1.
5. Messages, Eq. 9, in the log domain and normalised every iteration
   (max-product by default, sum-product as an option), on a synchronous
   schedule:

   .. math:: M_{ij}(x_j) = Z \max_{x_i} \Psi(x_i, x_j)\, \Phi(x_i, y_i)
             \prod_{k \in N(i) \setminus j} M_{ki}(x_i)

   **Edge-constraint rule**: a node sends a message once it has heard from
   all its other neighbours *except those labelled as edges* — so nodes on an
   intensity edge send no messages, and evidence does not flow across edges.
   refsynth's default reading, ``edge_rule="silent"``: a node on an edge sends
   nothing, measured nodes included (an unknown one no message, a measured one
   no Ψ term on its unknown neighbours), but still listens. ``"deaf"``: no
   message crosses an edge at all — a node on an edge neither sends nor
   receives (no message, no term of a measured neighbour), so its belief is
   its own evidence Φ alone.
6. Eq. 8, the MAP label of each node,
   ``x_i = argmax Φ(x_i, y_i) Π_j M_ji(x_i)``; the centre of its range patch is
   the synthesized range. The pixel's confidence is the normalised belief of
   that label, pooled with the labels whose centre range is the same (within
   ``VALUE_TOLERANCE`` of the known span): different training patches often
   propose the same range, and splitting the belief between them would read
   as doubt about the range where there is none.

Everything is array operations over all nodes × k (× k for Ψ and the
messages), in blocks that bound the memory: the candidate search runs tile by
tile over measured offsets only (:mod:`refsynth.synthesis.belief.search`), Ψ is
computed block by block where the messages need it and never held whole
(:attr:`BPResult.log_psi` computes it on first access), and the sends after
the first sweep touch only the edges whose inputs changed
(:func:`~refsynth.synthesis.belief.messages.belief_propagation`). What a call needs
is estimated before any work (:func:`bp_memory_estimate`), and a call over the
limit is refused then (:mod:`refsynth.synthesis.belief.memory`).

Φ, Ψ and the grid of pairs (steps 3–4) are :mod:`refsynth.synthesis.belief.model`.

**A departure, the default preset's** (``range_copy="offset"``,
:mod:`refsynth.synthesis.range_copy`): each label is moved by the consistent difference in
range between its node's observation and its patch (NP's offset copy), in Ψ, in the measured
neighbours' terms and in the value step 6 gives. ``range_copy="value"`` keeps Fig. 6's
labels.

**A departure, off by default**: with ``proposals``, dense
fills of the range (NP's, from :func:`refsynth.synthesize` with
``proposals="np"``) give every node more labels after its ``k`` training
candidates — their patches centred on it, from frames stacked below the
measured range's — so Ψ sees synthesized range
(:mod:`refsynth.synthesis.belief.proposals`, where the measured gain is). Without
it, Fig. 6 as printed, bit for bit.

The numeric contract (:mod:`refsynth.numeric`): the candidates are ranked by
the exact Eq. 2 of :class:`~refsynth.synthesis.patch_table.PatchTable` (its
integer sums, evaluated tile by tile; stable sort: ties by the raster order of
the disc offsets), Eq. 6's mean squares are
exact integer sums over the quantised range, and BP runs in float64 in the log
domain. Max-product needs only ``+ − max``; a node's incoming messages are
added in the order left, up, right, down, and the fixed neighbours' terms to
the unary term in the order right, left, below, above. Sum-product and the
confidence use :func:`~refsynth.numeric.portable_exp` /
:func:`~refsynth.numeric.portable_log` and sums over the labels from left to
right. So the output is the same on any machine, and the same as the literal
reference :func:`refsynth.synthesis.reference.bp_reference`: every array of
:class:`BPResult` included.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eqs. 6–9, Fig. 6,
doi:10.1007/s11263-007-0108-2.
W. T. Freeman, E. C. Pasztor and O. T. Carmichael, "Learning low-level
vision", IJCV 40:25–47 (2000) (patch candidates, overlap compatibilities).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.numeric import (
    NO_RANGE,
    RANGE_BITS,
    left_to_right_sum,
    portable_exp,
    quantise_grey,
    quantise_intensity,
    quantise_range,
    window_weights,
)
from refsynth.synthesis.belief.gap_radius import TRAINING_RADII, gap_radius_candidates
from refsynth.synthesis.belief.memory import BP_MEMORY_LIMIT, bp_memory_estimate, check_bp_memory
from refsynth.synthesis.belief.messages import belief_propagation
from refsynth.synthesis.belief.model import (
    COMPATIBILITIES,
    SHIFT_LIFT,
    Compatibilities,
    fixed_neighbour_terms,
    grid_edges,
    pair_compatibilities,
    phi,
    psi,
)
from refsynth.synthesis.belief.observation import observed_ranges
from refsynth.synthesis.belief.proposals import proposal_frame
from refsynth.synthesis.belief.search import candidates, search_candidates
from refsynth.synthesis.progress import StagedProgress
from refsynth.synthesis.range_copy import (
    OFFSET_TOLERANCE,
    RANGE_COPIES,
    check_offset_tolerance,
    offset_shifts,
    shifted_values,
)

__all__ = ["BPResult", "BP_STAGES", "bp_fill", "bp_memory_estimate", "BP_MEMORY_LIMIT",
           "candidates", "phi", "psi", "pair_compatibilities", "fixed_neighbour_terms",
           "grid_edges", "belief_propagation"]

#: BP's stages and their shares of its work, for its progress reports
#: (:class:`~refsynth.synthesis.progress.StagedProgress`): each stage's share of BP's CPU
#: time on the Motorcycle, x-stripes 78 %, at 450×375 and 900×750, which
#: ``python benchmarks/bench_speed.py --bp-stages --sizes 450x375,900x750`` prints.
BP_STAGES = (("search", 0.43), ("measured neighbours", 0.09), ("compatibilities", 0.01),
             ("messages", 0.45), ("MAP", 0.02))

_FIXED_BLOCK = 4096  # nodes per block of the fixed neighbours' terms (about 8 MB each)
_NODE_BLOCK = 1 << 16  # nodes per block of step 6
#: Labels per block of the labels' shifts: their int64 temporaries (a few hundred kB) stay in
#: cache and are reused from block to block; blocks of 2**16 labels (13 MB a temporary) cost
#: 0.56-2.7 µs a label against 0.35 (fresh pages at every block; the smallest images worst).
_SHIFT_BLOCK = 1 << 12

#: The readings of the edge-constraint rule (see above).
EDGE_RULES = ("silent", "deaf")

#: Candidates whose centre ranges differ by at most this fraction of the known
#: range's span count as one range hypothesis in the confidence map.
VALUE_TOLERANCE = 0.01


@dataclass(frozen=True)
class BPResult:
    """What :func:`bp_fill` returns (and :attr:`refsynth.SynthesisResult.bp` holds).

    Laid out as :class:`refsynth.synthesis.reference.BPReference`: the nodes are the
    unknown pixels in raster order (the rows of ``order``); the pairs are the
    4-neighbour pairs of unknown pixels, horizontal then vertical, each in raster
    order.

    Attributes
    ----------
    range : ndarray of shape (H, W)
        The measured range with every unknown pixel filled (Eq. 8's MAP label's
        centre range), in the caller's unit.
    confidence : ndarray of shape (H, W)
        1 where measured; elsewhere the normalised belief of the chosen range.
    order : ndarray of shape (N, 2), int64
        The synthesized pixels, (row, col), in raster order.
    iterations : int
        The message-passing sweeps BP ran (at most ``iterations`` of
        :func:`bp_fill`; fewer when the messages settled within ``tolerance``).
    candidate_values : ndarray of shape (N, k)
        The centre range of every candidate (label), in the caller's unit
        (moved by its shift with ``range_copy="offset"``).
    labels : ndarray of shape (N,), int64
        The MAP label of each node (Eq. 8, the first maximum).
    candidates : ndarray of shape (N, k, 2), int64
        The (row, col) of every candidate's centre, best-ranked first.
    unary : ndarray of shape (N, k)
        ``log Φ`` (Eq. 7) plus the terms of measured neighbours.
    pairs : ndarray of shape (E, 2), int64
        Node indices of each pair.
    messages : ndarray of shape (2E, k)
        The final log messages: row ``e`` goes ``pairs[e, 0] → pairs[e, 1]``, row
        ``E + e`` back.
    beliefs : ndarray of shape (N, k)
        The unnormalised log beliefs ``unary + Σ incoming messages``.
    compatibilities : callable, optional
        ``compatibilities()`` computes :attr:`log_psi`; BP itself never holds
        the whole table (see :func:`bp_fill`).

    Examples
    --------
    >>> import refsynth
    >>> image = np.tile(np.linspace(0, 1, 12), (10, 1))
    >>> partial = np.where(np.arange(12) % 3 == 0, 2.0, np.nan) + np.zeros((10, 1))
    >>> bp = refsynth.synthesize(image, partial, method="bp", radius=3.0).bp
    >>> bp.labels.shape == (80,) and bp.log_psi.shape == (bp.pairs.shape[0], 8, 8)
    True
    >>> bool(np.all(bp.range == 2.0)), bp.iterations >= 1
    (True, True)
    """

    range: np.ndarray
    confidence: np.ndarray
    order: np.ndarray
    iterations: int
    candidate_values: np.ndarray
    labels: np.ndarray
    candidates: np.ndarray | None = None
    unary: np.ndarray | None = None
    pairs: np.ndarray | None = None
    messages: np.ndarray | None = None
    beliefs: np.ndarray | None = None
    compatibilities: Callable[[], np.ndarray] | None = field(default=None, repr=False,
                                                            compare=False)

    @cached_property
    def log_psi(self) -> np.ndarray | None:
        """``log Ψ`` (Eq. 6) of every pair, (E, k, k): label of ``pairs[e, 0]`` first.

        Computed on first access (then kept): ``E·k²`` float64, 8 bytes each
        (:func:`refsynth.synthesis.belief.memory.psi_bytes`; 522 MB at 900×750),
        the same numbers BP's sends used.
        """
        return None if self.compatibilities is None else self.compatibilities()


# -- the whole algorithm -------------------------------------------------------------------


def bp_fill(
    image: np.ndarray,
    range_values: np.ndarray,
    edges: np.ndarray,
    *,
    neighbourhood: int = 5,
    radius: float = 10.0,
    k: int = 8,
    sigma_i: float = 0.1,
    sigma_s: float = 0.2,
    iterations: int = 50,
    tolerance: float = 1e-4,
    product: str = "max",
    damping: float = 0.0,
    use_edges: bool = True,
    range_weight: float = 1.0,
    missing_range: str = "mean",
    proximity: float = 0.0,
    colour: bool = True,
    edge_rule: str = "silent",
    channels: str = "sum",
    progress: Callable[[int, int], None] | None = None,
    memory_limit: int | None = None,
    proposals: np.ndarray | None = None,
    proposal_phi: str = "match",
    proposal_centred: bool = True,
    proposal_completed: bool = False,
    observation: np.ndarray | None = None,
    observation_completed: bool = False,
    compatibility: str = "overlap",
    training_radius: str = "fixed",
    range_copy: str = "offset",
    offset_tolerance: float = OFFSET_TOLERANCE,
) -> BPResult:
    """Fill the unknown range by the MRF-BP algorithm of Fig. 6.

    Called by :func:`refsynth.synthesize`, which validates the inputs and
    documents the parameters at length (``k`` is its ``candidates``). BP itself is
    deterministic: no random choice is made here (with ``observation="np"``, the
    default, the observations come from NP's fill, which draws before this is called).

    Parameters
    ----------
    image : ndarray of shape (H, W, C)
        The intensity (any offset and scale; quantised to ``2**-16`` of its span).
    range_values : ndarray of shape (H, W)
        The measured range, NaN where unknown (the pixels to fill).
    edges : ndarray of bool, shape (H, W)
        The intensity edges of the edge-constraint rule (Canny, §3.2).
    neighbourhood : int, default 5
        Odd side ``n`` of the patches of Eq. 2 and Eq. 6.
    radius : float, default 10
        ``r``: a node's training set is the measured pixels within ``r``,
        doubled until it holds ``k``.
    k : int, default 8
        Candidates (labels) per node.
    sigma_i : float, default 0.1
        σ_i of Eq. 7 (the local evidence Φ).
    sigma_s : float, default 0.2
        σ_s of Eq. 6 (the compatibility Ψ).
    iterations : int, default 50
        At most this many synchronous sweeps of Eq. 9.
    tolerance : float, default 1e-4
        Stop when no log message changes by more than this.
    product : {"max", "sum"}, default "max"
        Max-product (MAP) or sum-product messages.
    damping : float in [0, 1), default 0
        Log-domain damping of the messages.
    use_edges : bool, default True
        Apply the edge-constraint rule; ``False`` ignores ``edges``.
    range_weight : float, default 1
        λ of Eq. 2.
    missing_range : {"mean", "ignore"}, default "mean"
        Eq. 2's treatment of range a candidate lacks
        (:mod:`refsynth.synthesis.similarity`).
    proximity : float, default 0
        μ of the candidates' spatial prior ``μ (|p − q| / r)²``; 0 ranks by
        Eq. 2 alone (the paper's Fig. 6, step 2).
    colour : bool, default True
        Compare all intensity channels in Eq. 2; ``False``: the grey level.
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's intensity term: the sum over the colour channels (the
        paper's) or their mean.
    edge_rule : {"silent", "deaf"}, default "silent"
        The reading of the edge-constraint rule (see above).
    progress : callable, optional
        ``progress(done, 1000)``: per mille of the work, each stage — the
        candidate search (steps 2–3), the measured neighbours' terms and the
        compatibilities (step 4), the messages (step 5) and the MAP (step 6) —
        in its share of :data:`BP_STAGES` (:mod:`refsynth.synthesis.progress`),
        the search by nodes and the messages by the edges sent; ``(1000,
        1000)`` at the end.
    memory_limit : int, optional
        Bytes; refuse (``ValueError``), before any work, a call whose
        :func:`bp_memory_estimate` exceeds it. Default
        :data:`BP_MEMORY_LIMIT` (4 GiB).
    proposals : ndarray of shape (S, H, W) or (H, W), optional
        **A departure from Fig. 6** (:mod:`refsynth.synthesis.belief.proposals`):
        dense ranges (e.g. NP's fills), finite at every unknown pixel. Each
        node gets ``S`` more labels after its ``k`` training candidates, the
        patches of the proposals centred on it; Ψ and the measured
        neighbours' terms see their synthesized range. None (the default):
        Fig. 6 as printed, bit for bit.
    proposal_phi : {"match", "twin", "best", "worst", "zero"}, default "match"
        A proposal's Eq. 2 distance in Φ (Eq. 7)
        (:data:`~refsynth.synthesis.belief.proposals.PROPOSAL_PHI`).
    proposal_centred : bool, default True
        Give each node the proposals' patches centred on it as labels.
    proposal_completed : bool, default False
        Complete the training patches' unknown range from the first proposal.
    observation : ndarray of shape (H, W), optional
        **A departure from Fig. 6, step 2**
        (:mod:`refsynth.synthesis.belief.observation`): a dense range on the
        measured range's unit scale, ``(D − low) / span``, finite at every
        unknown pixel (:func:`~refsynth.synthesis.belief.observation.observation_fill`,
        the colorization fill), that completes the observations ``y_i`` for
        Eq. 2's ranking of the candidates. None: the observations hold the
        measured range only, as printed. (:func:`refsynth.synthesize` passes
        the colorization fill by default; this function's defaults are
        Fig. 6's.)
    observation_completed : bool, default False
        With ``observation``, complete the training patches' range for Eq. 2
        from it too.
    compatibility : {"overlap", "overlap-centres"}, default "overlap"
        Eq. 6's mean square over the overlap's shared measured pixels (the
        default), or with the two candidates' centre ranges as one more shared
        pixel (**a departure**, :mod:`refsynth.synthesis.belief.centres`).
    training_radius : {"fixed", "gap"}, default "fixed"
        A node's training disc: radius ``r`` (Fig. 6), or ``r`` plus the
        node's distance to the nearest measured pixel, floored (**a
        departure**, :mod:`refsynth.synthesis.belief.gap_radius`).
    range_copy : {"offset", "value"}, default "offset"
        Move every label by its offset-copy shift against the node's
        observation (``observation`` where given, else the measured range) in
        Ψ, the measured neighbours' terms and step 6 (**a departure**,
        :mod:`refsynth.synthesis.range_copy`), or ``"value"``: Fig. 6's labels.
    offset_tolerance : float, default :data:`~refsynth.synthesis.range_copy.OFFSET_TOLERANCE`
        The agreement the shift needs, a fraction of the measured span (a power of two;
        :func:`refsynth.synthesize` gives ``2**-3`` with NP's fill as the observation).

    Returns
    -------
    BPResult
        ``range`` (measured values unchanged), ``confidence`` (1 where
        measured; the normalised belief of the MAP label elsewhere), ``order``
        (the synthesized pixels in raster order), ``iterations`` (the sweeps
        run), ``candidate_values`` ((N, k) centre range of every candidate, in
        the caller's unit, rows in ``order``), ``labels`` ((N,) index of the MAP
        candidate), and the model and its messages (see :class:`BPResult`).

    Raises
    ------
    ValueError
        When the call would need more memory than ``memory_limit``.

    Examples
    --------
    >>> image = np.tile(np.linspace(0, 1, 12), (10, 1))[:, :, None]
    >>> partial = np.where(np.arange(12) % 3 == 0, 2.0, np.nan) + np.zeros((10, 1))
    >>> result = bp_fill(image, partial, np.zeros((10, 12), bool), radius=3.0)
    >>> bool(np.all(result.range == 2.0)), result.order.shape
    (True, (80, 2))
    >>> bp_fill(image, partial, np.zeros((10, 12), bool), memory_limit=10**5)
    ... # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: BP on 12×10 (80 unknown pixels) with k=8 ... more than the limit of 0.0001 GB; ...
    """
    H, W = range_values.shape
    n = neighbourhood
    h = n // 2
    if compatibility not in COMPATIBILITIES:
        raise ValueError(f"The parameter `compatibility` must be one of {COMPATIBILITIES}, "
                         f"got {compatibility!r}")
    centres = compatibility == "overlap-centres"
    if range_copy not in RANGE_COPIES:
        raise ValueError(f"The parameter `range_copy` must be one of {RANGE_COPIES}, "
                         f"got {range_copy!r}")
    offset_tolerance = check_offset_tolerance(offset_tolerance)
    known = np.isfinite(range_values)
    unknown = ~known
    # up front: the memory this call needs, against the limit
    n_channels = 1 if not colour or np.ndim(image) == 2 else np.shape(image)[2]
    if proposals is not None:
        proposals = np.asarray(proposals, dtype=np.float64)
        if proposals.shape[-2:] != (H, W) or proposals.ndim not in (2, 3):
            raise ValueError(f"The parameter `proposals` must have shape (S, {H}, {W}) or "
                             f"({H}, {W}), got {proposals.shape}")
        proposals = proposals.reshape(-1, H, W)
        if not np.all(np.isfinite(proposals[:, unknown])):
            raise ValueError("The parameter `proposals` must be finite at every unknown pixel")
    n_labels = k if proposals is None else k + proposals.shape[0]
    check_bp_memory((H, W), int(unknown.sum()), k=n_labels, neighbourhood=n,
                    channels=n_channels, n_pairs=_count_pairs(unknown), limit=memory_limit)
    # the contract: intensity and range on the 2**-16 grids of their spans
    rq, low, span = quantise_range(range_values)
    levels = quantise_intensity(image)
    if not colour:
        levels = quantise_grey(levels)[:, :, None]
    pad = max(int(np.ceil(radius)), h + 1)  # the literal search's frame (its stopping rule)
    flat = np.flatnonzero(unknown)
    rows, cols = np.divmod(flat, W)
    on_edge = (np.asarray(edges, dtype=bool) & use_edges).ravel()
    deaf = on_edge[flat] if edge_rule == "deaf" else np.zeros(flat.size, dtype=bool)
    stages = StagedProgress(progress, [share for _, share in BP_STAGES])

    # step 2: candidates, and step 3: log Phi
    observed = training = None
    if observation is not None:  # the departure: the observations' range from a fill
        observed, training = observed_ranges(rq, observation,
                                             completed=observation_completed)
    if training_radius not in TRAINING_RADII:
        raise ValueError(f"The parameter `training_radius` must be one of {TRAINING_RADII}, "
                         f"got {training_radius!r}")
    search = gap_radius_candidates if training_radius == "gap" else search_candidates
    labels, dist = search(levels, rq, rows, cols, n=n, k=k, radius=radius,
                          proximity=proximity, range_weight=range_weight,
                          missing_range=missing_range, pad=pad, channels=channels,
                          observed=observed, training=training, progress=stages.stage(0))
    target_pad = None
    if range_copy == "offset":  # the departure: each label shifted to the observation's level
        target = observed if observed is not None else rq
        target_pad = np.pad(np.asarray(target, dtype=np.int64), h, constant_values=NO_RANGE)
    del observed, training
    del levels
    frame = None
    if proposals is not None:  # the departure: proposals' labels after the k candidates
        frame = proposal_frame(range_values, rq, low, span, proposals, labels, dist, flat, n,
                               phi=proposal_phi, centred=proposal_centred,
                               completed=proposal_completed)
        labels, dist, k = frame.labels, frame.distance, frame.labels.shape[1]
    unary = phi(dist, sigma_i)
    del dist
    stages.complete(0)
    # every pixel's range patch on the contract's grid (−1 where unknown), a view; with
    # proposals, their frames stacked below the measured one
    if frame is None:
        qpad = np.pad(np.where(known, rq, -1).astype(np.float64), h, constant_values=-1.0)
        centre_q = np.where(known, rq, 0)  # step 6 pools labels on the range's integer grid
        centre = np.where(known, range_values, 0.0)
    else:
        qpad, centre_q, centre = frame.plane, frame.centre_q, frame.centre
    del rq
    patches = sliding_window_view(qpad, (n, n))  # (H, W, n, n)
    label_shifts = measured_span = None
    if target_pad is not None:
        measured_span = (float(np.min(range_values[known])), float(np.max(range_values[known])))
        label_shifts = _label_shifts(target_pad, patches, rows, cols, labels, W, n,
                                     offset_tolerance)
        del target_pad

    node_of = np.full(H * W, -1, dtype=np.int64)
    node_of[flat] = np.arange(flat.size)
    pairs_all = grid_edges(unknown)
    # step 4: fixed neighbours -> unary terms, in the order right, left, below, above;
    # the edge rule: a measured node on an edge sends no term (and, with the paper's
    # rule, a node on an edge receives none)
    for direction in ("h", "v"):
        fixed_pairs = pairs_all.pop(direction + "_fixed")
        if fixed_pairs.size == 0:
            continue
        first_unknown = unknown.ravel()[fixed_pairs[:, 0]]
        for side, which in (("right", first_unknown), ("left", ~first_unknown)):
            sel = fixed_pairs[which]
            node_pix = sel[:, 0] if side == "right" else sel[:, 1]
            fixed_pix = sel[:, 1] if side == "right" else sel[:, 0]
            keep = ~on_edge[fixed_pix] & ~deaf[node_of[node_pix]]
            node_pix, fixed_pix = node_pix[keep], fixed_pix[keep]
            if node_pix.size == 0:
                continue
            fr, fc = np.divmod(fixed_pix, W)
            node = node_of[node_pix]
            for start in range(0, node.size, _FIXED_BLOCK):
                s = slice(start, start + _FIXED_BLOCK)
                cr, cc = np.divmod(labels[node[s]], W)
                cp = patches[cr, cc]
                fp = patches[fr[s], fc[s]][:, None]
                if label_shifts is not None:
                    lift = (label_shifts[node[s]] + SHIFT_LIFT)[:, :, None, None]
                    cp = np.where(cp >= 0, cp + lift, -1.0)
                    fp = np.where(fp >= 0, fp + SHIFT_LIFT, -1.0)
                ms = fixed_neighbour_terms(cp, fp, direction, side, quantised=True,
                                           centres=centres)
                # each node has one such neighbour per direction and side
                unary[node[s]] += psi(ms, sigma_s)
    stages.complete(1)
    # step 4: k x k compatibilities between unknown neighbours, computed where needed
    pair_h, pair_v = node_of[pairs_all.pop("h")], node_of[pairs_all.pop("v")]
    del node_of, pairs_all
    pairs = np.concatenate([pair_h, pair_v]).reshape(-1, 2).astype(np.int64)
    compatibilities = Compatibilities(qpad, n, labels, W, pairs, pair_h.shape[0], sigma_s,
                                      centres=centres, shifts=label_shifts)
    del pair_h, pair_v
    stages.complete(2)
    # step 5: messages; the edge-constraint rule silences (and deafens) edge nodes
    belief, done, messages = belief_propagation(
        unary, pairs, compatibilities, silent=on_edge[flat] if use_edges else None,
        deaf=deaf if edge_rule == "deaf" else None, iterations=iterations,
        tolerance=tolerance, product=product, damping=damping, return_messages=True,
        progress=stages.stage(3),
    )
    stages.complete(3)
    # step 6: MAP label, its centre range, and its normalised belief (by blocks of nodes)
    out = range_values.copy()
    confidence = known.astype(np.float64)
    best = np.empty(flat.size, dtype=np.int64)
    cand_values = np.empty((flat.size, k))
    chosen_all = np.empty(flat.size)
    pooled_all = np.empty(flat.size)
    for start in range(0, flat.size, _NODE_BLOCK):
        sl = slice(start, start + _NODE_BLOCK)
        cand_rows, cand_cols = np.divmod(labels[sl], W)
        cand_values[sl] = centre[cand_rows, cand_cols]
        cand_q = centre_q[cand_rows, cand_cols]
        if label_shifts is not None:  # the offset copy: the shifted centres
            cand_q, cand_values[sl] = shifted_values(cand_q, label_shifts[sl], cand_values[sl],
                                                     span, *measured_span)
        best[sl], chosen_all[sl], pooled_all[sl] = _map_and_belief(
            belief[sl], cand_values[sl], cand_q)
    out[unknown] = chosen_all
    confidence[unknown] = np.minimum(pooled_all, 1.0)
    del chosen_all, pooled_all
    cand = np.empty((flat.size, k, 2), dtype=np.int64)
    for start in range(0, flat.size, _NODE_BLOCK):
        sl = slice(start, start + _NODE_BLOCK)
        cand[sl, :, 0], cand[sl, :, 1] = np.divmod(labels[sl], W)
    if frame is not None:  # a proposal's centre is its node: the row within its frame
        cand[:, :, 0] %= H + 2 * h
    stages.finish()
    order = np.stack([rows, cols], axis=1).astype(np.int64)
    return BPResult(range=out, confidence=confidence, order=order, iterations=done,
                    candidate_values=cand_values, labels=best, candidates=cand, unary=unary,
                    pairs=pairs, messages=messages, beliefs=belief,
                    compatibilities=compatibilities.all)


def _label_shifts(target_pad, patches, rows, cols, labels, width, n,
                  tolerance=OFFSET_TOLERANCE):
    """Every label's shift Δ (:mod:`refsynth.synthesis.range_copy`) against its node's
    observation, (N, k) int64: the node's window of ``target_pad`` against the label's
    patch, block by block, with the agreement ``tolerance``."""
    out = np.empty(labels.shape, dtype=np.int64)
    weights = window_weights(n).ravel()
    windows = sliding_window_view(target_pad, (n, n))
    step = max(1, _SHIFT_BLOCK // labels.shape[1])  # about _SHIFT_BLOCK labels per block
    for start in range(0, labels.shape[0], step):
        sl = slice(start, start + step)
        m, k = labels[sl].shape
        target = windows[rows[sl], cols[sl]].reshape(m, 1, -1)
        cr, cc = np.divmod(labels[sl], width)
        source = patches[cr, cc].reshape(m, k, -1).astype(np.int64)
        out[sl] = offset_shifts(np.broadcast_to(target, source.shape).reshape(m * k, -1),
                                source.reshape(m * k, -1), weights,
                                tolerance).reshape(m, k)
    return out


def _map_and_belief(belief: np.ndarray, cand_values: np.ndarray, cand_q: np.ndarray):
    """Eq. 8 for a block of nodes: the MAP label, its centre range, its pooled belief.

    Labels are pooled on the quantised range (integers on the 2**-16 grid of the known
    span), so that the pooling is exact and a positive scale of the range changes nothing.
    """
    best = np.argmax(belief, axis=1)
    prob = portable_exp(belief - belief.max(axis=1, keepdims=True))
    prob = prob / left_to_right_sum(prob, axis=1)[:, None]
    # the belief that the range is the chosen value: candidates whose centres lie
    # within VALUE_TOLERANCE of the known span of it are the same range hypothesis
    index = np.arange(cand_values.shape[0])
    chosen = cand_values[index, best]
    same = np.abs(cand_q - cand_q[index, best][:, None]) <= VALUE_TOLERANCE * 2.0**RANGE_BITS
    return best, chosen, left_to_right_sum(np.where(same, prob, 0.0), axis=1)


def _count_pairs(unknown: np.ndarray) -> int:
    """The number of 4-neighbour pairs of unknown pixels."""
    return int(np.count_nonzero(unknown[:, :-1] & unknown[:, 1:])
               + np.count_nonzero(unknown[:-1, :] & unknown[1:, :]))
