"""Eqs. 10–12 (§3.2.4): confidence, isophote data term, edge count, fill order."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from refsynth.synthesis.priority import (
    FillFront,
    confidence_term,
    data_term,
    edge_count,
    fill_front,
    front_normals,
    onion_order,
    priority,
    range_gradient,
)

masks = hnp.arrays(np.bool_, st.tuples(st.integers(3, 12), st.integers(3, 12)))


@given(masks, st.sampled_from([1, 3, 5]), st.integers(0, 2**32 - 1))
def test_eq11_lies_in_unit_interval(known, n, seed):
    conf = np.where(known, np.random.default_rng(seed).random(known.shape), 0.0)
    c = confidence_term(conf, n)
    assert np.all(c >= 0.0) and np.all(c <= 1.0 + 1e-12)


@given(st.integers(3, 12), st.integers(3, 12), st.sampled_from([1, 3, 5]))
def test_eq11_is_one_inside_fully_known_areas(h, w, n):
    """Including at the border, since |N_p| counts the voxels inside the image."""
    np.testing.assert_allclose(confidence_term(np.ones((h, w)), n), 1.0, rtol=1e-12)


def test_eq11_hand_computed():
    conf = np.zeros((5, 5))
    conf[2, 1] = 1.0
    conf[1, 1] = 0.5
    c = confidence_term(conf, 3)
    assert c[2, 2] == pytest.approx(1.5 / 9)
    assert c[0, 0] == pytest.approx(0.5 / 4)  # corner: 4 in-image voxels


@given(masks)
def test_front_is_unknown_and_touches_filled(filled):
    front = fill_front(filled)
    assert not np.any(front & filled)
    padded = np.pad(filled, 1)
    for r, c in np.argwhere(front):
        assert padded[r : r + 3, c : c + 3].any()


@given(st.floats(0.0, 0.5), st.integers(5, 12))
def test_eq12_is_one_without_isophote(level, width):
    """A constant range has no gradient, hence no isophote: D = 1 everywhere."""
    filled = np.zeros((9, width), dtype=bool)
    filled[:, : width // 2] = True
    d = data_term(np.full(filled.shape, level), filled, 5)
    np.testing.assert_array_equal(d, 1.0)


@given(st.floats(0.0, np.pi), st.floats(0.01, 0.1))
def test_eq12_hand_computed_for_a_planar_range(angle, slope):
    """Known left half, front normal along the columns; planar range at ``angle``.

    The range gradient is slope·(cos t, sin t) in (row, col); the isophote
    (gradient turned by 90°) is slope·(−sin t, cos t), so ``|∇I⊥ · n| = slope·|cos t|``.
    """
    rows, cols = np.mgrid[:15, :16]
    range_norm = slope * (np.cos(angle) * rows + np.sin(angle) * cols)
    filled = cols < 8
    d = data_term(range_norm, filled, 5)
    # a front pixel far from the top and bottom: the window sees whole pairs
    assert d[7, 8] == pytest.approx(1.0 - slope * abs(np.cos(angle)), abs=1e-12)


@given(st.floats(0.0, np.pi / 2), st.floats(0.0, np.pi / 2))
def test_eq12_falls_as_the_isophote_aligns_with_the_front_normal(a, b):
    rows, cols = np.mgrid[:15, :16]
    filled = cols < 8

    def d_at(angle):
        rn = 0.05 * (np.cos(angle) * rows + np.sin(angle) * cols)
        return data_term(rn, filled, 5)[7, 8]

    # the isophote is aligned with the normal (0, 1) when the gradient is along rows (angle 0)
    if abs(np.cos(a)) >= abs(np.cos(b)):
        assert d_at(a) <= d_at(b) + 1e-12


def test_front_normal_points_across_a_straight_front():
    filled = np.zeros((7, 8), dtype=bool)
    filled[:, :4] = True
    n_row, n_col = front_normals(filled)
    assert n_row[3, 4] == pytest.approx(0.0) and abs(n_col[3, 4]) == pytest.approx(1.0)


def test_eq10_hand_computed():
    """P = C·D + 1/(1 + E) at one front pixel."""
    known = np.zeros((7, 7), dtype=bool)
    known[:, :3] = True
    edges = np.zeros((7, 7), dtype=bool)
    edges[3, 4] = edges[2, 4] = True
    p = priority(known.astype(float), np.zeros((7, 7)), known, edges, 3)
    # pixel (3, 3): 3 known voxels of 9 in its window, D = 1, two edges in window
    assert p[3, 3] == pytest.approx(3 / 9 + 1 / 3)
    assert np.isnan(p[3, 5])  # not on the front
    no_edges = priority(known.astype(float), np.zeros((7, 7)), known, edges, 3, use_edges=False)
    assert no_edges[3, 3] == pytest.approx(3 / 9 + 1.0)


def test_edge_count_counts_the_window():
    edges = np.zeros((5, 5), dtype=bool)
    edges[0, 0] = edges[2, 2] = True
    e = edge_count(edges, 3)
    assert e[1, 1] == 2 and e[4, 4] == 0 and e[2, 3] == 1


@given(masks.filter(lambda m: m.any() and not m.all()), st.integers(0, 2**32 - 1))
def test_onion_order_walks_layer_by_layer(known, seed):
    order = onion_order(known, np.random.default_rng(seed))
    assert sorted(order.tolist()) == np.flatnonzero(~known).tolist()
    # every pixel, when its turn comes, touches a filled pixel (8-neighbourhood)
    filled = known.copy()
    padded_shape = (known.shape[0] + 2, known.shape[1] + 2)
    for flat in order:
        r, c = divmod(int(flat), known.shape[1])
        window = np.zeros(padded_shape, dtype=bool)
        window[1:-1, 1:-1] = filled
        assert window[r : r + 3, c : c + 3].any()
        filled[r, c] = True


@given(
    st.integers(6, 12),
    st.integers(6, 12),
    st.sampled_from([3, 5]),
    st.booleans(),
    st.booleans(),
    st.integers(0, 2**32 - 1),
)
def test_incremental_front_matches_full_recomputation(h, w, n, use_edges, use_iso, seed):
    """After any sequence of fills, FillFront's sums equal Eqs. 10–12 computed afresh."""
    rng = np.random.default_rng(seed)
    known = rng.random((h, w)) < 0.3
    known[0, 0] = True
    range_norm = np.where(known, rng.random((h, w)), 0.0)
    edges = rng.random((h, w)) < 0.15
    pad = n // 2 + 1
    front = FillFront(
        known, range_norm, edges, n, pad, rng, use_edges=use_edges, use_isophotes=use_iso
    )
    inner = (slice(pad, pad + h), slice(pad, pad + w))
    conf = known.astype(float)
    filled = known.copy()
    values = range_norm.copy()
    for _ in range(int(rng.integers(1, (~known).sum() + 1))):
        p = front.pop()
        assert p >= 0
        r, c = divmod(p, front.shape[1])
        r, c = r - pad, c - pad
        expected = priority(
            conf, values, filled, edges, n, use_edges=use_edges, use_isophotes=use_iso
        )
        tier = edges & use_edges
        on_front = ~np.isnan(expected)
        # the chosen pixel is on the front, in the lowest tier present, with the top priority
        assert on_front[r, c]
        assert tier[r, c] == tier[on_front].min()
        same_tier = on_front & (tier == tier[r, c])
        assert expected[r, c] == pytest.approx(expected[same_tier].max(), abs=1e-9)
        value, cval = float(rng.random()), float(rng.random())
        front.fill(p, value, cval)
        filled[r, c] = True
        values[r, c] = value
        conf[r, c] = cval
        np.testing.assert_allclose(
            front.confidence_at(np.arange(front.state[..., 0].size)).reshape(front.shape)[inner],
            confidence_term(conf, n),
            atol=1e-9,
        )
    got = front.priorities()[inner]
    want = priority(conf, values, filled, edges, n, use_edges=use_edges, use_isophotes=use_iso)
    sel = ~np.isnan(want)
    np.testing.assert_allclose(got[sel], want[sel], atol=1e-9)


# -- symmetry: mirroring the input mirrors the order ---------------------------------------


class _GivenTies:
    """A stand-in for the generator FillFront draws its tie-break permutation from."""

    def __init__(self, tie: np.ndarray) -> None:
        self.tie = tie

    def permutation(self, size: int) -> np.ndarray:
        assert size == self.tie.size
        return self.tie.ravel().copy()


def _front_order(known, levels, edges, n, tie, use_edges, edges_last):
    """Pop and fill FillFront to the end: each pixel gets its own truth (on the 2**-16 grid)
    and a confidence that depends on it, so the whole state is a function of the scene."""
    pad = n // 2 + 1
    front = FillFront(known, levels * 2.0**-16, edges, n, pad, _GivenTies(tie),
                      use_edges=use_edges, edges_last=edges_last)
    width = front.shape[1]
    order = []
    while (p := front.pop()) >= 0:
        r, c = divmod(p, width)
        value = levels[r - pad, c - pad]
        front.fill(p, value * 2.0**-16, (value % 7 + 1) / 8.0)
        order.append((r - pad, c - pad))
    return order


@given(
    st.integers(4, 11),
    st.integers(4, 11),
    st.sampled_from([1, 3, 5]),
    st.booleans(),
    st.booleans(),
    st.integers(0, 2**32 - 1),
)
def test_mirrored_input_gives_the_mirrored_order(h, w, n, use_edges, edges_last, seed):
    """Left-right, up-down and transposed scenes (with the tie-break permutation mirrored
    the same way) are filled in the mirrored order, bit for bit: Eq. 12's isophote reaches
    as far on every side of N_p."""
    rng = np.random.default_rng(seed)
    known = rng.random((h, w)) < 0.4
    known[rng.integers(h), rng.integers(w)] = True
    known[rng.integers(h), rng.integers(w)] = False
    levels = rng.integers(0, 2**16 + 1, (h, w)).astype(np.float64)
    edges = rng.random((h, w)) < 0.2
    pad = n // 2 + 1
    tie = rng.permutation((h + 2 * pad) * (w + 2 * pad)).reshape(h + 2 * pad, w + 2 * pad)
    args = (n, use_edges, edges_last)
    order = _front_order(known, levels, edges, n, tie, use_edges, edges_last)
    assert sorted(order) == sorted(map(tuple, np.argwhere(~known).tolist()))
    mirrors = {
        "left-right": (lambda a: a[:, ::-1], lambda r, c: (r, w - 1 - c)),
        "up-down": (lambda a: a[::-1, :], lambda r, c: (h - 1 - r, c)),
        "transposed": (lambda a: a.T, lambda r, c: (c, r)),
    }
    for name, (flip, image_of) in mirrors.items():
        got = _front_order(flip(known), flip(levels), flip(edges), args[0], flip(tie),
                           *args[1:])
        assert got == [image_of(r, c) for r, c in order], name


def test_a_lone_range_pair_weighs_the_same_on_both_sides():
    """One filled pair, (3, 4)–(3, 5), straddles the right border of
    the 5×5 window of (3, 2). Pairs count only when both voxels lie in N_p, so that window
    sees no gradient — as the mirror window, whose border the mirror pair straddles on the
    left, never did — and the data term of the mirrored input is the mirrored data term."""
    filled = np.zeros((7, 7), dtype=bool)
    filled[3, 4:6] = True
    range_norm = np.zeros((7, 7))
    range_norm[3, 5] = 0.9
    g_row, g_col = range_gradient(range_norm, filled, 5)
    assert g_col[3, 2] == 0.0 and g_col[3, 3] == pytest.approx(0.9)
    mirrored = range_gradient(range_norm[:, ::-1], filled[:, ::-1], 5)
    np.testing.assert_array_equal(mirrored[1], -g_col[:, ::-1])
    np.testing.assert_array_equal(mirrored[0], g_row[:, ::-1])
    d = data_term(range_norm, filled, 5)
    np.testing.assert_array_equal(data_term(range_norm[:, ::-1], filled[:, ::-1], 5), d[:, ::-1])
