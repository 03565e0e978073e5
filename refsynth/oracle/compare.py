"""Comparing a case's returned arrays with the golden ones: the first difference, in words.

:func:`compare_case` takes a case's metadata, its golden arrays and what the function under
test returned (already arrays), and gives the first :class:`Mismatch` or None.

The order of comparison follows the run's causes, so that the report names where a port
first goes wrong, not the consequences:

- NP's trace step by step: the earliest step at which any returned ``step_*`` / ``cand_*``
  array differs. At that step the **decision** is named first: which pixel was filled
  (``step_pixel``), else which candidate was copied (``step_source``); the arrays compared
  at that step follow from it (a wrong pixel has other candidates, other distances), so the
  first of them that differs too is added after it. Then ``order``, ``range``,
  ``confidence`` and the other outputs.
- BP's label sets first (``candidates``: which labels a node has, each named by its centre
  pixel, so a wrong label reads ``node i pixel (r, c), label j: expected (r', c'), got …``), then
  what follows from them: ``candidate_values``, the unary terms, the pairs and their
  compatibilities, the messages sweep by sweep (``sweep_messages`` and ``sweep_change``
  at the exported ``sweeps``), the final messages, the beliefs, the MAP labels, and the
  outputs.
- An equation case: its outputs in the case's order.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Mismatch", "compare_case", "TOLERANCES", "TOLERANCE_NAMES", "RUN_REQUIRED"]

#: name → (rtol, atol) for float arrays; None is exact equality.
TOLERANCES = {"exact": None, "float64": (1e-9, 1e-12), "float32": (1e-4, 1e-6)}
#: From the strictest to the loosest.
TOLERANCE_NAMES = ("exact", "float64", "float32")
#: What a whole run (NP or BP) must return.
RUN_REQUIRED = ("range", "confidence", "order")

_BP_ORDER = ("candidates", "candidate_values", "unary", "pairs", "log_psi", "sweep_messages",
             "sweep_change", "messages", "beliefs", "labels", "iterations", "range",
             "confidence", "order")
#: NP's per-step arrays in the order the step computes them.
_NP_STEP_ORDER = ("step_pixel", "step_tier", "step_tie", "step_C", "step_D", "step_E",
                  "step_P", "cand_start", "cand_pixel", "cand_distance", "step_best",
                  "cand_in_gamma", "step_draw", "step_source", "step_value", "step_confidence")
#: A step's decisions: the pixel filled, then the candidate copied.
_NP_DECISIONS = ("step_pixel", "step_source")
#: Arrays whose rows are pixels, printed as ``(row, column)``.
_PIXEL_ROWS = ("step_pixel", "step_source", "cand_pixel", "order")


@dataclass(frozen=True)
class Mismatch:
    """The first difference found in a case: which array, where, and the two values.

    Attributes
    ----------
    case : str
        The case's name.
    key : str
        The array that differs (``"range"``, ``"step_pixel"``,
        ``"sweep_messages"`` …), or what went wrong instead
        (``"(the function raised)"``, ``"(time limit)"``, ``"(the result)"`` …).
    step : int or None
        NP's synthesis step or BP's sweep where it starts, if any.
    pixel : tuple of int or None
        ``(row, column)`` of the pixel concerned, if any.
    expected, got : object
        The two values (a number, a tuple, a list, or words such as
        ``"shape (8, 8)"``).
    where : str, default ""
        The place in words; by default built from ``step`` and ``pixel``.
    also : str, default ""
        What else differs at that place (NP: the first array of the step
        that follows from the decision named).
    message : str, default ""
        The whole finding in words, when there are no two values to show
        (the function raised, exited, ran out of time …).

    Examples
    --------
    >>> print(Mismatch("np-8x8-noise", "range", None, (2, 3), 1.5, 1.25))
    case np-8x8-noise: range pixel (2, 3): expected 1.5, got 1.25
    >>> print(Mismatch("eq7", "(the function raised)", None, None, None, None,
    ...                message="the function raised ZeroDivisionError: division by zero"))
    case eq7: the function raised ZeroDivisionError: division by zero
    """

    case: str
    key: str
    step: int | None
    pixel: tuple | None
    expected: object
    got: object
    where: str = ""
    also: str = ""
    message: str = ""

    def __str__(self) -> str:
        if self.message:
            return f"case {self.case}: {self.message}"
        where = self.where
        if not where:
            where = "" if self.step is None else f"step {self.step}"
            where += "" if self.pixel is None else f" pixel {self.pixel}"
        where = f" {where.strip()}" if where.strip() else ""
        also = f"; also {self.also}" if self.also else ""
        return (f"case {self.case}: {self.key}{where}: expected {self.expected!r}, "
                f"got {self.got!r}{also}")


# ----------------------------------------------------------------------------- elementwise


def _is_float(array) -> bool:
    return np.issubdtype(np.asarray(array).dtype, np.floating)


def _agree(expected: np.ndarray, got: np.ndarray, tolerance: str) -> np.ndarray:
    """Elementwise agreement (same shape assumed): exact, or within the float tolerance."""
    if _is_float(expected):
        got = got.astype(np.float64)
        same = (expected == got) | (np.isnan(expected) & np.isnan(got))
        if TOLERANCES[tolerance] is not None:
            rtol, atol = TOLERANCES[tolerance]
            same |= np.isclose(got, expected, rtol=rtol, atol=atol, equal_nan=True)
        return same
    return expected == got   # an integer output returned as floats: equal values are fine


def _value(array, index, key=""):
    item = np.asarray(array)[index]
    if isinstance(item, np.ndarray):
        value = item.tolist()
        pixels = key in _PIXEL_ROWS or key == "candidates"
        return tuple(value) if pixels and item.shape == (2,) else value
    return item.item()


def _first_difference(expected, got, tolerance):
    """``None`` if equal; ``"shape"`` if the shapes differ; else the first differing index."""
    expected, got = np.asarray(expected), np.asarray(got)
    if expected.shape != got.shape:
        return "shape"
    ok = _agree(expected, got, tolerance)
    if np.all(ok):
        return None
    return tuple(int(i) for i in np.argwhere(~np.asarray(ok))[0])


class _Locator:
    """Turns an array index into (step, pixel, detail) for the report."""

    def __init__(self, kind, expected, sweeps):
        self.kind = kind
        self.order = expected.get("order")
        self.pairs = expected.get("pairs")
        self.sweeps = sweeps

    def _node(self, i):
        return None if self.order is None or i >= len(self.order) else tuple(
            int(v) for v in self.order[i])

    def sweep(self, t):
        return int(self.sweeps[t]) if self.sweeps is not None and t < len(self.sweeps) else None

    def _message(self, row):
        edges = 0 if self.pairs is None else len(self.pairs)
        e = row % edges if edges else 0
        a, b = (self.pairs[e] if row < edges else self.pairs[e][::-1]) if edges else (0, 0)
        return self._node(int(a)), f"message {row} {self._node(int(a))} → {self._node(int(b))}"

    def locate(self, key, index):
        """``(step, pixel, where)``: the step (NP) or sweep (BP), the pixel, and the words."""
        if key in ("range", "confidence") and len(index) == 2:
            return None, index, f"pixel {index}"
        if key == "order":
            return index[0], self._node(index[0]), f"step {index[0]}"
        if self.kind == "bp" and key in ("candidates", "candidate_values", "unary", "beliefs",
                                         "labels"):
            pixel = self._node(index[0])
            label = f", label {index[1]}" if len(index) >= 2 else ""
            return None, pixel, f"node {index[0]} pixel {pixel}{label}"
        if self.kind == "bp" and key in ("pairs", "log_psi"):
            a, b = ((int(v) for v in self.pairs[index[0]]) if self.pairs is not None
                    and index[0] < len(self.pairs) else (0, 0))
            labels = f", labels {index[1:]}" if len(index) >= 3 else ""
            return None, self._node(a), (f"pair {index[0]} {self._node(a)}–{self._node(b)}"
                                         f"{labels}")
        if self.kind == "bp" and key == "sweep_change" and index:
            return self.sweep(index[0]), None, f"sweep {self.sweep(index[0])}"
        if self.kind == "bp" and key in ("messages", "sweep_messages"):
            sweep = self.sweep(index[0]) if key == "sweep_messages" else None
            rest = index[1:] if key == "sweep_messages" else index
            pixel, text = self._message(rest[0])
            label = f", label {rest[1]}" if len(rest) >= 2 else ""
            prefix = f"sweep {sweep} " if sweep is not None else ""
            return sweep, pixel, f"{prefix}{text}{label}"
        if self.kind not in ("np", "bp") and index:
            return None, None, f"item {index[0]}" + (f", index {index[1:]}" if len(index) > 1
                                                     else "")
        return None, None, f"index {index}" if index else ""


# ----------------------------------------------------------------------------- BP


def _compare_sweeps(name, expected, got, tolerance, locator):
    """BP's messages sweep by sweep: the first differing one, or the first one missing."""
    want, have = np.asarray(expected), np.asarray(got)
    if have.ndim != 3 or have.shape[1:] != want.shape[1:]:
        return Mismatch(name, "sweep_messages", None, None, f"shape {want.shape}",
                        f"shape {have.shape}")
    for t in range(max(len(want), len(have))):
        sweep = locator.sweep(t)
        if t >= len(want) or t >= len(have):
            return Mismatch(name, "sweep_messages", sweep, None,
                            "messages" if t < len(want) else "nothing",
                            "messages" if t < len(have) else "nothing",
                            f"sweep {sweep or len(want) + 1} (the run stopped after "
                            f"{min(len(want), len(have))} of the exported sweeps)")
        where = _first_difference(want[t], have[t], tolerance)
        if where is not None:
            step, pixel, detail = locator.locate("sweep_messages", (t, *where))
            return Mismatch(name, "sweep_messages", step, pixel, _value(want[t], where),
                            _value(have[t], where), detail)
    return None


def _at_exported_sweeps(array: np.ndarray, sweeps) -> np.ndarray:
    """A per-sweep array returned for every sweep, cut down to the exported ``sweeps``."""
    if sweeps is None or array.ndim < 1 or len(array) == len(sweeps):
        return array
    if len(sweeps) and len(array) >= int(sweeps.max()):
        return array[sweeps - 1]
    return array


def _compare(name, kind, key, expected, got, tolerance, locator):
    if kind == "bp" and key == "sweep_messages":
        return _compare_sweeps(name, expected, got, tolerance, locator)
    where = _first_difference(expected, got, tolerance)
    if where is None:
        return None
    if where == "shape":
        return Mismatch(name, key, None, None, f"shape {np.shape(expected)}",
                        f"shape {np.shape(got)}")
    if key in _PIXEL_ROWS and np.ndim(expected) == 2 and len(where) == 2:
        where = where[:1]                                 # the whole (row, column) pair
    elif key == "candidates" and np.ndim(expected) == 3 and len(where) == 3:
        where = where[:2]                                 # the label's centre (row, column)
    step, pixel, detail = locator.locate(key, where)
    return Mismatch(name, key, step, pixel, _value(expected, where, key),
                    _value(got, where, key), detail)


# ----------------------------------------------------------------------------- NP's trace


def _row(array, row, key):
    if row >= len(array):
        return "nothing"
    value = array[row].tolist()
    return tuple(value) if key in _PIXEL_ROWS and isinstance(value, list) else value


def _step_differences(expected, got, tolerance) -> list:
    """Every returned trace array's first differing row: (step, key, want, have, detail)."""
    starts = expected["cand_start"]
    found = []
    for key in sorted(k for k in expected if k.startswith(("step_", "cand_")) and k in got):
        e, g = np.asarray(expected[key]), np.asarray(got[key])
        if e.ndim != g.ndim or e.shape[1:] != g.shape[1:]:
            found.append((-1, key, f"shape {e.shape}", f"shape {g.shape}", ""))
            continue
        rows = min(len(e), len(g))
        ok = np.asarray(_agree(e[:rows], g[:rows], tolerance)).reshape(rows, -1).all(axis=1)
        if ok.all() and len(e) == len(g):
            continue
        row = int(np.argmin(ok)) if not ok.all() else rows
        detail = ""
        if key.startswith("cand_") and key != "cand_start":
            step = int(np.searchsorted(starts, row, side="right") - 1)
            detail = f"candidate {row - int(starts[step])}"
            if row < len(expected["cand_pixel"]):
                detail += f" {tuple(int(v) for v in expected['cand_pixel'][row])}"
        elif key == "cand_start":
            step = max(row - 1, 0)
            detail = "the number of candidates"
        else:
            step = row
        found.append((step, key, _row(e, row, key), _row(g, row, key), detail))
    return found


def _step_rank(key: str) -> tuple:
    return (_NP_STEP_ORDER.index(key), key) if key in _NP_STEP_ORDER else (len(_NP_STEP_ORDER),
                                                                           key)


def _trace_step(name, expected, got, tolerance):
    """The earliest NP step at which a returned trace array differs, its decision first."""
    found = _step_differences(expected, got, tolerance)
    if not found:
        return None
    first = min(item[0] for item in found)
    if first < 0:
        step, key, want, have, _ = min(item for item in found if item[0] < 0)
        return Mismatch(name, key, None, None, want, have)
    at_step = sorted((item for item in found if item[0] == first),
                     key=lambda item: _step_rank(item[1]))
    decisions = [item for item in at_step if item[1] in _NP_DECISIONS]
    head = decisions[0] if decisions else at_step[0]
    others = [item for item in at_step if item is not head]
    also = ""
    if others:
        _, key, want, have, detail = others[0]
        more = f" (and {len(others) - 1} more arrays of this step)" if len(others) > 1 else ""
        also = f"{key}{' ' + detail if detail else ''}: expected {want!r}, got {have!r}{more}"
    step, key, want, have, detail = head
    pixels = expected["step_pixel"]
    pixel = tuple(int(v) for v in pixels[step]) if step < len(pixels) else None
    where = f"step {step} pixel {pixel}" + (f", {detail}" if detail else "")
    return Mismatch(name, key, step, pixel, want, have, where, also)


# ----------------------------------------------------------------------------- a case


def compare_case(meta: dict, arrays: dict, got: dict, tolerance: str) -> Mismatch | None:
    """The first difference between ``got`` and the case's golden arrays (None: they agree).

    Parameters
    ----------
    meta : dict
        The case's JSON (``name``, ``kind`` and each array's ``role``).
    arrays : dict of str to ndarray
        The case's arrays (inputs, prepared, outputs, trace).
    got : dict of str to ndarray
        What the function returned, as numeric arrays.
    tolerance : str
        A key of :data:`TOLERANCES`.

    Returns
    -------
    Mismatch or None

    Examples
    --------
    >>> meta = {"name": "eq7", "kind": "eq7", "arrays": {
    ...     "distances": {"role": "input"}, "log_phi": {"role": "output"}}}
    >>> arrays = {"distances": np.zeros((1, 2)), "log_phi": np.array([[0.0, -1.0]])}
    >>> print(compare_case(meta, arrays, {"log_phi": np.array([[0.0, -2.0]])}, "exact"))
    case eq7: log_phi item 0, index (1,): expected -1.0, got -2.0
    """
    name, kind = meta["name"], meta["kind"]
    role = {key: meta["arrays"][key]["role"] for key in arrays}
    expected = {k: v for k, v in arrays.items() if role[k] in ("output", "trace")}
    if kind in ("np", "bp"):
        missing = [k for k in RUN_REQUIRED if k not in got]
    else:
        missing = [k for k in expected if role[k] == "output" and k not in got]
    if missing:
        return Mismatch(name, missing[0], None, None, "an array", "nothing")
    got = {k: np.asarray(v) for k, v in got.items() if k in expected}
    sweeps = arrays.get("sweeps")
    if kind == "bp":
        for key in ("sweep_messages", "sweep_change"):
            if key in got:
                got[key] = _at_exported_sweeps(got[key], sweeps)
    locator = _Locator(kind, {**expected, "order": arrays.get("order")}, sweeps)
    if kind == "np":
        if any(k.startswith(("step_", "cand_")) for k in got):
            # without step_pixel, the order is the pixel decision of each step
            alias = "step_pixel" not in got and "step_pixel" in expected
            steps = dict(got, step_pixel=got["order"]) if alias else got
            mismatch = _trace_step(name, expected, steps, tolerance)
            if mismatch is not None and alias and mismatch.key == "step_pixel":
                mismatch = replace(mismatch, key="order")
            if mismatch is not None:
                return mismatch
        keys = ["order", "range", "confidence"] + sorted(
            k for k in got if k not in ("order", "range", "confidence")
            and not k.startswith(("step_", "cand_")))
    elif kind == "bp":
        keys = [k for k in _BP_ORDER if k in got] + sorted(k for k in got if k not in _BP_ORDER)
    else:
        keys = [k for k in expected if k in got]
    for key in keys:
        mismatch = _compare(name, kind, key, expected[key], got[key], tolerance, locator)
        if mismatch is not None:
            return mismatch
    return None
