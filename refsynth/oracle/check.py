"""``oracle check MODULE:FUNCTION [--case NAME]``: run a function on the golden cases.

The function under test is called as ``function(inputs, options) -> dict``: ``inputs`` holds the
case's ``input`` and ``prepared`` arrays (a port with another random generator uses ``tie``
and ``draws`` instead of its own), ``options`` the case's options with ``method`` (its kind)
and ``seed``. It returns whichever outputs it has (at least ``range``, ``confidence`` and
``order`` for NP and BP runs; ``distance_mean``/``distance_ignore`` for Eq. 2; ``members`` for
Eq. 5), or None for a kind of case it does not handle (skipped); any ``step_*`` or
``cand_*`` trace it returns is compared too.

Comparison: exact for every array (the numeric contract makes the floats exact too), unless a
float tolerance is asked for (``"float32"``: rtol 1e-6, atol 1e-7). Steps are compared in fill
order, so the report names the *first* differing step and pixel, not its consequences.
"""

from __future__ import annotations

import importlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Mismatch", "resolve_function", "load_case", "check_function", "refsynth_fast",
           "refsynth_reference", "TOLERANCES"]

TOLERANCES = {"exact": (0.0, 0.0), "float64": (1e-12, 1e-15), "float32": (1e-6, 1e-7)}


@dataclass(frozen=True)
class Mismatch:
    """The first difference found: where, and the two values."""

    case: str
    key: str
    step: int | None
    pixel: tuple | None
    expected: object
    got: object

    def __str__(self) -> str:
        where = "" if self.step is None else f" step {self.step}"
        where += "" if self.pixel is None else f" pixel {self.pixel}"
        return (f"case {self.case}: {self.key}{where}: expected {self.expected!r}, "
                f"got {self.got!r}")


def resolve_function(spec: str):
    """``"package.module:function"`` → the callable."""
    module, _, name = spec.partition(":")
    if not module or not name:
        raise ValueError(f"The parameter `function` must read MODULE:FUNCTION, got {spec!r}")
    function = getattr(importlib.import_module(module), name, None)
    if not callable(function):
        raise ValueError(f"{spec!r} is not a callable")
    return function


def load_case(directory, name: str) -> tuple[dict, dict]:
    """The case's JSON metadata and its arrays."""
    root = Path(directory)
    meta = json.loads((root / "cases" / f"{name}.json").read_text())
    with np.load(root / "cases" / f"{name}.npz", allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    return meta, arrays


def _equal(expected, got, tolerance) -> np.ndarray:
    expected, got = np.asarray(expected), np.asarray(got)
    if expected.shape != got.shape:
        return np.zeros(expected.shape, bool)
    if tolerance == "exact" or not np.issubdtype(expected.dtype, np.floating):
        return (expected == got) | (np.isnan(expected) & np.isnan(got)
                                    if np.issubdtype(expected.dtype, np.floating) else False)
    rtol, atol = TOLERANCES[tolerance]
    return np.isclose(got, expected, rtol=rtol, atol=atol, equal_nan=True)


def _first(case, key, expected, got, tolerance, pixels=None):
    """The first mismatch of one array, in row order (steps first for traces), or None."""
    ok = _equal(expected, got, tolerance)
    if ok.all():
        return None
    if np.shape(expected) != np.shape(got):
        return Mismatch(case, key, None, None, f"shape {np.shape(expected)}",
                        f"shape {np.shape(got)}")
    index = tuple(np.argwhere(~ok)[0])
    step = int(index[0]) if key.startswith("step_") or key == "order" else None
    if step is not None and pixels is not None:
        pixel = tuple(int(i) for i in pixels[step])
    elif key in ("range", "confidence") and np.ndim(expected) == 2:
        pixel = tuple(int(i) for i in index)
    else:
        pixel = None
    return Mismatch(case, key, step, pixel, np.asarray(expected)[index].tolist(),
                    np.asarray(got)[index].tolist())


def _first_step(case, expected, got, tolerance, pixels):
    """The earliest step at which any returned trace array (``step_*``, ``cand_*``) differs."""
    found = []
    starts = expected.get("cand_start")
    for key in sorted(k for k in expected if k.startswith(("step_", "cand_")) and k in got):
        e, g = np.asarray(expected[key]), np.asarray(got[key])
        if e.shape[1:] != g.shape[1:]:
            return Mismatch(case, key, None, None, f"shape {e.shape}", f"shape {g.shape}")
        rows = min(len(e), len(g))
        ok = _equal(e[:rows], g[:rows], tolerance).reshape(rows, -1).all(axis=1)
        if ok.all() and len(e) == len(g):
            continue
        row = int(np.argmin(ok)) if not ok.all() else rows
        step = row
        if key.startswith("cand_") and key != "cand_start":
            step = int(np.searchsorted(starts, row, side="right") - 1)
        elif key == "cand_start":
            step = max(row - 1, 0)
        found.append((step, key, _row(e, row), _row(g, row)))
    if not found:
        return None
    step, key, want, have = min(found)
    pixel = None if pixels is None or step >= len(pixels) else tuple(int(i) for i in pixels[step])
    return Mismatch(case, key, step, pixel, want, have)


def _row(array, row):
    return array[row].tolist() if row < len(array) else "nothing"


def _inputs(meta, arrays) -> tuple[dict, dict]:
    inputs = {k: v for k, v in arrays.items() if meta["arrays"][k]["role"] in ("input", "prepared")}
    return inputs, dict(meta["options"], method=meta["kind"], seed=meta["seed"])


def check_function(function, directory, *, case: str | None = None,
                   tolerance: str = "exact") -> Mismatch | None:
    """Run ``function`` on every case (or one) and return the first mismatch, or None.

    Within a run, the step trace is compared first (in step order), then ``order``, then the
    other outputs in the manifest's order of arrays.
    """
    manifest = json.loads((Path(directory) / "manifest.json").read_text())
    names = [c["name"] for c in manifest["cases"]]
    if case is not None:
        if case not in names:
            raise ValueError(
                f"The parameter `case` must be one of the exported cases, got {case!r}")
        names = [case]
    for name in names:
        meta, arrays = load_case(directory, name)
        got = function(*_inputs(meta, arrays))
        if got is None:   # the function does not handle this kind of case
            continue
        expected = {k: v for k, v in arrays.items() if meta["arrays"][k]["role"] in
                    ("output", "trace")}
        pixels = arrays.get("step_pixel", arrays.get("order"))
        mismatch = _first_step(name, expected, got, tolerance, pixels)
        if mismatch is not None:
            return mismatch
        keys = sorted((k for k in expected if k in got and not k.startswith(("step_", "cand_"))),
                      key=lambda k: k != "order")
        for key in keys:
            mismatch = _first(name, key, expected[key], got[key], tolerance, pixels)
            if mismatch is not None:
                return mismatch
        missing = {"range", "confidence", "order"} - set(got)
        if meta["kind"] in ("np", "bp") and missing:
            return Mismatch(name, sorted(missing)[0], None, None, "an output", "nothing")
    return None


def refsynth_fast(inputs: dict, options: dict) -> dict:
    """refsynth's own fast code (:func:`refsynth.synthesize`) in the checker's convention."""
    import refsynth

    options = dict(options)
    method = options.pop("method")
    if method not in ("np", "bp"):
        return None   # per-equation cases: checked against the reference's own functions
    result = refsynth.synthesize(inputs["intensity"], inputs["partial_range"], method=method,
                                 edges=inputs["edges"] & options["use_edges"], **options)
    return dict(range=result.range, confidence=result.confidence, order=result.order)


def refsynth_reference(inputs: dict, options: dict) -> dict:
    """The literal reference in the checker's convention (it passes by construction)."""
    from refsynth.oracle.cases import Case, expected_outputs

    options = dict(options)
    kind, seed = options.pop("method"), options.pop("seed")
    names = {"np": ("intensity", "partial_range", "edges"), "bp": ("intensity", "partial_range",
             "edges"), "eq2": ("q_intensity", "q_range"), "eq5": ("distances",)}[kind]
    case = Case("check", kind, {k: inputs[k] for k in names}, options, seed)
    return expected_outputs(case)
