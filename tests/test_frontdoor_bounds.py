"""Every parameter of ``synthesize`` bounded before the work starts.

Each test's docstring says what the value did unchecked.
Validation only refuses: a radius beyond the image runs as the image's reach and gives the
result the given radius gives, bit for bit.
"""

import io
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.cli.synth import pixel_progress
from refsynth.synthesis import reference as ref
from refsynth.synthesis import validate_inputs
from refsynth.synthesis.belief.fill import bp_fill
from refsynth.synthesis.limits import PARAMETER_BOUNDS, image_reach, search_radius
from refsynth.synthesis.nonparametric import np_fill
from refsynth.synthesis.readings import split_options

RNG = np.random.default_rng(14)
IMAGE = RNG.random((12, 12, 3))
PARTIAL = np.full((12, 12), np.nan)
PARTIAL[:, ::4] = RNG.random((12, 3)) * 3 + 1
KNOWN = np.isfinite(PARTIAL)


def _sane(result, partial=PARTIAL):
    """The invariants of every result: measured kept, copied values (NP's default offset copy:
    within the measured span), confidence in [0, 1]."""
    known = np.isfinite(partial)
    assert np.array_equal(result.range[known], partial[known])
    if result.params.get("range_copy") == "offset":
        low, high = partial[known].min(), partial[known].max()
        assert np.all((result.range >= low) & (result.range <= high))
    else:
        assert np.isin(result.range[~known], partial[known]).all()
    assert np.isfinite(result.confidence).all()
    assert result.confidence.min() >= 0 and result.confidence.max() <= 1


def _same(a, b):
    assert np.array_equal(a.range, b.range) and np.array_equal(a.confidence, b.confidence)
    assert np.array_equal(a.order, b.order)


# ----------------------------------------------------------------------------- item 7: spans


@pytest.mark.parametrize("method", ["np", "bp"])
def test_a_range_whose_span_overflows_is_refused(method):
    """Unchecked: -1e308..1e308 ran on NaN quantised range (int64 garbage, or an IndexError)."""
    partial = PARTIAL.copy()
    partial[0, 0], partial[0, 4] = -1e308, 1e308
    with pytest.raises(ValueError, match="`partial_range` spans -1e.308 to 1e.308: max − min"):
        refsynth.synthesize(IMAGE, partial, method=method)


def test_an_intensity_whose_span_overflows_is_refused():
    """Unchecked: accepted; the quantised intensity was garbage (NaN cast to int64)."""
    image = IMAGE.copy()
    image[0, 0, 0], image[1, 1, 1] = -1e308, 1e308
    with pytest.raises(ValueError, match="`intensity` spans"):
        refsynth.synthesize(image, PARTIAL)


def test_huge_and_tiny_ranges_whose_span_is_finite_still_run():
    for scale in (1e300, 1e-300):
        _sane(refsynth.synthesize(IMAGE, PARTIAL * scale), PARTIAL * scale)


# ----------------------------------------------------------------------------- item 7: bounds


BOUNDED = [("np", "range_weight"), ("bp", "range_weight"), ("np", "epsilon"),
           ("bp", "proximity"), ("bp", "sigma_i"), ("bp", "sigma_s")]


@pytest.mark.parametrize(("method", "name"), BOUNDED)
def test_each_bounded_parameter_runs_at_its_bounds(method, name):
    low, high = PARAMETER_BOUNDS[name]
    for value in (low, high):
        keywords, readings = split_options({name: value})
        _sane(refsynth.synthesize(IMAGE, PARTIAL, method=method, **keywords, readings=readings))


@pytest.mark.parametrize(("method", "name"), BOUNDED)
def test_each_bounded_parameter_is_refused_beyond_its_bounds_naming_the_range(method, name):
    """Unchecked: range_weight or proximity 1e308 gave NaN confidence; sigma_i / sigma_s at 1e-200
    and below NaN confidence; 1e200 was accepted though Eqs. 6-7 are then flat."""
    low, high = PARAMETER_BOUNDS[name]
    for value in (high * 10, 1e308, max(low / 10, -1.0) if low else -1e-300):
        keywords, readings = split_options({name: value})
        with pytest.raises(ValueError, match=rf"`{name}` must be (in \[|>= |finite)"):
            refsynth.synthesize(IMAGE, PARTIAL, method=method, **keywords, readings=readings)


def test_canny_sigma_is_bounded_by_the_image():
    """Unchecked: canny_sigma=1e300 -> "Maximum allowed size exceeded", 1e10 a MemoryError."""
    for value in (1e300, 1e10, 13.0):
        with pytest.raises(ValueError, match=r"`canny_sigma` must be in \[0, 12\]"):
            refsynth.synthesize(IMAGE, PARTIAL, canny_sigma=value)
    refsynth.synthesize(IMAGE, PARTIAL, canny_sigma=12.0)


# ----------------------------------------------------------------------------- item 8: radius


@pytest.mark.parametrize("radius", [1e4, 1e30, 1e308])
def test_bp_runs_a_radius_beyond_the_image_as_the_whole_image(radius):
    """Unchecked: radius=1e4 tried to allocate 149 GiB; 1e30 "Maximum allowed dimension exceeded".
    BP's own search is cut to the image (here on the colorization fill's observations); its
    default observations run NP at that radius first, which is refused as NP's is, naming
    the way out."""
    reach = image_reach(PARTIAL.shape)
    assert reach == math.ceil(math.hypot(11, 11)) == 16
    fill = dict(method="bp", readings={"observation": "colorization", "proximity": 0.0})
    _same(refsynth.synthesize(IMAGE, PARTIAL, radius=radius, **fill),
          refsynth.synthesize(IMAGE, PARTIAL, radius=float(reach), **fill))
    _sane(refsynth.synthesize(IMAGE, PARTIAL, radius=radius, **fill))
    with pytest.raises(ValueError, match=r"synthesize\(method='bp'\) runs NP first "
                       r"\(`observation='np'`, BP's default\) on a 12x12 image with "
                       r"neighbourhood=3, radius=[0-9e+]+ would need about .*; lower "
                       r"`neighbourhood`, `radius` \(radius 16 already reaches the whole "
                       r"image\), or take `observation='colorization'`$"):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", radius=radius)
    with pytest.raises(ValueError, match=r"runs NP first \(`proposals`\).*or drop `proposals`$"):
        refsynth.synthesize(IMAGE, PARTIAL, radius=radius, method="bp",
                            readings={"observation": "colorization", "proposals": "np"})


@pytest.mark.parametrize("radius", [1e4, 1e30, 1e308])
def test_np_refuses_a_radius_whose_frame_does_not_fit_naming_the_reach(radius):
    """Unchecked: the same allocations; NP keeps its radius (the frame of its tie-break draws)."""
    with pytest.raises(ValueError, match=r"synthesize\(method='np'\) on a 12x12 image with "
                       r"neighbourhood=3, radius=[0-9e+]+ would need about .* of memory, more "
                       r"than this machine's .*; lower `neighbourhood`, `radius` \(radius 16 "
                       r"already reaches the whole image\)"):
        refsynth.synthesize(IMAGE, PARTIAL, radius=radius)


def _prepared(result):
    image, values = validate_inputs(IMAGE, PARTIAL)
    return image, values, result.edges


def test_np_runs_a_radius_beyond_the_image_as_given():
    result = refsynth.synthesize(IMAGE, PARTIAL, radius=40.0, seed=3,
                                 readings={"gaps": "copy", "median": 0, "window": "fixed"})
    image, values, edges = _prepared(result)
    filled, confidence, order = np_fill(image, values, edges, np.random.default_rng(3),
                                        radius=40.0)
    assert np.array_equal(result.range, filled) and np.array_equal(result.confidence, confidence)
    assert np.array_equal(result.order, order)


@pytest.mark.parametrize("proximity", [1.0, 0.3, 1e-90, 1e100])
def test_bp_with_a_radius_beyond_the_image_keeps_the_priors_scale_bit_for_bit(proximity):
    """BP's prior mu (|p - q| / r)^2 scales with r: it keeps the caller's r (Fig. 6's disc)."""
    result = refsynth.synthesize(IMAGE, PARTIAL, method="bp", radius=40.0,
                                 readings={"proximity": proximity, "observation": "measured",
                                           "training_radius": "fixed", "gaps": "copy", "median": 0,
                                           "window": "fixed"})
    image, values, edges = _prepared(result)
    direct = bp_fill(image, values, edges, radius=40.0, proximity=proximity)
    assert np.array_equal(result.range, direct.range)
    assert np.array_equal(result.confidence, direct.confidence)
    assert np.array_equal(result.candidate_values, direct.candidate_values)
    assert result.params["radius"] == 40.0 and result.params["proximity"] == proximity


@pytest.mark.parametrize("proximity", [1.0, 1e100])
def test_bp_with_the_gap_radius_beyond_the_image_is_the_reference_bit_for_bit(proximity):
    """The gap's discs r + d beyond the image are cut one by one, each keeping its prior
    mu (|p - q| / (r + d))^2: the literal reference (no cut) gives the same bits."""
    small_image, small = IMAGE[:8, :9], PARTIAL[:8, :9]
    result = refsynth.synthesize(small_image, small, method="bp", radius=20.0, candidates=3,
                                 neighbourhood=3, iterations=5, readings={"proximity": proximity})
    slow = ref.bp_reference(small_image, small, result.edges, neighbourhood=3, radius=20.0,
                            k=3, proximity=proximity, iterations=5,
                            rng=np.random.default_rng(0))   # NP's fill first, seed 0
    assert np.array_equal(result.bp.unary, slow.unary)
    assert np.array_equal(result.range, slow.range)


def test_bp_with_more_candidates_than_the_cut_radius_disc_holds_is_unchanged():
    """k beyond the disc of the cut radius: the same padded candidates as the radius given."""
    image = RNG.random((3, 3))
    partial = np.full((3, 3), 2.0)
    partial[1, 1] = np.nan
    partial[0, 2] = 5.0
    result = refsynth.synthesize(image, partial, method="bp", candidates=60, radius=10.0,
                                 readings={"observation": "measured", "training_radius": "fixed"})
    assert search_radius("bp", 10.0, 1.0, (3, 3))[0] == 4.0  # a disc of 48 offsets < 60
    prepared, values = validate_inputs(image, partial)
    direct = bp_fill(prepared, values, result.edges, radius=10.0, k=60)
    assert np.array_equal(result.candidate_values, direct.candidate_values)
    assert np.array_equal(result.range, direct.range)


@given(st.floats(0.0, 1e100), st.floats(1.0, 1e300), st.integers(2, 40), st.integers(2, 40))
def test_search_radius_gives_bp_the_same_prior_coefficient(mu, r, h, w):
    """Beyond R (a power of two, R >= the reach) BP runs as R with mu' for the same prior."""
    radius, proximity = search_radius("bp", r, mu, (h, w))
    cut = 2 ** math.ceil(math.log2(image_reach((h, w))))
    assert image_reach((h, w)) <= cut < 2 * image_reach((h, w)) or cut == 1 == image_reach((h, w))
    if r <= cut:
        assert (radius, proximity) == (r, mu)
    else:
        assert radius == cut and proximity / (radius * radius) == mu / (r * r)
    assert search_radius("np", r, mu, (h, w)) == (r, mu)


# ----------------------------------------------------------------------------- item 8: memory


def test_candidates_beyond_memory_are_refused_with_the_memory_needed():
    """Unchecked: candidates=10**6 tried to allocate 175 TiB (a MemoryError after the search)."""
    with pytest.raises(ValueError, match=r"k=1000000 candidates .* would need about [0-9.]+ GB, "
                       r"more than the limit"):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", candidates=10**6)


def test_bp_is_refused_before_canny_runs(monkeypatch):
    """The memory check comes before any work: Canny is never called."""
    def canny(*args, **kwargs):
        raise AssertionError("Canny ran before the memory check")

    monkeypatch.setattr("refsynth.synthesis.api.canny", canny)
    with pytest.raises(ValueError, match="would need about"):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", candidates=10**6)


def test_a_neighbourhood_beyond_memory_is_refused_with_the_memory_needed():
    """Unchecked: "array is too big" from numpy deep inside the patch table."""
    with pytest.raises(ValueError, match="neighbourhood=1000001, .* would need about"):
        refsynth.synthesize(IMAGE, PARTIAL, neighbourhood=10**6 + 1)


def test_the_memory_limit_is_the_machines_physical_memory(monkeypatch):
    monkeypatch.setattr("refsynth._checks.physical_memory", lambda: 2**16)
    with pytest.raises(ValueError, match=r"would need about [0-9.]+ [KM]iB of memory, more "
                       r"than this machine's 64\.0 KiB"):
        refsynth.synthesize(IMAGE, PARTIAL)


# ----------------------------------------------------------------------------- item 9


def test_a_masked_partial_range_counts_the_masked_values_as_unknown():
    """Unchecked: "nothing to fill (no NaN)" although the mask hid values."""
    masked = np.ma.masked_array(np.where(KNOWN, PARTIAL, 0.0), mask=~KNOWN)
    for method in ("np", "bp"):
        _same(refsynth.synthesize(IMAGE, masked, method=method),
              refsynth.synthesize(IMAGE, PARTIAL, method=method))


def test_a_masked_intensity_is_refused_unless_nothing_is_masked():
    mask = np.zeros(IMAGE.shape, bool)
    mask[3, 4, 1] = True
    with pytest.raises(ValueError, match="`intensity` is a masked array with 1 masked values"):
        refsynth.synthesize(np.ma.masked_array(IMAGE, mask=mask), PARTIAL)
    _same(refsynth.synthesize(np.ma.masked_array(IMAGE), PARTIAL),
          refsynth.synthesize(IMAGE, PARTIAL))


@pytest.mark.parametrize("value", [np.timedelta64(1, "s"), np.datetime64("2020-01-01")])
def test_a_time_intensity_is_a_type_error_naming_intensity(value):
    """Unchecked: timedelta64 -> "Invalid integer data type 'm'" (numpy counts it as an integer)."""
    with pytest.raises(TypeError, match="`intensity` must have a real numeric dtype"):
        refsynth.synthesize(np.full((12, 12), value), PARTIAL)


def test_a_long_double_beyond_float64_says_so():
    partial = PARTIAL.astype(np.longdouble)
    partial[0, 0] = np.longdouble("1e400")
    if np.isinf(partial[0, 0]):
        pytest.skip("this platform's long double is float64")
    with pytest.raises(ValueError, match="beyond float64"):
        refsynth.synthesize(IMAGE, partial)


def test_a_long_double_intensity_beyond_float64_says_so():
    image = IMAGE.astype(np.longdouble)
    image[0, 0, 0] = np.longdouble("1e400")
    if np.isinf(image[0, 0, 0]):
        pytest.skip("this platform's long double is float64")
    with pytest.raises(ValueError, match="`intensity` must be finite .* beyond float64"):
        refsynth.synthesize(image, PARTIAL)


def test_a_negative_seed_is_named():
    with pytest.raises((TypeError, ValueError), match="`seed`"):
        refsynth.synthesize(IMAGE, PARTIAL, seed=-1)


# ----------------------------------------------------------------------------- the fuzz


EXTREMES = [0.0, 5e-324, 1e-300, 1e-100, 1e-51, 1e-50, 1e-20, 1e-3, 0.5, 1.0, 12.0, 1e3, 1e20,
            1e50, 1e51, 1e100, 1e101, 1e200, 1e308, -1e-300, -1.0, math.nan, math.inf]
OPTIONS = {"np": ["range_weight", "epsilon", "canny_sigma", "radius"],
           "bp": ["range_weight", "proximity", "sigma_i", "sigma_s", "tolerance", "canny_sigma",
                  "radius"]}
ACCEPTED = dict(PARAMETER_BOUNDS, canny_sigma=(0.0, 12.0), radius=(1.0, math.inf),
                tolerance=(0.0, math.inf))


@given(st.sampled_from(sorted((m, n) for m, names in OPTIONS.items() for n in names)),
       st.sampled_from(EXTREMES), st.integers(0, 2))
def test_extreme_options_are_refused_by_name_or_give_a_sane_result(option, value, pattern):
    method, name = option
    partial = PARTIAL.copy()
    if pattern == 1:  # a hole wider than the radius
        partial[:] = 2.0 + RNG.random(partial.shape)
        partial[2:-2, 2:-2] = np.nan
    elif pattern == 2:  # scattered pixels of two values
        partial = np.where(RNG.random(partial.shape) < 0.2, 5.0, np.nan)
        partial[0, 0] = 1.0
    low, high = ACCEPTED[name]
    inside = math.isfinite(value) and low <= value <= high
    try:
        keywords, readings = split_options({name: value})
        result = refsynth.synthesize(IMAGE, partial, method=method, **keywords,
                                     readings=readings)
    except (ValueError, TypeError) as error:
        # NP keeps its radius: beyond the image, only as far as its padded frame fits in memory
        # (BP's default observations run NP first, at BP's radius)
        refused_for_memory = name == "radius" and "would need about" in str(error)
        assert f"`{name}`" in str(error) and (not inside or refused_for_memory)
    else:
        assert inside
        _sane(result, partial)


# ----------------------------------------------------------------------------- progress


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_synth_progress_off_a_terminal_says_the_rate_and_the_time_left():
    clock, out = _Clock(), io.StringIO()
    report = pixel_progress("synthesizing", stream=out, clock=clock, rate="px")
    for done in range(100, 10_001, 100):
        clock.now += 0.5
        report(done, 10_000)
    lines = out.getvalue().splitlines()
    assert len(lines) == 10 and "\r" not in out.getvalue()  # at 5, 10, ... 45 s, and the end
    assert lines[0] == "synthesizing:  10 % (1000/10000), 0:05 elapsed, 200 px/s, ~0:45 left"
    assert lines[-1] == "synthesizing: 100 % (10000/10000), 0:50 elapsed, 200 px/s"


def test_synth_progress_without_a_rate_is_unchanged():
    clock, out = _Clock(), io.StringIO()
    report = pixel_progress("synthesizing", stream=out, clock=clock)
    clock.now = 6.0
    report(1, 2)
    assert out.getvalue() == "synthesizing:  50 % (1/2), 0:06 elapsed, ~0:06 left\n"


@pytest.mark.parametrize(("options", "needle"), [
    (["--method", "bp", "--sigma-i", "1e-300"], "`sigma_i` must be in [1e-50, 1e+50]"),
    (["--method", "bp", "--proximity", "1e300"], "`proximity` must be in [0, 1e+100]"),
    (["--epsilon", "1e308"], "`epsilon` must be in [0, 1e+100]"),
    (["--method", "bp", "--candidates", "1000000"], "would need about"),
])
def test_synth_refuses_out_of_range_options_in_one_line(tmp_path, capsys, options, needle):
    from refsynth.cli.main import main

    np.save(tmp_path / "image.npy", IMAGE)
    np.save(tmp_path / "partial.npy", PARTIAL)
    status = main(["synth", str(tmp_path / "image.npy"), str(tmp_path / "partial.npy"),
                   "--out", str(tmp_path / "out.npy"), *options])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and needle in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "out.npy").exists()
