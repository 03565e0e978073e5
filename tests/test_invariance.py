"""Invariances of the whole fill that the numeric contract makes exact.

The intensity convention (refsynth.synthesis.api): the intensity is brought to its own span
before Canny and Eq. 2, so an offset or a positive scale of it — and uint8 against the same
values as floats — change nothing, bit for bit; a positive scale of the range scales the
result and changes nothing else: bit for bit where every synthesized value is a copy (BP,
NP with Eq. 5's value copy), to rounding where NP shifts its copies (the default offset
copy: the decisions are the same, the values written differ by a few ulp).
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import refsynth
from refsynth.numeric import quantise_grey, quantise_intensity
from refsynth.synthesis.api import normalise_intensity

SOME = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def scenes(draw):
    """A small scene: 8-bit intensity (grey or colour) with structure, range, a random mask."""
    seed = draw(st.integers(0, 2**32 - 1))
    g = np.random.default_rng(seed)
    H, W = draw(st.integers(8, 14)), draw(st.integers(8, 14))
    C = draw(st.sampled_from([1, 3]))
    rows, cols = np.mgrid[:H, :W]
    base = np.where(cols > W // 2, 170, 40)[..., None] + g.integers(0, 60, (H, W, C))
    image = base.astype(np.uint8)
    image = image[..., 0] if C == 1 else image
    truth = np.round(1.0 + 3.0 * g.random((H, W)), draw(st.integers(0, 2)))
    known = g.random((H, W)) < draw(st.floats(0.25, 0.6))
    known[g.integers(H), g.integers(W)] = True
    known[g.integers(H), g.integers(W)] = False
    method = draw(st.sampled_from(["np", "bp"]))
    options = dict(method=method, seed=seed % 1000, neighbourhood=draw(st.sampled_from([3, 5])),
                   radius=4.0, readings={"colour": draw(st.booleans())})
    if method == "bp":
        options.update(candidates=3, iterations=5)
    else:
        options["readings"]["range_copy"] = draw(st.sampled_from(["offset", "value"]))
    return image, np.where(known, truth, np.nan), options


def _same(a, b, range_scale=1.0):
    if range_scale != 1.0 and a.params.get("range_copy") == "offset":
        np.testing.assert_allclose(a.range * range_scale, b.range, rtol=1e-12, atol=0)
    else:
        np.testing.assert_array_equal(a.range * range_scale, b.range)
    np.testing.assert_array_equal(a.confidence, b.confidence)
    np.testing.assert_array_equal(a.order, b.order)
    np.testing.assert_array_equal(a.edges, b.edges)
    if a.bp is not None:
        np.testing.assert_array_equal(a.bp.messages, b.bp.messages)


@SOME
@given(scenes(), st.floats(-50.0, 50.0), st.floats(0.01, 300.0))
def test_an_offset_and_a_positive_scale_of_the_intensity_change_nothing(scene, offset, scale):
    image, partial, options = scene
    plain = refsynth.synthesize(image, partial, **options)
    _same(plain, refsynth.synthesize(image * scale + offset, partial, **options))


@SOME
@given(scenes())
def test_uint8_and_the_same_values_as_floats_give_the_same_result(scene):
    image, partial, options = scene
    plain = refsynth.synthesize(image, partial, **options)
    _same(plain, refsynth.synthesize(image.astype(np.float64), partial, **options))   # 0–255
    _same(plain, refsynth.synthesize(image / 255.0, partial, **options))              # 0–1
    _same(plain, refsynth.synthesize(image.astype(np.uint16) * 257, partial, **options))


@SOME
@given(scenes(), st.floats(0.001, 1000.0))
def test_a_positive_scale_of_the_range_scales_the_result(scene, scale):
    image, partial, options = scene
    plain = refsynth.synthesize(image, partial, **options)
    _same(plain, refsynth.synthesize(image, partial * scale, **options), range_scale=scale)


@SOME
@given(scenes())
def test_grey_eq2_is_eq2_on_the_grey_level_image(scene):
    """colour=False compares the grey level of the quantised intensity: the same as passing
    that grey level as the image (and Canny sees the same image either way)."""
    image, partial, options = scene
    levels = quantise_grey(quantise_intensity(normalise_intensity(image))) / 2.0**16
    options = dict(options, readings={**options["readings"], "colour": False})
    _same(refsynth.synthesize(levels, partial, **options),
          refsynth.synthesize(image, partial, **options))
