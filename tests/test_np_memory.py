"""NP's memory estimate (issue #15, item 3): what ``synthesize(method="np")`` allocates.

``limits.np_memory`` decides whether NP is refused before any work, so it must not
undercount what the fill allocates, nor overcount it so far that runs which fit are refused.
numpy reports its buffers to :mod:`tracemalloc`, so the peak of a run is measurable here
without reading the process's resident memory (which other tests move).
"""

import tracemalloc

import numpy as np
import pytest

import refsynth
from refsynth.synthesis.limits import np_memory


@pytest.mark.parametrize(("shape", "channels", "neighbourhood", "radius"), [
    ((40, 56), 3, 5, 10.0),
    ((48, 30), 1, 3, 4.0),
    ((36, 44), 3, 7, 6.0),
])
def test_np_memory_bounds_the_traced_peak(shape, channels, neighbourhood, radius):
    rng = np.random.default_rng(3)
    image = rng.random(shape + (channels,))
    partial = np.where(np.arange(shape[1]) % 4 == 0, rng.random(shape), np.nan)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        refsynth.synthesize(image, partial, method="np", neighbourhood=neighbourhood,
                            radius=radius, seed=0)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    estimate = np_memory(shape, channels, neighbourhood, radius)
    assert peak <= estimate <= 1.5 * peak, (peak, estimate)


def test_np_memory_grows_with_the_frame_and_the_window():
    small = np_memory((400, 400), 3, 5, 10.0)
    assert np_memory((800, 800), 3, 5, 10.0) > 3.5 * small  # per pixel, past the fixed part
    assert np_memory((400, 400), 3, 7, 10.0) > small
    assert np_memory((400, 400), 1, 5, 10.0) < small
    assert np_memory((400, 400), 3, 5, 20.0) > small  # a wider padding
