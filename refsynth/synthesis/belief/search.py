r"""BP's candidate search (§3.2.3, Fig. 6, step 2), evaluated tile by tile.

Step 2 of Fig. 6 ranks, for every unknown pixel ``p``, the measured pixels ``q``
within ``r`` of it by the distance of Eq. 2 between their neighbourhoods (with
the mean-filled range term of :mod:`refsynth.synthesis.similarity`), plus the
proximity prior ``μ (|p − q| / r)²`` when μ > 0 (the default μ = 0 ranks by
Eq. 2 alone, as Fig. 6 does). :func:`refsynth.synthesis.belief.fill.candidates`
does it one node at a time over every offset of the disc, measured or not,
from the rows of a :class:`~refsynth.synthesis.patch_table.PatchTable` — a
table of 150 float64 per pixel (850 MB at 900×750). Most disc offsets are
unmeasured (78 % on the x-stripes benchmark), and neighbouring nodes share
most of their training patches, so :func:`search_candidates` instead

1. groups the nodes into square tiles (16 pixels, or ``r`` when the search has
   widened), and takes as candidate rows ``U`` only the *measured* pixels
   within ``r`` of some node of the tile;
2. evaluates the expanded sums of Eq. 2 for every (candidate, node) pair of
   the tile as three matrix products — ``[I]·(−2 G I_p)``,
   ``[V | R | R²]·[G R_p² | −2 G R_p | G V_p]`` and ``[V]·(G V_p)`` — on
   patch rows gathered on the fly through sliding-window views of the
   quantised image's padded planes (no table);
3. reads each node's disc from those products (a measured offset only) and
   ranks it as :func:`~refsynth.synthesis.belief.fill.candidates` does, on the node's
   measured offsets alone, packed in their raster order (every other offset
   is ∞, so cannot come first while ``k`` finite ones remain; a node with
   fewer is ranked over its whole disc).

The same numbers: under the numeric contract (:mod:`refsynth.numeric`) the
intensity and range are integers on ``2**-16`` grids and the window is the
integer table :func:`~refsynth.numeric.window_weights`, so every partial sum of
the three products is an integer below ``2**53`` and is exact, whatever the
order in which BLAS adds it up; :func:`~refsynth.numeric.combine_eq2` then
makes the distance from the same four sums by the same IEEE operations. The
ranking is the stable sort's (ties in the raster order of the disc offsets),
found with a partition: the ``k`` smallest are those below the ``k``-th
value and the first of those equal to it, sorted
(:mod:`refsynth.synthesis.belief.ranking`). So the candidates and their
distances are bit for bit those of :func:`~refsynth.synthesis.belief.fill.candidates`
(and of the literal reference).

:func:`search_at_radii` is the first pass of :func:`search_candidates` for
nodes that each have a radius of their own (the gap radius,
:mod:`refsynth.synthesis.belief.gap_radius`): one pass over tiles of 12 holding
every radius, each node's disc cut from the tile's widest by the test of
:func:`~refsynth.synthesis.neighbourhood.disc_offsets`, the same steps 1–3.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2–§3.2.3, Eqs. 2 and 6–9, Fig. 6,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.numeric import NO_RANGE, combine_eq2, window_weights
from refsynth.synthesis.belief.ranking import smallest_measured, stable_smallest
from refsynth.synthesis.neighbourhood import disc_offsets, window_offsets
from refsynth.synthesis.patch_table import PatchTable

__all__ = ["search_candidates", "search_at_radii", "search_features", "candidates",
           "stable_smallest"]

_CHUNK_FLOATS = 1 << 24  # about 128 MB of float64 per block of the literal search
_BLOCK = 1 << 21  # entries of a (candidate rows × nodes) or (nodes × offsets) block
_TILE = 16  # the side of a tile of nodes in the first search
_RADII_TILE = 12  # the same in search_at_radii, whose discs are wider
_ONE_THREAD = 4 * 65536  # m·n·k of the largest matrix product run on one thread



class _Features:
    """Patch rows of any pixels, built on demand from the quantised image (no table).

    The rows are those of :class:`~refsynth.synthesis.patch_table.PatchTable`: the
    intensity window (mirror-extended) and the range window's has-range ``V``, range
    ``R`` (0 where unknown) and ``R²``, all integers held in float64. They are read
    through sliding-window views of the padded planes, one gather per pixel set.
    ``intensity``: another :class:`_Features` of the same ``levels`` and ``n``, whose
    intensity planes are shared (the observations' rows differ from the training
    rows only in range).
    """

    def __init__(self, levels: np.ndarray, rq: np.ndarray, n: int,
                 intensity: _Features | None = None) -> None:
        h = n // 2
        self.h = h
        self.nn = n * n
        self.channels = levels.shape[2]
        self.g = window_weights(n).ravel().astype(np.float64)  # raster order of the window
        self.gi = np.repeat(self.g, self.channels)  # intensity columns: (offset, channel)
        wr, wc = window_offsets(n)
        wr, wc = wr + h, wc + h
        H, W = rq.shape
        if intensity is None:
            ipad = np.pad(levels.astype(np.float64), ((h, h), (h, h), (0, 0)),
                          mode="symmetric")
            # (H, W, n, n, C): the window of every pixel, row-major, channels last
            self.iwin = sliding_window_view(ipad, (n, n), axis=(0, 1)).transpose(0, 1, 3, 4, 2)
            # Σ_v G_v Σ_c I² of every pixel: an integer sum, exact in any order
            square = (ipad * ipad).sum(axis=2)  # Σ_c I² of every padded pixel, once
            self.self_term = np.zeros((H, W))
            for g, r, c in zip(self.g, wr, wc, strict=True):
                self.self_term += g * square[r : r + H, c : c + W]
        else:
            self.iwin, self.self_term = intensity.iwin, intensity.self_term
        rf = np.where(rq != NO_RANGE, rq, 0).astype(np.float64)
        # the planes V, R, R² side by side: (H, W, 3, n, n), one row (V | R | R²) per pixel
        vrr = np.pad(np.stack([(rq != NO_RANGE).astype(np.float64), rf, rf * rf], axis=2),
                     ((h, h), (h, h), (0, 0)))
        self.rwin = sliding_window_view(vrr, (n, n), axis=(0, 1))
        # Σ_v G_v V of every pixel: an integer sum, exact in any order
        self.support = np.zeros((H, W))
        for g, r, c in zip(self.g, wr, wc, strict=True):
            self.support += g * vrr[r : r + H, c : c + W, 0]

    def rows(self, r: np.ndarray, c: np.ndarray):
        """``(I, [V | R | R²])`` rows of the pixels ``(r, c)``: (P, nn·C) and (P, 3·nn)."""
        return self.iwin[r, c].reshape(r.size, -1), self.rwin[r, c].reshape(r.size, -1)


def search_features(
    levels: np.ndarray,
    rq: np.ndarray,
    n: int,
    *,
    observed: np.ndarray | None = None,
    training: np.ndarray | None = None,
) -> tuple[_Features, _Features]:
    """The training and the observations' patch rows :func:`search_candidates` reads.

    Built once per image (each costs a pass over the whole image); a caller that
    runs the search several times on one image —
    :func:`~refsynth.synthesis.belief.gap_radius.gap_radius_candidates`, once per gap
    depth — builds them here and passes them as ``features``, which changes no number.

    Parameters
    ----------
    levels, rq, n, observed, training
        As :func:`search_candidates` takes them.

    Returns
    -------
    training_rows, observation_rows
        The rows of the training patches (``training``, or ``rq``) and of the
        nodes' observations (``observed``, or the training rows themselves).

    Examples
    --------
    >>> rq = np.array([[0, -1], [65536, -1]])
    >>> rows, same = search_features(np.zeros((2, 2, 1), dtype=np.int64), rq, 1)
    >>> rows is same, (rows.support > 0).tolist()  # Σ_v G_v V: where the window has range
    (True, [[True, False], [True, False]])
    """
    features = _Features(levels, rq if training is None else training, n)
    if observed is None:
        return features, features
    return features, _Features(levels, observed, n, intensity=features)


def search_candidates(
    levels: np.ndarray,
    rq: np.ndarray,
    node_rows: np.ndarray,
    node_cols: np.ndarray,
    *,
    n: int,
    k: int,
    radius: float,
    proximity: float,
    range_weight: float,
    missing_range: str,
    pad: int,
    channels: str = "sum",
    observed: np.ndarray | None = None,
    training: np.ndarray | None = None,
    features: tuple[_Features, _Features] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` closest training patches of each node by Eq. 2 (Fig. 6, step 2).

    The result of :func:`refsynth.synthesis.belief.fill.candidates` on the
    :class:`~refsynth.synthesis.patch_table.PatchTable` of the same image, bit for
    bit, computed tile by tile from measured offsets only (see above).

    Parameters
    ----------
    levels : ndarray of int, shape (H, W, C)
        The quantised intensity (:func:`refsynth.numeric.quantise_intensity`,
        or its grey level).
    rq : ndarray of int, shape (H, W)
        The quantised range (:func:`refsynth.numeric.quantise_range`),
        :data:`~refsynth.numeric.NO_RANGE` where unknown.
    node_rows, node_cols : ndarray of int, shape (N,)
        The unknown pixels (image coordinates).
    n : int
        Odd window side of Eq. 2.
    k : int
        Candidates per node.
    radius : float
        Search radius ``r``, doubled for a node until it has ``k`` candidates.
    proximity : float
        μ of the spatial prior ``μ (|p − q| / r)²``.
    range_weight : float
        λ of Eq. 2.
    missing_range : {"mean", "ignore"}
        Eq. 2's treatment of range the candidate lacks.
    pad : int
        Padding of the literal search's frame (:func:`candidates`): as there,
        the search of a node that has not found ``k`` candidates stops once
        ``ceil(r)`` reaches the frame's larger side, ``max(H, W) + 2 pad``.
    channels : {"sum", "mean"}, default "sum"
        Eq. 2's intensity term over the colour channels: their sum (the
        paper's) or their mean.
    observed : ndarray of int, shape (H, W), optional
        **A departure** (:mod:`refsynth.synthesis.belief.observation`): the range
        of the nodes' observations ``y_i`` on ``rq``'s grid (``NO_RANGE``
        where none), e.g. ``rq`` completed by a classical fill. None: ``rq``
        (Fig. 6, bit for bit).
    training : ndarray of int, shape (H, W), optional
        **A departure**, likewise: the range of the training patches in Eq. 2.
        The training set stays the measured pixels of ``rq``.
    features : pair, optional
        :func:`search_features` of the same ``levels``, ``rq``, ``n``,
        ``observed`` and ``training`` (then those two are not read): the rows
        built once for several searches on one image. None: built here.
    progress : callable, optional
        ``progress(done, total)``: the nodes ranked so far, of ``N``, after
        each tile of the first pass (the nodes whose radius doubles are
        counted there, and the doubled passes report nothing).

    Returns
    -------
    labels : ndarray of int64, shape (N, k)
        Flat indices (``row · W + col``) of the candidates' centres, best first.
    distances : ndarray of float64, shape (N, k)
        Their Eq. 2 distances plus the proximity prior.

    Examples
    --------
    A 4×4 grey ramp whose left half is measured: the best two candidates of the
    pixel (0, 2) are the measured pixels nearest to it.

    >>> from refsynth.numeric import quantise_range
    >>> levels = (np.arange(16).reshape(4, 4, 1) * 4096)
    >>> rq, _, _ = quantise_range(np.where(np.arange(4) < 2, 1.0, np.nan) + np.zeros((4, 1)))
    >>> labels, d = search_candidates(levels, rq, np.array([0]), np.array([2]), n=3, k=2,
    ...                               radius=2.0, proximity=1.0, range_weight=1.0,
    ...                               missing_range="mean", pad=2)
    >>> [(int(r), int(c)) for r, c in zip(*np.divmod(labels[0], 4))]  # (row, col)
    [(0, 1), (1, 1)]
    """
    H, W = rq.shape
    if features is None:
        features = search_features(levels, rq, n, observed=observed, training=training)
    features, node_features = features
    known = rq != NO_RANGE
    total_known = int(known.sum())
    n_nodes = node_rows.size
    labels = np.zeros((n_nodes, k), dtype=np.int64)
    dist = np.full((n_nodes, k), np.inf)
    todo = np.arange(n_nodes)
    r = first = float(radius)
    # no offset longer than the image's diagonal can reach a pixel: the disc stops there
    longest = float(np.hypot(H, W))
    options = dict(k=k, radius=radius, proximity=proximity, range_weight=range_weight,
                   missing_range=missing_range, frame=max(H, W) + 2 * pad,
                   divisor=levels.shape[2] if channels == "mean" else 1,
                   total_known=total_known, node_features=node_features)
    while todo.size:
        dr, dc = disc_offsets(min(r, longest))
        tile = max(_TILE, int(min(r, longest)))
        key = (node_rows[todo] // tile) * (W // tile + 1) + node_cols[todo] // tile
        grouped = todo[np.argsort(key, kind="stable")]
        bounds = np.flatnonzero(np.diff(np.sort(key))) + 1
        step = max(1, _BLOCK // max(dr.size, 1))
        found = []
        ranked = 0
        for members in np.split(grouped, bounds):
            for start in range(0, members.size, step):
                part = members[start : start + step]
                found.append(_rank_block(features, known, node_rows[part], node_cols[part],
                                         part, (dr, dc), r, labels, dist, options))
            ranked += members.size
            if progress is not None and r == first:
                progress(ranked, n_nodes)
        done = np.concatenate(found) if found else np.zeros(0, dtype=np.int64)
        left = np.ones(n_nodes, dtype=bool)
        left[done] = False
        todo = todo[left[todo]]  # still in raster order
        r *= 2.0
    return labels, dist


def search_at_radii(
    levels: np.ndarray,
    rq: np.ndarray,
    node_rows: np.ndarray,
    node_cols: np.ndarray,
    radii: np.ndarray,
    proximities: np.ndarray,
    *,
    k: int,
    range_weight: float,
    missing_range: str,
    features: tuple[_Features, _Features],
    channels: str = "sum",
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The first pass of :func:`search_candidates` with a radius of each node's own, at once.

    Node ``i`` is ranked on the measured offsets of ``disc_offsets(radii[i])``
    with the prior ``proximities[i] (|p − q| / radii[i])²``, in tiles that hold
    nodes of every radius (one block per tile and not one per radius: the
    candidate rows of a tile are gathered once). Its candidates are those of
    ``search_candidates`` at that radius and μ whenever its disc holds ``k``
    measured pixels with finite distances — that search's first pass then
    stores it, from the same measured offsets in the same order, the distances
    of the same exact sums — and only those nodes are returned as ``done``;
    the others (which that search would widen) are the caller's.

    Parameters
    ----------
    levels, rq, node_rows, node_cols, k, range_weight, missing_range, channels
        As :func:`search_candidates` takes them.
    radii : ndarray of float, shape (N,)
        Each node's search radius ``r`` (its disc stops at the image's diagonal, as
        in :func:`search_candidates`; its prior keeps ``r``).
    proximities : ndarray of float, shape (N,)
        Each node's μ.
    features : pair
        :func:`search_features` of the image.
    progress : callable, optional
        ``progress(done, total)``: the nodes stored so far, of ``N``, after each tile.

    Returns
    -------
    labels, distances : ndarray of shape (N, k)
        As :func:`search_candidates` returns them, where ``done``.
    done : ndarray of bool, shape (N,)

    Examples
    --------
    Two nodes of a row measured at both ends, with radii 1 and 3: the first
    finds one measured pixel (not done), the second both.

    >>> rq = np.array([[0, -1, -1, -1, 65536]])
    >>> levels = np.zeros((1, 5, 1), dtype=np.int64)
    >>> labels, _, done = search_at_radii(
    ...     levels, rq, np.array([0, 0]), np.array([1, 2]), np.array([1.0, 3.0]),
    ...     np.zeros(2), k=2, range_weight=1.0, missing_range="mean",
    ...     features=search_features(levels, rq, 1))
    >>> done.tolist(), sorted(labels[1].tolist())
    ([False, True], [0, 4])
    """
    H, W = rq.shape
    features, node_features = features
    known = rq != NO_RANGE
    n_nodes = node_rows.size
    labels = np.zeros((n_nodes, k), dtype=np.int64)
    dist = np.full((n_nodes, k), np.inf)
    radii = np.asarray(radii, dtype=np.float64)
    proximities = np.asarray(proximities, dtype=np.float64)
    # as in search_candidates: the disc stops at the image's diagonal, the prior does not
    reach = np.minimum(radii, float(np.hypot(H, W)))
    # r² as disc_offsets forms it (a Python float's ** 2), for each radius there is
    values, which = np.unique(reach, return_inverse=True)
    squared = np.array([float(x) ** 2 for x in values.tolist()])[which]
    own = (squared, proximities / (radii * radii), proximities != 0)
    options = dict(k=k, range_weight=range_weight, missing_range=missing_range,
                   divisor=levels.shape[2] if channels == "mean" else 1,
                   node_features=node_features)
    # as in search_candidates, a tile no smaller than the discs (here the smallest)
    tile = max(_RADII_TILE, int(reach.min()) if n_nodes else 0)
    key = (node_rows // tile) * (W // tile + 1) + node_cols // tile
    grouped = np.argsort(key, kind="stable")
    bounds = np.flatnonzero(np.diff(key[grouped])) + 1
    discs = {}
    found = []
    stored = 0
    for members in np.split(grouped, bounds) if n_nodes else ():
        widest = float(reach[members].max())
        if widest not in discs:
            discs[widest] = disc_offsets(widest)
        dr, dc = discs[widest]
        step = max(1, _BLOCK // max(dr.size, 1))
        for start in range(0, members.size, step):
            part = members[start : start + step]
            found.append(_rank_block(features, known, node_rows[part], node_cols[part], part,
                                     (dr, dc), widest, labels, dist, options,
                                     own=tuple(x[part] for x in own)))
            stored += found[-1].size
        if progress is not None:
            progress(stored, n_nodes)
    done = np.zeros(n_nodes, dtype=bool)
    if found:
        done[np.concatenate(found)] = True
    return labels, dist, done


def _rank_block(features, known, rows, cols, members, disc, r, labels, dist, options,
                own=None):
    """Eq. 2 over the disc of the nodes ``members`` (one tile); rank; store the complete.

    ``own``: ``(r², μ / r², μ ≠ 0)`` of each node's own radius (:func:`search_at_radii`),
    the disc ``disc`` holding all of theirs; a node is then stored only when its own
    disc holds ``k`` finite candidates.
    """
    H, W = known.shape
    dr, dc = disc
    k = options["k"]
    reach = int(max(np.abs(dr).max(initial=0), np.abs(dc).max(initial=0)))
    # the box the tile's discs cover, with the measured pixels' indices in it (−1: none)
    top, left = int(rows.min()) - reach, int(cols.min()) - reach
    bh, bw = int(rows.max()) + reach + 1 - top, int(cols.max()) + reach + 1 - left
    t0, l0 = max(top, 0), max(left, 0)
    ur, uc = np.nonzero(known[t0 : top + bh, l0 : left + bw])
    uid = np.full((bh, bw), -1, dtype=np.int64)
    uid[ur + (t0 - top), uc + (l0 - left)] = np.arange(ur.size)
    u = uid.ravel()[((rows - top) * bw + (cols - left))[:, None] + (dr * bw + dc)[None, :]]
    square = dr * dr + dc * dc
    measured = u >= 0
    if own is not None:  # each node's own disc: disc_offsets' test, ‖v‖² ≤ r²
        measured &= square[None, :] <= own[0][:, None]
    pairs = np.flatnonzero(measured)  # the measured offsets, node by node in raster order
    bi, mi = np.divmod(pairs, max(dr.size, 1))
    u_valid = u.ravel()[pairs]
    # the candidate rows: the measured pixels some node of the tile reaches
    reached = np.zeros(ur.size, dtype=bool)
    reached[u_valid] = True
    ur, uc = ur[reached] + t0, uc[reached] + l0
    u_valid = (np.cumsum(reached) - 1)[u_valid]
    values = np.zeros(0)
    if bi.size:
        values = _distances(features, rows, cols, ur, uc, bi, u_valid, options)
        if own is not None:
            with_prior = own[2][bi]  # a μ of 0 adds no prior, as above
            if with_prior.any():
                values = np.where(with_prior, values + own[1][bi] * square.astype(
                    np.float64)[mi], values)
        elif options["proximity"]:
            radius = options["radius"]
            prior = (options["proximity"] / (radius * radius)) * square.astype(np.float64)
            values = values + prior[mi]
    kk = min(k, dr.size)
    best, bd = smallest_measured(values, bi, mi, rows.size, dr.size, kk)
    enough = np.isfinite(bd[:, -1]) if kk == k else np.zeros(bd.shape[0], bool)
    if own is not None:
        take = enough
    else:
        exhausted = int(np.ceil(r)) >= options["frame"] or options[
            "total_known"] <= np.isfinite(bd).sum(axis=1)
        take = enough | exhausted
    qr, qc = rows[:, None] + dr[best], cols[:, None] + dc[best]
    inside = (qr >= 0) & (qr < H) & (qc >= 0) & (qc < W)
    cand = np.where(inside, qr * W + qc, 0)[take]
    cd = bd[take]
    if kk < k or not np.all(np.isfinite(cd)):
        cand, cd = _pad_candidates(cand, cd, k)
    labels[members[take]] = cand
    dist[members[take]] = cd
    return members[take]



def _distances(features, rows, cols, ur, uc, b_index, u_valid, options):
    """Eq. 2 of every (node, candidate) pair: three exact matrix products per block of ``U``."""
    nn, g = features.nn, features.g
    si_u = features.self_term[ur, uc]
    nodes = options.get("node_features", features)  # the observations' rows
    ni, nvr = nodes.rows(rows, cols)  # nvr: [V_p | R_p | R_p²]
    b = rows.size
    w0 = ni * (-2.0 * features.gi)
    # against a candidate's [V | R | R²]: [G R_p² | −2 G R_p | G V_p]
    w1 = (nvr.reshape(b, 3, nn)[:, ::-1] * (g * np.array([[1.0], [-2.0], [1.0]]))).reshape(b, -1)
    w2 = nvr[:, :nn] * g
    node_self = features.self_term[rows, cols]
    support = nodes.support[rows, cols]
    out = np.empty(u_valid.size)
    step = max(1, _BLOCK // max(b, w0.shape[1] + w1.shape[1]))
    for start in range(0, ur.size, step):
        stop = min(start + step, ur.size)
        ui, uvr = features.rows(ur[start:stop], uc[start:stop])
        t = np.empty((3, stop - start, b))
        # products small enough for BLAS to run them on one thread (OpenBLAS splits
        # m·n·k above 4·65536 over threads, which on a busy machine is far slower)
        for term, left, right in ((0, ui, w0), (1, uvr, w1), (2, uvr[:, :nn], w2)):
            cols_step = max(1, _ONE_THREAD // ((stop - start) * right.shape[1]))
            for j in range(0, b, cols_step):
                sl = slice(j, j + cols_step)
                np.matmul(left, right[sl].T, out=t[term, :, sl])
        if start == 0 and stop == ur.size:
            uu, bb, sel = u_valid, b_index, slice(None)
        else:
            sel = (u_valid >= start) & (u_valid < stop)
            uu, bb = u_valid[sel] - start, b_index[sel]
        t0, t1, t2 = np.take(t.reshape(3, -1), uu * b + bb, axis=1)
        si = t0 + (si_u[uu + start] + node_self[bb])
        out[sel] = combine_eq2(si, t1, t2, support[bb], options["divisor"],
                               options["range_weight"], options["missing_range"])
    return out


# -- the literal search, from a PatchTable ------------------------------------------------


def candidates(
    table: PatchTable,
    nodes: np.ndarray,
    known: np.ndarray,
    shape: tuple[int, int],
    k: int,
    radius: float,
    proximity: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` closest training patches of each node, by Eq. 2 (Fig. 6, step 2).

    Parameters
    ----------
    table : PatchTable
        Patch rows of the padded frame (intensity and known range).
    nodes : ndarray of int, shape (N,)
        Padded flat indices of the unknown pixels.
    known : ndarray of bool
        Padded flat mask of the measured pixels (the training set's centres).
    shape : (int, int)
        Shape of the padded frame.
    k : int
        Number of candidates per node.
    radius : float
        Search radius ``r``; doubled for a node until it has ``k`` candidates.
    proximity : float
        μ of the spatial prior ``μ (|p − q| / r)²`` added to Eq. 2 (a
        departure from the paper, which ranks by the observation alone).

    Returns
    -------
    labels : ndarray of int, shape (N, k)
        Padded flat indices of the candidates' centres, best first (ties in the
        raster order of the disc offsets). Where the whole image holds fewer
        than ``k`` training patches, the last one repeats.
    distances : ndarray of float64, shape (N, k)
        Their Eq. 2 distances (plus the proximity prior).

    Notes
    -----
    The literal reading, one block of nodes at a time over every disc offset,
    from the rows of a table. :func:`~refsynth.synthesis.belief.fill.bp_fill` uses
    :func:`search_candidates`, which gives the same numbers without the table
    (its tests compare the two).

    Examples
    --------
    >>> from refsynth.synthesis.patch_table import PatchTable
    >>> image = (np.arange(16.0).reshape(4, 4, 1)) / 16
    >>> partial = np.where(np.arange(4) < 2, 0.5, np.nan) + np.zeros((4, 1))
    >>> table = PatchTable(image, partial, 3, 2, 1.0)
    >>> known = np.pad(np.isfinite(partial), 2).ravel()
    >>> labels, d = candidates(table, np.array([2 * 8 + 4]), known, (8, 8), 2, 2.0)
    >>> [(int(r) - 2, int(c) - 2) for r, c in zip(*np.divmod(labels[0], 8))]  # (row, col)
    [(0, 1), (1, 1)]
    """
    width = shape[1]
    n_nodes = nodes.size
    labels = np.zeros((n_nodes, k), dtype=np.int64)
    dist = np.full((n_nodes, k), np.inf)
    todo = np.arange(n_nodes)
    r = float(radius)
    total_known = int(known.sum())
    while todo.size:
        dr, dc = disc_offsets(r)
        offsets = dr * width + dc
        pad = int(np.ceil(r))
        chunk = max(1, _CHUNK_FLOATS // (offsets.size * table.table.shape[1]))
        found = np.zeros(todo.size, dtype=bool)
        for start in range(0, todo.size, chunk):
            sl = slice(start, start + chunk)
            rows, cols = np.divmod(nodes[todo[sl]], width)
            rr, cc = rows[:, None] + dr[None, :], cols[:, None] + dc[None, :]
            valid = (rr >= 0) & (rr < shape[0]) & (cc >= 0) & (cc < width)
            idx = np.where(valid, rr * width + cc, 0)
            valid &= known[idx]
            d = table.batch_distances(nodes[todo[sl]], idx)
            if proximity:
                d = d + (proximity / (radius * radius)) * (dr * dr + dc * dc).astype(np.float64)
            d[~valid] = np.inf
            kk = min(k, d.shape[1])
            # a stable sort: ties in the raster order of the offsets (argpartition's
            # order is whatever its selection algorithm, SIMD-dispatched, leaves)
            best = np.argsort(d, axis=1, kind="stable")[:, :kk]
            bd = np.take_along_axis(d, best, axis=1)
            enough = np.isfinite(bd[:, -1]) if kk == k else np.zeros(bd.shape[0], bool)
            exhausted = pad >= max(shape) or total_known <= np.isfinite(bd).sum(axis=1)
            take = enough | exhausted
            rows_sel = todo[sl][take]
            cand = np.take_along_axis(idx, best, axis=1)[take]
            cd = bd[take]
            # too few training patches in the whole image: repeat the last finite one
            if kk < k or not np.all(np.isfinite(cd)):
                cand, cd = _pad_candidates(cand, cd, k)
            labels[rows_sel] = cand
            dist[rows_sel] = cd
            found[sl] = take
        todo = todo[~found]
        r *= 2.0
    return labels, dist


def _pad_candidates(cand: np.ndarray, cd: np.ndarray, k: int):
    """Too few training patches in the whole image: repeat the last finite one."""
    finite = np.isfinite(cd)
    count = np.maximum(finite.sum(axis=1), 1)
    cols = np.minimum(np.arange(k)[None, :], count[:, None] - 1)
    cols = np.minimum(cols, cand.shape[1] - 1)
    return np.take_along_axis(cand, cols, axis=1), np.take_along_axis(cd, cols, axis=1)
