"""NP's per-step paths: the queue's keys are Eq. 10 afresh, bit for bit."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from refsynth.synthesis.frontqueue import ABSENT, encode_keys
from refsynth.synthesis.priority import FillFront

#: Tests of a fast kernel's internals (``-m kernel`` selects them).
pytestmark = pytest.mark.kernel


@given(
    st.integers(4, 10),
    st.integers(4, 10),
    st.sampled_from([1, 3, 5, 7]),
    st.booleans(),
    st.booleans(),
    st.integers(0, 2**32 - 1),
)
def test_queued_keys_are_the_full_frame_priorities_after_every_fill(h, w, n, use_edges,
                                                                   use_iso, seed):
    """After every fill, each front voxel's key in the queue is the key of
    :meth:`FillFront.priorities` (Eq. 10 over the whole frame, from the running sums)
    and every other voxel's key is ``ABSENT``: the per-step Eq. 10 on the changed
    block (field-major buffers, one product for ``g · m`` and ``m²``) is the
    full-frame one, bit for bit."""
    rng = np.random.default_rng(seed)
    draws = rng.random((3, h, w))
    known = draws[0] < 0.3
    known.flat[seed % known.size] = True
    levels = np.rint(draws[1] * 2**16) * 2.0**-16  # on the contract's range grid
    pad = max(n // 2 + 1, 2)
    front = FillFront(known, np.where(known, levels, 0.0), draws[2] < 0.2, n, pad, rng,
                      use_edges=use_edges, use_isophotes=use_iso)
    queue = front.queue
    while True:
        p = front.priorities()
        on = np.isfinite(p).ravel()
        want = np.full(p.size, ABSENT, dtype=np.int64)
        want[on] = encode_keys(p.ravel()[on], front.tier.ravel()[on])
        assert np.array_equal(queue.keys[queue.rank], want)
        got = front.pop()
        if got < 0:
            break
        r, c = divmod(got, front.shape[1])
        confidence = np.rint(rng.random() * 2.0**40) * 2.0**-40
        front.fill(got, levels[r - pad, c - pad], confidence)
