"""Eq. 2 (§3.2.2): the distance between partial neighbourhoods, and the MRF window."""

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from strategies import UNIT, neighbourhood_pair, partial_neighbourhood

from refsynth.synthesis import reference as ref
from refsynth.synthesis.neighbourhood import (
    disc_offsets,
    gaussian_window,
    intensity_patches,
    range_patches,
)
from refsynth.synthesis.similarity import PatchTable, neighbourhood_distance, range_scale

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
    """3×3 grey, one differing intensity at the centre and one range pair at a corner."""
    g = gaussian_window(3)
    ia = np.zeros((3, 3))
    ib = np.zeros((3, 3))
    ib[1, 1] = 0.5
    ra = np.full((3, 3), np.nan)
    rb = np.full((3, 3), np.nan)
    ra[0, 0], rb[0, 0] = 0.2, 0.6
    ra[2, 2] = 0.9  # only in a: ignored
    expected = g[1, 1] * 0.25 + 4.0 * g[0, 0] * 0.16
    assert neighbourhood_distance(ia, ra, ib, rb, range_weight=4.0) == pytest.approx(
        expected, rel=10 * EPS
    )


def test_eq2_colour_sums_the_channels_or_averages_them():
    ia = np.zeros((3, 3, 3))
    ib = np.zeros((3, 3, 3))
    ib[1, 1] = 0.5
    grey_a, grey_b = np.zeros((3, 3)), np.zeros((3, 3))
    grey_b[1, 1] = 0.5
    r = np.full((3, 3), np.nan)
    grey = neighbourhood_distance(grey_a, r, grey_b, r)
    # Eq. 2 sums the channels: three channels that differ cost three times one
    assert neighbourhood_distance(ia, r, ib, r) == pytest.approx(3 * grey, rel=10 * EPS)
    assert neighbourhood_distance(ia, r, ib, r, channels="mean") == pytest.approx(
        grey, rel=10 * EPS
    )


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
    st.floats(0.0, 8.0),
    st.sampled_from(["ignore", "mean"]),
    st.sampled_from([np.float64, np.float32]),
    st.integers(0, 2**32 - 1),
)
def test_expanded_eq2_in_np_matches_the_literal_sum(h, w, c, n, lam, missing, dtype, seed):
    """NP's matrix-product form of Eq. 2 equals the pair-by-pair definition, both
    for the literal Eq. 2 and for the mean-filled range term.

    PatchTable works on the numeric contract's grids: the intensity and range it is
    given, rint(2**16 x), and the integer window (refsynth.numeric). The literal sum is
    taken on those same values; in float64 the table is moreover *exactly* the
    literal reference's Eq. 2 (refsynth.synthesis.reference.eq2_distance)."""
    rng = np.random.default_rng(seed)
    image = rng.random((h, w, c))
    rimg = np.where(rng.random((h, w)) < 0.5, rng.random((h, w)), np.nan)
    pad = n // 2 + 1
    table = PatchTable(image, rimg, n, pad, lam, missing, dtype)
    qi = np.rint(image * 2**16)
    qr = np.rint(rimg * 2**16)
    ip = intensity_patches(qi * 2.0**-16, n)
    rp = range_patches(qr * 2.0**-16, n)
    window = ref.window_weights(n)
    wp = w + 2 * pad
    p = (int(rng.integers(h)), int(rng.integers(w)))
    qs = [(int(rng.integers(h)), int(rng.integers(w))) for _ in range(6)]
    flat = np.array([(q[0] + pad) * wp + q[1] + pad for q in qs])
    got = table.distances((p[0] + pad) * wp + p[1] + pad, flat)
    want = [
        neighbourhood_distance(ip[p], rp[p], ip[q], rp[q], range_weight=lam,
                               window=window * 2.0**-18, missing_range=missing)
        for q in qs
    ]
    batch = table.batch_distances(np.array([(p[0] + pad) * wp + p[1] + pad]), flat[None, :])
    # float32 rounds the integers of the expanded squares: a few digits lost to cancellation
    tol = dict(rtol=1e-9, atol=1e-12) if dtype == np.float64 else dict(rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(got, want, **tol)
    np.testing.assert_allclose(batch[0], want, **tol)
    if dtype == np.float64:
        def quantised(r, c):
            i = intensity_patches(qi, n)[r, c].astype(np.int64)
            q = np.nan_to_num(range_patches(qr, n)[r, c], nan=ref.NO_RANGE).astype(np.int64)
            return i, q

        exact = [ref.eq2_distance(*quantised(*p), *quantised(*q), window, lam, missing)
                 for q in qs]
        np.testing.assert_array_equal(got, exact)
        np.testing.assert_array_equal(batch[0], exact)


@given(neighbourhood_pair(), st.floats(0.1, 10.0))
def test_mean_filled_range_term_equals_eq2_when_the_candidate_covers_the_target(pair, lam):
    """Up to the prior pseudo-offset ε: (r + ε) t / (t + ε) with r the shared sum, t = Σ_A G."""
    (ia, ra), (ib, rb) = pair
    rb = np.where(np.isfinite(ra) & ~np.isfinite(rb), 0.5, rb)  # b has range wherever a has
    intensity_only = neighbourhood_distance(ia, ra, ib, rb, range_weight=0.0)
    r = (neighbourhood_distance(ia, ra, ib, rb, range_weight=lam) - intensity_only) / lam
    t = gaussian_window(ra.shape[0])[np.isfinite(ra)].sum()
    eps = 1e-4
    filled = neighbourhood_distance(ia, ra, ib, rb, range_weight=lam, missing_range="mean")
    assert filled == pytest.approx(intensity_only + lam * (r + eps) * t / (t + eps),
                                   rel=1e-9, abs=1e-12)


def test_mean_filled_range_term_charges_missing_offsets_the_mean_discrepancy():
    """Two offsets in a, one shared with b: the missing one costs the shared one's error."""
    g = gaussian_window(3)
    zero = np.zeros((3, 3))
    ra = np.full((3, 3), np.nan)
    rb = np.full((3, 3), np.nan)
    ra[0, 1], ra[1, 0] = 0.2, 0.4
    rb[0, 1] = 0.5
    eps = 1e-4  # the prior pseudo-offset
    got = neighbourhood_distance(zero, ra, zero, rb, range_weight=1.0, missing_range="mean")
    want = (0.3**2 * g[0, 1] + eps) * (g[0, 1] + g[1, 0]) / (g[0, 1] + eps)
    assert got == pytest.approx(want, rel=1e-12)
    assert got == pytest.approx(0.3**2 * (g[0, 1] + g[1, 0]), rel=0.02)
    # nothing shared: every offset a has costs the whole span
    rb[0, 1] = np.nan
    got = neighbourhood_distance(zero, ra, zero, rb, range_weight=2.0, missing_range="mean")
    assert got == pytest.approx(2.0 * (g[0, 1] + g[1, 0]), rel=1e-12)
    with pytest.raises(ValueError, match="`missing_range`"):
        neighbourhood_distance(zero, ra, zero, rb, missing_range="zero")
