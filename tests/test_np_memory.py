"""NP's memory estimate: what ``synthesize(method="np")`` allocates.

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


@pytest.mark.parametrize("side", [200, 1600])  # float64 intensity rows, float32
def test_np_memory_grows_with_the_frame_and_the_window(side):
    small = np_memory((side, side), 3, 5, 10.0)
    # the padded frame grows 3.6 times (200 -> 400) or 3.9 (1600 -> 3200), past a fixed part
    # (one block of the build's temporaries); without it, each doubling costs about 4 times
    # the last
    middle, large = np_memory((2 * side, 2 * side), 3, 5, 10.0), np_memory(
        (4 * side, 4 * side), 3, 5, 10.0)
    assert middle > 3.4 * small
    assert large - middle > 3.8 * (middle - small)
    assert np_memory((side, side), 3, 7, 10.0) > small
    assert np_memory((side, side), 1, 5, 10.0) < small
    assert np_memory((side, side), 3, 5, 20.0) > small  # a wider padding


def test_np_memory_counts_the_rows_dtype(monkeypatch):
    """Float64 intensity rows up to WIDE_TABLE_BYTES: they take twice the bytes."""
    from refsynth.synthesis import filltable

    rows = (375 + 20) * (450 + 20)
    wide = np_memory((375, 450), 3, 5, 10.0)
    monkeypatch.setattr(filltable, "WIDE_TABLE_BYTES", 0)
    narrow = np_memory((375, 450), 3, 5, 10.0)
    assert wide - narrow == rows * 4 * (25 * 3 + 4)


@pytest.mark.parametrize("wide", [True, False])
def test_np_memory_bounds_the_traced_peak_with_either_rows(wide, monkeypatch):
    from refsynth.synthesis import filltable

    if not wide:
        monkeypatch.setattr(filltable, "WIDE_TABLE_BYTES", 0)
    rng = np.random.default_rng(4)
    shape = (40, 56)
    image = rng.random(shape + (3,))
    partial = np.where(np.arange(shape[1]) % 4 == 0, rng.random(shape), np.nan)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        refsynth.synthesize(image, partial, method="np", seed=0, neighbourhood=5)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    estimate = np_memory(shape, 3, 5, 10.0)
    assert peak <= estimate <= 1.5 * peak, (peak, estimate)


def test_np_frees_its_table_and_front_by_reference_counting(monkeypatch):
    """NP's table (most of its memory) and its fill front are freed when the fill returns,
    with the garbage collector off: no reference cycle holds them. BP's default runs NP
    first, and a cycle through a step closure (a closure holding the
    table) would keep it alive through BP's own stage: BP's peak at 900×750 would rise
    from 820 MB to 1335 MB."""
    import gc
    import importlib
    import weakref

    from refsynth.synthesis.filltable import FillTable

    front_class = importlib.import_module("refsynth.synthesis.priority").FillFront
    made = []
    for cls in (FillTable, front_class):
        def recorded(self, *args, _init=cls.__init__, **kwargs):
            _init(self, *args, **kwargs)
            made.append(weakref.ref(self))

        monkeypatch.setattr(cls, "__init__", recorded)
    rng = np.random.default_rng(5)
    image = rng.random((24, 30, 3))
    partial = np.where(np.arange(30) % 3 == 0, rng.random((24, 30)), np.nan)
    enabled = gc.isenabled()
    gc.disable()
    try:
        refsynth.synthesize(image, partial, method="np", seed=0)
        alive = [ref for ref in made if ref() is not None]
    finally:
        if enabled:
            gc.enable()
    assert len(made) == 2 and alive == []
