"""BP's sends and Ψ, made cheaper: the same numbers, bit for bit.

The max-product send takes the sender's labels one at a time (no (E, k, k) temporary),
the rows of Ψ are kept in a bounded cache that prefers the edges still changing, and
:class:`~refsynth.synthesis.belief.model.Compatibilities` reads the shared pixels of two
candidate patches straight from the range plane. Each must give the numbers of the
plain formulas (§3.2.3, Eqs. 6 and 9), whatever the cache's size or the blocks.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.synthesis.belief.messages import belief_propagation
from refsynth.synthesis.belief.model import Compatibilities, grid_edges, pair_compatibilities, psi

#: Tests of a fast kernel's internals (``-m kernel`` selects them).
pytestmark = pytest.mark.kernel


def _bits(a):
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def _pairs(unknown):
    """BP's pairs of unknown 4-neighbours, as node indices, and how many are horizontal."""
    edges = grid_edges(unknown)
    node_of = np.cumsum(unknown.ravel()) - 1
    both = np.concatenate([edges["h"], edges["v"]]).reshape(-1, 2)
    return node_of[both].astype(np.int64), edges["h"].shape[0]


def _grid_model(g, h, w, k, ties):
    unknown = g.random((h, w)) < 0.85
    pairs, _ = _pairs(unknown)
    n = int(unknown.sum())
    unary = -g.random((n, k)) * 3
    log_psi = -g.random((pairs.shape[0], k, k)) * 2
    if ties:  # exact agreement (log Ψ = −0) and ties, as candidate patches give
        unary, log_psi = np.round(unary), -np.round(-log_psi)
    return unary, pairs, log_psi


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 8), st.integers(2, 8), st.integers(1, 12), st.integers(0, 2**31 - 1),
       st.booleans())
def test_the_first_sweep_is_eq9_of_the_whole_array(h, w, k, seed, ties):
    """One sweep from zero messages: ``max_l (log Ψ + log Φ)``, less its maximum, exactly."""
    unary, pairs, log_psi = _grid_model(np.random.default_rng(seed), h, w, k, ties)
    if pairs.shape[0] == 0:
        return
    _, _, messages = belief_propagation(unary, pairs, log_psi, iterations=1,
                                        return_messages=True)
    forward = (log_psi + unary[pairs[:, 0]][:, :, None]).max(axis=1)
    backward = (log_psi + unary[pairs[:, 1]][:, None, :]).max(axis=2)
    want = np.concatenate([forward - forward.max(axis=1, keepdims=True),
                           backward - backward.max(axis=1, keepdims=True)])
    np.testing.assert_array_equal(_bits(messages), _bits(want))


@settings(max_examples=30, deadline=None)
@given(st.integers(3, 9), st.integers(3, 9), st.integers(1, 6), st.integers(0, 2**31 - 1),
       st.sampled_from([0, 1, 3, 10, 10_000]), st.sampled_from([0.0, 0.3]), st.booleans())
def test_any_size_of_the_psi_cache_changes_no_bit(h, w, k, seed, rows, damping, ties):
    """Ψ as a function, with room for 0 to 10 000 rows: the table's numbers, sweep by sweep."""
    import refsynth.synthesis.belief.messages as messages

    unary, pairs, log_psi = _grid_model(np.random.default_rng(seed), h, w, k, ties)
    silent = np.random.default_rng(seed + 1).random(unary.shape[0]) < 0.2
    kw = dict(silent=silent, iterations=25, tolerance=0.0, damping=damping,
              return_messages=True)
    want = belief_propagation(unary, pairs, log_psi, **kw)
    saved = messages._PSI_CACHE
    messages._PSI_CACHE = rows * k * k * 8
    try:
        asked = []
        got = belief_propagation(unary, pairs,
                                 lambda e: (asked.append(np.size(e)), log_psi[e])[1], **kw)
    finally:
        messages._PSI_CACHE = saved
    assert got[1] == want[1]
    np.testing.assert_array_equal(_bits(got[0]), _bits(want[0]))
    np.testing.assert_array_equal(_bits(got[2]), _bits(want[2]))
    if rows >= pairs.shape[0]:  # room for every edge: each row is computed once
        assert sum(asked) == pairs.shape[0]

        def into(e, out=None):  # a function that writes its rows where it is told
            asked.append(np.size(e))
            if out is None:
                return log_psi[e]
            out[...] = log_psi[e]
            return out

        asked.clear()
        messages._PSI_CACHE = rows * k * k * 8
        try:
            again = belief_propagation(unary, pairs, into, **kw)
        finally:
            messages._PSI_CACHE = saved
        assert sum(asked) == pairs.shape[0] and again[1] == want[1]
        np.testing.assert_array_equal(_bits(again[0]), _bits(want[0]))
        np.testing.assert_array_equal(_bits(again[2]), _bits(want[2]))


@st.composite
def planes(draw):
    h, w = draw(st.integers(2, 9)), draw(st.integers(2, 9))
    n = draw(st.sampled_from([1, 3, 5]))
    k = draw(st.integers(1, 6))
    g = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    values = g.integers(0, 2**16, (h, w)).astype(np.float64)
    if draw(st.booleans()):  # few levels: exact agreement, Ψ = 1
        values = np.round(values / 2**15) * 2**15
    missing = g.random((h, w)) < draw(st.sampled_from([0.0, 0.3, 0.8]))
    plane = np.pad(np.where(missing, -1.0, values), n // 2, constant_values=-1.0)
    unknown = g.random((h, w)) < 0.7
    pairs, n_h = _pairs(unknown)
    labels = g.integers(0, h * w, (int(unknown.sum()), k))
    return plane, n, labels, w, pairs, n_h


def _literal_mean_square(pi, pj, direction, centres):
    """Eq. 6's mean square, label pair by label pair, over the pixels both patches have
    (−1: none) where the two overlap, plus (``centres``) the two centres, on the grid."""
    n = pi.shape[-1]
    out = np.zeros((pi.shape[0], pj.shape[0]))
    for a, left in enumerate(pi):
        for b, right in enumerate(pj):
            x, y = (left[:, 1:], right[:, :-1]) if direction == "h" else (left[1:], right[:-1])
            pairs = [(u, v) for u, v in zip(x.ravel(), y.ravel()) if u >= 0 and v >= 0]
            if centres and left[n // 2, n // 2] >= 0 and right[n // 2, n // 2] >= 0:
                pairs.append((left[n // 2, n // 2], right[n // 2, n // 2]))
            if pairs:
                total = sum(int(u - v) ** 2 for u, v in pairs)  # exact integers
                out[a, b] = total * 2.0**-32 / len(pairs)
    return out


@settings(max_examples=60, deadline=None)
@given(planes(), st.sampled_from([1, 2, 7, 512]), st.booleans(), st.booleans())
def test_compatibilities_are_eq6_of_the_candidate_patches(case, block, moved, centres):
    """Ψ from the plane's shared pixels equals Eq. 6 of the whole patches, in any blocks;
    with the offset copy's shifts, of the patches moved by them; with the centres too."""
    import refsynth.synthesis.belief.model as bp_model

    plane, n, labels, width, pairs, n_h = case
    patches = sliding_window_view(plane, (n, n))
    rows, cols = np.divmod(labels, width)
    shifts = None
    if moved:  # each label's patch moved by its shift (any value the span allows)
        shifts = np.random.default_rng(labels.size).integers(-2**16, 2**16 + 1, labels.shape)
    want = np.empty((pairs.shape[0], labels.shape[1], labels.shape[1]))
    for e, (i, j) in enumerate(pairs):
        direction = "h" if e < n_h else "v"
        pi, pj = patches[rows[i], cols[i]][None], patches[rows[j], cols[j]][None]
        if moved:  # lifted by 2**18, as Compatibilities does: a difference, unchanged
            pi = np.where(pi >= 0, pi + shifts[i][None, :, None, None] + 2**18, -1.0)
            pj = np.where(pj >= 0, pj + shifts[j][None, :, None, None] + 2**18, -1.0)
        if centres:
            ms = _literal_mean_square(pi[0], pj[0], direction, centres=True)
        else:
            ms = pair_compatibilities(pi, pj, direction, quantised=True)[0]
        want[e] = psi(ms, 0.2)
    compat = Compatibilities(plane, n, labels, width, pairs, n_h, 0.2, centres=centres,
                             shifts=shifts)
    saved = bp_model._PSI_BLOCK
    bp_model._PSI_BLOCK = block
    try:
        got = compat.all()
        order = np.random.default_rng(block).permutation(pairs.shape[0])
        some = compat(order)
        again = pickle.loads(pickle.dumps(compat)).all()
    finally:
        bp_model._PSI_BLOCK = saved
    np.testing.assert_array_equal(_bits(got), _bits(want))
    np.testing.assert_array_equal(_bits(some), _bits(want[order]))
    np.testing.assert_array_equal(_bits(again), _bits(want))
