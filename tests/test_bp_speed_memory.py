"""BP fast and memory-bounded: the same numbers.

The tile-by-tile candidate search equals the literal one from a PatchTable; the message
schedule that skips unchanged edges equals plain synchronous sweeps, bit for bit; Ψ
computed on demand equals the table; a call over the memory limit is refused up front.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import refsynth
from refsynth.numeric import (
    INTENSITY_BITS,
    RANGE_BITS,
    left_to_right_sum,
    portable_exp,
    portable_log,
    quantise_intensity,
    quantise_range,
)
from refsynth.synthesis.belief.fill import bp_fill, bp_memory_estimate, grid_edges
from refsynth.synthesis.belief.memory import BP_MEMORY_LIMIT, check_bp_memory, psi_bytes
from refsynth.synthesis.belief.messages import belief_propagation
from refsynth.synthesis.belief.search import candidates, search_candidates, stable_smallest
from refsynth.synthesis.patch_table import PatchTable

#: Tests of a fast kernel's internals (``-m kernel`` selects them).
pytestmark = pytest.mark.kernel


def _bits(a):
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


# -- the candidate search ----------------------------------------------------------------


@st.composite
def search_cases(draw):
    H, W = draw(st.integers(4, 18)), draw(st.integers(4, 18))
    seed = draw(st.integers(0, 2**31 - 1))
    g = np.random.default_rng(seed)
    channels = draw(st.sampled_from([1, 3]))
    image = g.integers(0, draw(st.sampled_from([2, 5, 256])), (H, W, channels)).astype(float)
    fraction = draw(st.sampled_from([0.1, 0.3, 0.6]))
    known = g.random((H, W)) < fraction
    if draw(st.booleans()):  # a gap wider than r: the search widens
        known[:, W // 3 : W // 3 + draw(st.integers(2, 6))] = False
    known.flat[draw(st.integers(0, H * W - 1))] = True
    if known.all():
        known.flat[0] = False
    rng_range = np.round(g.random((H, W)) * draw(st.sampled_from([1.0, 10.0])), 2)
    partial = np.where(known, rng_range, np.nan)
    return dict(image=image, partial=partial, n=draw(st.sampled_from([3, 5])),
                k=draw(st.integers(1, 9)), radius=draw(st.sampled_from([1.0, 1.5, 3.0, 4.5])),
                proximity=draw(st.sampled_from([0.0, 1.0, 3.0])),
                range_weight=draw(st.sampled_from([0.0, 1.0, 16.0])),
                missing_range=draw(st.sampled_from(["mean", "ignore"])))


@settings(max_examples=60, deadline=None)
@given(search_cases())
def test_the_tiled_search_equals_the_literal_one(case):
    image, partial, n, k = case["image"], case["partial"], case["n"], case["k"]
    radius = case["radius"]
    known = np.isfinite(partial)
    rq, _, _ = quantise_range(partial)
    levels = quantise_intensity(image)
    H, W = partial.shape
    pad = max(int(np.ceil(radius)), n // 2 + 1)
    rows, cols = np.divmod(np.flatnonzero(~known), W)
    got = search_candidates(levels, rq, rows, cols, n=n, k=k, radius=radius,
                            proximity=case["proximity"], range_weight=case["range_weight"],
                            missing_range=case["missing_range"], pad=pad)
    table = PatchTable(levels * 2.0**-INTENSITY_BITS, np.where(known, rq * 2.0**-RANGE_BITS,
                       np.nan), n, pad, case["range_weight"], case["missing_range"])
    Wp = W + 2 * pad
    nodes = (rows + pad) * Wp + cols + pad
    want = candidates(table, nodes, np.pad(known, pad).ravel(), (H + 2 * pad, Wp), k, radius,
                      case["proximity"])
    rp, cp = np.divmod(want[0], Wp)
    np.testing.assert_array_equal(got[0], (rp - pad) * W + cp - pad)
    np.testing.assert_array_equal(_bits(got[1]), _bits(want[1]))


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 40), st.integers(1, 12), st.integers(0, 2**31 - 1), st.booleans())
def test_stable_smallest_is_the_stable_sort(m, count, seed, with_nan):
    g = np.random.default_rng(seed)
    values = g.integers(0, 4, (7, m)).astype(float)  # many ties
    values[g.random(values.shape) < 0.3] = np.inf
    values[g.random(values.shape) < 0.1] = -0.0
    if with_nan:
        values[g.random(values.shape) < 0.1] = np.nan
    count = min(count, m)
    np.testing.assert_array_equal(stable_smallest(values, count),
                                  np.argsort(values, axis=1, kind="stable")[:, :count])


# -- the messages ------------------------------------------------------------------------


def _plain_sweeps(unary, pairs, log_psi, silent=None, iterations=50, tolerance=1e-4,
                  product="max", damping=0.0):
    """The synchronous schedule of Eq. 9 as first written: every edge, every sweep."""
    n, k = unary.shape
    e = pairs.shape[0]
    a, b = pairs[:, 0], pairs[:, 1]
    messages = np.zeros((2 * e + 1, k))
    src, dst = np.concatenate([a, b]), np.concatenate([b, a])
    rev = np.concatenate([np.arange(e, 2 * e), np.arange(e)])
    order = np.argsort(dst, kind="stable")
    counts = np.bincount(dst, minlength=n)
    slot = np.arange(2 * e) - np.repeat(np.cumsum(counts) - counts, counts)
    incoming = np.full((n, max(int(counts.max(initial=0)), 1)), 2 * e, dtype=np.int64)
    incoming[dst[order], slot] = order
    sends = np.ones(2 * e, bool) if silent is None else ~silent[src]

    def beliefs():
        total = np.zeros((n, k))
        for column in range(incoming.shape[1]):
            total = total + messages[incoming[:, column]]
        return unary + total

    def send(h, axis):
        t = log_psi + (h[:, :, None] if axis == 1 else h[:, None, :])
        if product == "max":
            m = t.max(axis=axis)
            return m - m.max(axis=1, keepdims=True)
        top = t.max(axis=axis)
        m = portable_log(left_to_right_sum(portable_exp(t - np.expand_dims(top, axis)),
                                           axis=axis)) + top
        top2 = m.max(axis=1)
        lse = portable_log(left_to_right_sum(portable_exp(m - top2[:, None]), axis=1)) + top2
        return m - lse[:, None]

    done = 0
    for done in range(1, iterations + 1):  # noqa: B007
        h = beliefs()[src] - messages[rev]
        new = np.concatenate([send(h[:e], 1), send(h[e:], 2)])
        new[~sends] = 0.0
        if damping:
            new = new * (1.0 - damping) + damping * messages[:-1]
        change = float(np.max(np.abs(new - messages[:-1]), initial=0.0))
        messages[:-1] = new
        if change <= tolerance:
            break
    return beliefs(), done, messages[:-1]


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 9), st.integers(2, 9), st.integers(1, 5), st.integers(0, 2**31 - 1),
       st.sampled_from(["max", "sum"]), st.sampled_from([0.0, 0.3]), st.booleans())
def test_skipping_unchanged_edges_changes_no_bit(h, w, k, seed, product, damping, quantised):
    g = np.random.default_rng(seed)
    unknown = g.random((h, w)) < 0.8
    edges = grid_edges(unknown)
    node_of = np.full(h * w, -1)
    node_of[unknown.ravel()] = np.arange(int(unknown.sum()))
    pairs = node_of[np.concatenate([edges["h"], edges["v"]])].reshape(-1, 2)
    n = int(unknown.sum())
    unary = -g.random((n, k)) * 3
    log_psi = -g.random((pairs.shape[0], k, k)) * 2
    if quantised:  # ties and exact agreement, as candidate patches give
        unary, log_psi = np.round(unary), -np.round(-log_psi)
    silent = g.random(n) < 0.2
    kw = dict(iterations=30, tolerance=0.0 if seed % 2 else 1e-4, product=product,
              damping=damping)
    b1, d1, m1 = belief_propagation(unary, pairs, log_psi, silent=silent,
                                    return_messages=True, **kw)
    b2, d2, m2 = _plain_sweeps(unary, pairs, log_psi, silent=silent, **kw)
    assert d1 == d2
    np.testing.assert_array_equal(_bits(b1), _bits(b2))
    np.testing.assert_array_equal(_bits(m1), _bits(m2))
    # Ψ given as a function of the edges: the same
    b3, d3, m3 = belief_propagation(unary, pairs, lambda e: log_psi[e], silent=silent,
                                    return_messages=True, **kw)
    assert d3 == d1
    np.testing.assert_array_equal(_bits(b3), _bits(b1))
    np.testing.assert_array_equal(_bits(m3), _bits(m1))


# -- memory --------------------------------------------------------------------------------


def test_the_estimate_grows_with_the_work():
    small = bp_memory_estimate((100, 100), 5000)
    assert bp_memory_estimate((200, 200), 20000) > small
    assert bp_memory_estimate((100, 100), 5000, k=16) > small
    assert bp_memory_estimate((100, 100), 5000, n_pairs=100) < small
    assert psi_bytes(10, 4) == 10 * 16 * 8


def test_a_call_over_the_limit_is_refused_up_front():
    image = np.zeros((30, 40, 3))
    partial = np.where(np.arange(40) % 4 == 0, 1.0, np.nan) + np.zeros((30, 1))
    with pytest.raises(ValueError, match=r"BP on 40×30 \(900 unknown pixels\) with k=8 .*GB"):
        bp_fill(image, partial, np.zeros((30, 40), bool), memory_limit=2**20)
    with pytest.raises(ValueError, match="more than the limit"):
        check_bp_memory((5000, 5000), 20_000_000, k=32)


def test_a_4096_square_image_is_refused_before_any_work():
    """About 13 M unknown pixels: well over 4 GiB; refused at once, not after minutes."""
    assert bp_memory_estimate((4096, 4096), 13_000_000) > BP_MEMORY_LIMIT
    partial = np.full((4096, 4096), np.nan, dtype=np.float32)
    partial[::5] = 1.0
    with pytest.raises(ValueError, match=r"BP on 4096×4096 .* would need about \d+\.\d GB"):
        bp_fill(np.zeros((4096, 4096, 1), dtype=np.float32), partial,
                np.zeros((1, 1), bool))


def test_log_psi_is_computed_on_first_access_and_equals_the_sends():
    g = np.random.default_rng(4)
    image = g.integers(0, 256, (14, 16, 3)).astype(np.uint8)
    partial = np.where(g.random((14, 16)) < 0.4, g.random((14, 16)) + 1, np.nan)
    bp = refsynth.synthesize(image, partial, method="bp", radius=4.0).bp
    assert "log_psi" not in vars(bp)
    table = bp.log_psi
    assert table.shape == (bp.pairs.shape[0], 8, 8) and bp.log_psi is table
    # the same numbers as Ψ of the pairs' own candidate patches (the reference checks all)
    first = refsynth.synthesize(image, partial, method="bp", radius=4.0).bp
    np.testing.assert_array_equal(_bits(first.log_psi[::7]), _bits(table[::7]))


def test_a_result_pickles_compactly_and_keeps_its_log_psi():
    import pickle

    g = np.random.default_rng(5)
    image = g.integers(0, 256, (12, 15, 3)).astype(np.uint8)
    partial = np.where(g.random((12, 15)) < 0.4, g.random((12, 15)) + 1, np.nan)
    bp = refsynth.synthesize(image, partial, method="bp", radius=4.0).bp
    again = pickle.loads(pickle.dumps(bp))
    np.testing.assert_array_equal(_bits(again.log_psi), _bits(bp.log_psi))
    np.testing.assert_array_equal(_bits(again.messages), _bits(bp.messages))
