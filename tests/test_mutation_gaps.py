"""Tests that kill the mutants of ``benchmarks/mutation_check.py`` nothing else killed.

Each test names the mutant it kills and the assembly step the other tests leave open.
"""

from __future__ import annotations

import numpy as np
import pytest

import refsynth
from refsynth.synthesis import reference as ref
from refsynth.synthesis.api import normalise_intensity


def _sparse_case(seed: int, shape=(9, 11)):
    """Noise intensity, a few isolated measured pixels with distinct ranges."""
    g = np.random.default_rng(seed)
    image = g.random(shape)
    truth = np.round(1.0 + 4.0 * g.random(shape), 2)
    known = g.random(shape) < 0.12
    known[g.integers(shape[0]), g.integers(shape[1])] = True
    return image, np.where(known, truth, np.nan)


@pytest.mark.parametrize("ordering", ["priority", "onion"])
@pytest.mark.parametrize("radius", [1.0, 1.2])
@pytest.mark.parametrize("seed", range(6))
def test_np_widened_search_equals_the_reference(seed, radius, ordering):
    """Kills ``np-widened``: with ``r < √2`` a front voxel whose filled neighbours are all
    diagonal has an empty ``A_p``, and the search widens to every filled voxel within
    ``d + r`` (not only those at the nearest distance ``d``). The reference tests draw
    ``r ≥ 1.5``, where ``A_p`` is never empty, so only this reaches the widened set."""
    image, partial = _sparse_case(seed)
    edges = np.zeros(partial.shape, dtype=bool)
    options = dict(neighbourhood=3, radius=radius, epsilon=0.0, ordering=ordering,
                   use_edges=False)
    fast = refsynth.synthesize(image, partial, method="np", seed=seed, edges=edges, **options)
    slow = ref.np_reference(normalise_intensity(image), partial, edges,
                            np.random.default_rng(seed), **options)
    np.testing.assert_array_equal(fast.order, slow.order)
    np.testing.assert_array_equal(fast.range, slow.range)
    np.testing.assert_array_equal(fast.confidence, slow.confidence)


def _expected_pop(front) -> int:
    """The order's choice from Eq. 10 afresh: lowest tier, highest P, smallest tie."""
    p = front.priorities().ravel()
    on = np.flatnonzero(~np.isnan(p))
    tier = front.tier.ravel()[on]
    on = on[tier == tier.min()]
    on = on[p[on] == p[on].max()]
    return int(on[np.argmin(front.tie.ravel()[on])])


@pytest.mark.parametrize("n", [3, 5])
@pytest.mark.parametrize("seed", range(20))
def test_every_pop_is_the_order_of_eq10_clipped_with_ties(seed, n):
    """Kills ``pr-clip-d-step``: after a fill, the queue's key of a front voxel whose Eq. 12
    term ``D`` is negative must be that of ``max(D, 0)``, as Eq. 10 reads. Negative ``D``
    needs steep range differences around a corner of the front (0 and 1 side by side on
    two sides of it, ``D = 1 − √2``); the clipped priority is then Eq. 10's least, equal
    to that of every voxel with ``C · D = 0``, so only the tie order tells the two apart.
    Every pop must be the front voxel of lowest tier, highest Eq. 10 priority (recomputed
    from the running sums by :meth:`FillFront.priorities`) and smallest tie rank, and after
    every fill the queue must hold each voxel's key (:func:`encode_keys` of that priority,
    in its tier) bit for bit: the re-prioritised keys of ``fill_step`` equal those of
    ``_eq10``."""
    from refsynth.synthesis.frontqueue import ABSENT
    from refsynth.synthesis.priority import FillFront

    g = np.random.default_rng(seed)
    h, w = int(g.integers(6, 10)), int(g.integers(6, 10))
    known = g.random((h, w)) < 0.3
    known[0, 0] = True
    range_norm = np.where(known, g.integers(0, 2, (h, w)).astype(float), 0.0)
    edges = g.random((h, w)) < 0.1
    front = FillFront(known, range_norm, edges, n, n // 2 + 1, g, use_edges=bool(seed % 2))
    for _ in range(int((~known).sum())):
        expected = _expected_pop(front)
        p = front.pop()
        assert p == expected
        front.fill(p, float(g.integers(0, 2)), float(g.choice([0.0, 0.5, 1.0])))
        # the queue holds every voxel's key as Eq. 10 gives it now (absent off the front)
        priorities = front.priorities().ravel()
        on = ~np.isnan(priorities)
        keys = np.where(on, np.where(on, priorities, 1.0).view(np.int64), ABSENT)
        keys[on] += np.where(front.tier.ravel()[on] != 0, ABSENT, 0)
        np.testing.assert_array_equal(front.queue.keys[front.tie.ravel()], keys)



@pytest.mark.parametrize("product", ["max", "sum"])
def test_bp_paper_reference_sums_a_belief_left_up_right_down(product):
    """Kills ``bpref-belief-order``: BP as printed (``synthesis.belief.reference``) sums a
    node's incoming messages left, up, right, down, ``unary + ((((0 + M_l) + M_u) + M_r) +
    M_d)``. In a closed hole every inner node has four, and another order of the last three
    moves a belief by an ulp (here under sum-product); the beliefs are recomputed from
    the run's own unary terms and final messages in the contract's order."""
    from refsynth.synthesis.belief.reference import bp_reference

    g = np.random.default_rng(5)
    image = g.random((10, 10))
    partial = np.round(1 + 3 * g.random((10, 10)), 2)
    partial[2:8, 2:8] = np.nan
    out = bp_reference(image, partial, radius=3.0, iterations=6, product=product,
                       use_edges=False)
    node = {tuple(p): i for i, p in enumerate(out.order.tolist())}
    E = len(out.pairs)
    row = {(int(a), int(b)): e for e, (a, b) in enumerate(out.pairs)}   # a -> b
    row |= {(int(b), int(a)): E + e for e, (a, b) in enumerate(out.pairs)}
    expected = np.zeros_like(out.beliefs)
    for i, (r, c) in enumerate(out.order.tolist()):
        total = np.zeros(out.beliefs.shape[1])
        for q in ((r, c - 1), (r - 1, c), (r, c + 1), (r + 1, c)):   # left, up, right, down
            if q in node:
                total = total + out.messages[row[(node[q], i)]]
        expected[i] = out.unary[i] + total
    assert expected.tobytes() == out.beliefs.tobytes()
