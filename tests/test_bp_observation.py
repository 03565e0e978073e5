"""BP's departures: observations completed by a fill, Eq. 6 with the centres.

``observation="colorization"`` (:mod:`refsynth.synthesis.belief.observation`) and
``compatibility="overlap-centres"`` (:mod:`refsynth.synthesis.belief.centres`): hand-built
cases, a brute-force Eq. 6 under hypothesis, and the front door's checks. The
default path is covered bit for bit by ``tests/test_golden_hashes.py``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import refsynth
from refsynth.numeric import quantise_intensity, quantise_range
from refsynth.synthesis.belief.fill import bp_fill
from refsynth.synthesis.belief.model import (
    Compatibilities,
    _overlap_mean_square,
    fixed_neighbour_terms,
    pair_compatibilities,
    psi,
)
from refsynth.synthesis.belief.observation import observation_fill, observed_ranges
from refsynth.synthesis.belief.search import search_candidates

U = 2.0**-32  # one squared step of the 2**-16 grid


# -- observed_ranges ------------------------------------------------------------------------


def test_observed_ranges_quantises_the_fill_and_keeps_the_measured():
    rq = np.array([[0, -1, 65536, -1]])
    observed, training = observed_ranges(rq, np.array([[7.0, 0.5, 7.0, -0.25]]))
    # 0.5 is half the span above the minimum; -0.25 is below it: clipped to 0
    assert observed.tolist() == [[0, 32768, 65536, 0]]
    assert observed.dtype == np.int64 and training is None
    observed, training = observed_ranges(rq, np.array([[7.0, 0.25, 7.0, 1.0]]),
                                         completed=True)
    assert observed.tolist() == [[0, 16384, 65536, 65536]]
    assert training is observed


def test_observed_ranges_refuses_a_fill_with_holes_or_the_wrong_shape():
    rq = np.array([[0, -1]])
    with pytest.raises(ValueError, match="finite at every unknown"):
        observed_ranges(rq, np.array([[0.0, np.nan]]))
    observed_ranges(rq, np.array([[np.nan, 0.5]]))  # a measured pixel may be NaN
    with pytest.raises(ValueError, match="shape"):
        observed_ranges(rq, np.zeros((2, 2)))


def test_observation_fill_is_the_portable_colorization_of_the_quantised_inputs():
    from refsynth.evaluation.baselines import colorization_fill
    from refsynth.synthesis.completion import portable_colorization

    rng = np.random.default_rng(1)
    image = rng.random((9, 11, 3))
    partial = np.where(np.arange(11) % 4 == 0, rng.random((9, 11)) + 1.0, np.nan)
    fill = observation_fill(image, partial, "colorization")
    # the portable solve of the quantised range guided by the quantised intensity, bit for
    # bit, on the measured range's unit scale; close to the baseline's direct solve
    q = quantise_intensity(image) / 2.0**16
    rq, low, span = quantise_range(partial)
    unit = np.where(rq < 0, np.nan, rq / 2.0**16)
    np.testing.assert_array_equal(fill, portable_colorization(q, unit))
    np.testing.assert_allclose(low + span * fill, colorization_fill(image, partial), atol=1e-3)
    np.testing.assert_array_equal(fill, observation_fill(image, partial,
                                                         "colorization-completed"))
    with pytest.raises(ValueError, match="observation"):
        observation_fill(image, partial, "measured")


@pytest.mark.parametrize("change", ["offset", "scale", "uint8", "range"])
def test_observation_fill_follows_the_intensity_convention_bit_for_bit(change):
    rng = np.random.default_rng(8)
    image = rng.integers(0, 256, (10, 12, 3)).astype(np.uint8)
    partial = np.where(rng.random((10, 12)) < 0.35, rng.random((10, 12)) * 3.0 + 1.0, np.nan)
    plain = observation_fill(image, partial, "colorization")
    if change == "offset":
        other = observation_fill(image + 17.5, partial, "colorization")
    elif change == "scale":
        other = observation_fill(image * 0.37, partial, "colorization")
    elif change == "uint8":
        other = observation_fill(image / 255.0, partial, "colorization")
    else:
        other = observation_fill(image, partial * 41.0 + 3.0, "colorization")
    np.testing.assert_array_equal(plain, other)


def test_the_observation_option_never_reaches_the_evaluation_package():
    # layering (DESIGN.md): synthesis does not import evaluation, not even lazily
    import ast
    import inspect

    from refsynth.synthesis import completion
    from refsynth.synthesis.belief import observation as bp_observation

    for module in (bp_observation, completion):
        for node in ast.walk(ast.parse(inspect.getsource(module))):
            if isinstance(node, ast.ImportFrom):
                assert not (node.module or "").startswith("refsynth.evaluation")


# -- Eq. 6 with the centres ------------------------------------------------------------------


def test_centres_count_as_one_more_shared_pixel():
    # one shared pixel differing by 3 steps, centres differing by 4: (9 + 16) / 2
    a = np.array([[[10.0, -1.0]]])
    b = np.array([[[13.0, 5.0]]])
    plain = _overlap_mean_square(a, b, quantised=True)
    assert plain[0, 0, 0] == 9 * U
    both = _overlap_mean_square(a, b, quantised=True,
                                centres=(np.array([[100.0]]), np.array([[104.0]])))
    assert both[0, 0, 0] == (9 + 16) * U / 2


def test_centres_alone_where_the_overlap_is_empty_and_nothing_where_one_is_missing():
    a = np.array([[[-1.0, 7.0]]])
    b = np.array([[[3.0, -1.0]]])
    assert _overlap_mean_square(a, b, quantised=True)[0, 0, 0] == 0.0  # Ψ = 1
    out = _overlap_mean_square(a, b, quantised=True,
                               centres=(np.array([[50.0]]), np.array([[45.0]])))
    assert out[0, 0, 0] == 25 * U
    out = _overlap_mean_square(a, b, quantised=True,
                               centres=(np.array([[-1.0]]), np.array([[45.0]])))
    assert out[0, 0, 0] == 0.0


@settings(deadline=None, max_examples=60)
@given(st.integers(0, 2**31 - 1), st.integers(1, 3), st.integers(1, 3), st.integers(1, 6))
def test_centres_mean_square_matches_brute_force(seed, k, m, f):
    rng = np.random.default_rng(seed)
    a = np.where(rng.random((2, k, f)) < 0.4, -1.0, rng.integers(0, 2**16, (2, k, f)))
    b = np.where(rng.random((2, m, f)) < 0.4, -1.0, rng.integers(0, 2**16, (2, m, f)))
    ca = np.where(rng.random((2, k)) < 0.2, -1.0, rng.integers(0, 2**16, (2, k)))
    cb = np.where(rng.random((2, m)) < 0.2, -1.0, rng.integers(0, 2**16, (2, m)))
    out = _overlap_mean_square(a, b, quantised=True, centres=(ca, cb))
    for e in range(2):
        for i in range(k):
            for j in range(m):
                terms = [(a[e, i, v] - b[e, j, v]) ** 2 for v in range(f)
                         if a[e, i, v] >= 0 and b[e, j, v] >= 0]
                if ca[e, i] >= 0 and cb[e, j] >= 0:
                    terms.append((ca[e, i] - cb[e, j]) ** 2)
                want = sum(terms) * U / len(terms) if terms else 0.0
                assert out[e, i, j] == pytest.approx(want, rel=1e-12, abs=0.0)


def _patch(centre, fill=-1.0, n=3):
    p = np.full((n, n), fill)
    p[n // 2, n // 2] = centre
    return p


def test_fixed_neighbour_terms_with_centres_compare_the_centres():
    # a horizontal pair, the fixed node on the left: the patches' overlaps share nothing
    # measured (only the centres are measured), so only the centres speak
    cand = np.stack([_patch(100.0), _patch(110.0)])[None]  # (1, 2, 3, 3)
    fixed = _patch(104.0)[None, None]
    plain = fixed_neighbour_terms(cand, fixed, "h", "left", quantised=True)
    assert plain.tolist() == [[0.0, 0.0]]
    out = fixed_neighbour_terms(cand, fixed, "h", "left", quantised=True, centres=True)
    assert out.tolist() == [[16 * U, 36 * U]]
    out = fixed_neighbour_terms(cand, fixed, "v", "right", quantised=True, centres=True)
    assert out.tolist() == [[16 * U, 36 * U]]


def test_compatibilities_with_centres_match_pair_compatibilities():
    # two horizontal neighbours (0, 1), (0, 2) of a 3×6 image; candidates at measured pixels
    rng = np.random.default_rng(3)
    values = rng.integers(0, 2**16, (3, 6)).astype(np.float64)
    values[:, [1, 2]] = -1.0  # the two nodes' columns unknown
    values[1, 4] = -1.0
    plane = np.pad(values, 1, constant_values=-1.0)
    labels = np.array([[0, 3, 9], [5, 15, 11]])
    pairs = np.array([[0, 1]])
    psi_of = Compatibilities(plane, 3, labels, 6, pairs, 1, 0.2, centres=True)
    plain_of = Compatibilities(plane, 3, labels, 6, pairs, 1, 0.2)
    patches = np.lib.stride_tricks.sliding_window_view(plane, (3, 3))
    pj = patches[labels[0] // 6, labels[0] % 6][None]
    pk = patches[labels[1] // 6, labels[1] % 6][None]
    centres = (pj[:, :, 1, 1], pk[:, :, 1, 1])
    a = pj[..., :, 1:].reshape(1, 3, -1)
    b = pk[..., :, :-1].reshape(1, 3, -1)
    want = psi(_overlap_mean_square(a, b, True, centres), 0.2)
    np.testing.assert_array_equal(psi_of(np.array([0])), want)
    np.testing.assert_array_equal(
        plain_of(np.array([0])), psi(pair_compatibilities(pj, pk, "h", quantised=True), 0.2))
    assert not np.array_equal(psi_of.all(), plain_of.all())


# -- the observations in the search and in bp_fill -----------------------------------------


def _two_plateaus():
    """A flat image; column 0 measured at 1, column 8 at 5: intensity cannot choose."""
    image = np.full((5, 9, 1), 0.5)
    image[0, 8, 0] = 0.0  # a span for the quantisation (ties: column 0 first)
    partial = np.full((5, 9), np.nan)
    partial[:, 0] = 1.0
    partial[:, 8] = 5.0
    return image, partial


def test_the_observed_range_picks_the_candidate_whose_range_fits():
    image, partial = _two_plateaus()
    rq, low, span = quantise_range(partial)
    levels = quantise_intensity(image)
    rows, cols = np.array([2]), np.array([3])  # nearer column 0 in raster order
    opts = dict(n=3, k=1, radius=10.0, proximity=0.0, range_weight=1.0,
                missing_range="mean", pad=10)
    labels, _ = search_candidates(levels, rq, rows, cols, **opts)
    assert partial.ravel()[labels[0, 0]] == 1.0
    fill = (np.where(np.isfinite(partial), partial, 5.0) - low) / span
    observed, _ = observed_ranges(rq, fill)
    labels, dist = search_candidates(levels, rq, rows, cols, observed=observed, **opts)
    assert partial.ravel()[labels[0, 0]] == 5.0
    # the measured range as the observation changes nothing, bit for bit
    same = search_candidates(levels, rq, rows, cols, observed=rq, training=rq, **opts)
    plain = search_candidates(levels, rq, rows, cols, **opts)
    assert all(np.array_equal(x, y) for x, y in zip(same, plain, strict=True))


def test_bp_fill_follows_the_observation():
    image, partial = _two_plateaus()
    edges = np.zeros(partial.shape, bool)
    plain = bp_fill(image, partial, edges, neighbourhood=3, radius=10.0, k=2)
    # the observation on the measured range's unit scale: 1 is 5.0, 0 is 1.0
    unknown = np.isnan(partial)
    moved = bp_fill(image, partial, edges, neighbourhood=3, radius=10.0, k=2,
                    observation=np.where(unknown, 1.0, np.nan))
    assert np.all(moved.range[unknown] == 5.0)
    assert np.any(plain.range[unknown] != 5.0)
    again = bp_fill(image, partial, edges, neighbourhood=3, radius=10.0, k=2,
                    observation=np.where(unknown, 0.0, np.nan))
    assert np.all(again.range[unknown] == 1.0)


def test_bp_fill_defaults_are_the_paper_bit_for_bit():
    rng = np.random.default_rng(5)
    image = rng.random((10, 12, 3))
    partial = np.where(np.arange(12) % 4 == 0, rng.random((10, 12)) + 1.0, np.nan)
    edges = np.zeros(partial.shape, bool)
    plain = bp_fill(image, partial, edges, radius=4.0)
    named = bp_fill(image, partial, edges, radius=4.0, observation=None,
                    compatibility="overlap")
    np.testing.assert_array_equal(plain.range, named.range)
    np.testing.assert_array_equal(plain.beliefs, named.beliefs)
    centred = bp_fill(image, partial, edges, radius=4.0, compatibility="overlap-centres")
    assert not np.array_equal(plain.beliefs, centred.beliefs)
    np.testing.assert_array_equal(plain.labels.shape, centred.labels.shape)
    with pytest.raises(ValueError, match="`compatibility`"):
        bp_fill(image, partial, edges, radius=4.0, compatibility="centres")


# -- the front door --------------------------------------------------------------------------


def _small():
    image = np.tile(np.linspace(0, 1, 12), (10, 1))
    partial = np.where(np.arange(12) % 3 == 0, 2.0 + np.arange(12) / 12, np.nan) + np.zeros(
        (10, 1))
    return image, partial


def test_synthesize_checks_the_options_by_name():
    image, partial = _small()
    with pytest.raises(ValueError, match="`observation`"):
        refsynth.synthesize(image, partial, method="bp", readings={"observation": "nearest"})
    with pytest.raises(ValueError, match="`compatibility`"):
        refsynth.synthesize(image, partial, method="bp", readings={"compatibility": "centres"})
    with pytest.raises(ValueError, match="`observation` applies to method='bp' only"):
        refsynth.synthesize(image, partial, method="np", readings={"observation": "measured"})
    with pytest.raises(ValueError, match="`compatibility` applies to method='bp' only"):
        refsynth.synthesize(image, partial, method="np",
                            readings={"compatibility": "overlap-centres"})
    # BP's defaults are accepted by NP and leave no trace
    out = refsynth.synthesize(image, partial, method="np",
                              readings={"observation": "np", "compatibility": "overlap",
                                        "training_radius": "gap"})
    with pytest.raises(ValueError, match="`observation` applies to method='bp' only"):
        refsynth.synthesize(image, partial, method="np", readings={"observation": "colorization"})
    assert not {"observation", "compatibility", "training_radius"} & set(out.params)


def test_synthesize_passes_the_options_to_bp():
    image, partial = _small()
    plain = refsynth.synthesize(image, partial, method="bp", radius=3.0)
    named = refsynth.synthesize(image, partial, method="bp", radius=3.0,
                                readings={"observation": "np", "compatibility": "overlap",
                                          "training_radius": "gap"})
    np.testing.assert_array_equal(plain.range, named.range)
    np.testing.assert_array_equal(plain.bp.beliefs, named.bp.beliefs)
    # the defaults are recorded: a result says which BP made it (NP's fill)
    assert plain.params["observation"] == "np"
    assert plain.params["offset_tolerance"] == 2.0**-3
    assert plain.params["training_radius"] == "gap"
    assert plain.params["compatibility"] == "overlap"
    fig6 = refsynth.synthesize(image, partial, method="bp", radius=3.0,
                               readings={"observation": "measured", "training_radius": "fixed"})
    want = bp_fill(image[:, :, None], partial, fig6.edges, radius=3.0,
                   neighbourhood=fig6.params["neighbourhood"])   # the window reading's side
    np.testing.assert_array_equal(fig6.bp.range, want.range)
    np.testing.assert_array_equal(fig6.bp.beliefs, want.beliefs)
    assert fig6.params["observation"] == "measured"
    assert not np.array_equal(fig6.bp.unary, plain.bp.unary)
    fill = observation_fill(image, partial, "colorization")
    for name, completed in (("colorization", False), ("colorization-completed", True)):
        out = refsynth.synthesize(image, partial, method="bp", radius=3.0,
                                  readings={"observation": name,
                                            "compatibility": "overlap-centres"})
        edges = out.edges
        want = bp_fill(image[:, :, None], partial, edges, radius=3.0, observation=fill,
                       observation_completed=completed, compatibility="overlap-centres",
                       training_radius="gap", neighbourhood=out.params["neighbourhood"])
        np.testing.assert_array_equal(out.bp.range, want.range)
        np.testing.assert_array_equal(out.bp.beliefs, want.beliefs)
        assert out.params["observation"] == name
        assert out.params["compatibility"] == "overlap-centres"


# -- the training disc widened by the gap (bp_gap_radius) ----------------------------------


def test_gap_depth_is_the_floored_distance_to_the_nearest_measured_pixel():
    from refsynth.synthesis.belief.gap_radius import gap_depth

    rq = np.full((5, 7), -1)
    rq[0, 0] = 3
    rows, cols = np.nonzero(rq == -1)
    want = np.floor(np.hypot(rows, cols)).astype(int)
    np.testing.assert_array_equal(gap_depth(rq, rows, cols), want)
    assert gap_depth(np.full((2, 2), -1), np.array([0]), np.array([1])).tolist() == [0]


@settings(deadline=None, max_examples=15)
@given(st.integers(0, 2**31 - 1))
def test_gap_radius_is_the_search_at_each_nodes_own_radius(seed):
    from refsynth.synthesis.belief.gap_radius import gap_depth, gap_radius_candidates

    rng = np.random.default_rng(seed)
    H, W = 9, 14
    image = rng.random((H, W, 1))
    partial = np.where(np.arange(W) % 6 == 0, rng.random((H, W)) + 1.0, np.nan)
    rq, _, _ = quantise_range(partial)
    levels = quantise_intensity(image)
    rows, cols = np.nonzero(np.isnan(partial))
    opts = dict(n=3, k=3, proximity=0.0, range_weight=1.0, missing_range="mean")
    labels, dist = gap_radius_candidates(levels, rq, rows, cols, radius=2.0, pad=2, **opts)
    depth = gap_depth(rq, rows, cols)
    assert depth.max() >= 2  # nodes at different depths
    for i in rng.choice(rows.size, 6, replace=False):
        r = 2.0 + depth[i]
        want = search_candidates(levels, rq, rows[i : i + 1], cols[i : i + 1], radius=r,
                                 pad=int(np.ceil(r)), **opts)
        np.testing.assert_array_equal(labels[i], want[0][0])
        np.testing.assert_array_equal(dist[i], want[1][0])


def _per_depth_search(levels, rq, rows, cols, radius, pad, n, proximity, **opts):
    """The gap-radius search done plainly: search_candidates once per depth."""
    import math

    from refsynth.synthesis.belief.gap_radius import gap_depth
    from refsynth.synthesis.limits import search_radius

    depth = gap_depth(rq, rows, cols)
    labels = np.zeros((rows.size, opts["k"]), dtype=np.int64)
    dist = np.zeros((rows.size, opts["k"]))
    for extra in np.unique(depth):
        mine = np.flatnonzero(depth == extra)
        run, mu = search_radius("bp", radius + float(extra), proximity, rq.shape)
        labels[mine], dist[mine] = search_candidates(
            levels, rq, rows[mine], cols[mine], n=n, radius=run, proximity=mu,
            pad=max(pad, math.ceil(run), n // 2 + 1), **opts)
    return labels, dist


@settings(deadline=None, max_examples=25)
@given(st.integers(0, 2**31 - 1), st.sampled_from([1.0, 1.5, 3.0]),
       st.sampled_from([0.0, 0.7, 1e300]), st.sampled_from([1, 2, 6, 40]),
       st.sampled_from(["stripes", "random", "corner"]), st.booleans())
def test_gap_radius_in_one_pass_is_the_search_of_each_depth(seed, radius, proximity, k,
                                                             sampling, observe):
    """Every node's candidates and distances: those of search_candidates at its own depth's
    radius and prior, bit for bit, whether its disc holds k candidates (one pass) or must
    widen (its depth's search); beyond the image (k = 40, μ = 1e300) too."""
    from refsynth.synthesis.belief.gap_radius import gap_radius_candidates

    rng = np.random.default_rng(seed)
    H, W = rng.integers(3, 12), rng.integers(3, 16)
    image = np.round(rng.random((H, W, 3)) * 4) / 4  # few levels: ties in Eq. 2
    if sampling == "stripes":
        known = (np.arange(W) % 5 == 0) & np.ones((H, 1), bool)
    elif sampling == "random":
        known = rng.random((H, W)) < 0.3
    else:
        known = np.zeros((H, W), bool)
        known[0, 0] = True
    known[0, 0] = True
    partial = np.where(known, np.round(rng.random((H, W)) * 8) / 8 + 1.0, np.nan)
    rq, _, _ = quantise_range(partial)
    levels = quantise_intensity(image)
    rows, cols = np.nonzero(~known)
    opts = dict(n=3, k=k, range_weight=1.0, missing_range="mean", channels="sum")
    if observe:
        observed = np.where(known, rq, rng.integers(0, 2**16, (H, W)))
        opts["observed"] = observed
    got = gap_radius_candidates(levels, rq, rows, cols, radius=radius, pad=2,
                                proximity=proximity, **opts)
    want = _per_depth_search(levels, rq, rows, cols, radius, 2, proximity=proximity, **opts)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1].view(np.int64), want[1].view(np.int64))


def test_gap_radius_beyond_the_image_keeps_each_depths_prior_in_one_pass():
    """Discs r + d past the image's diagonal: cut to it, the prior still μ (|v| / (r + d))²."""
    from refsynth.synthesis.belief.gap_radius import gap_radius_candidates

    rng = np.random.default_rng(3)
    levels = quantise_intensity(rng.random((5, 6, 1)))
    partial = np.full((5, 6), np.nan)
    partial[:, 0] = rng.random(5) + 1.0  # the first column measured: depths 1 to 5
    rq, _, _ = quantise_range(partial)
    rows, cols = np.nonzero(np.isnan(partial))
    opts = dict(n=3, k=3, range_weight=1.0, missing_range="mean", channels="sum")
    got = gap_radius_candidates(levels, rq, rows, cols, radius=10.0, pad=2, proximity=0.7,
                                **opts)
    want = _per_depth_search(levels, rq, rows, cols, 10.0, 2, proximity=0.7, **opts)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1].view(np.int64), want[1].view(np.int64))


def test_the_one_pass_leaves_short_discs_to_the_widening_search():
    """search_at_radii stores a node only when its own disc holds k finite candidates."""
    from refsynth.synthesis.belief.search import search_at_radii, search_features

    rq = np.full((1, 9), -1)
    rq[0, [0, 8]] = [0, 65536]
    levels = np.zeros((1, 9, 1), dtype=np.int64)
    cols = np.arange(1, 8)
    radii = np.full(7, 6.5)  # from col c, the ends are c and 8 - c away
    labels, dist, done = search_at_radii(
        levels, rq, np.zeros(7, int), cols, radii, np.zeros(7), k=2, range_weight=1.0,
        missing_range="mean", features=search_features(levels, rq, 1))
    assert done.tolist() == [False, True, True, True, True, True, False]
    assert all(sorted(row) == [0, 8] for row in labels[done].tolist())
    assert np.isfinite(dist[done]).all()


def test_bp_fill_training_radius():
    rng = np.random.default_rng(6)
    image = rng.random((10, 16, 3))
    partial = np.where(np.arange(16) % 7 == 0, rng.random((10, 16)) + 1.0, np.nan)
    edges = np.zeros(partial.shape, bool)
    plain = bp_fill(image, partial, edges, radius=2.0)
    fixed = bp_fill(image, partial, edges, radius=2.0, training_radius="fixed")
    np.testing.assert_array_equal(plain.beliefs, fixed.beliefs)
    gap = bp_fill(image, partial, edges, radius=2.0, training_radius="gap")
    assert not np.array_equal(plain.candidates, gap.candidates)
    with pytest.raises(ValueError, match="`training_radius`"):
        bp_fill(image, partial, edges, training_radius="wide")
    image2, partial2 = _small()
    with pytest.raises(ValueError, match="`training_radius`"):
        refsynth.synthesize(image2, partial2, method="bp", readings={"training_radius": "wide"})
    with pytest.raises(ValueError, match="`training_radius` applies to method='bp' only"):
        refsynth.synthesize(image2, partial2, method="np", readings={"training_radius": "fixed"})
    for name in ("gap", "fixed"):
        out = refsynth.synthesize(image2, partial2, method="bp", radius=2.0,
                                  readings={"observation": "measured", "training_radius": name})
        want = bp_fill(image2[:, :, None], partial2, out.edges, radius=2.0,
                       training_radius=name, neighbourhood=out.params["neighbourhood"])
        np.testing.assert_array_equal(out.bp.range, want.range)
        np.testing.assert_array_equal(out.bp.beliefs, want.beliefs)
        assert out.params["training_radius"] == name


# -- observations completed by NP's fill (observation="np") --------------------------------


def test_np_observation_is_nps_fill_on_the_measured_ranges_unit_scale():
    from refsynth.synthesis.belief.observation import np_observation

    partial = np.array([[2.0, np.nan, 6.0, np.nan]])
    unit = np_observation(np.array([[2.0, 3.0, 6.0, 1.0]]), partial)
    assert unit.tolist() == [[0.0, 0.25, 1.0, -0.25]]
    # on the grid: the measured pixels are quantise_range's, a value below the minimum is 0
    rq, _, _ = quantise_range(partial)
    assert observed_ranges(rq, unit)[0].tolist() == [[0, 16384, 65536, 0]]


def test_observation_np_is_bp_on_nps_fill_from_the_same_seed():
    from refsynth.synthesis.belief.observation import np_observation
    from refsynth.synthesis.belief.proposals import np_proposals

    image, partial = _small()
    for seed in (0, 5):
        out = refsynth.synthesize(image, partial, method="bp", radius=3.0, seed=seed,
                                  readings={"observation": "np"})
        nps = refsynth.synthesize(image, partial, method="np", radius=3.0, seed=seed,
                                  readings={"gaps": "copy", "median": 0})   # NP's fill as filled
        want = bp_fill(image[:, :, None], partial, out.edges, radius=3.0,
                       observation=np_observation(nps.range, partial), training_radius="gap",
                       neighbourhood=out.params["neighbourhood"])
        np.testing.assert_array_equal(out.bp.range, want.range)
        np.testing.assert_array_equal(out.bp.beliefs, want.beliefs)
        assert out.params["observation"] == "np"
    # with proposals, NP runs once: its first proposal completes the observations
    both = refsynth.synthesize(image, partial, method="bp", radius=3.0, seed=5,
                               readings={"observation": "np", "proposals": "np"})
    proposals = np_proposals(image[:, :, None], partial, both.edges, np.random.default_rng(5),
                             neighbourhood=both.params["neighbourhood"], radius=3.0)
    want = bp_fill(image[:, :, None], partial, both.edges, radius=3.0, proposals=proposals,
                   proposal_phi="match", observation=np_observation(proposals[0], partial),
                   training_radius="gap", neighbourhood=both.params["neighbourhood"])
    np.testing.assert_array_equal(both.bp.range, want.range)
    np.testing.assert_array_equal(both.bp.beliefs, want.beliefs)


def test_observation_np_depends_on_the_seed_and_keeps_the_conventions():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (12, 14, 3)).astype(np.uint8)
    partial = np.where(np.arange(14) % 4 == 0, rng.random((12, 14)) * 3.0 + 1.0, np.nan)
    plain = refsynth.synthesize(image, partial, method="bp", radius=3.0,
                                readings={"observation": "np"})
    again = refsynth.synthesize(image, partial, method="bp", radius=3.0,
                                readings={"observation": "np"})
    np.testing.assert_array_equal(plain.range, again.range)
    other = [refsynth.synthesize(image, partial, method="bp", radius=3.0, seed=s,
                                 readings={"observation": "np"}).range for s in (1, 2, 3)]
    assert any(not np.array_equal(plain.range, o) for o in other)
    # an intensity offset, uint8 against the same values as floats, a range scale: bit for bit
    for intensity, rv, scale in ((image + 17.5, partial, 1.0), (image / 255.0, partial, 1.0),
                                 (image, partial * 41.0 + 3.0, 41.0)):
        out = refsynth.synthesize(intensity, rv, method="bp", radius=3.0,
                                  readings={"observation": "np"})
        np.testing.assert_allclose((out.range - (3.0 if scale != 1 else 0.0)) / scale,
                                   plain.range, rtol=1e-12)
        np.testing.assert_array_equal(out.bp.labels, plain.bp.labels)


def test_the_reference_runs_np_first_from_its_generator():
    from refsynth.synthesis import reference as ref

    image, partial = _small()
    edges = np.zeros(partial.shape, bool)
    with pytest.raises(TypeError, match="rng"):
        ref.bp_reference(image[:, :, None], partial, edges, radius=3.0, observation="np")
    slow = ref.bp_reference(image[:, :, None], partial, edges, radius=3.0, observation="np",
                            rng=np.random.default_rng(2))
    fast = refsynth.synthesize(image, partial, method="bp", radius=3.0, seed=2, edges=edges,
                               readings={"observation": "np"})
    np.testing.assert_array_equal(fast.range, slow.range)
    np.testing.assert_array_equal(fast.bp.beliefs, slow.beliefs)
