"""NP's narrow Eq. 2 table: the same distances as PatchTable, bit for bit."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from refsynth.numeric import EQ2_UNIT
from refsynth.synthesis.filltable import FillTable
from refsynth.synthesis.patch_table import PatchTable

#: Tests of a fast kernel's internals (``-m kernel`` selects them).
pytestmark = pytest.mark.kernel


@given(
    st.integers(3, 9),
    st.integers(3, 9),
    st.sampled_from([1, 3]),
    st.sampled_from([1, 3, 5]),
    st.sampled_from(["mean", "ignore"]),
    st.sampled_from([0.0, 1.0, 16.0, 0.3]),
    st.integers(0, 2**32 - 1),
    st.sampled_from([np.float32, np.float64]),  # the intensity rows (intensity_dtype)
)
def test_fill_table_matches_patch_table_through_fills(h, w, channels, n, missing, lam, seed,
                                                      dtype):
    """Intensity and range on the 2**-16 grid, extremes included (0 and 2**16, whose R²
    float32 cannot hold: it is squared per step in float64); after every set_range the two
    tables agree on every target and candidate."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2**16 + 1, (h, w, channels)).astype(np.float64)
    image.flat[0], image.flat[-1] = 0.0, 2.0**16
    image *= 2.0**-16
    known = rng.random((h, w)) < 0.5
    known.flat[0] = True
    values = rng.choice([0, 1, 2**15 + 1, 2**16 - 1, 2**16], (h, w)) * 2.0**-16
    range_norm = np.where(known, values, np.nan)
    pad = n // 2 + 1
    fast = FillTable(image, range_norm, n, pad, lam, missing, dtype=dtype)
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


@given(
    st.integers(1, 7),
    st.integers(1, 7),
    st.sampled_from([1, 3]),
    st.sampled_from([1, 3, 5]),
    st.integers(0, 2),
    st.integers(0, 2**32 - 1),
    st.sampled_from([np.float32, np.float64]),  # the intensity rows (intensity_dtype)
)
def test_set_range_writes_the_rows_a_fresh_table_holds(h, w, channels, n, extra_pad, seed,
                                                       dtype):
    """set_range: after synthesizing some pixels (border pixels included,
    whose windows reach into the padding), every row of the image equals, bit for bit, that
    of a table built afresh with those pixels' range known (every column: R and V, and
    nothing else touched; R² is not stored). The padding's rows are never read (they are
    neither targets nor candidates) and a fresh table leaves them blank."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2**16 + 1, (h, w, channels)) * 2.0**-16
    known = rng.random((h, w)) < 0.4
    values = rng.choice([0, 1, 3, 2**15 + 1, 2**16 - 1, 2**16], (h, w)) * 2.0**-16
    pad = n // 2 + extra_pad
    fast = FillTable(image, np.where(known, values, np.nan), n, pad, 1.0, dtype=dtype)
    now = known.copy()
    wp = w + 2 * pad
    inside = ((np.arange(h)[:, None] + pad) * wp + np.arange(w)[None, :] + pad).ravel()
    for flat in rng.permutation(np.flatnonzero(~known.ravel())):
        r, c = divmod(int(flat), w)
        fast.set_range((r + pad) * wp + c + pad, float(values[r, c]))
        now[r, c] = True
        fresh = FillTable(image, np.where(now, values, np.nan), n, pad, 1.0, dtype=dtype)
        assert np.array_equal(fast.table[inside], fresh.table[inside])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_distances_are_exact_on_the_largest_sums(dtype):
    """The products' sums are exact (so any BLAS order gives the same bits) on the largest
    sums the contract allows (every level 2**16 against 0, full range against none)."""
    rng = np.random.default_rng(1)
    image = np.where(rng.random((9, 9, 3)) < 0.5, 1.0, 0.0)
    range_norm = np.where(rng.random((9, 9)) < 0.6, rng.choice([0.0, 1.0], (9, 9)), np.nan)
    fast = FillTable(image, range_norm, 5, 3, 1.0, dtype=dtype)
    wide = PatchTable(image, range_norm, 5, 3, 1.0)
    inside = ((np.arange(9)[:, None] + 3) * 15 + np.arange(9)[None, :] + 3).ravel()
    for p in inside:
        assert np.array_equal(fast.distances(int(p), inside), wide.distances(int(p), inside))


@given(
    st.integers(3, 9),
    st.integers(3, 9),
    st.sampled_from([1, 3, 5, 7]),
    st.sampled_from([0.0, 0.5, 1.0]),
    st.integers(0, 2**32 - 1),
    st.sampled_from([np.float32, np.float64]),  # the intensity rows (intensity_dtype)
)
def test_offset_shift_from_the_gathered_rows_is_range_copys(h, w, n, known_share, seed, dtype):
    """FillTable.offset_shift (NP's hot path, from the rows distances() gathered) gives
    range_copy.offset_shift's integer for every candidate: planes at any depth (the shift
    taken), differences on both sides of the agreement test's bound (2**9 steps), ties of
    the rounding (half-integer means), windows off the image and empty shared supports,
    and after set_range has written synthesized pixels."""
    from refsynth.numeric import window_weights
    from refsynth.synthesis.neighbourhood import window_offsets
    from refsynth.synthesis.range_copy import offset_shift

    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2**16 + 1, (h, w, 1)) * 2.0**-16
    rows, cols = np.mgrid[:h, :w]
    plane = 2000 + 37 * rows + int(rng.integers(-300, 300)) * cols
    bump = rng.choice([0, 0, 1, 511, 512, 513, -512, 20000], (h, w))
    q = np.clip(plane + bump * (rng.random((h, w)) < 0.3), 0, 2**16)
    known = rng.random((h, w)) < known_share if known_share < 1 else np.ones((h, w), bool)
    known.flat[int(rng.integers(h * w))] = False  # one target at least
    pad = max(n // 2 + 1, 2)
    table = FillTable(image, np.where(known, q * 2.0**-16, np.nan), n, pad, 1.0, dtype=dtype)
    wp = w + 2 * pad
    frame = np.full((h + 2 * pad, wp), -1.0)
    frame[pad:-pad, pad:-pad] = np.where(known, q, -1.0)
    # a few synthesized pixels, written as NP writes them
    for flat in rng.permutation(np.flatnonzero(~known.ravel()))[1:3]:
        r, c = divmod(int(flat), w)
        table.set_range((r + pad) * wp + c + pad, float(q[r, c]) * 2.0**-16)
        frame[r + pad, c + pad] = q[r, c]
    wr, wc = window_offsets(n)
    window = wr * wp + wc
    g = window_weights(n).ravel().astype(np.float64)
    flat_frame = frame.ravel()
    inside = ((rows + pad) * wp + cols + pad).ravel()
    targets = inside[flat_frame[inside] < 0]
    for p in rng.choice(targets, min(3, targets.size), replace=False):
        candidates = inside[flat_frame[inside] >= 0]
        if candidates.size == 0:
            continue
        table.distances(int(p), candidates)
        for j, cand in enumerate(candidates):
            tp, tq = flat_frame[window + p], flat_frame[window + cand]
            want = offset_shift(np.maximum(tp, 0), np.maximum(tq, 0), tp >= 0, tq >= 0, g)
            assert table.offset_shift(j) == want, (int(p), int(cand))


@pytest.mark.parametrize("chunk", [1, 7, 1 << 20])
def test_the_table_does_not_depend_on_its_build_blocks(chunk, monkeypatch):
    """FillTable is built in blocks of about _CHUNK_PIXELS pixels (whole rows, temporaries
    that stay in cache): one row at a time, a few rows, or the whole image at once give
    the same table, bit for bit."""
    from refsynth.synthesis import filltable

    rng = np.random.default_rng(3)
    image = rng.integers(0, 2**16 + 1, (11, 13, 3)) * 2.0**-16
    values = rng.integers(0, 2**16 + 1, (11, 13)) * 2.0**-16
    range_norm = np.where(rng.random((11, 13)) < 0.5, values, np.nan)
    want = FillTable(image, range_norm, 5, 3, 1.0)
    monkeypatch.setattr(filltable, "_CHUNK_PIXELS", chunk)
    got = FillTable(image, range_norm, 5, 3, 1.0)
    assert np.array_equal(got.table, want.table)
    assert np.array_equal(got.self_unit, want.self_unit)


@given(
    st.integers(3, 9),
    st.integers(3, 9),
    st.sampled_from([1, 3]),
    st.sampled_from([1, 3, 5]),
    st.sampled_from(["mean", "ignore"]),
    st.sampled_from([0.0, 1.0, 16.0, 0.3]),
    st.sampled_from([1.0, 1.1, 2.0]),
    st.integers(0, 2**32 - 1),
    st.sampled_from([np.float32, np.float64]),  # the intensity rows (intensity_dtype)
)
def test_shortlist_keeps_eq4_and_eq5_with_the_same_distances(h, w, channels, n, missing, lam,
                                                             scale, seed, dtype):
    """FillTable.shortlist (NP's hot path) keeps, in order, every candidate whose Eq. 2 is
    within ``scale`` of the best (the best included), with distances bit for bit those of
    distances(); and offset_shift reads the kept candidates' rows. Coarse intensity levels
    make ties and equal intensity terms common."""
    rng = np.random.default_rng(seed)
    image = rng.choice([0, 1, 2**15, 2**16], (h, w, channels)) * 2.0**-16
    known = rng.random((h, w)) < 0.5
    known.flat[0] = True
    values = rng.choice([0, 1, 2**15 + 1, 2**16], (h, w)) * 2.0**-16
    pad = n // 2 + 1
    table = FillTable(image, np.where(known, values, np.nan), n, pad, lam, missing, dtype=dtype)
    wp = w + 2 * pad
    inside = ((np.arange(h)[:, None] + pad) * wp + np.arange(w)[None, :] + pad).ravel()
    for p in rng.choice(inside, min(4, inside.size), replace=False):
        candidates = rng.permutation(inside)[: max(1, inside.size // 2)]
        every = table.distances(int(p), candidates)
        shifts = [table.offset_shift(j) for j in range(candidates.size)]
        members = np.flatnonzero(every <= scale * every[int(every.argmin())])
        kept, d = table.shortlist(int(p), candidates, scale)
        position = np.flatnonzero(np.isin(candidates, kept))
        assert np.array_equal(candidates[position], kept)  # in the candidates' order
        assert np.array_equal(d, every[position])
        assert set(members) <= set(position.tolist())
        assert int(position[int(d.argmin())]) == int(every.argmin())
        assert [table.offset_shift(j) for j in range(kept.size)] == [shifts[i] for i in position]


@given(
    st.integers(4, 9),
    st.integers(4, 9),
    st.sampled_from([1, 3]),
    st.sampled_from([3, 5]),
    st.sampled_from(["mean", "ignore"]),
    st.sampled_from([1.0, 16.0, 0.3]),
    st.integers(0, 2**32 - 1),
    st.sampled_from([np.float32, np.float64]),  # the intensity rows (intensity_dtype)
)
def test_shortlist_of_one_returns_the_bounds_distance_and_its_shift(h, w, channels, n, missing,
                                                                    lam, seed, dtype):
    """Fine random levels make a lone survivor common (about half of NP's steps on real
    images): the shortlist then returns the distance it computed for the bound, without
    the batched product, and offset_shift reads that candidate's row and sums. Both must be
    distances()'s and the shift from distances()'s rows, bit for bit; and after a lone
    survivor a longer shortlist must not read stale sums."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2**16 + 1, (h, w, channels)) * 2.0**-16
    known = rng.random((h, w)) < 0.6
    known.flat[0] = True
    values = rng.integers(0, 2**16 + 1, (h, w)) * 2.0**-16
    pad = n // 2 + 1
    table = FillTable(image, np.where(known, values, np.nan), n, pad, lam, missing, dtype=dtype)
    wp = w + 2 * pad
    inside = ((np.arange(h)[:, None] + pad) * wp + np.arange(w)[None, :] + pad).ravel()
    for p in rng.choice(inside, min(6, inside.size), replace=False):
        for scale in (1.0 + 2.0**-30, 1.5):  # a lone survivor, then (often) several
            candidates = rng.permutation(inside)[: max(2, inside.size // 2)]
            every = table.distances(int(p), candidates)
            shifts = [table.offset_shift(j) for j in range(candidates.size)]
            kept, d = table.shortlist(int(p), candidates, scale)
            position = np.flatnonzero(np.isin(candidates, kept))
            assert np.array_equal(d, every[position])
            assert [table.offset_shift(j) for j in range(kept.size)] == [shifts[i]
                                                                         for i in position]


def test_a_lone_survivor_happens_and_is_the_best_match():
    """The one-candidate path is taken (not only the general one) on a textured image."""
    rng = np.random.default_rng(3)
    image = rng.integers(0, 2**16 + 1, (9, 9, 3)) * 2.0**-16
    known = rng.random((9, 9)) < 0.6
    table = FillTable(image, np.where(known, rng.random((9, 9)), np.nan), 5, 3, 1.0)
    inside = ((np.arange(9)[:, None] + 3) * 15 + np.arange(9)[None, :] + 3).ravel()
    lone = 0
    for p in inside:
        kept, d = table.shortlist(int(p), inside, 1.01)
        every = table.distances(int(p), inside)
        if kept.size == 1:
            lone += 1
            assert int(kept[0]) == int(inside[int(every.argmin())])
            assert d[0] == every.min()
    assert lone >= 10


def test_intensity_rows_dtype_by_their_size(monkeypatch):
    """float64 intensity rows up to WIDE_TABLE_BYTES (as float64), float32 above (the range
    rows are float32 either way); the build's parts of the self term sum to it in both."""
    from refsynth.synthesis import filltable

    rng = np.random.default_rng(5)
    image = rng.integers(0, 2**16 + 1, (6, 7, 3)) * 2.0**-16
    range_norm = np.where(rng.random((6, 7)) < 0.5, 0.25, np.nan)
    pixels = (6 + 6) * (7 + 6)
    monkeypatch.setattr(filltable, "WIDE_TABLE_BYTES", pixels * (25 * 3 + 4) * 8)
    wide = FillTable(image, range_norm, 5, 3, 1.0)
    assert wide.intensity.dtype == np.float64 and wide.ranges.dtype == np.float32
    monkeypatch.setattr(filltable, "WIDE_TABLE_BYTES", pixels * (25 * 3 + 4) * 8 - 1)
    narrow = FillTable(image, range_norm, 5, 3, 1.0)
    assert narrow.intensity.dtype == narrow.ranges.dtype == np.float32
    assert np.array_equal(narrow.table.astype(np.float64)[:, :75], wide.table[:, :75])
    parts = slice(75, 78)
    assert np.array_equal(narrow.table[:, parts].astype(np.float64).sum(axis=1),
                          wide.table[:, parts].sum(axis=1))
    assert np.array_equal(wide.table[:, parts].sum(axis=1), wide.self_unit / EQ2_UNIT)


@pytest.mark.parametrize("options", [{}, {"colour": False, "missing_range": "ignore"},
                                     {"range_weight": 16.0, "range_copy": "value"}])
def test_np_gives_the_same_bits_with_either_rows(options, monkeypatch):
    """The whole fill (range, confidence, order) with float32 intensity rows is that with
    float64."""
    import refsynth
    from refsynth.synthesis import filltable

    rng = np.random.default_rng(8)
    image = rng.random((24, 30, 3))
    partial = np.where(np.arange(30) % 3 == 0, 1.0 + rng.random((24, 30)), np.nan)
    wide = refsynth.synthesize(image, partial, method="np", seed=2, readings=options)
    monkeypatch.setattr(filltable, "WIDE_TABLE_BYTES", 0)
    narrow = refsynth.synthesize(image, partial, method="np", seed=2, readings=options)
    for field in ("range", "confidence", "order"):
        assert np.array_equal(getattr(wide, field), getattr(narrow, field)), field
