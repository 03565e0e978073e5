"""NP's copy shifted by the windows' consistent range difference (range_copy="offset")."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.numeric import RANGE_BITS, window_weights
from refsynth.synthesis.range_copy import (
    NP_OBSERVATION_TOLERANCE,
    OFFSET_BITS,
    OFFSET_TOLERANCE,
    check_offset_tolerance,
    default_offset_tolerance,
    offset_shift,
    offset_shifts,
    shifted_value,
    shifted_values,
)

G5 = window_weights(5).ravel().astype(np.float64)


def _oracle(target, source, has_target, has_source, weights, tolerance_bits=OFFSET_BITS):
    """The shift by exact fractions, written out (an independent copy of the rule), with the
    agreement ``2**-tolerance_bits`` of the span."""
    pairs = [(int(w), int(t) - int(s)) for t, s, a, b, w in
             zip(target, source, has_target, has_source, weights, strict=True) if a and b]
    if not pairs:
        return 0
    a = sum(w for w, _ in pairs)
    mean = Fraction(sum(w * d for w, d in pairs), a)
    if any(abs(d - mean) > Fraction(2**RANGE_BITS, 2**tolerance_bits) for _, d in pairs):
        return 0
    return round(mean)  # Fraction rounds half to even


windows = st.integers(0, 2**32 - 1).map(np.random.default_rng)


@given(windows, st.integers(-3000, 3000), st.sampled_from([0, 1, 40, 600, 5000]))
def test_the_shift_is_the_exact_rounded_weighted_mean_when_the_differences_agree(g, base,
                                                                                  spread):
    source = g.integers(0, 2**16, 25).astype(np.float64)
    target = source + base + g.integers(-spread, spread + 1, 25)
    has_t, has_s = g.random(25) < 0.7, g.random(25) < 0.8
    got = offset_shift(target, source, has_t, has_s, G5)
    assert got == _oracle(target, source, has_t, has_s, G5)
    if (has_t & has_s).any() and spread == 0:
        assert got == base  # a plane shifted by `base`: the shift is exact


@given(windows)
def test_the_shift_is_antisymmetric(g):
    source = g.integers(0, 2**16, 25).astype(np.float64)
    target = source + g.integers(-800, 800) + g.integers(-300, 301, 25)
    both = g.random(25) < 0.6
    assert offset_shift(source, target, both, both, G5) == -offset_shift(target, source, both,
                                                                         both, G5)


def test_no_shared_range_or_one_disagreeing_difference_gives_no_shift():
    source = np.full(25, 1000.0)
    target = source + 40
    none = np.zeros(25, dtype=bool)
    every = np.ones(25, dtype=bool)
    assert offset_shift(target, source, none, every, G5) == 0
    assert offset_shift(target, source, every, every, G5) == 40
    step = target.copy()
    step[7] += 5000  # one pixel across a depth edge: 4400 from the weighted mean
    assert offset_shift(step, source, every, every, G5) == 0
    only_step = every.copy()
    only_step[7] = False  # ... unless that pixel has no range in one of the windows
    assert offset_shift(step, source, only_step, every, G5) == 40


def test_the_shifted_value_stays_in_the_measured_span():
    assert shifted_value(65000, 1000) == 2**RANGE_BITS
    assert shifted_value(10, -11) == 0
    assert shifted_value(500, -11) == 489


def _ramp(height=20, width=39, slope=0.05):
    """A textured image over a slanted plane, known on x-stripes (3 known, 6 unknown).

    The first and last columns are measured: the plane stays within the measured span, to
    which a shifted value is clipped.
    """
    g = np.random.default_rng(5)
    rows, cols = np.mgrid[:height, :width]
    image = g.random((height, width, 3))
    truth = 2.0 + slope * cols + 0.01 * rows
    partial = np.where(cols % 9 < 3, truth, np.nan)
    return image, truth, partial


def test_a_slanted_plane_fills_as_a_plane_with_the_shift_and_as_steps_without():
    image, truth, partial = _ramp()
    unknown = np.isnan(partial)
    span = np.nanmax(partial) - np.nanmin(partial)
    # the fill as filled (gaps="copy", median=0): the gap reading would draw the line across
    # the gaps
    shifted = refsynth.synthesize(image, partial, seed=0, readings={"gaps": "copy", "median": 0})
    copied = refsynth.synthesize(image, partial, seed=0,
                                 readings={"range_copy": "value", "gaps": "copy", "median": 0})
    error_shifted = np.abs(shifted.range - truth)[unknown]
    error_copied = np.abs(copied.range - truth)[unknown]
    assert error_shifted.max() <= 2 * span * 2.0**-RANGE_BITS  # the grid's rounding, twice
    assert error_copied.mean() > 50 * error_shifted.mean()
    assert set(copied.range[unknown]) <= set(partial[~unknown])


def test_an_intensity_offset_changes_nothing_and_a_range_scale_scales_to_rounding():
    image, _, partial = _ramp()
    plain = refsynth.synthesize(image, partial, seed=1, readings={"range_copy": "offset"})
    moved = refsynth.synthesize(image * 0.5 + 0.25, partial, seed=1,
                                readings={"range_copy": "offset"})
    np.testing.assert_array_equal(plain.range, moved.range)
    scaled = refsynth.synthesize(image, partial * 3.7, seed=1, readings={"range_copy": "offset"})
    np.testing.assert_array_equal(plain.order, scaled.order)
    np.testing.assert_array_equal(plain.confidence, scaled.confidence)
    np.testing.assert_allclose(plain.range * 3.7, scaled.range, rtol=1e-12)


def test_bad_range_copy_is_refused_by_name_before_any_work():
    image, _, partial = _ramp()
    for method in ("np", "bp"):
        with pytest.raises(ValueError, match="`range_copy` must be one of"):
            refsynth.synthesize(image, partial, method=method, readings={"range_copy": "shift"})


# -- BP's labels (0.6) --------------------------------------------------------------------


def _window_pairs(g, spread, rows=30):
    """Thirty pairs of 5×5 windows: the target a shifted source plus noise up to ``spread``,
    each with range at about 70 % and 80 % of its offsets."""
    source = g.integers(0, 2**16, (rows, 25))
    target = source + g.integers(-3000, 3000, (rows, 1)) + g.integers(-spread, spread + 1,
                                                                          (rows, 25))
    target = np.maximum(target, 0)
    has_t, has_s = g.random((rows, 25)) < 0.7, g.random((rows, 25)) < 0.8
    return target, source, has_t, has_s


@given(windows, st.sampled_from([0, 3, 40, 600, 5000]))
def test_the_shifts_of_many_windows_are_the_shift_of_each(g, spread):
    target, source, has_t, has_s = _window_pairs(g, spread)
    got = offset_shifts(np.where(has_t, target, -1), np.where(has_s, source, -1), G5)
    want = [_oracle(t, s_, a, b, G5) for t, s_, a, b in zip(target, source, has_t, has_s,
                                                             strict=True)]
    assert got.tolist() == want


def test_the_shifts_of_many_windows_round_exact_halves_to_even():
    """Mean differences of exactly k + 1/2, k odd and even, of either sign: half to even, as
    :func:`offset_shift` (random windows almost never meet these ties)."""
    weights = np.ones(4)
    source = np.full((4, 4), 1000)
    deltas = np.array([[1, 2, 1, 2], [2, 3, 2, 3], [-1, -2, -1, -2], [-2, -3, -2, -3]])
    got = offset_shifts(source + deltas, source, weights)
    assert got.tolist() == [2, 2, -2, -2]  # 1.5, 2.5, -1.5, -2.5
    full = np.ones(4, dtype=bool)
    assert got.tolist() == [offset_shift((s + d).astype(float), s.astype(float), full, full,
                                         weights) for s, d in zip(source, deltas, strict=True)]


@given(windows)
def test_the_shifted_values_are_nps_arithmetic(g):
    q = g.integers(0, 2**16 + 1, 40)
    shift = g.integers(-2**15, 2**15, 40) * (g.random(40) < 0.7)
    low, span = 1.5, 3.25
    source = low + q * span * 2.0**-RANGE_BITS
    now, values = shifted_values(q, shift, source, span, low, low + span)
    for i in range(40):
        assert now[i] == shifted_value(int(q[i]), int(shift[i]))
        if now[i] == q[i]:
            assert values[i] == source[i]  # bit for bit: the value copy's
        else:  # as nonparametric.np_fill writes it
            step = span * 2.0**-RANGE_BITS
            assert values[i] == min(max((int(now[i]) - int(q[i])) * step + source[i], low),
                                    low + span)


def test_bps_labels_fill_a_slanted_plane_as_a_plane_with_the_shift_and_as_steps_without():
    # intensity that varies down the rows only: the colorization fill (BP's observations) is
    # then the plane itself, to its solver's tolerance, and every label's shift is taken
    rows, cols = np.mgrid[:20, :39]
    image, truth = 0.3 + 0.02 * rows, 2.0 + 0.05 * cols
    partial = np.where(cols % 9 < 3, truth, np.nan)
    unknown = np.isnan(partial)
    shifted = refsynth.synthesize(image, partial, method="bp",
                                  readings={"gaps": "copy", "median": 0})
    copied = refsynth.synthesize(image, partial, method="bp",
                                 readings={"range_copy": "value", "gaps": "copy", "median": 0})
    error_shifted = np.abs(shifted.range - truth)[unknown]
    error_copied = np.abs(copied.range - truth)[unknown]
    assert set(copied.range[unknown]) <= set(partial[~unknown])
    assert not set(shifted.range[unknown]) <= set(partial[~unknown])
    assert error_shifted.max() < 0.002  # a few steps of the 2**-16 grid and the fill's tolerance
    assert error_copied.mean() > 50 * error_shifted.mean()
    # the chosen value is the chosen label's moved centre
    chosen = shifted.bp.candidate_values[np.arange(len(shifted.bp.labels)), shifted.bp.labels]
    np.testing.assert_array_equal(chosen, shifted.range[shifted.order[:, 0],
                                                        shifted.order[:, 1]])


def test_bps_shift_ignores_an_intensity_offset_and_scales_with_the_range():
    image, _, partial = _ramp()
    plain = refsynth.synthesize(image, partial, method="bp")
    moved = refsynth.synthesize(image * 0.5 + 0.25, partial, method="bp")
    np.testing.assert_array_equal(plain.range, moved.range)
    scaled = refsynth.synthesize(image, partial * 3.7, method="bp")
    np.testing.assert_array_equal(plain.bp.labels, scaled.bp.labels)
    np.testing.assert_allclose(plain.range * 3.7, scaled.range, rtol=1e-12)


# -- the agreement BP's shift needs (offset_tolerance) ---------------------------------------


@given(windows, st.integers(0, 16), st.sampled_from([0, 40, 600, 5000, 20000]))
def test_the_shifts_at_any_tolerance_are_the_exact_rule_at_that_tolerance(g, bits, spread):
    target, source, has_t, has_s = _window_pairs(g, spread)
    tolerance = 2.0**-bits
    got = offset_shifts(np.where(has_t, target, -1), np.where(has_s, source, -1), G5,
                        tolerance)
    want = [_oracle(t, s_, a, b, G5, bits) for t, s_, a, b in zip(target, source, has_t, has_s,
                                                                   strict=True)]
    assert got.tolist() == want
    one = [offset_shift(t.astype(float), s_.astype(float), a, b, G5, tolerance)
           for t, s_, a, b in zip(target, source, has_t, has_s, strict=True)]
    assert got.tolist() == one
    # a looser agreement shifts every window a tighter one shifts, by the same amount
    if bits > 0:
        looser = offset_shifts(np.where(has_t, target, -1), np.where(has_s, source, -1), G5,
                               2 * tolerance)
        taken = got != 0
        assert looser[taken].tolist() == got[taken].tolist()


def test_the_tolerance_decides_a_window_at_its_boundary():
    """Differences 0 and 2d (mean d, every difference d from it): shifted exactly when
    d <= 2**16 t."""
    weights = np.ones(2)
    both = np.ones(2, dtype=bool)
    for bits in (3, 7):
        slack = 2**(RANGE_BITS - bits)
        for d, taken in ((slack, True), (slack + 1, False)):
            target, source = np.array([1000.0, 1000.0 + 2 * d]), np.array([1000.0, 1000.0])
            got = offset_shift(target, source, both, both, weights, 2.0**-bits)
            assert got == (d if taken else 0)
            assert offset_shifts(target[None].astype(np.int64), source[None].astype(np.int64),
                                 weights, 2.0**-bits).tolist() == [got]


def test_the_tolerance_is_a_power_of_two_from_2_to_the_minus_16_to_1():
    assert check_offset_tolerance(1) == 1.0 and check_offset_tolerance(2.0**-16) == 2.0**-16
    for bad in (0.0, 0.1, 3 * 2.0**-5, 2.0**-17, 2.0, -0.125):
        with pytest.raises(ValueError, match="`offset_tolerance` must be a power of two"):
            check_offset_tolerance(bad)
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match="`offset_tolerance` must be finite"):
            check_offset_tolerance(bad)
    for bad in ("0.125", None, True):
        with pytest.raises(TypeError, match="`offset_tolerance`"):
            check_offset_tolerance(bad)
    # None: BP's default observation, NP's fill
    for observation in ("np", None):
        assert default_offset_tolerance(observation) == NP_OBSERVATION_TOLERANCE == 2.0**-3
    for observation in ("colorization", "measured", "colorization-completed"):
        assert default_offset_tolerance(observation) == OFFSET_TOLERANCE == 2.0**-7


def test_synthesize_takes_the_tolerance_for_bp_only_and_records_the_one_it_used():
    image, _, partial = _ramp()
    assert refsynth.synthesize(image, partial, method="bp").params["offset_tolerance"] == 2**-3
    on_np = refsynth.synthesize(image, partial, method="bp", readings={"observation": "np"})
    assert on_np.params["offset_tolerance"] == 2**-3
    for observation in ("colorization", "colorization-completed", "measured"):
        other = refsynth.synthesize(image, partial, method="bp",
                                    readings={"observation": observation})
        assert other.params["offset_tolerance"] == 2**-7
    given = refsynth.synthesize(image, partial, method="bp", readings={"offset_tolerance": 0.5})
    assert given.params["offset_tolerance"] == 0.5
    with pytest.raises(ValueError, match="`offset_tolerance` applies to method='bp' only"):
        refsynth.synthesize(image, partial, method="np", readings={"offset_tolerance": 0.125})
    with pytest.raises(ValueError, match="`offset_tolerance` must be a power of two"):
        refsynth.synthesize(image, partial, method="bp", readings={"offset_tolerance": 0.1})


def test_bps_tolerance_reaches_the_labels_and_the_reference_agrees():
    """A rough slanted surface: the labels' windows disagree by more than 2**-7 of the span
    and less than 2**-1, so the tolerance changes BP's result; the literal reference gives
    the same bits at both."""
    from refsynth.synthesis import reference as ref

    g = np.random.default_rng(5)
    rows, cols = np.mgrid[0:12, 0:14]
    image = (0.5 + 0.4 * np.sin(cols / 2.0) + 0.05 * g.random((12, 14)))
    truth = 2.0 + 0.3 * cols + 0.2 * g.random((12, 14))
    partial = np.where(cols % 3 == 0, truth, np.nan)
    edges = np.zeros(partial.shape, dtype=bool)
    for observation in ("np", "colorization"):   # NP's fill (the default, seed 0) or not
        out = {}
        for tolerance in (2.0**-7, 2.0**-1):
            fast = refsynth.synthesize(image, partial, method="bp", radius=3.0, edges=edges,
                                       readings={"offset_tolerance": tolerance,
                                                 "observation": observation})
            slow = ref.bp_reference(image[:, :, None], partial, edges, radius=3.0,
                                    offset_tolerance=tolerance, observation=observation,
                                    rng=np.random.default_rng(0))
            np.testing.assert_array_equal(fast.range, slow.range)
            out[tolerance] = fast.range
        assert not np.array_equal(out[2.0**-7], out[2.0**-1]), observation
