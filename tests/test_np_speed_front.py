"""NP's fast fill order: the queue pops exactly what a fresh selection would."""

import heapq

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from refsynth.synthesis.frontqueue import ABSENT, FrontQueue, encode_keys
from refsynth.synthesis.priority import FillFront

#: Tests of a fast kernel's internals (``-m kernel`` selects them).
pytestmark = pytest.mark.kernel


@given(st.integers(1, 300), st.integers(0, 2**32 - 1), st.sampled_from([None, 8, 16]),
       st.booleans())
def test_queue_pops_as_a_heap_of_tier_priority_tie(size, seed, block, by_blocks):
    """Random sets, updates and removals: the pops follow (tier, -priority, tie), ties
    included (priorities drawn from a few values so that they tie often). ``by_blocks``:
    the updates go through set_in_blocks (NP's per-step path, which only raises the blocks'
    bounds, so that pop must tighten a bound left loose by a lowered or removed key)."""
    rng = np.random.default_rng(seed)
    tie = rng.permutation(size)
    queue = FrontQueue(tie, block)
    current: dict[int, tuple[int, float]] = {}
    levels = np.array([0.25, 0.5, 1.0, 1.5, 2.0, 1e-300, 0.1 + 0.2])
    for _ in range(int(rng.integers(1, 40))):
        pixels = np.unique(rng.integers(0, size, int(rng.integers(1, 10))))
        prio = levels[rng.integers(0, levels.size, pixels.size)]
        tier = rng.integers(0, 2, pixels.size)
        keys = encode_keys(prio, tier)
        drop = rng.random(pixels.size) < 0.2
        keys[drop] = ABSENT
        if by_blocks:
            slots = tie[pixels]
            queue.set_in_blocks(slots, slots >> queue.shift, keys)
        else:
            queue.set(pixels, keys)
        for x, t, p, d in zip(pixels.tolist(), tier.tolist(), prio.tolist(), drop.tolist()):
            if d:
                current.pop(x, None)
            else:
                current[x] = (t, p)
        for _ in range(int(rng.integers(0, 3))):
            heap = [(t, -p, int(tie[x]), x) for x, (t, p) in current.items()]
            want = heapq.nsmallest(1, heap)[0][3] if heap else -1
            assert queue.pop() == want
            current.pop(want, None)
    while current:
        want = min((t, -p, int(tie[x]), x) for x, (t, p) in current.items())[3]
        assert queue.pop() == want
        del current[want]
    assert queue.pop() == -1


def _fresh_choice(front: FillFront) -> int:
    """The front voxel a from-scratch selection takes: lowest tier, then highest Eq. 10
    priority (from the running sums, as FillFront computes it), then smallest tie."""
    p = front.priorities().ravel()
    on = np.flatnonzero(~np.isnan(p))
    if on.size == 0:
        return -1
    tier = front.tier.ravel()[on]
    tie = front.tie.ravel()[on]
    return int(on[np.lexsort((tie, -p[on], tier))[0]])


@given(
    st.integers(4, 12),
    st.integers(4, 12),
    st.sampled_from([1, 3, 5, 7]),
    st.booleans(),
    st.booleans(),
    st.booleans(),
    st.integers(0, 2**32 - 1),
)
def test_fill_front_pops_the_fresh_choice_at_every_step(h, w, n, use_edges, use_iso,
                                                        edges_last, seed):
    """Values on the contract's grids (range 2**-16, confidence 2**-40), so the running
    sums are exact: each pop must be the from-scratch choice, bit for bit, which also
    shows that a fill re-prioritises every voxel whose priority it changes."""
    rng = np.random.default_rng(seed)
    known = rng.random((h, w)) < 0.3
    known[rng.integers(h), rng.integers(w)] = True
    levels = rng.integers(0, 2**16 + 1, (h, w)) * 2.0**-16
    edges = rng.random((h, w)) < 0.2
    pad = max(n // 2 + 1, 2)
    front = FillFront(known, np.where(known, levels, 0.0), edges, n, pad, rng,
                      use_edges=use_edges, use_isophotes=use_iso, edges_last=edges_last)
    steps = 0
    while True:
        want = _fresh_choice(front)
        got = front.pop()
        assert got == want
        if got < 0:
            break
        r, c = divmod(got, front.shape[1])
        value = levels[r - pad, c - pad]
        confidence = np.rint(rng.random() * 2.0**40) * 2.0**-40
        front.fill(got, value, confidence)
        steps += 1
    assert steps == int((~known).sum())


def test_pop_tightens_a_loose_bound_before_trusting_it():
    """A block whose best key was lowered keeps a loose bound; pop must not take that
    block's new best over a higher key elsewhere, nor report the queue empty early."""
    queue = FrontQueue(np.arange(32), block=8)
    queue.set_in_blocks(np.array([1, 20]), np.array([0, 2]), encode_keys(np.array([3.0, 2.0])))
    queue.set_in_blocks(np.array([1, 2]), np.array([0, 0]),
                        np.array([ABSENT, encode_keys(np.array([1.0]))[0]]))
    assert queue.pop() == 20  # block 0's bound is still 3.0's key
    assert queue.retries == 1
    assert queue.pop() == 2
    queue.set_in_blocks(np.array([9]), np.array([1]), encode_keys(np.array([5.0])))
    queue.set_in_blocks(np.array([9]), np.array([1]), np.array([ABSENT]))
    assert queue.pop() == -1
