"""The cases catch the ulp-level mistakes a porter makes (:mod:`refsynth.oracle.contract`).

Each test writes a deliberately wrong port — refsynth's own literal reference, or a port
of one equation written here, with exactly one of the mistakes a porter made — and checks
that ``oracle check`` fails, naming the case and the array where the mistake first shows:

- Eq. 12's operation order (the un-normalised Sobel vector, divided by its norm once):
  ``eq10_12-arithmetic``'s ``D``;
- BP's confidence rule (normalise, sum left to right, pool, clip to 1): ``bp-10x12-k8``'s
  and ``bp-14x18-planes``' ``confidence``;
- the offset copy: shifted labels below 0 still present (``log_psi``), and the shifted
  centre clipped to the measured range (``candidate_values``, NP's ``step_value``);
- the intensity outside the image, mirrored with the edge pixel repeated (Eq. 2's
  ``cand_distance``, BP's ``candidates``).
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from refsynth.oracle import (
    build_cases,
    check_function,
    export_cases,
    refsynth_reference,
    runs,
)
from refsynth.oracle.cases import select_cases
from refsynth.oracle.runs import run_outputs

CASES = ["eq10_12-arithmetic", "eq10_12-n5", "bp-10x12-k8", "bp-14x18-planes",
         "bp-16x16-fig6-gap", "np-10x12-best-grey", "np-10x12-channel-mean",
         "np-16x16-noise", "bp-16x16-noise"]


@pytest.fixture(scope="module")
def cases_dir(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("oracle-contract")
    export_cases(root, select_cases(build_cases(), CASES))
    return root


def _perturbed(name: str, *edits: tuple[str, str]):
    """A copy of the literal reference behind the oracle's runs, with ``edits`` applied."""
    source = Path(runs.ref.__file__).read_text()
    for original, replacement in edits:
        assert source.count(original) == 1, original
        source = source.replace(original, replacement)
    spec = importlib.util.spec_from_loader(f"wrong_port_{name}", loader=None)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module   # dataclasses look their module up while being made
    try:
        exec(compile(source, f"<wrong port {name}>", "exec"), module.__dict__)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def _port(module):
    """The wrong reference in the checker's calling convention, with its trace."""

    def function(inputs, options):
        options = dict(options)
        kind, seed = options.pop("method"), options.pop("seed")
        if kind not in ("np", "bp"):
            return None
        names = ("intensity", "partial_range", "edges")
        return run_outputs(kind, {k: inputs[k] for k in names}, options, seed,
                           reference=module)

    return function


def _first(cases_dir, function, case):
    report = check_function(function, cases_dir, case=case, timeout=None)
    assert not report.passed, f"the wrong port passed {case}"
    return report.mismatch


#: The NPZ (inputs, expected outputs, trace) of the cases above as the reference writes them.
GOLDEN = {
    "np-16x16-noise": "fafa6e5ffa4fd16f9344caf81a91df4e1778f6a95368c44537871f328c3436a8",
    "bp-16x16-noise": "fb2441dfd6e4823386368eefe7753421ab0e5c3689c01a2877075b4fb3d0c9aa",
    "np-10x12-best-grey": "cf4faebf1041ed21cb2d4e791b54c857963bd1e8ed1d8bc5d712754785ebef8e",
    "np-10x12-channel-mean": "496173b9d8215c1894cfd7268a4b17ff8317acb75a2b408313630bd7c70d45d5",
    "bp-10x12-k8": "1f521ca39347e71b76ab2fd5f65f20e18d133d564fa4c1e282cc7dfe68710dcb",
    "bp-16x16-fig6-gap": "0419d2c3b748b4cf5a2d0a44fa6bcb348227b5d5fe85da7e53a5f2506f3b9332",
    "bp-14x18-planes": "907d2a5eb3e49af8cd8404332e0314b78b9ba37244c1c3460dfb82596b974d90",
    "eq10_12-n5": "d5eae251dbac108a221525f03d1acdd293bff28d906f15331fe3f8fc3f9a10b4",
    "eq10_12-arithmetic": "2003fcada1235e9ca769940ad32b95f8b38824e89bc085d832c8e7487412f599",
}


def test_the_cases_hold_the_contracts_bits(cases_dir):
    """The reference still writes these cases' bytes: a change of its Eq. 12 order, its
    confidence rule or its offset copy's clips changes them (before any port is checked)."""
    manifest = json.loads((cases_dir / "manifest.json").read_text())
    assert {entry["name"]: entry["sha256"] for entry in manifest["cases"]} == GOLDEN


# ----------------------------------------------------------------------------- Eq. 12

_SOBEL_ROW = ((-1, -2, -1), (0, 0, 0), (1, 2, 1))


def _eq12(filled, q_range, r, c, n, order):
    """Eq. 12's ``D`` at (r, c), ported from the contract, the last operations in ``order``."""
    H, W = filled.shape
    h = n // 2
    rows, cols = slice(max(r - h, 0), min(r + h, H - 1) + 1), slice(max(c - h, 0),
                                                                     min(c + h, W - 1) + 1)
    f, q = filled[rows, cols], q_range[rows, cols].astype(np.int64)
    down, right = f[:-1] & f[1:], f[:, :-1] & f[:, 1:]
    g_row = (int((q[1:] - q[:-1])[down].sum()) * 2.0**-16) / max(int(down.sum()), 1)
    g_col = (int((q[:, 1:] - q[:, :-1])[right].sum()) * 2.0**-16) / max(int(right.sum()), 1)
    m_row = m_col = 0
    for a in range(3):
        for b in range(3):
            i, j = r + a - 1, c + b - 1
            if 0 <= i < H and 0 <= j < W and filled[i, j]:
                m_row, m_col = m_row + _SOBEL_ROW[a][b], m_col + _SOBEL_ROW[b][a]
    norm = math.sqrt(m_row * m_row + m_col * m_col) or 1.0
    if order == "contract":                 # the cross product, then one division
        return 1.0 - abs(g_row * m_col - g_col * m_row) / norm
    if order == "normalise-first":          # the front normal made a unit vector first
        return 1.0 - abs(g_row * (m_col / norm) - g_col * (m_row / norm))
    if order == "separately":               # each product divided by the norm
        return 1.0 - abs(g_row * m_col / norm - g_col * m_row / norm)
    return 1.0 - abs(g_row * m_col - g_col * m_row) * (1.0 / norm)   # times the reciprocal


def _eq12_port(order):
    def port(inputs, options):
        if options["method"] != "eq10_12":
            return None
        out = refsynth_reference(inputs, options)
        if options["use_isophotes"]:
            D = np.array([_eq12(f, q, int(p[0]), int(p[1]), options["neighbourhood"], order)
                          for f, q, p in zip(inputs["filled"], inputs["q_range"],
                                             inputs["pixel"])])
            out["D"] = D
            out["P"] = out["C"] * np.maximum(D, 0.0) + out["E_term"]
        return out

    return port


def test_eq12_in_the_contracts_order_passes(cases_dir):
    report = check_function(_eq12_port("contract"), cases_dir, timeout=None)
    assert report.passed and set(report.checked) == {"eq10_12-arithmetic", "eq10_12-n5"}


@pytest.mark.parametrize("order", ["normalise-first", "separately", "reciprocal"])
def test_eq12_in_another_order_fails_on_the_arithmetic_case(cases_dir, order):
    mismatch = _first(cases_dir, _eq12_port(order), "eq10_12-arithmetic")
    assert (mismatch.case, mismatch.key) == ("eq10_12-arithmetic", "D")
    assert mismatch.expected != mismatch.got
    assert abs(mismatch.expected - mismatch.got) < 1e-15   # an ulp or so, no more


# ----------------------------------------------------------------------------- BP's confidence

_POOL = """        pooled = 0.0
        for label in range(k):
            # on the range's integer grid: exact, and unchanged by a scale of the range
            if abs(int(qvalues[i, label]) - int(qvalues[i, labels[i]])) <= (
                    VALUE_TOLERANCE * 2.0**RANGE_BITS):
                pooled += weights[label] / z
"""
_Z = "        z = 0.0\n        for w in weights:\n            z += w\n"
_CLIP = "confidence[r, c] = min(pooled, 1.0)"

CONFIDENCE_MISTAKES = {
    # the normaliser by numpy's pairwise sum (eight accumulators from eight terms on)
    "normaliser-summed-by-numpy": ("bp-10x12-k8", [(_Z, "        z = float(np.sum(weights))\n")]),
    # the pooled weights by numpy's sum
    "pool-summed-by-numpy": ("bp-10x12-k8", [(_POOL, (
        "        same = np.abs(qvalues[i] - qvalues[i, labels[i]]) <= (\n"
        "            VALUE_TOLERANCE * 2.0**RANGE_BITS)\n"
        "        pooled = float(np.sum(np.where(same, weights / z, 0.0)))\n"))]),
    # pooled first, normalised once
    "pooled-then-normalised": ("bp-10x12-k8", [("pooled += weights[label] / z",
                                                "pooled += weights[label]"),
                                               (_CLIP, "confidence[r, c] = min(pooled / z, 1.0)")]),
    # no clip to 1: a belief pooled over every label sums to 1 + 2**-52
    "not-clipped": ("bp-14x18-planes", [(_CLIP, "confidence[r, c] = pooled")]),
}


@pytest.mark.parametrize("mistake", list(CONFIDENCE_MISTAKES))
def test_bp_confidence_rule_mistakes_fail_on_the_confidence(cases_dir, mistake):
    case, edits = CONFIDENCE_MISTAKES[mistake]
    mismatch = _first(cases_dir, _port(_perturbed(mistake, *edits)), case)
    assert (mismatch.case, mismatch.key) == (case, "confidence")
    if mistake == "not-clipped":
        assert (mismatch.expected, mismatch.got) == (1.0, 1.0 + 2.0**-52)


# ----------------------------------------------------------------------------- the offset copy

_OVERLAP = "    d = np.where(both, (a + int(shifts[0])) - (b + int(shifts[1])), 0)"
_BP_MOVED = "moved = min(max(q + int(shifts[i, label]), 0), 2**RANGE_BITS)"
_BP_VALUE = ("values[i, label] = min(max(float(values[i, label] + (moved - q) * (\n"
             "                    frame.span * 2.0**-RANGE_BITS)), low), high)")
_NP_SHIFTED = ("shifted = min(max(int(value) + offset_shift(frame, p, source), 0), "
               "2**RANGE_BITS)")
_NP_VALUE = "frame.span * 2.0**-RANGE_BITS)), float(low)), float(high))"

OFFSET_MISTAKES = {
    # a shifted label's range below 0 read as missing (no lift): Eq. 6 loses those pixels
    "shifted-below-zero-missing": ("bp-16x16-fig6-gap", "log_psi", [(_OVERLAP, (
        "    a = np.where(a != NO_RANGE, a + int(shifts[0]), NO_RANGE)\n"
        "    b = np.where(b != NO_RANGE, b + int(shifts[1]), NO_RANGE)\n"
        "    both = (a >= 0) & (b >= 0)\n"
        "    count = int(both.sum())\n"
        "    if count == 0:\n"
        "        return 0.0\n"
        "    d = np.where(both, a - b, 0)"))]),
    # BP's shifted centre not clipped to the grid [0, 2**16]
    "bp-grid-not-clipped": ("bp-16x16-fig6-gap", "candidate_values",
                            [(_BP_MOVED, "moved = q + int(shifts[i, label])")]),
    # BP's shifted centre value not clipped to the measured range
    "bp-value-not-clipped": ("bp-16x16-fig6-gap", "candidate_values", [(_BP_VALUE, (
        "values[i, label] = float(values[i, label] + (moved - q) * (\n"
        "                    frame.span * 2.0**-RANGE_BITS))"))]),
    # NP's shifted value not clipped to the grid
    "np-grid-not-clipped": ("np-10x12-best-grey", "step_value",
                            [(_NP_SHIFTED, "shifted = int(value) + offset_shift(frame, p, "
                                           "source)")]),
    # NP's shifted value not clipped to the measured range
    "np-value-not-clipped": ("np-10x12-channel-mean", "step_value",
                             [(_NP_VALUE, "frame.span * 2.0**-RANGE_BITS)), -np.inf), np.inf)")]),
}


@pytest.mark.parametrize("mistake", list(OFFSET_MISTAKES))
def test_offset_copy_mistakes_fail_where_they_first_show(cases_dir, mistake):
    case, key, edits = OFFSET_MISTAKES[mistake]
    mismatch = _first(cases_dir, _port(_perturbed(mistake, *edits)), case)
    assert (mismatch.case, mismatch.key) == (case, key)


# ----------------------------------------------------------------------------- the border


@pytest.mark.parametrize("mode", ["reflect", "edge", "constant"])
@pytest.mark.parametrize("case, key", [("np-16x16-noise", "cand_distance"),
                                       ("bp-16x16-noise", "candidates")])
def test_intensity_outside_the_image_other_than_mirrored_fails(cases_dir, mode, case, key):
    """The contract mirrors with the edge pixel repeated (``numpy.pad`` mode "symmetric":
    ``I[-1] = I[0]``, ``I[-2] = I[1]``); "reflect" (``I[-1] = I[1]``), "edge" (the edge
    pixel repeated) and zeros each change an Eq. 2 distance of a border window."""
    port = _port(_perturbed(mode, ('mode="symmetric"', f'mode="{mode}"')))
    mismatch = _first(cases_dir, port, case)
    assert (mismatch.case, mismatch.key) == (case, key)
