r"""Non-parametric sampling (NP) range synthesis, the fast fill (§3.2.2, Eqs. 2–5).

The steps are those of the literal reference
:func:`refsynth.synthesis.nonparametric.reference.np_reference`, which reads as the paper;
this module makes the same decisions, bit for bit, at a cost per voxel independent of the
image's size.

For the voxel ``V_p`` chosen next by the fill order (:mod:`refsynth.synthesis.priority`):

.. math::

    A_p = \{ N_q : \|p - q\| \le r,\ R_q \text{ known or synthesized} \}       \quad (3)

    N_{best} = \arg\min_{N_q \in A_p} \|N_p - N_q\|                          \quad (4)

    \Gamma'(R_p) = \{ N_q \in A_p : \|N_p - N_q\| \le (1 + \epsilon)\,
                   \|N_p - N_{best}\| \}                                       \quad (5)

and ``R_p`` is drawn (seeded) from the histogram of the centre ranges of
``Γ'``. Each member of ``Γ'`` counts once in that histogram, so the draw is a
uniform choice of a member. We use ``≤`` in Eq. 5 (the paper writes ``<``) so
that the set always holds the best match, even when its distance is 0.

How each step stays a few numpy calls
-------------------------------------
The Eq. 2 distances of the candidate set ``A_p`` that can matter to Eqs. 4–5 are two
gathers and three matrix–vector products (one with three weight rows) of
:class:`refsynth.synthesis.filltable.FillTable`
(:meth:`~refsynth.synthesis.filltable.FillTable.shortlist`: the range term only where the
intensity term leaves a candidate within ``1 + ε`` of one candidate's distance)
(Eq. 2 with its squares expanded, on rows holding the contract's integers: float32 range
rows, float64 intensity rows where they fit in 1 GiB), whose rows are updated in place on
the n×n windows around each newly filled voxel (the offset copy's shift,
:meth:`FillTable.offset_shift <refsynth.synthesis.filltable.FillTable.offset_shift>`,
comes from the drawn candidate's row of the same gather); the fill order is kept up to
date the same way by :class:`refsynth.synthesis.priority.FillFront`, whose
:class:`~refsynth.synthesis.frontqueue.FrontQueue` pops the next voxel with two
``argmax`` over short arrays. Every step makes the decisions of the literal
reference; the cost per synthesized voxel is the same at every image size.

The numeric contract
--------------------
Eq. 2 runs on the intensity and range quantised to ``2**-16`` of their spans
(:mod:`refsynth.numeric`), in exact integer sums, and a synthesized pixel's
confidence is rounded to ``2**-40``: every decision of the loop (Eq. 4's
argmin, Eq. 5's threshold, the fill order) is then the same on any machine,
and the same as in the literal reference
:func:`refsynth.synthesis.nonparametric.reference.np_reference`. Ties: Eq. 4 takes the first
minimum in the raster order of the disc offsets, Eq. 5's members keep that
order and the step's draw ``u`` picks member ``floor(u |Γ'|)``.

The confidence of a synthesized voxel (Eq. 11)
----------------------------------------------
``confidence_update="best"`` (the default) gives ``V_p`` the confidence
``C(N_best)``, the text after Eq. 11 read literally ("the confidence of the
augmented voxel which most resemble the neighborhood of V_p is assigned to
C(V_p)"). ``"product"`` gives it ``C(p) · C(N_best)``: its own Eq. 11 value
times that of the neighbourhood it matched best. On the Motorcycle the literal
reading ties or wins at every fraction (the README's audit).

A gap wider than ``r``
----------------------
The fill proceeds along the front ``δΩ``: every voxel it picks has a known or
synthesized 8-neighbour, so ``A_p`` is never empty for ``r ≥ √2``; deep inside
a wide gap the candidates are voxels synthesized earlier, as Eq. 3 allows. If
``A_p`` is empty nonetheless (``1 ≤ r < √2`` with only a diagonal neighbour, or
the onion order), the search widens to every filled voxel within ``d + r`` of
``p``, where ``d`` is the distance to the nearest filled voxel.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eqs. 2–5, doi:10.1007/s11263-007-0108-2.
A. A. Efros and T. K. Leung, "Texture synthesis by non-parametric sampling",
ICCV 1999.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from refsynth.numeric import (
    CONFIDENCE_BITS,
    INTENSITY_BITS,
    RANGE_BITS,
    quantise_grey,
    quantise_intensity,
    quantise_range,
)
from refsynth.synthesis.filltable import FillTable
from refsynth.synthesis.neighbourhood import disc_offsets
from refsynth.synthesis.onion import onion_order
from refsynth.synthesis.priority import FillFront

#: The readings of the confidence a synthesized voxel receives (Eq. 11).
CONFIDENCE_UPDATES = ("product", "best")

__all__ = ["eq5_set", "np_fill"]


def eq5_set(distances: np.ndarray, epsilon: float) -> np.ndarray:
    """Eq. 5: indices of the candidates within ``(1 + ε)`` of the best match's distance.

    Parameters
    ----------
    distances : ndarray of shape (M,), M >= 1
        Eq. 2 distances of the candidate set ``A_p``.
    epsilon : float
        ε >= 0.

    Returns
    -------
    ndarray of int
        Indices into ``distances``, ascending; always includes ``argmin``.

    Examples
    --------
    >>> import numpy as np
    >>> eq5_set(np.array([2.0, 1.0, 1.05, 3.0]), 0.1).tolist()
    [1, 2]
    """
    return np.flatnonzero(distances <= (1.0 + epsilon) * distances.min())


def _widened_candidates(p: int, filled: np.ndarray, width: int, radius: float) -> np.ndarray:
    """All filled voxels within ``d + radius`` of ``p`` (``d``: distance to the nearest)."""
    flat = np.flatnonzero(filled)
    pr, pc = divmod(p, width)
    dr, dc = flat // width - pr, flat % width - pc
    dist = np.sqrt((dr * dr + dc * dc).astype(np.float64))  # correctly rounded, unlike hypot
    return flat[dist <= dist.min() + radius]


def np_fill(
    image: np.ndarray,
    range_values: np.ndarray,
    edges: np.ndarray,
    rng: np.random.Generator,
    *,
    neighbourhood: int = 5,
    radius: float = 10.0,
    epsilon: float = 0.1,
    use_edges: bool = True,
    use_isophotes: bool = True,
    ordering: str = "priority",
    range_weight: float = 1.0,
    missing_range: str = "mean",
    confidence_update: str = "best",
    colour: bool = True,
    edges_last: bool = True,
    channels: str = "sum",
    range_copy: str = "offset",
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fill the unknown range by NP sampling in the chosen order (§3.2.2, §3.2.4).

    Called by :func:`refsynth.synthesize`, which validates the inputs and
    describes the options in full.

    Parameters
    ----------
    image : ndarray of shape (H, W, C), float
        The intensity, normalised to [0, 1] (quantised here to ``2**-16``).
    range_values : ndarray of shape (H, W)
        The measured range, NaN where unknown.
    edges : ndarray of shape (H, W), bool
        The Canny edge map (Eq. 10's ``E``).
    rng : numpy.random.Generator
        Draws the tie-break permutation, then one number per synthesized voxel.
    neighbourhood : int, default 5
        Odd side ``n`` of ``N_p``.
    radius : float, default 10
        ``r`` of Eq. 3.
    epsilon : float, default 0.1
        ``ε`` of Eq. 5.
    use_edges : bool, default True
        Eq. 10's edge term (and, with ``edges_last``, the edge tier).
    use_isophotes : bool, default True
        Eq. 12's data term.
    ordering : {"priority", "onion"}
        Eqs. 10–12's order, or the onion-peel order (Fig. 7).
    range_weight : float, default 1
        ``λ`` of Eq. 2.
    missing_range : {"mean", "ignore"}
        Eq. 2's treatment of offsets the candidate has no range at.
    confidence_update : {"best", "product"}
        The confidence a synthesized voxel receives (Eq. 11, see above).
    colour : bool, default True
        Eq. 2 on the colour channels (False: on BT.709 grey).
    edges_last : bool, default True
        Edge voxels form a second tier, filled last.
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's intensity term: the sum over the colour channels (the paper's)
        or their mean.
    range_copy : {"offset", "value"}
        What ``p`` gets from the drawn ``N_q``: its centre value (Eq. 5, ``"value"``) or
        that value shifted by the windows' consistent difference in range (``"offset"``, a
        departure and the default, :mod:`refsynth.synthesis.range_copy`).
    progress : callable, optional
        Called as ``progress(done, total)`` every few thousand voxels and at the end.

    Returns
    -------
    range : ndarray of shape (H, W)
        Dense range; measured values unchanged.
    confidence : ndarray of shape (H, W)
        1 where measured, the Eq. 11 confidence assigned at synthesis elsewhere.
    order : ndarray of shape (N, 2), int64
        Synthesized pixels (row, col) in fill order.

    Examples
    --------
    >>> import numpy as np
    >>> image = np.linspace(0, 1, 36).reshape(6, 6, 1)
    >>> measured = np.where(np.arange(6)[:, None] % 3 == 0, 2.0, np.nan) * np.ones(6)
    >>> dense, confidence, order = np_fill(image, measured, np.zeros((6, 6), dtype=bool),
    ...                                    np.random.default_rng(0), neighbourhood=3)
    >>> bool((dense == 2.0).all()), order.shape
    (True, (24, 2))
    """
    H, W = range_values.shape
    n = neighbourhood
    known = np.isfinite(range_values)
    # the contract: intensity and range on the 2**-16 grids of their spans
    rq, _, span = quantise_range(range_values)
    range_norm = np.where(known, rq * 2.0**-RANGE_BITS, np.nan)
    levels = quantise_intensity(image)
    if not colour:
        levels = quantise_grey(levels)[:, :, None]

    pad = max(int(np.ceil(radius)), n // 2 + 1)
    table = FillTable(levels * 2.0**-INTENSITY_BITS, range_norm, n, pad, range_weight,
                      missing_range, channels)
    del levels, rq  # the table holds them now (image-sized: 100 MB of levels at 2048²)
    front = FillFront(
        known,
        range_norm,
        edges,
        n,
        pad,
        rng,
        use_edges=use_edges,
        use_isophotes=use_isophotes,
        edges_last=edges_last,
    )
    del range_norm  # the table and the front hold their own
    Wp = front.shape[1]
    dr, dc = disc_offsets(radius)
    disc = dr * Wp + dc
    filled = front.filled.ravel()
    values = front.range_norm.ravel()
    # the range in the caller's unit, so that a copied value is copied bit for bit
    original = np.pad(np.where(known, range_values, 0.0), pad).ravel()

    total = int((~known).sum())
    draws = rng.random(total)
    if ordering == "onion":
        schedule = onion_order(known, rng)
        schedule = (schedule // W + pad) * Wp + (schedule % W + pad)
    order = np.empty(total, dtype=np.int64)
    tick = max(1, min(2000, total // 20))
    # the loop body, in as few numpy calls as it takes: Python floats where the
    # operands are scalars (the same IEEE operations as numpy's on float64)
    draws = memoryview(draws)  # Python floats one at a time (a list of them: 32 bytes each)
    scale = 1.0 + epsilon
    update = ordering != "onion"
    pop, fill, set_range = front.queue.pop, front.fill_step, table.set_range
    shortlist = table.shortlist_step
    # single values through memoryviews (Python scalars, cheaper than numpy's indexing)
    values_at, original_at, order_at = memoryview(values), memoryview(original), memoryview(order)
    confidence_of = front.confidence_of
    grid, unit = 2.0**CONFIDENCE_BITS, 2.0**-CONFIDENCE_BITS
    # p and Eq. 5's threshold as 0-d arrays: a ufunc takes a Python scalar by a slower path
    at, threshold = np.zeros((), dtype=np.int64), np.zeros(())
    shifting = range_copy == "offset"  # the departure: the drawn value shifted (range_copy)
    if shifting:
        offset_shift = table.offset_shift
        to_grid, span_unit, full = 2.0**RANGE_BITS, span * 2.0**-RANGE_BITS, 2**RANGE_BITS
        low, high = float(np.min(range_values[known])), float(np.max(range_values[known]))
    for step in range(total):
        # np_reference's order: the onion schedule, or the front's (tier, -P, tie) minimum
        p = int(schedule[step]) if not update else pop()
        at[()] = p
        candidates = np.add(disc, at)  # Eq. 3, as np_reference's disc offsets
        candidates = candidates.compress(filled[candidates])
        if candidates.size == 0:  # np_reference's gap wider than r: d + r
            candidates = _widened_candidates(p, filled, Wp, radius)
        # Eq. 2 (similarity.eq2_distance, bit for bit) of the candidates that can be the best
        # match or in Eq. 5's set, in order
        candidates, d = shortlist(p, candidates, scale)
        if candidates.size == 1:  # the best match and Eq. 5's only member (j below: 0)
            best = j = 0
        else:
            best = int(d.argmin())  # Eq. 4: the first minimum, as np_reference's
            # Eq. 5 (eq5_set): the members within (1 + epsilon) of the best, in candidate order
            threshold[()] = scale * d[best]
            members = np.less_equal(d, threshold).nonzero()[0]  # indices into candidates
            j = int(members[int(draws[step] * members.size)])
        q = int(candidates[j])
        value = values_at[q]
        original_at[p] = original_at[q]
        if shifting:
            shift = offset_shift(j)  # np_reference's offset_shift, on the rows just gathered
            was = int(value * to_grid)
            now = min(max(was + shift, 0), full) if shift else was  # range_copy.shifted_value
            if now != was:
                value = now * 2.0**-RANGE_BITS
                # (+ commutes); in the measured span in the caller's unit too
                original_at[p] = min(max((now - was) * span_unit + original_at[q], low), high)
        confidence = confidence_of(int(candidates[best]))  # Eq. 11 of N_best (confidence_term)
        if confidence_update == "product":
            confidence = confidence_of(p) * confidence
        # on_confidence_grid: round half to even onto multiples of 2**-40
        fill(p, value, round(confidence * grid) * unit, update)
        set_range(p, value)
        order_at[step] = p
        if progress is not None and (step + 1) % tick == 0:
            progress(step + 1, total)
    if progress is not None:
        progress(total, total)
    # the table (three quarters of NP's memory) goes before the outputs are made
    del table, shortlist, set_range
    if shifting:
        del offset_shift

    inner = (slice(pad, pad + H), slice(pad, pad + W))
    out = np.where(known, range_values, original.reshape(front.shape)[inner])
    confidence = front.confidence[inner].copy()
    rows, cols = np.divmod(order, Wp)
    return out, confidence, np.stack([rows - pad, cols - pad], axis=1).astype(np.int64)
