"""The portable colorization fill (refsynth.synthesis.completion): the same system as
``colorization_fill``, the same bits on every machine."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from strategies import small_scene

from refsynth.evaluation.baselines import colorization_affinities, colorization_fill
from refsynth.synthesis import completion
from refsynth.synthesis.completion import COARSEST, portable_affinities, portable_colorization

ROOT = Path(__file__).resolve().parents[1]


def _random_case(seed: int, colour: bool = False):
    g = np.random.default_rng(seed)
    H, W = (int(v) for v in g.integers(6, 20, 2))
    image = g.random((H, W, 3)) if colour else g.random((H, W))
    truth = 1.0 + 4.0 * g.random((H, W))
    known = g.random((H, W)) < 0.3
    known[0, 0], known[-1, -1] = True, False
    return image, np.where(known, truth, np.nan)


def _step_scene(height=8, width=14, edge=7):
    """Dark left at range 2, bright right at range 5; two known columns at each end."""
    image = np.where(np.arange(width) < edge, 0.2, 0.8)[None, :].repeat(height, 0)
    truth = np.where(np.arange(width) < edge, 2.0, 5.0)[None, :].repeat(height, 0)
    known = np.zeros((height, width), dtype=bool)
    known[:, [0, 1, width - 2, width - 1]] = True
    return image, truth, known


# ----------------------------------------------------------------------------- hand-built


@given(small_scene(), st.floats(-1e3, 1e3, allow_subnormal=False))
def test_a_constant_range_comes_back_exactly(scene, level):
    image, _, known = scene
    out = portable_colorization(image, np.where(known, level, np.nan))
    assert np.all(out == level)


def test_a_two_level_range_stays_two_level_across_an_intensity_edge():
    image, truth, known = _step_scene()
    out = portable_colorization(image, np.where(known, truth, np.nan))
    step = 3.0  # the exact solution leaks 0.3 % of it across the edge (weights exp(-1/0.13))
    assert np.max(np.abs(out - truth)) < 0.01 * step
    assert np.all(out[:, :7] >= 2.0) and np.all(out[:, 7:] <= 5.0)


@given(small_scene())
def test_measured_pixels_are_unchanged_and_the_rest_finite(scene):
    image, truth, known = scene
    out = portable_colorization(image, np.where(known, truth, np.nan))
    np.testing.assert_array_equal(out[known], truth[known])
    assert out.shape == truth.shape and out.dtype == np.float64
    assert np.all(np.isfinite(out))
    # a weighted mean of measured values: within their span (to the stopping rule)
    slack = 1e-3 * (truth[known].max() - truth[known].min()) + 1e-12
    assert out.min() >= truth[known].min() - slack
    assert out.max() <= truth[known].max() + slack


def test_the_inputs_are_not_modified():
    image, partial = _random_case(3, colour=True)
    image_copy, partial_copy = image.copy(), partial.copy()
    portable_colorization(image, partial)
    np.testing.assert_array_equal(image, image_copy)
    np.testing.assert_array_equal(partial, partial_copy)


# ----------------------------------------------------------------------------- the same system


@pytest.mark.parametrize("seed", range(6))
def test_the_affinities_are_colorization_affinities(seed):
    guide = np.random.default_rng(seed).random((7 + seed, 9))
    guide[:, 4:] += 1.5 * (seed % 2)  # a strong edge in half the cases
    expected, offsets = colorization_affinities(guide)
    assert tuple(map(tuple, offsets)) == completion.OFFSETS
    np.testing.assert_allclose(portable_affinities(guide), expected, rtol=1e-13, atol=1e-300)


@pytest.mark.parametrize("seed", range(8))
def test_agrees_with_the_direct_solve(seed):
    """Within the stopping rule by default, to the direct solve's own rounding when run on."""
    image, partial = _random_case(seed, colour=bool(seed % 2))
    direct = colorization_fill(image, partial)
    span = np.nanmax(partial) - np.nanmin(partial)
    np.testing.assert_allclose(portable_colorization(image, partial), direct, atol=3e-3 * span)
    tight = portable_colorization(image, partial, tolerance=1e-13, max_sweeps=100_000)
    np.testing.assert_allclose(tight, direct, rtol=0, atol=1e-9 * span)


@pytest.mark.parametrize("alpha", [0.25, 4.0])
def test_alpha_is_the_data_term_of_colorization_fill(alpha):
    image, partial = _random_case(11)
    direct = colorization_fill(image, partial, alpha=alpha)
    tight = portable_colorization(image, partial, alpha=alpha, tolerance=0.0, max_sweeps=20_000)
    np.testing.assert_allclose(tight, direct, rtol=0, atol=1e-9)


def test_grey_and_colour_use_matlab_rgb2gray():
    image, partial = _random_case(5, colour=True)
    grey = (0.2989 * image[..., 0] + 0.5870 * image[..., 1]) + 0.1140 * image[..., 2]
    np.testing.assert_array_equal(portable_colorization(image, partial),
                                  portable_colorization(grey, partial))
    as_uint8 = np.round(image * 255).astype(np.uint8)
    np.testing.assert_array_equal(portable_colorization(as_uint8, partial),
                                  portable_colorization(as_uint8 / 255.0, partial))


def test_the_stopping_rule_stops_and_max_sweeps_bounds():
    image, partial = _random_case(2)
    one = portable_colorization(image, partial, max_sweeps=1)
    many = portable_colorization(image, partial, tolerance=0.0, max_sweeps=400)
    assert not np.array_equal(one, many)
    loose = portable_colorization(image, partial, tolerance=1.0)  # stops after one sweep
    np.testing.assert_array_equal(loose, one)


def _literal_gauss_seidel(weights, rhs, diagonal, stop, max_sweeps):
    """Four-colour Gauss–Seidel on the whole image, one colour at a time (an independent copy).

    The sweeps of :func:`completion._gauss_seidel` as 0.4 wrote them: a correction with a
    border of zeros, each colour updated at once from strided views of it.
    """
    H, W = rhs.shape
    y = np.zeros((H + 2, W + 2))
    sweeps = 0
    while sweeps < max_sweeps:
        sweeps += 1
        largest = 0.0
        for pr in (0, 1):
            for pc in (0, 1):
                h, w = rhs[pr::2, pc::2].shape
                total = rhs[pr::2, pc::2].copy()
                for k, (sr, sc) in enumerate(completion.OFFSETS):
                    read = y[1 + pr + sr:pr + sr + 2 * h:2, 1 + pc + sc:pc + sc + 2 * w:2]
                    total = total + weights[k][pr::2, pc::2] * read
                total = total / diagonal[pr::2, pc::2]
                cell = y[1 + pr:pr + 2 * h:2, 1 + pc:pc + 2 * w:2]
                if total.size:
                    largest = max(largest, float(np.max(np.abs(total - cell))))
                cell[...] = total
        if largest <= stop:
            break
    return y[1:-1, 1:-1], sweeps


@given(st.integers(2, 23), st.integers(2, 23), st.sampled_from([1, 5, 16, 1 << 15]),
       st.integers(0, 2**32 - 1), st.integers(1, 40))
def test_the_banded_sweeps_are_the_whole_colour_sweeps_bit_for_bit(height, width, band, seed,
                                                                    sweeps):
    """Colour planes and bands change no bit: the same sweeps, the same stop, any band size."""
    g = np.random.default_rng(seed)
    weights = portable_affinities(g.random((height, width)))
    rhs = g.normal(size=(height, width))
    diagonal = np.where(g.random((height, width)) < 0.3, 2.0, 1.0)
    stop = float(g.choice([0.0, 1e-3, 1e-1]))
    want, want_sweeps = _literal_gauss_seidel(weights, rhs, diagonal, stop, sweeps)
    saved = completion._BAND
    try:
        completion._BAND = band
        got, got_sweeps = completion._gauss_seidel(weights, rhs, diagonal, stop, sweeps)
    finally:
        completion._BAND = saved
    assert got_sweeps == want_sweeps
    assert got.tobytes() == want.tobytes()


# ----------------------------------------------------------------------------- properties


@given(small_scene(), st.floats(-50.0, 50.0))
def test_an_intensity_offset_changes_nothing_but_rounding(scene, offset):
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    kwargs = dict(tolerance=0.0, max_sweeps=60)  # the same number of sweeps
    np.testing.assert_allclose(portable_colorization(image + offset, partial, **kwargs),
                               portable_colorization(image, partial, **kwargs),
                               rtol=0, atol=1e-6 * 4.0)


@given(small_scene(), st.floats(0.01, 100.0), st.floats(-100.0, 100.0))
def test_a_positive_affine_map_of_the_range_commutes(scene, scale, shift):
    image, truth, known = scene
    kwargs = dict(tolerance=0.0, max_sweeps=60)
    out = portable_colorization(image, np.where(known, truth, np.nan), **kwargs)
    mapped = portable_colorization(image, np.where(known, scale * truth + shift, np.nan),
                                   **kwargs)
    np.testing.assert_allclose(mapped, scale * out + shift, rtol=0,
                               atol=1e-9 * (abs(shift) + 5.0 * scale))


# ----------------------------------------------------------------------------- the cascade


def _large_case(seed: int, height: int = 40, width: int = 52):
    """A textured image with an intensity edge, a slanted range, known columns: two levels."""
    g = np.random.default_rng(seed)
    rows, cols = np.mgrid[:height, :width]
    image = np.where(cols > width // 2, 0.7, 0.2) + 0.05 * g.random((height, width))
    truth = np.where(cols > width // 2, 4.0 + 0.02 * rows, 1.0 + 0.03 * cols)
    known = (cols % 7 < 2) & (g.random((height, width)) < 0.9)
    return image, np.where(known, truth, np.nan)


@given(small_scene(max_side=2 * COARSEST - 1), st.integers(1, 300))
def test_one_level_is_gauss_seidel_bit_for_bit(scene, sweeps):
    """Below 2·COARSEST on a side the cascade has one level: plain Gauss-Seidel, bit for bit."""
    image, truth, known = scene
    partial = np.where(known, truth, np.nan)
    np.testing.assert_array_equal(
        portable_colorization(image, partial, sweeps=sweeps),
        portable_colorization(image, partial, solver="gauss-seidel"))


def test_the_block_means_of_a_hand_built_grid():
    values = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]])
    valid = np.array([[True, False, False], [True, True, False], [False, False, True]])
    np.testing.assert_array_equal(completion._block_mean(values, np.ones((3, 3), bool)),
                                  [[3.0, 4.5], [7.5, 9.0]])
    got = completion._block_mean(values, valid)
    np.testing.assert_array_equal(got, [[10.0 / 3.0, np.nan], [np.nan, 9.0]])


@pytest.mark.parametrize("seed", [0, 1])
def test_the_cascade_converges_to_the_direct_solve(seed):
    """Run on, every level converges: the system is the baseline's, whatever the starts."""
    image, partial = _large_case(seed)
    direct = colorization_fill(image, partial)
    tight = portable_colorization(image, partial, tolerance=1e-13, sweeps=100_000,
                                  max_sweeps=100_000)
    np.testing.assert_allclose(tight, direct, rtol=0, atol=1e-9 * 3.0)


def test_the_coarse_start_does_most_of_the_work():
    """A ramp between two known columns on a flat image (the solution is the ramp): a few
    sweeps from the coarse solution come much closer than as many from the nearest fill."""
    H, W = 48, 64
    image = np.full((H, W), 0.5)
    truth = np.tile(np.linspace(1.0, 3.0, W), (H, 1))
    partial = np.where((np.arange(W) < 2) | (np.arange(W) >= W - 2), truth, np.nan)
    partial = np.broadcast_to(partial, (H, W)).copy()
    cascade, run = portable_colorization(image, partial, sweeps=5, tolerance=0.0,
                                         return_sweeps=True)
    plain = portable_colorization(image, partial, solver="gauss-seidel", max_sweeps=5,
                                  tolerance=0.0)
    assert run == 5
    error, plain_error = np.abs(cascade - truth).max(), np.abs(plain - truth).max()
    assert error < 0.1 * plain_error and error < 0.1


def test_the_cascade_bounds_its_finest_sweeps():
    image, partial = _large_case(3)
    _, run = portable_colorization(image, partial, sweeps=7, tolerance=0.0, return_sweeps=True)
    assert run == 7
    _, run = portable_colorization(image, partial, sweeps=7, max_sweeps=3, tolerance=0.0,
                                   return_sweeps=True)
    assert run == 3


def test_the_most_sweeps_double_on_each_coarser_level(monkeypatch):
    """Fine ``sweeps``, twice that on the next level, ``max_sweeps`` on the coarsest; the
    levels' shapes halve (rounded up) coarsest-first."""
    seen = []
    solve = completion._gauss_seidel

    def spy(weights, rhs, diagonal, stop, most, **kw):
        seen.append((rhs.shape, most))
        return solve(weights, rhs, diagonal, stop, most, **kw)

    monkeypatch.setattr(completion, "_gauss_seidel", spy)
    image, partial = _large_case(6, 130, 140)  # 130 → 65 → 33 → 17 on the short side
    portable_colorization(image, partial, sweeps=10, max_sweeps=500)
    assert seen == [((17, 18), 500), ((33, 35), 40), ((65, 70), 20), ((130, 140), 10)]


@pytest.mark.parametrize(("offset", "scale", "shift"), [(0.25, 1.0, 0.0), (0.0, 3.5, -2.0)])
def test_the_cascade_commutes_with_an_offset_and_an_affine_range(offset, scale, shift):
    image, partial = _large_case(4)
    out = portable_colorization(image, partial)
    np.testing.assert_allclose(portable_colorization(image * 0.5 + offset, partial,
                                                     tolerance=1e-9),
                               portable_colorization(image * 0.5, partial, tolerance=1e-9),
                               rtol=0, atol=1e-6)
    mapped = portable_colorization(image, scale * partial + shift)
    np.testing.assert_allclose(mapped, scale * out + shift, rtol=0, atol=1e-9 * 10 * scale)


def test_the_cascade_reports_progress_forward_and_changes_no_bit():
    image, partial = _large_case(5, 70, 80)  # three levels
    seen = []
    got = portable_colorization(image, partial, progress=lambda d, t: seen.append((d, t)))
    np.testing.assert_array_equal(got, portable_colorization(image, partial))
    values = [done for done, _ in seen]
    assert len(values) > 20 and values == sorted(set(values)) and seen[-1] == (1000, 1000)


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(("kwargs", "error", "name"), [
    (dict(alpha=0.0), ValueError, "alpha"),
    (dict(alpha="1"), TypeError, "alpha"),
    (dict(alpha=float("nan")), ValueError, "alpha"),
    (dict(tolerance=-1e-3), ValueError, "tolerance"),
    (dict(tolerance=None), TypeError, "tolerance"),
    (dict(max_sweeps=0), ValueError, "max_sweeps"),
    (dict(max_sweeps=10.0), TypeError, "max_sweeps"),
    (dict(sweeps=0), ValueError, "sweeps"),
    (dict(sweeps=2.5), TypeError, "sweeps"),
    (dict(solver="multigrid"), ValueError, "solver"),
])
def test_bad_parameters_are_refused_by_name(kwargs, error, name):
    image, truth, known = _step_scene()
    with pytest.raises(error, match=f"`{name}`"):
        portable_colorization(image, np.where(known, truth, np.nan), **kwargs)


def test_bad_images_are_refused_by_name():
    image, truth, known = _step_scene()
    partial = np.where(known, truth, np.nan)
    with pytest.raises(TypeError, match="`intensity`"):
        portable_colorization(image.tolist(), partial)
    with pytest.raises(ValueError, match="`intensity`"):
        portable_colorization(np.where(known, np.nan, image), partial)
    with pytest.raises(ValueError, match="`partial_range`"):
        portable_colorization(image, truth)  # nothing to fill
    with pytest.raises(ValueError, match="`partial_range`"):
        portable_colorization(image, np.full_like(truth, np.nan))  # nothing known
    with pytest.raises(ValueError, match="same height and width"):
        portable_colorization(image[:, :-1], partial)


# ----------------------------------------------------------------------------- the contract


def test_the_module_uses_no_reduction_blas_or_libm():
    """No float sum, mean, product or libm exp/log in the module: its sums are written out."""
    tree = ast.parse(Path(completion.__file__).read_text("utf-8"))
    banned = {"sum", "mean", "dot", "vdot", "inner", "matmul", "einsum", "tensordot", "prod",
              "cumsum", "average", "var", "std", "exp", "log", "linalg", "sparse", "convolve",
              "correlate", "uniform_filter", "gaussian_filter"}
    found = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)} & banned
    assert not found
    assert not any(isinstance(node, ast.MatMult) for node in ast.walk(tree))
    imported = {alias.name if isinstance(node, ast.Import) else node.module
                for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom))
                for alias in node.names}
    assert not any(name.startswith("refsynth.evaluation") for name in imported)  # layering


SCRIPT = r"""
import hashlib
import numpy as np
from refsynth.synthesis.completion import portable_colorization

g = np.random.default_rng(11)
H, W = 40, 44
rows, cols = np.mgrid[:H, :W]
texture = g.integers(0, 256, (H, W, 3)).astype(np.uint8)
image = np.where((cols > 20)[..., None], texture // 3 + 120, texture // 4).astype(np.uint8)
truth = np.where(cols > 20, 3.0 + 0.01 * rows, 1.5 + 0.02 * cols)
known = (cols % 9 < 2) & (g.random((H, W)) < 0.9)
out = [portable_colorization(image, np.where(known, truth, np.nan)),
       portable_colorization(image / 255.0, np.where(known, truth, np.nan), alpha=0.5,
                             tolerance=0.0, max_sweeps=300)]
print(" ".join(hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:16] for a in out))
"""

try:
    from test_determinism import _disabled_simd
except ImportError:  # another import mode: the same logic
    def _disabled_simd() -> str:
        from numpy._core._multiarray_umath import __cpu_dispatch__

        wanted = ("X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX512F", "AVX512_SKX", "X86_V3")
        return " ".join(name for name in wanted if name in __cpu_dispatch__)


def _run(**env) -> str:
    environment = {key: value for key, value in os.environ.items()
                   if not key.startswith(("OPENBLAS_", "OMP_", "NPY_DISABLE", "MKL_"))}
    environment.update(env)
    environment["PYTHONPATH"] = str(ROOT) + os.pathsep + environment.get("PYTHONPATH", "")
    done = subprocess.run([sys.executable, "-c", SCRIPT], env=environment, capture_output=True,
                          text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


@pytest.fixture(scope="module")
def default_hashes() -> str:
    return _run()


@pytest.mark.parametrize("variant", ["Prescott kernel", "one thread", "SIMD cut", "all at once"])
def test_the_same_bits_in_another_environment(variant, default_hashes):
    env = {"Prescott kernel": dict(OPENBLAS_CORETYPE="Prescott"),
           "one thread": dict(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"),
           "SIMD cut": {}, "all at once": dict(OPENBLAS_CORETYPE="Prescott",
                                               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")}
    env = dict(env[variant])
    if variant in ("SIMD cut", "all at once") and _disabled_simd():
        env["NPY_DISABLE_CPU_FEATURES"] = _disabled_simd()
    elif variant == "SIMD cut":
        pytest.skip("this numpy dispatches no AVX-512 or AVX2 code")
    assert _run(**env) == default_hashes


def test_the_script_is_the_same_in_process(default_hashes, capsys):
    """The subprocesses see the working tree (not an installed copy): the same hashes here."""
    exec(compile(SCRIPT, "<completion script>", "exec"), {})
    assert capsys.readouterr().out.strip() == default_hashes
