r"""BP's candidates from a dense proposal of the range (§3.2.3, Fig. 6, step 2): a departure.

Fig. 6, step 2 gives each unknown pixel ``k`` labels: the range patches of the
``k`` measured pixels whose neighbourhoods match its observation best (Eq. 2).
BP (Eqs. 8–9) can only *choose* among them, so its error is bounded below by
the *candidate ceiling*, the MAR if every node took its best label. On the
Motorcycle's x-stripes the training patches near a wide gap hold range only
where the stripes are, Ψ (Eq. 6) compares them on a few shared pixels, and at
85 % unknown Fig. 6's BP ends up worse than NP.

**This module is not the paper.** With ``proposals="np"``
(:func:`refsynth.synthesize`), NP (§3.2.2, :func:`np_proposals`) first fills
the range once (or ``proposal_runs`` times, the seeds drawn in turn from the
same generator), giving dense ranges ``D_1 … D_S``. Each unknown node ``p``
then gets ``S`` labels beside its ``k`` training candidates: the patch of
``D_s`` centred on ``p`` itself, whose centre is NP's value at ``p``
(:func:`proposal_frame`). These patches carry synthesized range everywhere, so
Ψ (Eq. 6) between two neighbouring proposals compares the whole overlap, and
a measured neighbour's term (the fixed node's message) compares it with every
measured pixel the two patches share. The labels are flat indices into a
stack of range frames on the contract's grid (:mod:`refsynth.numeric`): frame
0 the measured range (−1 where unknown), frame ``s`` the proposal ``D_s``; so
:class:`~refsynth.synthesis.belief.model.Compatibilities`,
:func:`~refsynth.synthesis.belief.model.fixed_neighbour_terms` and the message loop
run unchanged on ``k + S`` labels.

Φ (Eq. 7) of a proposal (:data:`PROPOSAL_PHI`). Its observation is ``p``'s
own, so Eq. 2 between ``y_p`` and the proposal is 0 (``phi="zero"``: the same
intensity, and where ``p``'s window has range ``D_s`` holds the same range);
``"best"`` gives it the distance of ``p``'s best training candidate. Either
way the proposal wins nearly everywhere — neighbouring proposals agree exactly
on their overlap, and a tie goes to the first label — and BP returns NP's
fill (measured on the Motorcycle, x-stripes 78 %: 100 % of the nodes).
``"match"`` (what :func:`refsynth.synthesize` uses) gives it the distance of
the best training candidate whose centre range is the same (within 1 % of the
known span), or of the worst candidate when none is: the proposal is as
likely as the training evidence for its range, and Ψ then decides. ``"twin"``
falls back to the best instead of the worst (it returns NP's fill within
±0.01 px).

``completed`` (``proposals="np-completed"``) also completes the measured
frame's unknown pixels from ``D_1``, so the training candidates' patches, and
the fixed neighbours' patches, are whole too; Ψ between two training patches
then compares their full overlap instead of the few measured pixels they
share (with no shared pixel Ψ = 1, which favours partial patches).

Measured (``benchmarks/bench_bp.py --proposals``, the Motorcycle at 450×375,
stripe phase 1, seeds 0–2; MAR in disparity px, candidate ceiling in
brackets): at 63 / 78 / 85 % unknown the paper's BP 0.328 (0.130) / 0.597
(0.275) / 0.848 (0.519), NP 0.400 / 0.624 / 0.742, ``"np"`` 0.339 (0.111) /
0.571 (0.220) / 0.819 (0.336), ``"np-completed"`` 0.378 / 0.584 / 0.804. The
proposals lower the ceiling at every fraction (by 35 % at 85 %) and BP's MAR at
78 and 85 %, but BP still chooses far above its ceiling, loses to NP at 85 %
and to the paper's BP at 63 %. On the report split (stripe phase 0) ``"np"``
gives 0.353 / 0.550 / 0.788 at 450×375 (BP 0.353 / 0.570 / 0.809, NP 0.408 /
0.589 / 0.738) and 0.331 / 0.585 / 0.913 at 741×500 (BP 0.333 / 0.600 / 0.932,
NP 0.373 / 0.599 / 0.799); on the room (128×128, grids 10/20 and 5/25) 0.159 /
0.179 against BP's 0.244 / 0.312 and NP's 0.114 / 0.153. Fig. 6 stays the
default (``proposals=None``).

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.3, Eqs. 2, 6–9, Fig. 6,
doi:10.1007/s11263-007-0108-2.
W. T. Freeman, E. C. Pasztor and O. T. Carmichael, "Learning low-level
vision", IJCV 40:25–47 (2000) (candidates, overlap compatibilities).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsynth.numeric import RANGE_BITS
from refsynth.synthesis.nonparametric import np_fill

__all__ = ["PROPOSALS", "PROPOSAL_PHI", "ProposalFrame", "np_proposals", "proposal_frame"]

#: The sources of proposals :func:`refsynth.synthesize` accepts (None: Fig. 6 as printed).
PROPOSALS = ("np", "np-completed")
#: The readings of a proposal's Φ (see above).
PROPOSAL_PHI = ("match", "twin", "best", "worst", "zero")


def np_proposals(image: np.ndarray, range_values: np.ndarray, edges: np.ndarray,
                 rng: np.random.Generator, *, runs: int = 1, **np_options) -> np.ndarray:
    """Dense proposals of the range: ``runs`` fills by NP (§3.2.2), one after another.

    Parameters
    ----------
    image, range_values, edges
        As :func:`refsynth.synthesis.nonparametric.np_fill` takes them.
    rng : numpy.random.Generator
        Drawn on by each run in turn: the first run is the NP result
        :func:`refsynth.synthesize` gives with the same seed.
    runs : int, default 1
        How many fills.
    **np_options
        Passed to :func:`~refsynth.synthesis.nonparametric.np_fill` (NP's own
        options at their defaults).

    Returns
    -------
    ndarray of shape (runs, H, W)
        Each fill; measured pixels unchanged.

    Examples
    --------
    >>> image = np.tile(np.linspace(0, 1, 8), (8, 1))[:, :, None]
    >>> partial = np.full((8, 8), np.nan); partial[:, ::3] = 2.0
    >>> np_proposals(image, partial, np.zeros((8, 8), bool), np.random.default_rng(0),
    ...              runs=2, neighbourhood=3).shape
    (2, 8, 8)
    """
    return np.stack([np_fill(image, range_values, edges, rng, **np_options)[0]
                     for _ in range(runs)])


@dataclass(frozen=True)
class ProposalFrame:
    """The labels of every node and the frames their patches come from.

    Attributes
    ----------
    plane : ndarray of float64, shape (F·(H + 2h), W + 2h)
        ``F = S + 1`` padded range frames stacked by rows, on the contract's
        grid (``rint(2**16 (R − low) / span)``, −1 where unknown): frame 0 the
        measured range, frame ``s`` the proposal ``D_s`` (clipped below at 0,
        so that a proposal below the measured minimum still reads as range).
        Label ``L`` is the patch ``plane[R : R + n, c : c + n]`` with
        ``R, c = divmod(L, W)``.
    centre : ndarray of float64, shape (F·(H + 2h), W)
        The centre range of the label at ``(R, c)``, in the caller's unit
        (0 where a measured frame's pixel is unknown).
    centre_q : ndarray of int64, the shape of ``centre``
        The same on the contract's grid (step 6 pools labels on it).
    labels : ndarray of int64, shape (N, k + S)
        The training candidates first (as the search ranked them), then one
        proposal per frame: node ``p = (r, c)``'s proposal from frame ``s`` is
        ``(s (H + 2h) + r) W + c``.
    distance : ndarray of float64, shape (N, k + S)
        The Eq. 2 distance Φ (Eq. 7) is made from: the search's, then the
        proposals' (see :data:`PROPOSAL_PHI`).
    """

    plane: np.ndarray
    centre: np.ndarray
    centre_q: np.ndarray
    labels: np.ndarray
    distance: np.ndarray

    def position(self, labels: np.ndarray, width: int, height: int) -> tuple[np.ndarray, ...]:
        """``(row, col)`` in the image of each label's centre (any frame)."""
        rows, cols = np.divmod(labels, width)
        return rows % (height + 2 * self.halo), cols

    @property
    def halo(self) -> int:
        """``h = n // 2``, the padding of each frame."""
        return (self.plane.shape[1] - self.centre.shape[1]) // 2


def proposal_frame(
    range_values: np.ndarray, rq: np.ndarray, low: float, span: float, proposals: np.ndarray,
    labels: np.ndarray, distance: np.ndarray, flat: np.ndarray, n: int, *, phi: str = "best",
    centred: bool = True, completed: bool = False,
) -> ProposalFrame:
    """Stack the proposal frames under the measured one and give every node its proposals.

    Parameters
    ----------
    range_values : ndarray of shape (H, W)
        The measured range, NaN where unknown, in the caller's unit.
    rq : ndarray of int64, shape (H, W)
        Its quantisation (:func:`refsynth.numeric.quantise_range`), −1 where unknown.
    low, span : float
        That quantisation's offset and span (the proposals go on the same grid).
    proposals : ndarray of shape (S, H, W)
        Dense ranges, finite wherever the range is unknown.
    labels, distance : ndarray of shape (N, k)
        The training candidates (flat pixel indices) and their Eq. 2 distances,
        best first (:func:`refsynth.synthesis.belief.search.search_candidates`).
    flat : ndarray of int, shape (N,)
        The nodes' flat pixel indices, in raster order.
    n : int
        The patch side.
    phi : {"match", "twin", "best", "worst", "zero"}, default "best"
        A proposal's distance (:data:`PROPOSAL_PHI`): that of the best
        training candidate proposing the same range (within 1 % of the span),
        else the worst (``"match"``, what :func:`refsynth.synthesize` uses) or
        the best (``"twin"``) candidate's; the best's or the worst's outright;
        or 0 (see the module's notes).
    centred : bool, default True
        Give the nodes their proposals; ``False`` keeps only the training
        candidates (on the stacked frame).
    completed : bool, default False
        Fill the training patches' unknown range from the first proposal.

    Returns
    -------
    ProposalFrame

    Examples
    --------
    One node at (0, 1) of a 1×3 image, one training candidate (pixel 0) and
    one proposal:

    >>> r = np.array([[1.0, np.nan, 3.0]])
    >>> rq = np.array([[0, -1, 65536]])
    >>> f = proposal_frame(r, rq, 1.0, 2.0, np.array([[[1.0, 2.0, 3.0]]]),
    ...                    np.array([[0]]), np.array([[0.5]]), np.array([1]), 1)
    >>> f.labels.tolist(), f.distance.tolist(), f.centre.ravel().tolist()
    ([[0, 4]], [[0.5, 0.5]], [1.0, 0.0, 3.0, 1.0, 2.0, 3.0])
    >>> f.centre_q.ravel().tolist()
    [0, 0, 65536, 0, 32768, 65536]
    """
    H, W = range_values.shape
    h = n // 2
    known = np.isfinite(range_values)
    proposals = np.asarray(proposals, dtype=np.float64).reshape(-1, H, W)
    S = proposals.shape[0]
    # every frame on the measured range's grid; measured pixels keep their own value
    values = np.where(known, range_values, proposals)
    quantised = np.where(known, rq, np.rint((values - low) / span * 2.0**RANGE_BITS))
    frames_q = [np.where(known, rq, -1).astype(np.float64)]
    if completed:  # the training patches' unknown range from the first proposal
        frames_q[0] = np.maximum(quantised[0], 0.0)
    frames_q += [np.maximum(q, 0.0) for q in quantised]
    plane = np.concatenate([np.pad(f, h, constant_values=-1.0) for f in frames_q], axis=0)
    rows_per_frame = H + 2 * h
    centre = np.zeros(((S + 1) * rows_per_frame, W))
    centre_q = np.zeros(centre.shape, dtype=np.int64)
    centre[:H] = np.where(known, range_values, 0.0)
    centre_q[:H] = np.where(known, rq, 0)
    for s in range(S):
        top = (s + 1) * rows_per_frame
        centre[top : top + H] = values[s]
        centre_q[top : top + H] = quantised[s].astype(np.int64)
    rows, cols = np.divmod(np.asarray(flat, dtype=np.int64), W)
    extra = np.stack([((s + 1) * rows_per_frame + rows) * W + cols for s in range(S)], axis=1)
    if not centred:
        extra = extra[:, :0]
        S = 0
    if phi == "best":
        extra_distance = np.repeat(distance[:, :1], S, axis=1)
    elif phi == "worst":
        extra_distance = np.repeat(distance[:, -1:], S, axis=1)
    elif phi in ("match", "twin"):
        # the best training candidate proposing the same range, else the worst candidate
        cand_q = centre_q[:H].ravel()[labels]  # (N, k)
        extra_distance = np.empty((distance.shape[0], S))
        for s in range(S):
            mine = quantised[s].ravel()[flat][:, None]
            same = np.abs(cand_q - mine) <= 0.01 * 2.0**RANGE_BITS
            matched = np.where(same, distance, np.inf).min(axis=1)
            fallback = distance[:, -1] if phi == "match" else distance[:, 0]
            extra_distance[:, s] = np.where(np.isfinite(matched), matched, fallback)
    else:
        extra_distance = np.zeros((distance.shape[0], S))
    return ProposalFrame(plane=plane, centre=centre, centre_q=centre_q,
                         labels=np.concatenate([labels, extra], axis=1),
                         distance=np.concatenate([distance, extra_distance], axis=1))
