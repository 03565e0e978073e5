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

    Every point of a segment votes for the offsets (along its normal,
    within ``±radius`` px, ±1 px tolerance) at which a compatible intensity
    edge lies (:func:`match_edges`' candidates). The segment takes the most
    voted offset if at least ``support`` of its points voted for it and no
    other offset two or more pixels away got ``distinct`` as many votes;
    its offset is the median of those points' sub-pixel positions. A wrong
    intensity edge (a texture line, a skirting board beside a box top that
    blends into the floor) rarely runs along a whole segment at one
    offset, and a parallel one two pixels off makes the segment ambiguous.

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
        A segment is ambiguous (unmatched) if an offset two or more pixels
        from the winner gets at least this fraction of its votes.

    Returns
    -------
    offset : ndarray of shape (N,)
        The segment's offset, for each of its points; NaN if unmatched.
    votes : ndarray of shape (N,)
        The fraction of the segment's points that agreed.
    """
    radius = int(radius)
    hits, offsets = _candidates(positions, found.axis, edges, gx, gy, radius)
    near = ndi.maximum_filter1d(hits.astype(np.int64), 3, axis=1)  # ±1 px tolerance
    n_segments = int(found.segment.max()) + 1 if found.segment.size else 0
    votes = np.zeros((n_segments, hits.shape[1]))
    np.add.at(votes, found.segment, near)
    size = np.bincount(found.segment, minlength=n_segments)
    steps = np.arange(-radius, radius + 1)
    best = (votes - 1e-3 * np.abs(steps)).argmax(axis=1)  # ties: the smaller offset
    peak = votes[np.arange(n_segments), best]
    rival = np.where(np.abs(steps[None, :] - steps[best][:, None]) >= 2, votes, 0).max(axis=1)
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
    agreement = np.where(size > 0, peak / np.maximum(size, 1), 0.0)
    return segment_offset[found.segment], agreement[found.segment]
