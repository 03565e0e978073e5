"""Golden hashes: NP and BP on two small scenes, pinned bit for bit.

Under the numeric contract (:mod:`refsynth.numeric`) these hashes are the same on every
machine, BLAS and SIMD width. A change that alters any of them — on purpose or not — fails
here loudly: if it is on purpose, say so in the commit, regenerate the README's tables and
figures and the oracle's cases, and paste the new hashes printed by the failing assertion.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

import refsynth


def _steps() -> tuple[np.ndarray, np.ndarray]:
    """24×26 grey: two textured planes meeting at a slanted edge; x-stripes known."""
    g = np.random.default_rng(2008)
    rows, cols = np.mgrid[:24, :26]
    right = cols > 10 + rows // 3
    image = np.where(right, 0.6, 0.2) + 0.1 * g.random((24, 26))
    truth = np.where(right, 4.0 - 0.05 * rows, 2.0 + 0.03 * cols)
    known = (cols % 5 == 0) | (rows % 7 == 0)
    return image, np.where(known, truth, np.nan)


def _texture() -> tuple[np.ndarray, np.ndarray]:
    """20×28 colour uint8 texture, random mask (35 % measured), range with few decimals."""
    g = np.random.default_rng(11)
    image = g.integers(0, 256, (20, 28, 3)).astype(np.uint8) // 4 * 4
    rows, cols = np.mgrid[:20, :28]
    truth = np.round(1.0 + 0.1 * rows + 0.05 * (cols // 4), 2)
    known = g.random((20, 28)) < 0.35
    return image, np.where(known, truth, np.nan)


SCENES = {"steps": _steps, "texture": _texture}


def _digest(result) -> str:
    h = hashlib.sha256()
    for array in (result.range, result.confidence, result.order, result.edges):
        h.update(np.ascontiguousarray(array).tobytes())
    if result.bp is not None:
        for array in (result.bp.unary, result.bp.log_psi, result.bp.messages, result.bp.beliefs):
            h.update(np.ascontiguousarray(array).tobytes())
    return h.hexdigest()[:24]


GOLDEN = {
    ("steps", "np"): "cc9097f8caec9e751fa29dfe",
    ("steps", "bp"): "0a43089e6824b25cb2683c27",
    ("texture", "np"): "0859f634596abb5cdf19d6e1",
    ("texture", "bp"): "0e39aa4ac95b9c537ff604c2",
}
#: The fill without the 3 × 3 median after it (``median=0``): the readings below keep it off,
#: so that their hashes pin the fill itself.
FILL = dict(median=0)
GOLDEN_FILL = {
    ("steps", "np"): "27f7cd040b1f223cc74298c2",   # NP's offset copy
    ("steps", "bp"): "de888bd52dfba104db0a840b",   # BP on NP's fill
    ("texture", "np"): "f2f579904e60b638f8084138",
    ("texture", "bp"): "e4ec2240a65b662ea60ea88a",
}
#: BP's observations completed by the colorization fill, the other defaults kept.
COLORIZATION = dict(observation="colorization", **FILL)
GOLDEN_COLORIZATION = {
    ("steps", "bp"): "207c5aede45dc5d1bac3b32c",
    ("texture", "bp"): "d7a8bbc8b58ef66e5f6701ca",
}
#: BP as Fig. 6 prints it (the observations' measured range, the fixed training disc, the
#: labels' centre values), without refsynth's departures.
FIG6 = dict(observation="measured", training_radius="fixed", range_copy="value", **FILL)
GOLDEN_FIG6 = {
    ("steps", "bp"): "da696a7a6b4edcc3d5f381ca",
    ("texture", "bp"): "e2699b75d7f964ac7ec9c282",
}
#: The centre's value copied (Eq. 5 as printed; Fig. 6's labels), the other defaults kept
#: (BP on the colorization fill's observations).
VALUE_COPY = {"np": dict(range_copy="value", **FILL),
              "bp": dict(range_copy="value", observation="colorization", **FILL)}
GOLDEN_VALUE_COPY = {
    ("steps", "np"): "1eb29b548dae38f8b4218494",
    ("steps", "bp"): "7ce147a968fc672ca5e0f018",
    ("texture", "np"): "2cebdade5732edbd0564aa81",
    ("texture", "bp"): "7b4f1ad4a4db7c38cbcda397",
}
#: Eq. 2's channel mean with the value copy; BP's proximity prior μ = 1 on Fig. 6's
#: observations and training disc.
CHANNEL_MEAN = {"np": dict(channels="mean", range_copy="value", **FILL),
               "bp": dict(channels="mean", proximity=1.0, observation="measured",
                          training_radius="fixed", range_copy="value", **FILL)}
GOLDEN_CHANNEL_MEAN = {
    ("steps", "np"): "1eb29b548dae38f8b4218494",
    ("steps", "bp"): "d8dab12d04faac1c1f7e756e",
    ("texture", "np"): "4260a959c73bb8eba56b0feb",
    ("texture", "bp"): "b631a82b1c6716aedcb65810",
}

#: The paper's readings as printed (``readings="paper"``: Eq. 2 as written, Eq. 5's value
#: copy, Fig. 6's BP with 50 sweeps): the preset that the literal references default to.
PAPER = {"np": "paper", "bp": "paper"}
GOLDEN_PAPER = {
    ("steps", "np"): "acbf89ebf41be1aed63b8b32",
    ("steps", "bp"): "f2e49efd1db8c74dc595c748",
    ("texture", "np"): "6fc14a94079c3ffc937d339e",
    ("texture", "bp"): "4e872206931ebe5c39956138",
}


#: Every pinned reading: its name, its readings by method and its hashes.
PINNED = [
    ("the defaults", {"np": {}, "bp": {}}, GOLDEN),
    ("the fill", {"np": FILL, "bp": FILL}, GOLDEN_FILL),
    ("the channel mean", CHANNEL_MEAN, GOLDEN_CHANNEL_MEAN),
    ("Eq. 5's value copy", VALUE_COPY, GOLDEN_VALUE_COPY),
    ("Fig. 6", {"bp": FIG6}, GOLDEN_FIG6),
    ("the colorization fill's observations", {"bp": COLORIZATION}, GOLDEN_COLORIZATION),
    ("the paper's readings", PAPER, GOLDEN_PAPER),
]
CASES = [pytest.param(reading, scene, method, options[method], golden[scene, method],
                      id=f"{reading}-{scene}-{method}")
         for reading, options, golden in PINNED for scene, method in golden]


@pytest.mark.parametrize(("reading", "scene", "method", "options", "expected"), CASES)
def test_the_golden_hash_holds(reading, scene, method, options, expected):
    intensity, partial = SCENES[scene]()
    result = refsynth.synthesize(intensity, partial, method=method, seed=7, radius=5.0,
                                 readings=options)
    assert _digest(result) == expected, (
        f"{scene}/{method} ({reading}): the output changed; new hash {_digest(result)}")


def _slices() -> tuple[np.ndarray, np.ndarray]:
    """22×30 colour: a slanted wall behind a box, scanned in columns with the sensor's holes."""
    g = np.random.default_rng(42)
    rows, cols = np.mgrid[:22, :30]
    box = (cols >= 11) & (cols < 19) & (rows >= 6)
    image = np.stack([np.where(box, 0.7, 0.3) + 0.05 * g.random((22, 30))] * 3, axis=-1)
    truth = np.where(box, 1.5, 3.0 + 0.02 * cols)
    known = (cols % 4 == 0) & (g.random((22, 30)) < 0.9)
    return image, np.where(known, truth, np.nan)


#: A column scan with gaps of 3 columns, where the readings ``gaps`` and ``window`` act: the
#: defaults (the 3 × 3 window, ``gaps="gate"``, then ``median=3``), the same with the 5 × 5
#: window (``window="fixed"``), with it the gate alone and the fill as copied, and the
#: paper's readings.
GOLDEN_SLICES = {
    ("defaults", "np"): "c3d801559645bea1639a14e4",
    ("defaults", "bp"): "80988b26060fd31609cd560c",
    ("window", "np"): "aa06077a49cbbb2345e4197d",
    ("window", "bp"): "28674185b085226b965fade4",
    ("gate", "np"): "ec82aacc92c738591faf839d",
    ("gate", "bp"): "14ecc224a7a51af26676c268",
    ("copy", "np"): "63f6b732228ddfbb249592ca",
    ("copy", "bp"): "6d46d68100808a7f6783e721",
    ("paper", "np"): "aed0483601aeebd1e591b18a",
    ("paper", "bp"): "00c268bab03e14d49124972f",
}
FIXED = {"window": "fixed"}
SLICE_READINGS = {"defaults": {}, "window": FIXED, "gate": {**FILL, **FIXED},
                  "copy": {"gaps": "copy", **FILL, **FIXED}, "paper": "paper"}


@pytest.mark.parametrize(("reading", "method"), sorted(GOLDEN_SLICES))
def test_the_golden_hash_holds_on_a_column_scan(reading, method):
    intensity, partial = _slices()
    result = refsynth.synthesize(intensity, partial, method=method, seed=7, radius=5.0,
                                 readings=SLICE_READINGS[reading])
    assert _digest(result) == GOLDEN_SLICES[reading, method], (
        f"slices/{method} ({reading}): the output changed; new hash {_digest(result)}")
