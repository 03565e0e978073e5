"""The lower bound on Eq. 2's intensity term that NP's shortlist prunes by (window_bound)."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from refsynth.numeric import EQ2_UNIT, window_weights
from refsynth.synthesis.filltable import FillTable
from refsynth.synthesis.window_bound import (
    PARTS,
    SLACK,
    bound_rows,
    bound_weights,
    expanded_lower_bounds,
    lower_bounds,
    margin,
    part_sums,
    part_sums_matrix,
    pinwheel_parts,
)

#: Tests of a fast kernel's internals (``-m kernel`` selects them).
pytestmark = pytest.mark.kernel


@pytest.mark.parametrize("n", [1, 3, 5, 7, 9])
def test_the_pinwheel_cuts_the_window_into_five_parts_once(n):
    parts = pinwheel_parts(n)
    h = n // 2
    assert parts[h, h] == 0 and np.count_nonzero(parts == 0) == 1
    if n > 1:
        assert [int(np.count_nonzero(parts == p)) for p in range(1, PARTS)] == [h * (h + 1)] * 4
    # four-fold rotational symmetry: a quarter turn (anticlockwise) puts part 2 where 1 was,
    # 4 where 2 was, 3 where 4 was and 1 where 3 was
    assert np.array_equal(np.rot90(parts), np.array([0, 2, 4, 1, 3])[parts])


@given(st.sampled_from([1, 3, 5, 7]), st.sampled_from([1, 3]), st.integers(0, 2**32 - 1))
def test_part_sums_are_the_weighted_sums_of_each_part_and_channel(n, channels, seed):
    rng = np.random.default_rng(seed)
    levels = rng.integers(0, 2**16 + 1, (n, n, channels))
    g, parts = window_weights(n), pinwheel_parts(n)
    expected = [int((g[parts == p][:, None] * levels[parts == p]).sum(axis=0)[c])
                for p in range(PARTS) for c in range(channels)]
    got = levels.reshape(-1).astype(np.float64) @ part_sums_matrix(n, channels)
    assert got.tolist() == [float(v) for v in expected]  # exact


@given(st.sampled_from([1, 3, 5, 7]), st.sampled_from([1, 3]), st.integers(0, 2**32 - 1))
def test_part_sums_by_reduceat_are_the_matrix_product(n, channels, seed):
    """FillTable builds the sums by part_sums (on its thread): exactly the product with
    part_sums_matrix, in every part and channel."""
    levels = np.random.default_rng(seed).integers(0, 2**16 + 1, (7, n * n * channels))
    levels = levels.astype(np.float64)
    assert np.array_equal(part_sums(levels, n, channels), levels @ part_sums_matrix(n, channels))


def _exact_intensity_term(a, b, n):
    """Σ_v G_v Σ_c (a − b)² in Python integers, times EQ2_UNIT (exact: a power of two)."""
    g = window_weights(n).ravel().tolist()
    d = (a.reshape(n * n, -1).astype(object) - b.reshape(n * n, -1).astype(object))
    return Fraction(sum(gv * int((dv * dv).sum()) for gv, dv in zip(g, d, strict=True))) * \
        Fraction(EQ2_UNIT)


@given(
    st.sampled_from([1, 3, 5, 7]),
    st.sampled_from([1, 3]),
    st.sampled_from([1, 3]),  # the channel divisor: their sum, or their mean
    st.integers(0, 2**32 - 1),
    st.sampled_from(["wide", "coarse", "near"]),
)
def test_the_bound_never_exceeds_the_intensity_term(n, channels, divisor, seed, kind):
    """L_q <= t_q exactly (Cauchy–Schwarz, in rationals), the computed L_q within the
    margin of it, and the expansion the shortlist uses within the margin too."""
    if divisor > channels:
        divisor = channels
    rng = np.random.default_rng(seed)
    size = (6, n, n, channels)
    if kind == "wide":
        levels = rng.integers(0, 2**16 + 1, size)
    elif kind == "coarse":
        levels = rng.choice([0, 1, 2**15, 2**16], size)
    else:  # windows one level apart: bounds near 0 against large sums
        levels = 2**16 - rng.integers(0, 2, size)
    flat = levels.reshape(6, -1).astype(np.float64)
    sums = flat @ part_sums_matrix(n, channels)
    w = bound_weights(n, channels, divisor)
    rows = bound_rows(sums, w)
    computed = lower_bounds(sums[0], sums, w)
    fast = expanded_lower_bounds(rows[0], rows, w) + rows[0, -1]
    g = window_weights(n).ravel()
    parts = pinwheel_parts(n).ravel()
    for q in range(6):
        t = _exact_intensity_term(levels[0], levels[q], n) / divisor
        exact_bound = sum(
            (Fraction(int(sums[0, p * channels + c]) - int(sums[q, p * channels + c])) ** 2
             / int(g[parts == p].sum()))
            for p in range(PARTS) for c in range(channels)
            if g[parts == p].sum() > 0) * Fraction(EQ2_UNIT) / divisor
        assert exact_bound <= t
        limit = SLACK * t + margin(rows)
        assert Fraction(float(computed[q])) <= exact_bound + limit
        assert Fraction(float(fast[q])) <= exact_bound + limit
        assert abs(Fraction(float(fast[q])) - exact_bound) <= margin(rows)


@given(
    st.integers(3, 9),
    st.integers(3, 9),
    st.sampled_from([1, 3]),
    st.sampled_from([1, 3, 5]),
    st.sampled_from(["sum", "mean"]),
    st.sampled_from([1.0, 1.1, 2.0]),
    st.integers(0, 2**32 - 1),
    st.sampled_from(["coarse", "flat", "smooth"]),
)
def test_the_pruned_shortlist_is_the_unpruned_one(h, w, channels, n, mean_or_sum, scale, seed,
                                                  kind):
    """float64 rows (the bound prunes) and float32 rows (no bound) keep the same candidates'
    distances and the same best match and Eq. 5 set, on images with many equal windows
    (coarse levels; a flat image, where every bound is 0) and on smooth ones."""
    rng = np.random.default_rng(seed)
    if kind == "coarse":
        image = rng.choice([0, 1, 2**15, 2**16], (h, w, channels)) * 2.0**-16
    elif kind == "flat":
        image = np.full((h, w, channels), 1.0)
    else:
        image = (np.linspace(0, 1, w)[None, :, None] * np.ones((h, 1, channels))
                 + rng.integers(0, 3, (h, w, channels)) * 2.0**-16) / 2
    known = rng.random((h, w)) < 0.5
    known.flat[0] = True
    values = np.where(known, rng.random((h, w)), np.nan)
    pad = n // 2 + 1
    pruned = FillTable(image, values, n, pad, 1.0, channels=mean_or_sum, dtype=np.float64)
    plain = FillTable(image, values, n, pad, 1.0, channels=mean_or_sum, dtype=np.float32)
    assert pruned.bound_rows is not None and plain.bound_rows is None
    wp = w + 2 * pad
    inside = ((np.arange(h)[:, None] + pad) * wp + np.arange(w)[None, :] + pad).ravel()
    for p in rng.choice(inside, min(4, inside.size), replace=False):
        candidates = rng.permutation(inside)[: max(1, inside.size // 2)]
        every = plain.distances(int(p), candidates)
        members = set(candidates[every <= scale * every.min()].tolist())
        kept, d = pruned.shortlist(int(p), candidates, scale)
        kept_plain, d_plain = plain.shortlist(int(p), candidates, scale)
        position = np.flatnonzero(np.isin(candidates, kept))
        assert np.array_equal(candidates[position], kept)
        assert np.array_equal(d, every[position])  # the same bits
        assert members <= set(kept.tolist())
        assert int(kept[int(d.argmin())]) == int(kept_plain[int(d_plain.argmin())])
        assert set(kept[d <= scale * d.min()].tolist()) == members


def test_the_bound_rows_come_with_float64_intensity_rows_only():
    image, values = np.zeros((4, 5, 3)), np.full((4, 5), np.nan)
    values[0, 0] = 1.0
    wide = FillTable(image, values, 3, 2, 1.0, dtype=np.float64)
    assert wide.bound_rows.shape == (8 * 9, PARTS * 3 + 1)
    assert FillTable(image, values, 3, 2, 1.0, dtype=np.float32).bound_rows is None
