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
    OFFSET_BITS,
    offset_shift,
    offset_shifts,
    shifted_value,
    shifted_values,
)

G5 = window_weights(5).ravel().astype(np.float64)


def _oracle(target, source, has_target, has_source, weights):
    """The shift by exact fractions, written out (an independent copy of the rule)."""
    pairs = [(int(w), int(t) - int(s)) for t, s, a, b, w in
             zip(target, source, has_target, has_source, weights, strict=True) if a and b]
    if not pairs:
        return 0
    a = sum(w for w, _ in pairs)
    mean = Fraction(sum(w * d for w, d in pairs), a)
    if any(abs(d - mean) > Fraction(2**RANGE_BITS, 2**OFFSET_BITS) for _, d in pairs):
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
    shifted = refsynth.synthesize(image, partial, seed=0)  # the default since 0.5
    copied = refsynth.synthesize(image, partial, seed=0, range_copy="value")
    error_shifted = np.abs(shifted.range - truth)[unknown]
    error_copied = np.abs(copied.range - truth)[unknown]
    assert error_shifted.max() <= 2 * span * 2.0**-RANGE_BITS  # the grid's rounding, twice
    assert error_copied.mean() > 50 * error_shifted.mean()
    assert set(copied.range[unknown]) <= set(partial[~unknown])


def test_an_intensity_offset_changes_nothing_and_a_range_scale_scales_to_rounding():
    image, _, partial = _ramp()
    plain = refsynth.synthesize(image, partial, seed=1, range_copy="offset")
    moved = refsynth.synthesize(image * 0.5 + 0.25, partial, seed=1, range_copy="offset")
    np.testing.assert_array_equal(plain.range, moved.range)
    scaled = refsynth.synthesize(image, partial * 3.7, seed=1, range_copy="offset")
    np.testing.assert_array_equal(plain.order, scaled.order)
    np.testing.assert_array_equal(plain.confidence, scaled.confidence)
    np.testing.assert_allclose(plain.range * 3.7, scaled.range, rtol=1e-12)


def test_bad_range_copy_is_refused_by_name_before_any_work():
    image, _, partial = _ramp()
    for method in ("np", "bp"):
        with pytest.raises(ValueError, match="`range_copy` must be one of"):
            refsynth.synthesize(image, partial, method=method, range_copy="shift")


# -- BP's labels (0.6) --------------------------------------------------------------------


@given(windows, st.sampled_from([0, 3, 40, 600, 5000]))
def test_the_shifts_of_many_windows_are_the_shift_of_each(g, spread):
    rows = 30
    source = g.integers(0, 2**16, (rows, 25))
    target = source + g.integers(-3000, 3000, (rows, 1)) + g.integers(-spread, spread + 1,
                                                                          (rows, 25))
    target = np.maximum(target, 0)
    has_t, has_s = g.random((rows, 25)) < 0.7, g.random((rows, 25)) < 0.8
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
    shifted = refsynth.synthesize(image, partial, method="bp")  # the default since 0.6
    copied = refsynth.synthesize(image, partial, method="bp", range_copy="value")
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
