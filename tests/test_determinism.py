"""The numeric contract: the same call gives the same bits on any machine.

Each variant runs NP and BP in a fresh interpreter with another BLAS kernel
(``OPENBLAS_CORETYPE``), one BLAS/OpenMP thread, numpy's SIMD dispatch cut down to
AVX2 and below (``NPY_DISABLE_CPU_FEATURES``), or an offset added to the intensity, and
prints a hash of every output: all must agree with the default run. Before the contract,
``OPENBLAS_CORETYPE=Prescott`` alone changed 14 % of NP's pixels.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

#: Each variant runs in a fresh interpreter (``-m "not slow"`` leaves them out).
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]

#: Runs NP and BP (with Canny's edges, so the grey conversion and Canny count too) on a
#: small textured scene and prints one hash per method. ``offset`` shifts and rescales the
#: intensity: the intensity convention makes that invisible.
SCRIPT = r"""
import hashlib, sys
import numpy as np
import refsynth

variant = sys.argv[1]
g = np.random.default_rng(11)
H, W = 40, 44
rows, cols = np.mgrid[:H, :W]
texture = g.integers(0, 256, (H, W, 3)).astype(np.uint8)
image = np.where((cols > 20)[..., None], texture // 3 + 120, texture // 4).astype(np.uint8)
truth = np.where(cols > 20, 3.0 + 0.01 * rows, 1.5 + 0.02 * cols)
known = g.random((H, W)) < 0.35
partial = np.where(known, truth, np.nan)
intensity = image if variant != "offset" else image / 51.0 + 7.3
out = []
for method in ("np", "bp"):
    result = refsynth.synthesize(intensity, partial, method=method, seed=3, radius=6.0)
    digest = hashlib.sha256()
    for array in (result.range, result.confidence, result.order, result.edges):
        digest.update(np.ascontiguousarray(array).tobytes())
    if method == "bp":
        for array in (result.bp.messages, result.bp.beliefs, result.bp.unary):
            digest.update(np.ascontiguousarray(array).tobytes())
    out.append(f"{method}:{digest.hexdigest()[:16]}")
print(" ".join(out))
"""


def _disabled_simd() -> str:
    """The AVX-512 and AVX2 groups that this numpy dispatches, as NPY_DISABLE_CPU_FEATURES
    takes them (numpy 2.4 warns about a name it does not dispatch; others refuse to start)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__

    wanted = ("X86_V4", "AVX512_ICL", "AVX512_SPR", "AVX512F", "AVX512_SKX", "X86_V3")
    return " ".join(name for name in wanted if name in __cpu_dispatch__)


def _run(variant: str, **env) -> str:
    environment = {key: value for key, value in os.environ.items()
                   if not key.startswith(("OPENBLAS_", "OMP_", "NPY_DISABLE", "MKL_"))}
    environment.update(env)
    environment["PYTHONPATH"] = str(ROOT) + os.pathsep + environment.get("PYTHONPATH", "")
    done = subprocess.run([sys.executable, "-c", SCRIPT, variant], env=environment,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


VARIANTS = {
    "Prescott kernel": dict(OPENBLAS_CORETYPE="Prescott"),
    "Sandybridge kernel": dict(OPENBLAS_CORETYPE="Sandybridge"),
    "one thread": dict(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1"),
    "SIMD cut to the baseline": "simd",
}


@pytest.fixture(scope="module")
def default_hashes() -> str:
    return _run("plain")


@pytest.mark.parametrize("name", list(VARIANTS))
def test_np_and_bp_give_the_same_bits_in_another_environment(name, default_hashes):
    env = VARIANTS[name]
    if env == "simd":
        disabled = _disabled_simd()
        if not disabled:
            pytest.skip("this numpy dispatches no AVX-512 or AVX2 code")
        env = dict(NPY_DISABLE_CPU_FEATURES=disabled)
    assert _run("plain", **env) == default_hashes


def test_an_offset_and_a_scale_of_the_intensity_give_the_same_bits(default_hashes):
    assert _run("offset") == default_hashes


def test_all_variants_at_once(default_hashes):
    """Every variable together, on the offset input."""
    env = dict(OPENBLAS_CORETYPE="Prescott", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    if _disabled_simd():
        env["NPY_DISABLE_CPU_FEATURES"] = _disabled_simd()
    assert _run("offset", **env) == default_hashes


def test_the_script_is_the_same_scene_in_process(default_hashes):
    """The subprocess sees the working tree (not an installed copy): same hashes here."""
    namespace: dict = {}
    argv = sys.argv
    try:
        sys.argv = ["-c", "plain"]
        from contextlib import redirect_stdout
        from io import StringIO

        buffer = StringIO()
        with redirect_stdout(buffer):
            exec(compile(SCRIPT, "<determinism script>", "exec"), namespace)
    finally:
        sys.argv = argv
    assert buffer.getvalue().strip() == default_hashes
