"""Hypothesis strategies shared by the tests, biased toward small, simple cases."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

UNIT = st.floats(0.0, 1.0, allow_nan=False, width=64)


@st.composite
def partial_neighbourhood(draw, n: int | None = None, channels: int | None = None):
    """An n×n neighbourhood: intensity (n, n, C) in [0, 1] and range (n, n), NaN = unknown."""
    n = draw(st.sampled_from([1, 3, 5])) if n is None else n
    c = draw(st.sampled_from([1, 3])) if channels is None else channels
    intensity = draw(hnp.arrays(np.float64, (n, n, c), elements=UNIT))
    values = draw(hnp.arrays(np.float64, (n, n), elements=UNIT))
    known = draw(hnp.arrays(np.bool_, (n, n)))
    return intensity, np.where(known, values, np.nan)


@st.composite
def neighbourhood_pair(draw):
    """Two partial neighbourhoods of the same size and channel count."""
    n = draw(st.sampled_from([1, 3, 5]))
    c = draw(st.sampled_from([1, 3]))
    return draw(partial_neighbourhood(n, c)), draw(partial_neighbourhood(n, c))


@st.composite
def small_scene(draw, min_side: int = 6, max_side: int = 14):
    """A tiny grey image, a range image and a known mask with at least one known pixel."""
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    image = draw(hnp.arrays(np.float64, (h, w), elements=UNIT))
    truth = draw(hnp.arrays(np.float64, (h, w), elements=st.floats(1.0, 5.0, width=64)))
    known = draw(hnp.arrays(np.bool_, (h, w), elements=st.booleans()))
    known[draw(st.integers(0, h - 1)), draw(st.integers(0, w - 1))] = True
    if known.all():
        known[0, 0] = False
        known[-1, -1] = True
    return image, truth, known
