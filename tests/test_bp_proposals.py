"""BP's proposals (a departure from Fig. 6): refsynth.synthesis.belief.proposals."""

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

import refsynth
from refsynth.numeric import quantise_range
from refsynth.synthesis.belief.fill import bp_fill
from refsynth.synthesis.belief.proposals import np_proposals, proposal_frame
from refsynth.synthesis.readings import split_options


def _scene(h=14, w=18):
    """Two flat surfaces split at a column, intensity telling them apart; x-stripes known."""
    cols = np.arange(w)
    image = np.where(cols < w // 2, 0.2, 0.8) + 0.05 * np.sin(np.arange(h))[:, None]
    truth = np.where(cols < w // 2, 2.0, 5.0) + 0.1 * np.arange(h)[:, None]
    known = np.zeros((h, w), bool)
    known[:, ::5] = True
    return image, truth, np.where(known, truth, np.nan)


IMAGE, TRUTH, PARTIAL = _scene()


def test_default_is_the_paper_bit_for_bit():
    plain = refsynth.synthesize(IMAGE, PARTIAL, method="bp", seed=3)
    none = refsynth.synthesize(IMAGE, PARTIAL, method="bp", seed=3, readings={"proposals": None})
    for name in ("range", "confidence", "order", "candidate_values"):
        np.testing.assert_array_equal(getattr(none, name), getattr(plain, name))
    np.testing.assert_array_equal(none.bp.unary, plain.bp.unary)
    np.testing.assert_array_equal(none.bp.messages, plain.bp.messages)
    assert none.params == plain.params and "proposals" not in plain.params
    assert plain.candidate_values.shape[1] == 8


def test_the_proposals_frame_holds_each_proposal_centred_on_its_node():
    h, w, n = 6, 7, 3
    rng = np.random.default_rng(1)
    rv = rng.uniform(1, 4, (h, w))
    rv[:, 1:3] = np.nan
    rv[4, 5] = np.nan
    props = rng.uniform(0, 5, (2, h, w))  # beyond the known span on both sides
    rq, low, span = quantise_range(rv)
    flat = np.flatnonzero(np.isnan(rv))
    labels = np.tile(np.flatnonzero(np.isfinite(rv))[:3], (flat.size, 1))
    dist = np.tile([0.1, 0.2, 0.3], (flat.size, 1))
    f = proposal_frame(rv, rq, low, span, props, labels, dist, flat, n, phi="best")
    assert f.labels.shape == (flat.size, 5) and f.halo == 1
    np.testing.assert_array_equal(f.labels[:, :3], labels)
    np.testing.assert_array_equal(f.distance, np.column_stack([dist, dist[:, :1], dist[:, :1]]))
    windows = sliding_window_view(f.plane, (n, n))
    for s in range(2):
        values = np.where(np.isfinite(rv), rv, props[s])
        grid = np.where(np.isfinite(rv), rq, np.maximum(
            np.rint((values - low) / span * 2.0**16), 0.0))
        padded = np.pad(grid, 1, constant_values=-1.0)
        for i, p in enumerate(flat):
            r, c = divmod(int(f.labels[i, 3 + s]), w)
            pr, pc = divmod(int(p), w)
            assert f.position(f.labels[i, 3 + s], w, h) == (pr, pc)
            np.testing.assert_array_equal(windows[r, c], padded[pr : pr + n, pc : pc + n])
            assert f.centre[r, c] == values[pr, pc]
            assert f.centre_q[r, c] == int(np.rint((values[pr, pc] - low) / span * 2**16))
    # the measured frame is the measured range: training labels read their own patches
    measured = np.pad(np.where(np.isfinite(rv), rq, -1).astype(float), 1, constant_values=-1)
    np.testing.assert_array_equal(f.plane[: h + 2], measured)
    np.testing.assert_array_equal(f.centre[:h], np.where(np.isfinite(rv), rv, 0.0))
    # completed: the measured frame's unknown pixels hold the first proposal
    g = proposal_frame(rv, rq, low, span, props, labels, dist, flat, n, completed=True)
    assert np.all(g.plane[1 : h + 1, 1 : w + 1] >= 0)
    np.testing.assert_array_equal(g.plane[h + 2 :], f.plane[h + 2 :])


@pytest.mark.parametrize("phi", ["match", "twin", "best", "worst", "zero"])
def test_the_proposals_distance(phi):
    rv = np.array([[1.0, np.nan, 3.0, np.nan]])
    rq, low, span = quantise_range(rv)
    flat = np.array([1, 3])
    labels = np.array([[0, 2], [2, 0]])
    dist = np.array([[0.1, 0.4], [0.2, 0.3]])
    props = np.array([[1.0, 3.0, 3.0, 2.0]])  # node 1 proposes 3 (candidate 2), node 3 2
    f = proposal_frame(rv, rq, low, span, props, labels, dist, flat, 1, phi=phi)
    expected = {"match": [0.4, 0.3], "twin": [0.4, 0.2], "best": [0.1, 0.2], "worst": [0.4, 0.3],
                "zero": [0.0, 0.0]}[phi]
    np.testing.assert_array_equal(f.distance[:, 2], expected)
    if phi == "match":  # above, node 3 proposed 2, which no candidate proposes: the worst;
        # here each proposal has a twin among the candidates: its distance
        g = proposal_frame(rv, rq, low, span, np.array([[1.0, 1.0, 3.0, 3.0]]), labels, dist,
                           flat, 1, phi="match")
        np.testing.assert_array_equal(g.distance[:, 2], [0.1, 0.2])


@pytest.mark.parametrize("phi", ["best", "zero", "match"])
def test_proposals_equal_to_the_truth_give_ceiling_zero_and_bp_recovers_it(phi):
    from refsynth.synthesis.api import validate_inputs

    image, rv = validate_inputs(IMAGE, PARTIAL)
    edges = np.zeros(rv.shape, bool)
    plain = bp_fill(image, rv, edges, radius=3.0)
    unknown = np.isnan(PARTIAL)
    truth = TRUTH[unknown]
    assert np.abs(plain.range[unknown] - truth).mean() > 0.01  # the paper's BP misses
    result = bp_fill(image, rv, edges, radius=3.0, proposals=TRUTH, proposal_phi=phi)
    assert result.candidate_values.shape == (unknown.sum(), 9)
    np.testing.assert_array_equal(result.candidate_values[:, -1], truth)
    np.testing.assert_array_equal(result.candidate_values[:, :8], plain.candidate_values)
    np.testing.assert_array_equal(result.candidates[:, -1], result.order)
    assert np.abs(result.candidate_values - truth[:, None]).min(axis=1).max() == 0.0
    assert np.all(result.range[~unknown] == PARTIAL[~unknown])
    if phi == "match":  # a proposal no better than its twin among the candidates: BP's choice
        # stands where the twin ranks low (here beside the step), never worse than the paper's
        error = np.abs(result.range - TRUTH)[unknown]
        assert error.mean() <= np.abs(plain.range - TRUTH)[unknown].mean()
    else:  # as likely as the best match (or Eq. 2's 0): the truth, exactly
        np.testing.assert_array_equal(result.range, TRUTH)


def test_np_proposals_are_nps_fills_from_the_same_seed():
    # on the colorization fill's observations, against which no proposal here is shifted
    # (on NP's fill, the default, the second proposal's labels take the offset copy's shift
    # against the first, which is the observation)
    result = refsynth.synthesize(IMAGE, PARTIAL, method="bp", seed=4,
                                 readings={"proposals": "np", "proposal_runs": 2,
                                           "observation": "colorization"})
    first = refsynth.synthesize(IMAGE, PARTIAL, method="np", seed=4,
                                readings={"gaps": "copy", "median": 0})   # NP's fill as filled
    rows, cols = result.order[:, 0], result.order[:, 1]
    assert result.candidate_values.shape[1] == 10
    np.testing.assert_array_equal(result.candidate_values[:, 8], first.range[rows, cols])
    rng = np.random.default_rng(4)
    from refsynth.synthesis.api import validate_inputs
    image, rv = validate_inputs(IMAGE, PARTIAL)
    both = np_proposals(image, rv, result.edges, rng, runs=2,
                        neighbourhood=result.params["neighbourhood"])   # the window reading's
    np.testing.assert_array_equal(both[0], first.range)
    np.testing.assert_array_equal(result.candidate_values[:, 9], both[1][rows, cols])
    again = refsynth.synthesize(IMAGE, PARTIAL, method="bp", seed=4,
                                readings={"proposals": "np", "proposal_runs": 2,
                                          "observation": "colorization"})
    np.testing.assert_array_equal(again.range, result.range)
    assert result.params["proposals"] == "np" and result.params["proposal_runs"] == 2
    assert np.all(np.isfinite(result.range))


def test_completed_changes_only_the_training_patches():
    # with the labels' values copied (Fig. 6); the offset copy's shifts are read off the
    # training patches, so with it the completed patches move the candidates' values too
    a = refsynth.synthesize(IMAGE, PARTIAL, method="bp", seed=0,
                            readings={"proposals": "np", "range_copy": "value"})
    b = refsynth.synthesize(IMAGE, PARTIAL, method="bp", seed=0,
                            readings={"proposals": "np-completed", "range_copy": "value"})
    np.testing.assert_array_equal(a.candidate_values, b.candidate_values)
    assert not np.array_equal(a.bp.unary, b.bp.unary)  # the measured neighbours' terms


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"method": "bp", "proposals": "nope"}, ValueError, "`proposals` must be one of"),
    ({"method": "bp", "proposals": 1}, ValueError, "`proposals`"),
    ({"method": "np", "proposals": "np"}, ValueError, "`proposals` applies to method='bp'"),
    ({"method": "bp", "proposals": "np", "proposal_runs": 0}, ValueError, "`proposal_runs`"),
    ({"method": "bp", "proposals": "np", "proposal_runs": 1.5}, TypeError, "`proposal_runs`"),
    ({"method": "bp", "proposal_runs": 2}, ValueError, "`proposal_runs` needs `proposals`"),
])
def test_bad_proposals_are_refused_before_any_work(kwargs, error, match):
    calls = []
    with pytest.raises(error, match=match):
        keywords, readings = split_options(kwargs)
        refsynth.synthesize(IMAGE, PARTIAL, progress=lambda *a: calls.append(a), **keywords,
                            readings=readings)
    assert calls == []


def test_bp_fill_refuses_proposals_of_the_wrong_shape_or_with_holes():
    from refsynth.synthesis.api import validate_inputs

    image, rv = validate_inputs(IMAGE, PARTIAL)
    edges = np.zeros(rv.shape, bool)
    with pytest.raises(ValueError, match="`proposals` must have shape"):
        bp_fill(image, rv, edges, proposals=TRUTH[:, :-1])
    holes = TRUTH.copy()
    holes[0, 1] = np.nan
    with pytest.raises(ValueError, match="`proposals` must be finite"):
        bp_fill(image, rv, edges, proposals=holes)
