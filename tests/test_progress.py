"""Progress over the stages of a fill: BP reports as it goes, bits unchanged."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis.api import OBSERVATION_SHARE
from refsynth.synthesis.belief.fill import BP_STAGES, bp_fill
from refsynth.synthesis.completion import portable_colorization
from refsynth.synthesis.progress import PER_MILLE, StagedProgress


def _scene(height=24, width=40, seed=3):
    g = np.random.default_rng(seed)
    rows, cols = np.mgrid[:height, :width]
    image = np.where((cols > width // 2)[..., None], 0.7, 0.2) + 0.1 * g.random((height, width, 3))
    truth = np.where(cols > width // 2, 3.0 + 0.02 * rows, 1.5 + 0.01 * cols)
    partial = np.where(cols % 7 < 2, truth, np.nan)
    return image, partial


# ----------------------------------------------------------------------------- StagedProgress


@given(st.lists(st.floats(0.0, 10.0), min_size=1, max_size=6).filter(lambda s: sum(s) > 0),
       st.lists(st.tuples(st.integers(0, 5), st.integers(0, 20), st.integers(1, 20)),
                max_size=30))
def test_staged_reports_never_go_back_stay_in_their_share_and_end_at_the_total(shares, calls):
    seen = []
    staged = StagedProgress(lambda done, total: seen.append((done, total)), shares)
    starts = np.concatenate([[0.0], np.cumsum(shares) / sum(shares)])
    for index, done, total in calls:
        index %= len(shares)
        before = len(seen)
        staged.stage(index)(min(done, total), total)
        if len(seen) > before:  # a new report lies in the stage's share
            low, high = starts[index] * PER_MILLE, starts[index + 1] * PER_MILLE
            assert int(low) - 1 <= seen[-1][0] <= high + 1e-9
    staged.finish()
    values = [done for done, _ in seen]
    assert values == sorted(set(values))  # strictly increasing: no repeats, never back
    assert seen[-1] == (PER_MILLE, PER_MILLE) and all(total == PER_MILLE for _, total in seen)


def test_staged_maps_each_stage_onto_its_share():
    seen = []
    staged = StagedProgress(lambda done, total: seen.append(done), [1, 0, 3])
    staged.stage(0)(1, 4)
    staged.complete(0)
    staged.complete(1)  # an empty share adds nothing
    staged.stage(2)(2, 3)
    staged.finish()
    assert seen == [62, 250, 750, 1000]


def test_staged_without_a_callback_reports_nothing_and_bad_shares_are_refused():
    staged = StagedProgress(None, [1, 2])
    assert staged.stage(0) is None and staged.stage(1) is None
    staged.complete(0)
    staged.finish()
    for shares in ([], [0, 0], [1, -1]):
        with pytest.raises(ValueError, match="shares"):
            StagedProgress(lambda *_: None, shares)


# ----------------------------------------------------------------------------- the fills


def test_the_colorization_fill_reports_its_sweeps_and_changes_no_bit():
    image, partial = _scene()
    seen = []
    got, sweeps = portable_colorization(image, partial, return_sweeps=True,
                                        progress=lambda done, total: seen.append((done, total)))
    np.testing.assert_array_equal(got, portable_colorization(image, partial))
    assert sweeps > 10 and len(seen) > 5
    values = [done for done, _ in seen]
    assert values == sorted(set(values)) and seen[-1] == (PER_MILLE, PER_MILLE)
    assert all(0 <= done < PER_MILLE for done in values[:-1])


def _bp_reports(**readings):
    image, partial = _scene()
    seen = []
    result = refsynth.synthesize(image, partial, method="bp",
                                 progress=lambda done, total: seen.append((done, total)),
                                 readings=readings)
    plain = refsynth.synthesize(image, partial, method="bp", readings=readings)
    np.testing.assert_array_equal(result.range, plain.range)  # reporting changes no bit
    np.testing.assert_array_equal(result.confidence, plain.confidence)
    values = [done for done, _ in seen]
    assert values == sorted(set(values)) and seen[-1] == (PER_MILLE, PER_MILLE)
    assert all(total == PER_MILLE for _, total in seen)
    return values


def test_bp_reports_within_the_fill_the_search_and_the_messages():
    """BP reports inside each long stage's share, not only at the stage's ends."""
    values = _bp_reports()
    rest = sum(share for _, share in BP_STAGES)
    bounds = np.concatenate([[0.0, OBSERVATION_SHARE], OBSERVATION_SHARE + (
        1 - OBSERVATION_SHARE) * np.cumsum([share for _, share in BP_STAGES]) / rest])
    bounds = bounds * PER_MILLE
    for stage in (0, 1, 4):  # the observations' fill, the search, the messages
        low, high = bounds[stage], bounds[stage + 1]
        inside = [v for v in values if low + 1 < v < high - 1]
        assert len(inside) >= 2, (stage, low, high, values)


def test_fig6_bp_has_no_fill_stage_and_still_reports_as_it_goes():
    values = _bp_reports(observation="measured", training_radius="fixed")
    assert len(values) > 5


def test_bp_fill_alone_reports_per_mille_to_the_end():
    from refsynth.synthesis.api import validate_inputs

    image, partial = _scene()
    image, partial = validate_inputs(image, partial)
    seen = []
    bp_fill(image, partial, np.zeros(partial.shape, bool),
            progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (PER_MILLE, PER_MILLE) and len(seen) > 5


def test_bp_on_nps_fill_reports_nps_steps_within_their_share():
    from refsynth.synthesis.api import NP_OBSERVATION_SHARE

    values = _bp_reports(observation="np")
    # NP's fill reports as it goes inside the first share, BP's stages after it
    inside = [v for v in values if 1 < v < NP_OBSERVATION_SHARE * PER_MILLE - 1]
    assert len(inside) >= 2, values
    assert any(v > NP_OBSERVATION_SHARE * PER_MILLE + 1 for v in values[:-1])
    # with proposals NP runs once, before the stages: the reports still climb to the end
    assert _bp_reports(observation="np", proposals="np")[-1] == PER_MILLE
