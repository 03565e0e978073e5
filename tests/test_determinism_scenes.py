"""The scenes give the same bits on any BLAS kernel, thread count and SIMD width.

Each scene is computed in a fresh interpreter under an environment variant and hashed:
``OPENBLAS_CORETYPE=Prescott`` (OpenBLAS's oldest x86-64 kernels, no FMA),
``OPENBLAS_NUM_THREADS``/``OMP_NUM_THREADS`` = 1 and 2, and ``NPY_DISABLE_CPU_FEATURES``
naming every SIMD target numpy dispatches to on this machine (so its vectorised ``exp``,
``tan``, ``arctan``… fall back to the baseline). Before the numeric contract, the
Motorcycle's resize changed with the thread count and the kernel, the synthetic room and
the rig with the kernel, and the rig's views with the SIMD width.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

#: Each variant runs in a fresh interpreter (``-m "not slow"`` leaves them out).
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = r"""
import hashlib, json, sys
import numpy as np

def digest(*arrays):
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes())
    return h.hexdigest()[:16]

from refsynth.scenes import (laser_scan, motorcycle, render_views, rig_room, synthetic_room,
                             texture_views)
from refsynth.acquisition import RigPose, RoomRig

out = {}
if sys.argv[1] == "1":
    for size in ((450, 375), (741, 500)):
        scene = motorcycle(size)
        out[f"motorcycle-{size[0]}x{size[1]}"] = digest(scene.intensity, scene.range)
for seed in (0, 3):
    scene = synthetic_room((128, 128), seed)
    out[f"synthetic_room-{seed}"] = digest(scene.intensity, scene.range)
room = rig_room(1)
views = render_views(room, n_views=3, height=64, supersample=2, seed=2)
out["render_views"] = digest(views.images, views.true_pan, views.translations)
scan = laser_scan(room, phi_range=(-0.6, 0.6), pan_step=0.02, seed=2)
out["laser_scan"] = digest(scan.r, scan.points)
y, x = np.mgrid[0:60, 0:400] / 5.0
tex = texture_views(np.sin(x) * np.cos(y), focal=100.0, pan_step=0.5, overlap=0.2)
out["texture_views"] = digest(tex.images)
rig = RoomRig(seed=1, pose=RigPose(x=0.3, z=0.5, heading=0.2))
out["room_rig"] = digest(*rig.measure(180, 300, 400, 5), rig.picture(75))
print(json.dumps(out))
"""


def _have_scikit_image() -> bool:
    try:
        from skimage import data  # noqa: F401
    except ImportError:
        return False
    return True


def _simd_targets() -> str:
    """Every SIMD target numpy dispatches to and this CPU has (the names it accepts here)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # numpy < 2
        from numpy.core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    return " ".join(name for name in __cpu_dispatch__ if __cpu_features__.get(name))


VARIANTS = {
    "default": {},
    "prescott": {"OPENBLAS_CORETYPE": "Prescott"},
    "threads-1": {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"},
    "threads-2": {"OPENBLAS_NUM_THREADS": "2", "OMP_NUM_THREADS": "2"},
    "no-simd": {"NPY_DISABLE_CPU_FEATURES": _simd_targets()},
}


def _run(variant: dict) -> dict:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("OPENBLAS_", "OMP_", "NPY_", "MKL_"))}
    env.update(variant, PYTHONPATH=str(ROOT) + os.pathsep + env.get("PYTHONPATH", ""))
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, "1" if _have_scikit_image() else "0"],
        env=env, capture_output=True, text=True, timeout=600, cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def hashes() -> dict:
    return {name: _run(variant) for name, variant in VARIANTS.items()}


@pytest.mark.parametrize("variant", [name for name in VARIANTS if name != "default"])
def test_scenes_are_bit_identical_under_every_variant(hashes, variant):
    reference, other = hashes["default"], hashes[variant]
    assert other.keys() == reference.keys()
    differing = sorted(k for k in reference if reference[k] != other[k])
    assert not differing, f"{variant} ({VARIANTS[variant]}) changes {differing}"


def test_the_variants_cover_every_scene(hashes):
    expected = {"synthetic_room-0", "synthetic_room-3", "render_views", "laser_scan",
                "texture_views", "room_rig"}
    if _have_scikit_image():
        expected |= {"motorcycle-450x375", "motorcycle-741x500"}
    assert expected <= set(hashes["default"])


def test_portable_functions_are_close_to_numpy():
    from refsynth.scenes.portable import (
        portable_arctan,
        portable_arctan2,
        portable_cos,
        portable_sin,
        portable_tan,
    )

    g = np.random.default_rng(0)
    x = np.concatenate([g.uniform(-10, 10, 20000), g.uniform(-2000, 2000, 20000)])
    small = g.uniform(-3, 3, 20000)
    y = g.uniform(-5, 5, 20000)

    def ulps(got, want):
        return np.max(np.abs(got - want) / np.spacing(np.maximum(np.abs(want), 1e-300)))

    assert ulps(portable_sin(x), np.sin(x)) <= 2
    assert ulps(portable_cos(x), np.cos(x)) <= 2
    assert ulps(portable_tan(small), np.tan(small)) <= 4
    assert ulps(portable_arctan(x), np.arctan(x)) <= 2
    assert ulps(portable_arctan2(y, small), np.arctan2(y, small)) <= 2
    assert portable_arctan2(0.0, -1.0) == np.pi and portable_arctan2(-1.0, 0.0) == -np.pi / 2
    assert isinstance(portable_sin(0.5), float) and portable_sin(np.zeros((2, 3))).shape == (2, 3)
    assert np.isnan(portable_sin(np.inf)) and np.isnan(portable_arctan(np.nan))


def test_resize_has_no_blas_product():
    """The fixed-order resize equals the area-weight matrices' product to rounding, and a
    NaN reaches only the output cells whose footprint it lies in."""
    from refsynth.scenes import resize_area

    g = np.random.default_rng(1)
    image = g.random((50, 74, 3))
    out = resize_area(image, (45, 37))

    def matrix(old, new):
        edges = np.arange(new + 1) * old / new
        j = np.arange(old)[None, :]
        overlap = np.minimum(edges[1:, None], j + 1) - np.maximum(edges[:-1, None], j)
        return np.clip(overlap, 0.0, None) / (old / new)

    rows, cols = matrix(50, 37), matrix(74, 45)
    want = np.stack([rows @ image[..., c] @ cols.T for c in range(3)], axis=-1)
    np.testing.assert_allclose(out, want, rtol=1e-13, atol=1e-15)
    holed = image[..., 0].copy()
    holed[10, 20] = np.nan
    small = resize_area(holed, (45, 37))
    touched = (rows[:, 10] > 0)[:, None] & (cols[:, 20] > 0)[None, :]
    np.testing.assert_array_equal(np.isnan(small), touched)
