r"""Edge correspondences between the range image and the mosaic (Appendix A.2).

The paper aligns the two images on their edges: "3-D edges", the depth
discontinuities of the partial range image (:func:`range_edges`), against
"2-D edges", the Canny edges of the mosaic (:func:`intensity_edges`). A range
edge, placed on the mosaic by the current warp
(:func:`refsynth.registration.warp.warp_forward`), is matched along its
normal to the nearest intensity edge of the same orientation, point by point
(:func:`match_edges`, for the global warp) or a whole segment at a time
(:func:`match_segments`, for the local stretch). The offsets found are the
misalignments that :mod:`refsynth.registration.alignment` removes.

Reading: the paper takes "two or more corresponding points" without saying
where they come from; here they come from these matches. Range edges are
matched as segments (a vote along each segment) rather than pixel by pixel
for the stretch, because a wrong intensity edge rarely runs along a whole
segment at one offset.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.2,
doi:10.1007/s11263-007-0108-2.

D. Cobzas, "Image-Based Models with Applications in Mobile Robotics", PhD
thesis, University of Alberta (2003) (the image-based registration the paper
follows).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import ndimage as ndi

from refsynth._checks import check_int, check_real, grey
from refsynth.registration.range_image import CylindricalRange
from refsynth.registration.warp import check_points
from refsynth.synthesis.canny import canny, sobel_gradients

__all__ = ["RangeEdges", "range_edges", "intensity_edges", "match_edges", "match_segments"]


# ----------------------------------------------------------------------------- 3-D edges


class RangeEdges(NamedTuple):
    """Depth discontinuities of a cylindrical range image (:func:`range_edges`, App. A.2).

    Attributes
    ----------
    phi, h : ndarray of shape (N,)
        The edge points: midway between two adjacent samples across the jump.
    axis : ndarray of shape (N,), int
        0: the samples are side by side (a vertical edge; it fixes ``u``);
        1: one above the other (a horizontal edge; it fixes ``v``).
    r : ndarray of shape (N,)
        The nearer sample's range (the occluding side, to which the edge
        belongs).
    segment : ndarray of shape (N,), int
        Edge points of one axis that touch (8-connected in the range image)
        form a segment, cut into pieces of at most ``segment_length``
        points; one id per piece.

    Examples
    --------
    >>> found = RangeEdges(phi=np.array([0.1, 0.1]), h=np.array([2.5, 1.5]), axis=np.array([0, 0]),
    ...                    r=np.array([2.0, 2.0]), segment=np.array([0, 0]))
    >>> len(found.phi), found.axis.tolist()
    (2, [0, 0])
    """

    phi: np.ndarray
    h: np.ndarray
    axis: np.ndarray
    r: np.ndarray
    segment: np.ndarray


def range_edges(
    cylinder: CylindricalRange,
    *,
    jump: float = 0.2,
    relative: float = 0.1,
    segment_length: int = 12,
) -> RangeEdges:
    """Depth discontinuities ("3-D edges") of a partial cylindrical range image (App. A.2).

    Two adjacent samples (in a row or a column), both measured, are across a
    depth discontinuity if their ranges differ by more than ``jump`` and by
    more than ``relative`` times the nearer one. Pairs with an unmeasured
    sample are skipped: the edge of the scanned area is not an edge.

    Parameters
    ----------
    cylinder : CylindricalRange
        The range image on the cylinder (Eq. 19); NaN where not scanned.
    jump : float, default 0.2
        In the range's unit (m).
    relative : float, default 0.1
        The jump must also exceed this fraction of the nearer range.
    segment_length : int, default 12
        Most points per segment (:attr:`RangeEdges.segment`).

    Returns
    -------
    RangeEdges

    Examples
    --------
    >>> image = CylindricalRange(np.array([[5.0, 5.0], [2.0, 2.0]]), np.array([0.0, 0.01]),
    ...                          np.array([1.0, 0.0]), 300.0)
    >>> found = range_edges(image)
    >>> found.axis, found.h, found.segment
    (array([1, 1]), array([0.5, 0.5]), array([0, 0]))
    """
    jump = check_real("jump", jump, minimum=0.0)
    relative = check_real("relative", relative, minimum=0.0)
    segment_length = check_int("segment_length", segment_length, minimum=1)
    values = cylinder.range
    found = []
    next_id = 0
    for axis, (first, second) in enumerate(
        [(values[:, :-1], values[:, 1:]), (values[:-1, :], values[1:, :])]
    ):
        near = np.fmin(first, second)
        with np.errstate(invalid="ignore"):
            step = np.abs(first - second)
            edge = (step > jump) & (step > relative * near)
        labels, _ = ndi.label(edge, structure=np.ones((3, 3), dtype=bool))
        rows, cols = np.nonzero(edge)
        label = labels[rows, cols]
        # cut each segment into pieces of at most `segment_length` points along it
        along = cols if axis == 1 else rows
        order = np.lexsort((along, label))
        rank = np.empty(order.size, dtype=np.int64)
        first_of = np.searchsorted(label[order], label[order])
        rank[order] = np.arange(order.size) - first_of
        piece = label * (rows.size + 1) + rank // segment_length
        _, segment = np.unique(piece, return_inverse=True)
        if axis == 0:
            phi = cylinder.phi[cols] + cylinder.phi_step / 2
            h = cylinder.h[rows]
        else:
            phi = cylinder.phi[cols]
            h = cylinder.h[rows] - cylinder.h_step / 2
        found.append((phi, h, np.full(rows.size, axis), near[rows, cols], segment + next_id))
        next_id += int(segment.max()) + 1 if segment.size else 0
    phi, h, axis, r, segment = (np.concatenate(parts) for parts in zip(*found))
    return RangeEdges(phi=phi, h=h, axis=axis, r=r, segment=segment.astype(np.int64))


# ----------------------------------------------------------------------------- 2-D edges


def intensity_edges(
    image: np.ndarray, *, sigma: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Canny edges of the mosaic and the direction of its gradient ("2-D edges", App. A.2).

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, 3)
        The mosaic; NaN where no view has data (no edges there, nor within
        a pixel of it).
    sigma : float, default 1
        Canny's smoothing (px).

    Returns
    -------
    edges : ndarray of shape (H, W), bool
        The Canny edge pixels.
    gx, gy : ndarray of shape (H, W)
        Sobel derivatives of the smoothed image along columns and rows.

    Examples
    --------
    >>> image = np.zeros((9, 9))
    >>> image[:, 5:] = 1.0
    >>> edges, gx, gy = intensity_edges(image)
    >>> edges.any(axis=0).nonzero()[0].tolist(), bool(abs(gx[4, 4]) > abs(gy[4, 4]))
    ([4], True)
    """
    luminance = grey(np.asarray(image, dtype=np.float64))
    valid = np.isfinite(luminance)
    filled = np.where(valid, luminance, 0.0)
    edges = canny(filled, sigma=sigma, mask=valid)
    numerator = ndi.gaussian_filter(filled, sigma)
    denominator = ndi.gaussian_filter(valid.astype(np.float64), sigma)
    smooth = np.where(valid, numerator / np.maximum(denominator, 1e-12), 0.0)
    gy, gx = sobel_gradients(smooth)
    return edges, gx, gy


# ----------------------------------------------------------------------------- matching


def _candidates(positions, axis, edges, gx, gy, radius):
    """Intensity edges along each range edge's normal: ``(hits, offsets)``, both (N, 2R+1).

    ``hits[i, k]``: a Canny pixel whose gradient points along ``axis[i]``
    (within 45°) lies ``k − R`` px from ``positions[i]`` (rounded) along the
    axis; ``offsets[i, k]``: its sub-pixel position relative to
    ``positions[i]`` (a parabola through the gradient magnitude at the pixel
    and its two neighbours along the axis), NaN where there is no hit.
    """
    height, width = edges.shape
    magnitude = np.hypot(gx, gy)
    compatible = (edges & (np.abs(gx) >= np.abs(gy)), edges & (np.abs(gy) >= np.abs(gx)))
    base = np.round(positions).astype(np.int64)
    steps = np.arange(-radius, radius + 1)
    hits = np.zeros((len(positions), steps.size), dtype=bool)
    offsets = np.full((len(positions), steps.size), np.nan)
    for which in (0, 1):
        pick = np.nonzero(axis == which)[0]
        if pick.size == 0:
            continue
        cols = base[pick, 0][:, None] + (steps if which == 0 else 0)
        rows = base[pick, 1][:, None] + (steps if which == 1 else 0)
        cols, rows = np.broadcast_arrays(cols, rows)
        inside = (rows >= 1) & (rows < height - 1) & (cols >= 1) & (cols < width - 1)
        rr, cc = np.clip(rows, 1, height - 2), np.clip(cols, 1, width - 2)
        hit = inside & compatible[which][rr, cc]
        dr, dc = (0, 1) if which == 0 else (1, 0)
        m0, m1, m2 = magnitude[rr - dr, cc - dc], magnitude[rr, cc], magnitude[rr + dr, cc + dc]
        curvature = m0 - 2 * m1 + m2
        with np.errstate(invalid="ignore", divide="ignore"):
            fraction = np.where(curvature < 0, 0.5 * (m0 - m2) / curvature, 0.0)
        target = (cc if which == 0 else rr) + np.clip(fraction, -0.5, 0.5)
        hits[pick] = hit
        offsets[pick] = np.where(hit, target - positions[pick, which][:, None], np.nan)
    return hits, offsets


def match_edges(
    positions: np.ndarray,
    axis: np.ndarray,
    edges: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    radius: int,
) -> np.ndarray:
    """Match each range edge to the nearest compatible intensity edge along its normal (App. A.2).

    A range edge at mosaic position ``(u, v)`` with ``axis = 0`` (vertical
    edge) is searched along its row, ``axis = 1`` along its column, within
    ``±radius`` px, for a Canny pixel whose gradient points along the same
    axis (within 45°). The nearest one wins and is placed to a fraction of
    a pixel by a parabola through the gradient magnitude at it and its two
    neighbours along the axis.

    Parameters
    ----------
    positions : ndarray of shape (N, 2)
        ``(u, v)`` of the range edges in the mosaic.
    axis : ndarray of shape (N,)
        0 for a vertical edge (searched along its row), 1 for a horizontal one.
    edges, gx, gy : ndarray of shape (H, W)
        From :func:`intensity_edges`.
    radius : int
        Search ``±radius`` px.

    Returns
    -------
    ndarray of shape (N,)
        Where the matched intensity edge is, along the axis, relative to the
        range edge (px); NaN where nothing matched.

    Examples
    --------
    >>> edges = np.zeros((9, 9), dtype=bool)
    >>> edges[:, 6] = True
    >>> gx, gy = np.ones((9, 9)), np.zeros((9, 9))
    >>> match_edges(np.array([[4.0, 4.0], [1.0, 4.0]]), np.array([0, 0]), edges, gx, gy, 3)
    array([ 2., nan])
    """
    positions = check_points("positions", positions)
    axis = np.asarray(axis)
    hits, offsets = _candidates(positions, axis, edges, gx, gy, int(radius))
    distance = np.where(hits, np.abs(np.arange(-radius, radius + 1)), np.inf)
    best = distance.argmin(axis=1)
    out = offsets[np.arange(len(positions)), best]
    return np.where(np.isfinite(distance.min(axis=1)), out, np.nan)


def _segment_votes(hits, segment, n_segments):
    """Per segment and offset: how many of its points have a hit within ±1 px of the offset."""
    near = ndi.maximum_filter1d(hits.astype(np.int64), 3, axis=1)  # ±1 px tolerance
    votes = np.zeros((n_segments, hits.shape[1]), dtype=np.int64)
    np.add.at(votes, segment, near)
    return votes


def match_segments(
    positions: np.ndarray,
    found: RangeEdges,
    edges: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    radius: int,
    *,
    support: float = 0.5,
    distinct: float = 0.7,
) -> tuple[np.ndarray, np.ndarray]:
    """Match each range-edge segment as a whole to intensity edges: one offset per segment.

    Every point of a segment votes for the whole-pixel offsets (along its
    normal, within ``±radius`` px, ±1 px tolerance) at which a compatible
    intensity edge lies (:func:`match_edges`' candidates). The rule:

    1. *The winner* is the offset with the most points within ±1 px of it;
       ties go to the offset with the most points exactly at it, then to
       the smaller offset. (An edge exactly ``d`` px away gives ``d − 1``,
       ``d`` and ``d + 1`` equal tolerant votes; the exact votes pick
       ``d``.)
    2. *Rivals* are intensity edges two or more pixels from the winner: an
       offset ``o`` with ``|o − winner| ≥ 2`` counts the points with a hit
       within ±1 px of ``o`` among their hits two or more pixels from the
       winner. The winner's own hits never count for a rival, so its ±1 px
       neighbours do not make the segment ambiguous.
    3. The segment is matched if at least ``support`` of its points (and
       at least two) voted for the winner and no rival got ``distinct`` as
       many votes; its offset is the median of its points' sub-pixel
       positions nearest the winner (within 1.5 px).
    4. An intensity edge is the match of one segment only: where two
       matched segments of one orientation matched the same Canny pixels,
       the one with the smaller ``|offset|`` keeps them, and a segment
       that loses half of its pixels or more is unmatched (two depth edges
       cannot both lie on one intensity edge, and the stretch could not
       move the one onto the other without a fold).

    A wrong intensity edge (a texture line, a skirting board beside a box
    top that blends into the floor) rarely runs along a whole segment at one
    offset, and a parallel one two or more pixels off (on either side)
    makes the segment ambiguous.

    Parameters
    ----------
    positions : ndarray of shape (N, 2)
        ``(u, v)`` of the range edges ``found`` in the mosaic (by the warp of
        Eq. 21).
    found : RangeEdges
        The range edges (:func:`range_edges`): their ``axis`` and ``segment``.
    edges, gx, gy : ndarray of shape (H, W)
        From :func:`intensity_edges`.
    radius : int
        Search ``±radius`` px along each point's normal.
    support : float, default 0.5
        The fraction of a segment's points that must vote for its offset.
    distinct : float, default 0.7
        A segment is ambiguous (unmatched) if a rival (an intensity edge two
        or more pixels from the winner, step 2 above) gets at least this
        fraction of the winner's votes.

    Returns
    -------
    offset : ndarray of shape (N,)
        The segment's offset, for each of its points; NaN if unmatched.
    votes : ndarray of shape (N,)
        The fraction of the segment's points that agreed.

    Examples
    --------
    One segment of a vertical depth edge, at column 4 on rows 2–3 and column 3
    on rows 4–5, and an intensity edge along column 6: the whole segment moves
    by the median of its points' offsets (2, 2, 3, 3).

    >>> edges = np.zeros((9, 9), dtype=bool)
    >>> edges[:, 6] = True
    >>> gx, gy = np.ones((9, 9)), np.zeros((9, 9))
    >>> found = RangeEdges(phi=np.zeros(4), h=np.zeros(4), axis=np.zeros(4, dtype=int),
    ...                    r=np.ones(4), segment=np.zeros(4, dtype=int))
    >>> positions = np.array([[4.0, 2.0], [4.0, 3.0], [3.0, 4.0], [3.0, 5.0]])
    >>> match_segments(positions, found, edges, gx, gy, 3)
    (array([2.5, 2.5, 2.5, 2.5]), array([1., 1., 1., 1.]))

    A straight segment on column 4 is matched two pixels off; a second
    intensity edge as far on the other side makes it ambiguous:

    >>> positions[:, 0] = 4.0
    >>> match_segments(positions, found, edges, gx, gy, 4)[0]
    array([2., 2., 2., 2.])
    >>> edges[:, 2] = True
    >>> match_segments(positions, found, edges, gx, gy, 4)[0]
    array([nan, nan, nan, nan])
    """
    radius = int(radius)
    hits, offsets = _candidates(positions, found.axis, edges, gx, gy, radius)
    n_segments = int(found.segment.max()) + 1 if found.segment.size else 0
    size = np.bincount(found.segment, minlength=n_segments)
    steps = np.arange(-radius, radius + 1)
    near = _segment_votes(hits, found.segment, n_segments)
    exact = np.zeros((n_segments, steps.size), dtype=np.int64)
    np.add.at(exact, found.segment, hits.astype(np.int64))
    # the winner: most points within ±1 px; ties to the most exact votes, then the smaller offset
    tall = int(size.max()) + 1 if n_segments else 1
    rank = (near * tall + exact) * (radius + 1) + (radius - np.abs(steps))
    best = rank.argmax(axis=1)
    peak = near[np.arange(n_segments), best]
    # rivals: intensity edges two or more pixels from the winner, their own ±1 px merged
    apart = np.abs(steps[None, :] - steps[best][found.segment][:, None]) >= 2
    others = _segment_votes(hits & apart, found.segment, n_segments)
    rival = np.where(np.abs(steps[None, :] - steps[best][:, None]) >= 2, others, 0).max(
        axis=1, initial=0
    )
    accepted = (peak >= np.maximum(support * size, 2)) & (rival < distinct * peak)
    # each point's candidate nearest the segment's offset, within 1.5 px
    wanted = steps[best][found.segment]
    gap = np.where(np.isfinite(offsets), np.abs(offsets - wanted[:, None]), np.inf)
    nearest = gap.argmin(axis=1)
    point_offset = np.where(
        gap.min(axis=1) <= 1.5, offsets[np.arange(len(offsets)), nearest], np.nan
    )
    # the median of each segment's finite point offsets (sorted by segment, then value)
    finite = np.isfinite(point_offset)
    values, owners = point_offset[finite], found.segment[finite]
    order = np.lexsort((values, owners))
    values = values[order]
    counts = np.bincount(owners, minlength=n_segments)
    starts = np.cumsum(counts) - counts
    has = counts > 0
    median = np.full(n_segments, np.nan)
    lower, upper = (starts + (counts - 1) // 2)[has], (starts + counts // 2)[has]
    median[has] = 0.5 * (values[lower] + values[upper])
    segment_offset = np.where(accepted, median, np.nan)
    claimed = accepted[found.segment] & finite
    taken = _claimed_by_nearer(positions, found, steps[nearest], claimed, segment_offset,
                               edges.shape)
    segment_offset[taken >= 0.5 * np.maximum(np.bincount(found.segment[claimed],
                                                         minlength=n_segments), 1)] = np.nan
    agreement = np.where(size > 0, peak / np.maximum(size, 1), 0.0)
    return segment_offset[found.segment], agreement[found.segment]


def _claimed_by_nearer(positions, found, step, claimed, segment_offset, shape):
    """Per segment: how many of the intensity-edge pixels its points matched a nearer segment holds.

    ``step[i]``: the whole-pixel offset of point ``i``'s matched Canny pixel;
    ``claimed``: the points of matched segments that matched one. Where two
    segments of one orientation matched the same pixel, the one with the
    smaller ``|offset|`` holds it (ties: the smaller id).
    """
    height, width = shape
    pick = np.nonzero(claimed)[0]
    if pick.size == 0:
        return np.zeros(segment_offset.size, dtype=np.int64)
    base = np.round(positions[pick]).astype(np.int64)
    axis = found.axis[pick]
    col = base[:, 0] + np.where(axis == 0, step[pick], 0)
    row = base[:, 1] + np.where(axis == 1, step[pick], 0)
    key = (axis * height + row) * width + col
    owner = found.segment[pick]
    order = np.lexsort((owner, np.abs(segment_offset[owner]), key))
    key, owner = key[order], owner[order]
    first = np.r_[True, key[1:] != key[:-1]]
    holder = owner[first][np.cumsum(first) - 1]
    return np.bincount(owner[owner != holder], minlength=segment_offset.size)
