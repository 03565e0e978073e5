"""Tests of the local stretch's segment matching (App. A.2): registration.match_segments.

Hand-built cases: a straight depth-edge segment and intensity edges (Canny
pixels with the gradient along the segment's normal) at whole-pixel offsets.
A clean edge at any offset within the search radius must be matched at that
offset; two edges two or more pixels apart along the whole segment make it
ambiguous (unmatched).
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from refsynth.registration import RangeEdges, intensity_edges, match_segments

SIZE = 40
#: The segment's column (axis 0) or row (axis 1): its points' position along the normal.
AT = 20


def _segment(axis, length=10, start=5, at=AT):
    """One straight depth-edge segment: its mosaic positions and its RangeEdges."""
    along = np.arange(start, start + length, dtype=np.float64)
    across = np.full(length, float(at))
    positions = np.column_stack([across, along] if axis == 0 else [along, across])
    found = RangeEdges(phi=np.zeros(length), h=np.zeros(length), axis=np.full(length, axis),
                       r=np.ones(length), segment=np.zeros(length, dtype=np.int64))
    return positions, found


def _edges(axis, shifts, rows=slice(None), at=AT):
    """Intensity edges parallel to the segment, ``shifts`` px from it, gradient along the normal."""
    edges = np.zeros((SIZE, SIZE), dtype=bool)
    for shift in shifts:
        if axis == 0:
            edges[rows, at + shift] = True
        else:
            edges[at + shift, rows] = True
    ones, zeros = np.ones((SIZE, SIZE)), np.zeros((SIZE, SIZE))
    gx, gy = (ones, zeros) if axis == 0 else (zeros, ones)
    return edges, gx, gy


def _two_segments(axis, first, second):
    """Two straight segments of one orientation (``_segment``'s keywords each), ids 0 and 1."""
    (one, found_one), (two, found_two) = _segment(axis, **first), _segment(axis, **second)
    found = RangeEdges(*(np.concatenate([a, b]) for a, b in zip(found_one, found_two)))
    sizes = [len(one), len(two)]
    return np.vstack([one, two]), found._replace(segment=np.repeat([0, 1], sizes))


def _match(axis, shifts, radius, *, length=10, start=5, rows=slice(None), **options):
    positions, found = _segment(axis, length, start)
    offset, votes = match_segments(positions, found, *_edges(axis, shifts, rows), radius,
                                   **options)
    return offset, votes


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("shift", range(-4, 5))
def test_a_clean_edge_is_matched_at_its_offset(axis, shift):
    # the bug: at 1, 2 or 3 px (either side) the ±1 px tolerance gave d − 1, d and d + 1 equal
    # votes, the tie went to the smaller one and d + 1, 2 px away, was counted as a rival
    offset, votes = _match(axis, [shift], 4)
    assert offset.tolist() == [float(shift)] * 10
    assert votes.tolist() == [1.0] * 10


@given(
    radius=st.integers(2, 8),
    data=st.data(),
    axis=st.sampled_from([0, 1]),
    length=st.integers(2, 12),
    start=st.integers(1, 20),
)
def test_a_segment_shifted_by_a_whole_pixel_is_matched_there(radius, data, axis, length, start):
    shift = data.draw(st.integers(-radius + 1, radius - 1), label="shift")
    offset, votes = _match(axis, [shift], radius, length=length, start=start)
    assert offset.tolist() == [float(shift)] * length
    assert votes.tolist() == [1.0] * length


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("pair", [(-1, 1), (-2, 2), (-3, 3), (0, 2), (1, 3), (-3, 0), (2, 4)])
def test_two_edges_two_or_more_pixels_apart_are_ambiguous(axis, pair):
    offset, votes = _match(axis, list(pair), 4)
    assert np.isnan(offset).all()
    assert votes.tolist() == [1.0] * 10  # every point agreed with the winner: not a lack of support


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("shift", [-3, 0, 2])
def test_an_edge_two_pixels_wide_is_one_edge(axis, shift):
    # hits at d and d + 1 on every point: within the ±1 px tolerance of each other, no rival
    offset, _ = _match(axis, [shift, shift + 1], 4)
    assert np.all((offset >= shift) & (offset <= shift + 1))


def test_a_rival_on_too_few_points_leaves_the_segment_matched():
    # the rival edge runs along 6 of the 10 points (rows 5–10): 0.6 < distinct = 0.7
    edges, gx, gy = _edges(0, [2])
    edges[5:11, AT - 2] = True
    positions, found = _segment(0)
    offset, _ = match_segments(positions, found, edges, gx, gy, 4)
    assert offset.tolist() == [2.0] * 10
    edges[5:12, AT - 2] = True  # on 7 of them: ambiguous
    offset, _ = match_segments(positions, found, edges, gx, gy, 4)
    assert np.isnan(offset).all()


def test_too_little_support_leaves_the_segment_unmatched():
    offset, votes = _match(0, [2], 4, rows=slice(5, 9))  # 4 of 10 points see the edge
    assert np.isnan(offset).all() and votes.tolist() == [0.4] * 10
    offset, _ = _match(0, [2], 4, rows=slice(5, 9), support=0.4)
    assert offset.tolist() == [2.0] * 10


def test_nothing_within_the_radius_is_unmatched():
    offset, votes = _match(1, [4], 3)
    assert np.isnan(offset).all() and votes.tolist() == [0.0] * 10


def test_segments_are_matched_independently():
    positions, found = _two_segments(0, dict(start=2, length=8),
                                     dict(start=20, length=8, at=AT + 1))
    edges, gx, gy = _edges(0, [3])  # column AT + 3: 3 px from the first, 2 px from the second
    offset, _ = match_segments(positions, found, edges, gx, gy, 4)
    assert offset.tolist() == [3.0] * 8 + [2.0] * 8


@pytest.mark.parametrize("shift", [-3, -2, -1, 0, 1, 2, 3])
def test_a_step_in_the_mosaic_is_matched_at_its_sub_pixel_offset(shift):
    # a vertical step between columns 19 and 20: Canny marks both (an edge two pixels wide),
    # the gradient's parabola puts either at 19.5; the segment sits `shift` px to its left
    image = np.zeros((SIZE, SIZE))
    image[:, AT:] = 1.0
    positions, found = _segment(0, length=12, start=10, at=AT - 0.5 - shift)
    offset, votes = match_segments(positions, found, *intensity_edges(image), 5)
    assert offset == pytest.approx(np.full(12, float(shift)), abs=1e-9)
    assert votes.tolist() == [1.0] * 12


def test_two_segments_on_one_intensity_edge_the_nearer_keeps_it():
    # two parallel horizontal depth edges, rows AT and AT + 2, over the same columns; one
    # intensity edge, on row AT: the first is on it, the second would have to move onto it
    positions, found = _two_segments(1, dict(start=5), dict(start=5, at=AT + 2))
    offset, votes = match_segments(positions, found, *_edges(1, [0]), 4)
    assert offset[:10].tolist() == [0.0] * 10 and np.isnan(offset[10:]).all()
    assert votes.tolist() == [1.0] * 20
    # over three of its ten columns only: the second keeps its match
    positions, found = _two_segments(1, dict(start=5), dict(start=12, at=AT + 2))
    offset, _ = match_segments(positions, found, *_edges(1, [0]), 4)
    assert offset.tolist() == [0.0] * 10 + [-2.0] * 10
