"""NP's narrow Eq. 2 table (issue #15): the same distances as PatchTable, bit for bit."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from refsynth.synthesis.filltable import FillTable
from refsynth.synthesis.similarity import PatchTable


@given(
    st.integers(3, 9),
    st.integers(3, 9),
    st.sampled_from([1, 3]),
    st.sampled_from([1, 3, 5]),
    st.sampled_from(["mean", "ignore"]),
    st.sampled_from([0.0, 1.0, 16.0, 0.3]),
    st.integers(0, 2**32 - 1),
)
def test_fill_table_matches_patch_table_through_fills(h, w, channels, n, missing, lam, seed):
    """Intensity and range on the 2**-16 grid, extremes included (0 and 2**16, where R²
    needs both float32 parts); after every set_range the two tables agree on every
    target and candidate."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2**16 + 1, (h, w, channels)).astype(np.float64)
    image.flat[0], image.flat[-1] = 0.0, 2.0**16
    image *= 2.0**-16
    known = rng.random((h, w)) < 0.5
    known.flat[0] = True
    values = rng.choice([0, 1, 2**15 + 1, 2**16 - 1, 2**16], (h, w)) * 2.0**-16
    range_norm = np.where(known, values, np.nan)
    pad = n // 2 + 1
    fast = FillTable(image, range_norm, n, pad, lam, missing)
    wide = PatchTable(image, range_norm, n, pad, lam, missing)
    wp = w + 2 * pad
    inside = ((np.arange(h)[:, None] + pad) * wp + np.arange(w)[None, :] + pad).ravel()
    order = rng.permutation(np.flatnonzero(~known.ravel()))[:4]
    for step in range(order.size + 1):
        for p in rng.choice(inside, min(4, inside.size), replace=False):
            got = fast.distances(int(p), inside)
            want = wide.distances(int(p), inside)
            assert np.array_equal(got, want)
        if step < order.size:
            r, c = divmod(int(order[step]), w)
            value = float(rng.choice([0, 3, 2**16 - 3, 2**16])) * 2.0**-16
            fast.set_range((r + pad) * wp + c + pad, value)
            wide.set_range((r + pad) * wp + c + pad, value)
