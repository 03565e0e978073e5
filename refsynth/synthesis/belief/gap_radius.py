r"""BP's training disc widened by the node's depth in the gap (§3.2.3, Fig. 6, step 2): a departure.

Fig. 6, step 2 takes a node's training set from the measured pixels within
``r`` of it (refsynth doubles ``r`` only when fewer than ``k`` are found).
A node ``d`` pixels from the nearest measured pixel then sees only the
measured pixels in a disc of radius ``r`` reaching ``r − d`` past that
nearest one: on the Motorcycle's x-stripes at 85 % unknown (17 unknown
columns between 3 known ones, ``r = 10``) a node in the middle of a gap reaches
each neighbouring stripe only over about ±5 rows.

**This option is not the paper, and it is the default preset's**,
with the completed observations (``training_radius="gap"``,
:func:`refsynth.synthesize`, BP; ``"fixed"`` is Fig. 6's): node ``i``'s disc has radius
``r + ⌊d_i⌋``, ``d_i`` its Euclidean distance to the nearest measured pixel,
so that every node searches the same ``r`` beyond the edge of its gap. A node
beside a measured pixel (``d_i = 1``) searches ``r + 1``. The rest of step 2 —
the ranking by Eq. 2, the doubling when fewer than ``k`` are found — is
unchanged; :func:`gap_radius_candidates` ranks every node at its own radius
in one pass (:func:`~refsynth.synthesis.belief.search.search_at_radii`, tiles
holding nodes of every depth), then runs
:func:`~refsynth.synthesis.belief.search.search_candidates` once per value of
``⌊d_i⌋`` on the nodes whose disc held fewer than ``k`` candidates (which
that search widens), all from patch rows built once
(:func:`~refsynth.synthesis.belief.search.search_features`), so each node's
candidates are exactly those of the search at its own radius. The distances are those of
:func:`scipy.ndimage.distance_transform_edt` (square roots of integers,
correctly rounded): exact, so the grouping is portable. A disc beyond the
image runs at the image's reach with the prior's coefficient
``μ / (r + ⌊d_i⌋)²`` kept bit for bit
(:func:`refsynth.synthesis.limits.search_radius`, group by group).

Measured (MAR in disparity px, the Motorcycle's x-stripes at 63 / 78 / 85 %
unknown, one run each: BP is deterministic)::

    python benchmarks/audit_departures.py --split choose --seeds 0 --jobs 1 \
        --variants bp-fig6,bp-gap-radius,bp-obs-colorization,bp-0.8

Alone it helps only where the gaps are wide: 0.354 / 0.629 / 0.791 on the
choosing split against Fig. 6's 0.328 / 0.597 / 0.848 (and on the room
0.281 / 0.329 m against 0.244 / 0.312): with observations that hold no range
deep in a gap, a wider disc only offers more intensity matches. With the
observations completed (``observation="colorization"``,
:mod:`refsynth.synthesis.belief.observation`), Eq. 2 ranks the wider disc by range
too:

===================  =======================  =======================  =====================
split, size          ``"colorization"``       ``"colorization"`` +      NP (3 seeds)
                                              ``"gap"``
===================  =======================  =======================  =====================
choose, 450×375      0.307 / 0.512 / 0.758    0.314 / 0.511 / 0.689    0.400 / 0.624 / 0.742
report, 450×375      0.312 / 0.504 / 0.743    0.316 / 0.509 / 0.677    0.408 / 0.589 / 0.738
report, 741×500      0.301 / 0.516 / 0.827    0.308 / 0.517 / 0.742    0.373 / 0.599 / 0.799
room, 10/20, 5/25    0.197 / 0.245 m          0.185 / 0.220 m          0.114 / 0.153 m
===================  =======================  =======================  =====================

(a tie at 63 and 78 %, 9–10 % lower at 85 %; the observations from
:func:`~refsynth.synthesis.completion.portable_colorization`, ``audit_departures.py``
and ``bench_bp.py --proposals --room``). Adding ``"colorization-completed"``,
``compatibility="overlap-centres"`` and σ_s = 0.1 (measured with the direct
colorization solve, before the portable one): 0.297 / 0.501 / 0.678 choosing,
0.302 / 0.497 / 0.664 and 0.287 / 0.490 / 0.744 report, 0.179 / 0.212 m on the room.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Fig. 6, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from refsynth.numeric import NO_RANGE
from refsynth.synthesis.belief.search import search_at_radii, search_candidates, search_features
from refsynth.synthesis.limits import search_radius

__all__ = ["TRAINING_RADII", "gap_depth", "gap_radius_candidates"]

#: The training discs :func:`refsynth.synthesize` accepts for BP: ``"fixed"`` is Fig. 6's
#: radius ``r``; ``"gap"`` (the default) widens it by the node's depth in its gap.
TRAINING_RADII = ("fixed", "gap")


def gap_depth(rq: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``⌊d⌋`` of each node: its Euclidean distance to the nearest measured pixel, floored.

    Parameters
    ----------
    rq : ndarray of int, shape (H, W)
        The quantised range, ``NO_RANGE`` where unknown.
    rows, cols : ndarray of int, shape (N,)
        The nodes.

    Returns
    -------
    ndarray of int64, shape (N,)
        0 where nothing is measured at all.

    Examples
    --------
    >>> rq = np.array([[5, -1, -1, -1, -1]])
    >>> gap_depth(rq, np.zeros(4, int), np.arange(1, 5)).tolist()
    [1, 2, 3, 4]
    >>> gap_depth(np.array([[0, -1], [-1, -1]]), np.array([1]), np.array([1])).tolist()
    [1]
    """
    unknown = np.asarray(rq) == NO_RANGE
    if unknown.all():
        return np.zeros(np.size(rows), dtype=np.int64)
    depth = ndimage.distance_transform_edt(unknown)
    return np.floor(depth[rows, cols]).astype(np.int64)


def gap_radius_candidates(levels, rq, rows, cols, *, radius: float, pad: int, n: int,
                          progress=None, **options):
    """:func:`~refsynth.synthesis.belief.search.search_candidates` at radius ``r + ⌊d_i⌋``.

    Parameters
    ----------
    levels, rq, rows, cols
        As :func:`~refsynth.synthesis.belief.search.search_candidates` takes them.
    radius : float
        ``r``.
    pad : int
        The frame's padding at radius ``r`` (widened with the radius, as
        :func:`refsynth.synthesis.belief.fill.bp_fill` sets it: ``max(⌈r⌉, n // 2 + 1)``).
    n : int
        The patch side.
    progress : callable, optional
        ``progress(done, total)``: the nodes ranked so far, of ``N``.
    **options
        The rest of ``search_candidates``'s keywords (``k`` …).

    Returns
    -------
    labels, distances : ndarray of shape (N, k)
        Each node's candidates as the search at its own radius gives them.

    Examples
    --------
    A row measured at both ends: the middle node (2 from each) searches
    ``r = 1 + 2`` and finds both ends; at ``r = 1`` alone it would double
    ``r`` until it did.

    >>> levels = np.zeros((1, 5, 1), dtype=np.int64)
    >>> rq = np.array([[0, -1, -1, -1, 65536]])
    >>> labels, _ = gap_radius_candidates(levels, rq, np.array([0]), np.array([2]),
    ...                                   radius=1.0, pad=2, n=1, k=2, proximity=0.0,
    ...                                   range_weight=1.0, missing_range="mean")
    >>> sorted(labels[0].tolist())
    [0, 4]
    """
    rows, cols = np.asarray(rows), np.asarray(cols)
    depth = gap_depth(rq, rows, cols)
    proximity = options.pop("proximity")
    # the patch rows once for every depth (each build is a pass over the whole image)
    options["features"] = search_features(levels, rq, n, observed=options.pop("observed", None),
                                          training=options.pop("training", None))
    # a disc beyond the image runs at the cut radius with the same prior, bit for bit
    depths, which = np.unique(depth, return_inverse=True)
    runs = np.array([search_radius("bp", float(radius) + float(extra), proximity, rq.shape)
                     for extra in depths], dtype=np.float64).reshape(-1, 2)
    # every node at its own radius in one pass; those whose disc lacks k candidates
    # then run the search of their own depth, which widens it
    labels, distances, done = search_at_radii(
        levels, rq, rows, cols, runs[which, 0], runs[which, 1], k=options["k"],
        range_weight=options["range_weight"], missing_range=options["missing_range"],
        features=options["features"], channels=options.get("channels", "sum"),
        progress=progress)
    ranked = int(done.sum())
    for at in np.unique(which[~done]):
        mine = np.flatnonzero((which == at) & ~done)  # raster order kept
        run, mu = float(runs[at, 0]), float(runs[at, 1])
        report = None if progress is None else (
            lambda count, _, before=ranked: progress(before + count, rows.size))
        labels[mine], distances[mine] = search_candidates(
            levels, rq, rows[mine], cols[mine], n=n, radius=run, proximity=mu,
            pad=max(pad, math.ceil(run), n // 2 + 1), progress=report, **options)
        ranked += mine.size
    return labels, distances
