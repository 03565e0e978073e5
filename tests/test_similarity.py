"""Eq. 2 (§3.2.2): the distance between partial neighbourhoods, and the MRF window."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from strategies import UNIT, neighbourhood_pair, partial_neighbourhood

from refsynth.numeric import NO_RANGE, window_weights
from refsynth.synthesis.filltable import FillTable
from refsynth.synthesis.neighbourhood import (
    disc_offsets,
    gaussian_window,
    intensity_patches,
    range_patches,
)
from refsynth.synthesis.patch_table import PatchTable
from refsynth.synthesis.similarity import eq2_distance, neighbourhood_distance, range_scale

EPS = np.finfo(np.float64).eps


@given(neighbourhood_pair(), st.floats(0.0, 10.0))
def test_eq2_is_symmetric(pair, lam):
    (ia, ra), (ib, rb) = pair
    assert neighbourhood_distance(ia, ra, ib, rb, range_weight=lam) == neighbourhood_distance(
        ib, rb, ia, ra, range_weight=lam
    )


@given(partial_neighbourhood(), st.floats(0.0, 10.0))
def test_eq2_zero_for_identical_neighbourhoods(nb, lam):
    intensity, rng = nb
    assert neighbourhood_distance(intensity, rng, intensity, rng, range_weight=lam) == 0.0


@given(neighbourhood_pair())
def test_eq2_is_non_negative(pair):
    (ia, ra), (ib, rb) = pair
    assert neighbourhood_distance(ia, ra, ib, rb) >= 0.0


@given(neighbourhood_pair(), UNIT)
def test_eq2_ignores_range_outside_the_shared_support(pair, junk):
    """Changing range where the other neighbourhood has none leaves Eq. 2 unchanged."""
    (ia, ra), (ib, rb) = pair
    only_a = np.isfinite(ra) & ~np.isfinite(rb)
    assume(only_a.any())
    ra2 = ra.copy()
    ra2[only_a] = junk
    assert neighbourhood_distance(ia, ra, ib, rb) == neighbourhood_distance(ia, ra2, ib, rb)


@given(neighbourhood_pair())
def test_eq2_range_term_vanishes_without_shared_range(pair):
    (ia, ra), (ib, rb) = pair
    rb = np.where(np.isfinite(ra), np.nan, rb)
    d0 = neighbourhood_distance(ia, ra, ib, rb, range_weight=0.0)
    d9 = neighbourhood_distance(ia, ra, ib, rb, range_weight=9.0)
    assert d0 == d9


def test_eq2_hand_computed_case():
    """3×3 grey, one differing intensity at the centre and one range pair at a corner, on
    the grid (0.25, 0.5, 0.75 are multiples of 2**-16): the sums are exact, one rounding."""
    w = window_weights(3)
    ia = np.zeros((3, 3))
    ib = np.zeros((3, 3))
    ib[1, 1] = 0.5
    ra = np.full((3, 3), np.nan)
    rb = np.full((3, 3), np.nan)
    ra[0, 0], rb[0, 0] = 0.25, 0.75
    ra[2, 2] = 0.9  # only in a: ignored
    expected = float(Fraction(int(w[1, 1]) + 4 * int(w[0, 0]), 2**20))   # ΔI² = ΔR² = 1/4
    assert neighbourhood_distance(ia, ra, ib, rb, range_weight=4.0) == expected
    assert expected == pytest.approx(0.25 * (w[1, 1] + 4 * w[0, 0]) / w.sum(), rel=1e-4)


def test_eq2_colour_sums_the_channels_or_averages_them():
    ia = np.zeros((3, 3, 3))
    ib = np.zeros((3, 3, 3))
    ib[1, 1] = 0.5
    grey_a, grey_b = np.zeros((3, 3)), np.zeros((3, 3))
    grey_b[1, 1] = 0.5
    r = np.full((3, 3), np.nan)
    grey = neighbourhood_distance(grey_a, r, grey_b, r)
    # Eq. 2 sums the channels: three channels that differ cost three times one
    assert neighbourhood_distance(ia, r, ib, r) == 3 * grey
    assert neighbourhood_distance(ia, r, ib, r, channels="mean") == grey
    assert grey == float(Fraction(int(window_weights(3)[1, 1]), 2**20))


@given(st.sampled_from([3, 5, 7]), st.floats(0.01, 0.5))
def test_eq2_weighs_the_centre_more(n, delta):
    """The same intensity difference costs more at the centre than at a corner."""
    h = n // 2
    base = np.zeros((n, n))
    centre, corner = base.copy(), base.copy()
    centre[h, h] = delta
    corner[0, 0] = delta
    r = np.full((n, n), np.nan)
    assert neighbourhood_distance(base, r, centre, r) > neighbourhood_distance(base, r, corner, r)


@given(st.sampled_from([1, 3, 5, 7, 9]))
def test_gaussian_window_is_normalised_and_peaked(n):
    g = gaussian_window(n)
    assert g.shape == (n, n)
    assert g.sum() == pytest.approx(1.0, rel=10 * EPS)
    assert g[n // 2, n // 2] == g.max()
    np.testing.assert_array_equal(g, g.T)
    np.testing.assert_array_equal(g, g[::-1, ::-1])


@pytest.mark.parametrize("n", [0, 2, -3])
def test_gaussian_window_rejects_bad_sizes(n):
    with pytest.raises(ValueError, match="`n`"):
        gaussian_window(n)


def test_gaussian_window_rejects_bad_sigma():
    with pytest.raises(ValueError, match="`sigma`"):
        gaussian_window(3, sigma=0.0)


@given(st.floats(1.0, 6.0))
def test_eq3_disc_holds_exactly_the_offsets_within_r(radius):
    dr, dc = disc_offsets(radius)
    k = int(radius) + 1
    rr, cc = np.mgrid[-k : k + 1, -k : k + 1]
    expected = int(((rr**2 + cc**2 <= radius**2) & ((rr != 0) | (cc != 0))).sum())
    assert dr.size == expected
    assert np.all(dr**2 + dc**2 <= radius**2)


@given(small_scene_args=st.tuples(st.integers(4, 9), st.integers(4, 9), st.sampled_from([1, 3])))
def test_patches_are_centred_windows(small_scene_args):
    h, w, c = small_scene_args
    image = np.arange(h * w * c, dtype=float).reshape(h, w, c)
    rng = np.arange(h * w, dtype=float).reshape(h, w)
    ip = intensity_patches(image, 3)
    rp = range_patches(rng, 3)
    assert ip.shape == (h, w, 3, 3, c) and rp.shape == (h, w, 3, 3)
    np.testing.assert_array_equal(ip[1:-1, 1:-1, 1, 1], image[1:-1, 1:-1])
    np.testing.assert_array_equal(ip[2, 2], image[1:4, 1:4])
    assert np.isnan(rp[0, 0, 0, 0]) and rp[0, 0, 1, 1] == rng[0, 0]


def test_range_scale_of_a_constant_is_one():
    assert range_scale(np.array([[2.0, np.nan], [2.0, 2.0]])) == (2.0, 1.0)


@given(
    st.integers(5, 9),
    st.integers(5, 9),
    st.sampled_from([1, 3]),
    st.sampled_from([3, 5]),
    st.sampled_from([0.0, 1.0, 0.3, 7.5]),
    st.sampled_from(["ignore", "mean"]),
    st.sampled_from(["sum", "mean"]),
    st.integers(0, 2**32 - 1),
)
def test_the_fast_eq2_tables_equal_the_literal_eq2_bit_for_bit(h, w, c, n, lam, missing,
                                                                 channels, seed):
    """PatchTable (NP's and BP's expanded squares) and FillTable (NP's narrow rows) give
    eq2_distance's bits under every reading of missing_range and channels, before and
    after ranges are recorded; so does neighbourhood_distance of the normalised floats."""
    rng = np.random.default_rng(seed)
    qi = rng.integers(0, 2**16 + 1, (h, w, c))
    qi.flat[0], qi.flat[-1] = 0, 2**16                   # the extremes of the grid
    qr = np.where(rng.random((h, w)) < 0.5, rng.integers(0, 2**16 + 1, (h, w)), NO_RANGE)
    image = qi * 2.0**-16
    pad = n // 2 + 1
    wide = PatchTable(image, np.where(qr == NO_RANGE, np.nan, qr * 2.0**-16), n, pad, lam,
                      missing, channels=channels)
    narrow = FillTable(image, np.where(qr == NO_RANGE, np.nan, qr * 2.0**-16), n, pad, lam,
                       missing, channels)
    window = window_weights(n)
    wp = w + 2 * pad
    flat = ((np.arange(h)[:, None] + pad) * wp + np.arange(w)[None, :] + pad).ravel()
    hh = n // 2
    qi_pad = np.pad(qi, ((hh, hh), (hh, hh), (0, 0)), mode="symmetric")   # the contract's

    def patch(r, c):                         # N_(r, c) on the grids, as qr is now
        qr_pad = np.pad(qr, hh, constant_values=NO_RANGE)
        return qi_pad[r : r + n, c : c + n], qr_pad[r : r + n, c : c + n]

    for _ in range(3):
        p = divmod(int(rng.integers(h * w)), w)
        literal = [eq2_distance(*patch(*p), *patch(*divmod(int(q), w)), window, lam, missing,
                                channels) for q in range(h * w)]
        target = (p[0] + pad) * wp + p[1] + pad
        np.testing.assert_array_equal(wide.distances(target, flat), literal)
        np.testing.assert_array_equal(wide.batch_distances(np.array([target]), flat[None])[0],
                                      literal)
        np.testing.assert_array_equal(narrow.distances(target, flat), literal)
        floats = [neighbourhood_distance(*(np.where(x == NO_RANGE, np.nan, x * 2.0**-16)
                                           for x in (*patch(*p), *patch(*divmod(int(q), w)))),
                                         range_weight=lam, missing_range=missing,
                                         channels=channels) for q in range(h * w)]
        assert floats == literal
        unknown = np.flatnonzero(qr.ravel() == NO_RANGE)
        if unknown.size:                                # a range becomes known
            r, cc = divmod(int(rng.choice(unknown)), w)
            qr[r, cc] = int(rng.integers(0, 2**16 + 1))
            for table in (wide, narrow):
                table.set_range((r + pad) * wp + cc + pad, qr[r, cc] * 2.0**-16)


@given(
    st.integers(5, 8),
    st.integers(5, 8),
    st.sampled_from([1, 3]),
    st.sampled_from([0.0, 8.0]),
    st.sampled_from(["ignore", "mean"]),
    st.integers(0, 2**32 - 1),
)
def test_the_float32_patch_table_is_near_the_literal_eq2(h, w, c, lam, missing, seed):
    """float32 rows round the integers of the expanded squares: close, not equal."""
    rng = np.random.default_rng(seed)
    image = rng.random((h, w, c))
    rimg = np.where(rng.random((h, w)) < 0.5, rng.random((h, w)), np.nan)
    table32 = PatchTable(image, rimg, 3, 2, lam, missing, np.float32)
    table64 = PatchTable(image, rimg, 3, 2, lam, missing)
    wp = w + 4
    flat = ((np.arange(h)[:, None] + 2) * wp + np.arange(w)[None, :] + 2).ravel()
    p = int(rng.choice(flat))
    np.testing.assert_allclose(table32.distances(p, flat), table64.distances(p, flat),
                               rtol=1e-4, atol=1e-4)


@given(neighbourhood_pair(), st.floats(0.1, 10.0))
def test_mean_filled_range_term_equals_eq2_when_the_candidate_covers_the_target(pair, lam):
    """Up to the prior pseudo-offset ε: (r + ε) t / (t + ε) with r the shared sum, t = Σ_A G."""
    (ia, ra), (ib, rb) = pair
    rb = np.where(np.isfinite(ra) & ~np.isfinite(rb), 0.5, rb)  # b has range wherever a has
    intensity_only = neighbourhood_distance(ia, ra, ib, rb, range_weight=0.0)
    r = (neighbourhood_distance(ia, ra, ib, rb, range_weight=lam) - intensity_only) / lam
    t = window_weights(ra.shape[0])[np.isfinite(ra)].sum() * 2.0**-18
    eps = 1e-4
    filled = neighbourhood_distance(ia, ra, ib, rb, range_weight=lam, missing_range="mean")
    assert filled == pytest.approx(intensity_only + lam * (r + eps) * t / (t + eps),
                                   rel=1e-9, abs=1e-12)


def test_mean_filled_range_term_charges_missing_offsets_the_mean_discrepancy():
    """Two offsets in a, one shared with b: the missing one costs the shared one's error."""
    g = window_weights(3) * 2.0**-18
    zero = np.zeros((3, 3))
    ra = np.full((3, 3), np.nan)
    rb = np.full((3, 3), np.nan)
    ra[0, 1], ra[1, 0] = 0.25, 0.5
    rb[0, 1] = 0.75
    eps = 1e-4  # the prior pseudo-offset
    got = neighbourhood_distance(zero, ra, zero, rb, range_weight=1.0, missing_range="mean")
    want = (0.5**2 * g[0, 1] + eps) * ((g[0, 1] + g[1, 0]) / (g[0, 1] + eps))
    assert got == want                                   # combine_eq2's operations, on the grid
    assert got == pytest.approx(0.5**2 * (g[0, 1] + g[1, 0]), rel=0.02)
    # nothing shared: every offset a has costs the whole span
    rb[0, 1] = np.nan
    got = neighbourhood_distance(zero, ra, zero, rb, range_weight=2.0, missing_range="mean")
    assert got == pytest.approx(2.0 * (g[0, 1] + g[1, 0]), rel=1e-12)


@pytest.mark.parametrize("name, value", [("missing_range", "zero"), ("channels", "max")])
def test_eq2_refuses_an_unknown_reading_naming_it(name, value):
    qi, qr = np.zeros((3, 3, 1), dtype=np.int64), np.full((3, 3), NO_RANGE)
    with pytest.raises(ValueError, match=f"`{name}`"):
        eq2_distance(qi, qr, qi, qr, window_weights(3), **{name: value})
    with pytest.raises(ValueError, match=f"`{name}`"):
        neighbourhood_distance(np.zeros((3, 3)), np.full((3, 3), np.nan), np.zeros((3, 3)),
                               np.full((3, 3), np.nan), **{name: value})


@pytest.mark.parametrize("bad, match", [
    (dict(intensity_a=np.full((3, 3), np.nan)), "`intensity_a`"),
    (dict(range_b=np.full((3, 3), -0.5)), "`range_b`"),
    (dict(range_a=np.full((5, 5), np.nan)), "matching shapes"),
    (dict(window=np.ones((5, 5)) / 25), "matching shapes"),
])
def test_neighbourhood_distance_refuses_bad_neighbourhoods(bad, match):
    args = dict(intensity_a=np.zeros((3, 3)), range_a=np.full((3, 3), np.nan),
                intensity_b=np.zeros((3, 3)), range_b=np.full((3, 3), 0.5)) | bad
    with pytest.raises(ValueError, match=match):
        neighbourhood_distance(**args)
