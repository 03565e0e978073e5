"""``oracle check MODULE:FUNCTION``: run a function on the golden cases, report the first mismatch.

The function under test is called once per case as ``function(inputs, options)``:

- ``inputs`` holds the case's ``input`` and ``prepared`` arrays (a port with another random
  generator uses ``tie`` and ``draws`` instead of its own; a port may also start from the
  quantised ``q_intensity``/``q_range``);
- ``options`` holds the case's options plus ``method`` (the case's kind: ``"np"``, ``"bp"``,
  ``"eq2"`` …) and ``seed``.

It returns a dict of arrays, or None for a kind of case it does not handle (the case is
skipped). A whole run must return at least ``range``, ``confidence`` and ``order``; any other
output or trace array it returns (NP's ``step_*``/``cand_*``, BP's ``unary``, ``log_psi``,
``messages``, ``sweep_messages`` …) is compared too. An equation case must return every
output of that case.

Comparison (:data:`TOLERANCES`): integer, boolean and index arrays are always compared
exactly. Float arrays are compared exactly too by default (the numeric contract makes them
exact), or within a stated tolerance: ``float64`` (rtol 1e-9, atol 1e-12) or ``float32``
(rtol 1e-4, atol 1e-6). A case that is not under the contract (Eq. 13 and the registration
stage, ``tolerance: float64`` in its JSON) is compared at least that loosely. NaN must match
NaN. The report is the *first* difference, where it starts, not its consequences: NP's trace
step by step (the earliest step at which any returned trace array differs), then ``order``,
then the other outputs; BP's candidates, unary terms, compatibilities, messages sweep by
sweep, beliefs, labels, then the outputs.
"""

from __future__ import annotations

import importlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Mismatch", "CheckReport", "resolve_function", "load_manifest", "load_case",
           "check_function", "TOLERANCES", "TOLERANCE_NAMES"]

#: name → (rtol, atol) for float arrays; None is exact equality.
TOLERANCES = {"exact": None, "float64": (1e-9, 1e-12), "float32": (1e-4, 1e-6)}
#: From the strictest to the loosest.
TOLERANCE_NAMES = ("exact", "float64", "float32")

_RUN_REQUIRED = ("range", "confidence", "order")
_BP_ORDER = ("candidates", "candidate_values", "unary", "pairs", "log_psi", "sweep_messages",
             "messages", "beliefs", "labels", "iterations", "range", "confidence", "order")


@dataclass(frozen=True)
class Mismatch:
    """The first difference found: which case and array, where, and the two values.

    Attributes
    ----------
    case : str
        The case's name.
    key : str
        The array that differs (``"range"``, ``"step_value"``,
        ``"sweep_messages"`` …), or what went wrong (``"(the function
        raised)"``, ``"(the result)"``).
    step : int or None
        NP's synthesis step or BP's sweep where it starts, if any.
    pixel : tuple of int or None
        ``(row, column)`` of the pixel concerned, if any.
    expected, got : object
        The two values (a number, a list, or words such as ``"shape (8, 8)"``).
    where : str, default ""
        The place in words; by default built from ``step`` and ``pixel``.

    Examples
    --------
    >>> print(Mismatch("np-8x8-noise", "range", None, (2, 3), 1.5, 1.25))
    case np-8x8-noise: range pixel (2, 3): expected 1.5, got 1.25
    """

    case: str
    key: str
    step: int | None
    pixel: tuple | None
    expected: object
    got: object
    where: str = ""

    def __str__(self) -> str:
        where = self.where
        if not where:
            where = "" if self.step is None else f"step {self.step}"
            where += "" if self.pixel is None else f" pixel {self.pixel}"
        where = f" {where.strip()}" if where.strip() else ""
        return f"case {self.case}: {self.key}{where}: expected {self.expected!r}, got {self.got!r}"


@dataclass
class CheckReport:
    """What :func:`check_function` found: the first mismatch (None: pass) and the case lists.

    ``passed`` is True when there is no mismatch and at least one case was
    checked; ``str()`` gives the one-line verdict ``oracle check`` prints.

    Attributes
    ----------
    mismatch : Mismatch or None
        The first difference; None if every checked case agreed.
    checked : list of str
        The cases compared, in manifest order.
    skipped : list of str
        The cases the function returned None for (kinds it does not handle).
    tolerance : str, default "exact"
        The tolerance asked for (a key of :data:`TOLERANCES`).

    Examples
    --------
    >>> report = CheckReport(None, checked=["eq7"], skipped=["eq13"])
    >>> report.passed, str(report)
    (True, 'PASS 1 cases at tolerance exact, 1 skipped (not handled)')
    """

    mismatch: Mismatch | None
    checked: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    tolerance: str = "exact"

    @property
    def passed(self) -> bool:
        return self.mismatch is None and bool(self.checked)

    def __str__(self) -> str:
        if self.mismatch is not None:
            return f"FAIL {self.mismatch}"
        if not self.checked:
            return (f"FAIL the function handled none of the {len(self.skipped)} cases "
                    "(it returned None for each)")
        skipped = f", {len(self.skipped)} skipped (not handled)" if self.skipped else ""
        return f"PASS {len(self.checked)} cases at tolerance {self.tolerance}{skipped}"


def resolve_function(spec: str):
    """``"package.module:function"`` → the callable (ValueError, one line, if it is not one).

    Parameters
    ----------
    spec : str
        ``MODULE:FUNCTION``, as ``oracle check`` takes it; ``FUNCTION`` may
        be dotted (``"package.module:Class.method"``). The module must be
        importable (on ``sys.path``).

    Returns
    -------
    callable
        The function to pass to :func:`check_function`.

    Raises
    ------
    ValueError
        If ``spec`` is not ``MODULE:FUNCTION``, the module does not import,
        or the name is not a callable of it.

    Examples
    --------
    >>> resolve_function("refsynth.oracle:refsynth_reference").__name__
    'refsynth_reference'
    """
    if not isinstance(spec, str) or spec.count(":") != 1:
        raise ValueError(f"The function must be given as MODULE:FUNCTION, got {spec!r}")
    module, name = spec.split(":")
    if not module or not name:
        raise ValueError(f"The function must be given as MODULE:FUNCTION, got {spec!r}")
    try:
        loaded = importlib.import_module(module)
    except ImportError as error:
        raise ValueError(f"Cannot import module {module!r} of {spec!r}: {error}") from None
    function = loaded
    for part in name.split("."):
        function = getattr(function, part, None)
    if not callable(function):
        raise ValueError(f"{spec!r}: module {module!r} has no callable {name!r}")
    return function


def load_manifest(directory) -> dict:
    """The manifest of an exported case set (ValueError / FileNotFoundError, one line).

    Parameters
    ----------
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.

    Returns
    -------
    dict
        ``manifest.json``: ``format`` (``"refsynth-oracle"``), ``version``,
        ``contract``, ``case_set``, the ``refsynth`` and ``numpy`` versions
        and ``cases``, a list of dicts (``name``, ``kind``, ``json``, ``npz``,
        ``sha256``).

    Raises
    ------
    FileNotFoundError
        If the folder or its ``manifest.json`` does not exist.
    ValueError
        If the manifest is not valid JSON or not a refsynth oracle manifest.

    Examples
    --------
    >>> from tempfile import mkdtemp
    >>> from refsynth.oracle import build_cases, export_cases
    >>> folder = mkdtemp()
    >>> export_cases(folder, build_cases()[:1])   # the first case, an 8×8 NP run
    ['np-8x8-noise']
    >>> manifest = load_manifest(folder)
    >>> manifest["format"], [entry["kind"] for entry in manifest["cases"]]
    ('refsynth-oracle', ['np'])
    """
    root = Path(directory)
    if not root.is_dir():
        raise FileNotFoundError(f"No such case folder: '{root}' (write it with "
                                "`python -m refsynth oracle export DIR`)")
    path = root / "manifest.json"
    if not path.is_file():
        raise FileNotFoundError(f"'{root}' holds no manifest.json: not an exported case set")
    try:
        manifest = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise ValueError(f"'{path}' is not valid JSON: {error}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != "refsynth-oracle":
        raise ValueError(f"'{path}' is not a refsynth oracle manifest")
    return manifest


def load_case(directory, name: str) -> tuple[dict, dict]:
    """The case's JSON metadata and its arrays.

    Parameters
    ----------
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.
    name : str
        The case's name (one of the manifest's).

    Returns
    -------
    meta : dict
        ``cases/<name>.json``: ``name``, ``kind``, ``equation``,
        ``function``, ``tolerance``, ``options``, ``seed`` and ``arrays``
        (each array's ``role``, ``dtype`` and ``shape``).
    arrays : dict of str to ndarray
        ``cases/<name>.npz``: the inputs, the prepared arrays, the expected
        outputs and the trace.

    Examples
    --------
    An Eq. 2 case (§3.2.2): 32 pairs of quantised 3×3 neighbourhoods in,
    the integer Gaussian window prepared, their two distances out.

    >>> import tempfile
    >>> from refsynth.oracle.cases import build_cases, select_cases
    >>> from refsynth.oracle.export import export_cases
    >>> folder = tempfile.mkdtemp()
    >>> written = export_cases(folder, select_cases(build_cases(), ["eq2-n3*"]))
    >>> meta, arrays = load_case(folder, "eq2-n3-c1")
    >>> {key: meta["arrays"][key]["role"] for key in ("q_range", "window", "distance_mean")}
    {'q_range': 'input', 'window': 'prepared', 'distance_mean': 'output'}
    >>> arrays["q_intensity"].shape, meta["tolerance"]
    ((32, 2, 3, 3, 1), 'exact')
    """
    root = Path(directory)
    meta = json.loads((root / "cases" / f"{name}.json").read_text())
    with np.load(root / "cases" / f"{name}.npz", allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    return meta, arrays


# ----------------------------------------------------------------------------- comparison


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
    if _is_float(got):   # an integer output returned as floats: equal values are fine
        return expected == got
    return expected == got


def _value(array, index):
    item = np.asarray(array)[index]
    return item.tolist() if isinstance(item, np.ndarray) else item.item()


def _first_difference(expected, got, tolerance):
    """``None`` if equal; ``"shape"`` if the shapes differ; else the first differing index."""
    expected, got = np.asarray(expected), np.asarray(got)
    if expected.shape != got.shape:
        return "shape"
    if got.dtype == object:
        return (0,) * expected.ndim if expected.ndim else ()
    ok = _agree(expected, got, tolerance)
    if np.all(ok):
        return None
    return tuple(int(i) for i in np.argwhere(~np.asarray(ok))[0])


class _Locator:
    """Turns an array index into (step, pixel, detail) for the report."""

    def __init__(self, kind, expected):
        self.kind = kind
        self.expected = expected
        self.order = expected.get("order")
        self.pairs = expected.get("pairs")

    def _node(self, i):
        return None if self.order is None or i >= len(self.order) else tuple(
            int(v) for v in self.order[i])

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
            return index[0], self._node(index[0]), f"step {index[0]} pixel {self._node(index[0])}"
        if self.kind == "bp" and key in ("candidates", "candidate_values", "unary", "beliefs",
                                         "labels"):
            pixel = self._node(index[0])
            label = f", label {index[1]}" if len(index) >= 2 else ""
            return None, pixel, f"node {index[0]} pixel {pixel}{label}"
        if self.kind == "bp" and key in ("pairs", "log_psi"):
            a, b = ((int(v) for v in self.pairs[index[0]]) if self.pairs is not None
                    else (0, 0))
            labels = f", labels {index[1:]}" if len(index) >= 3 else ""
            return None, self._node(a), (f"pair {index[0]} {self._node(a)}–{self._node(b)}"
                                         f"{labels}")
        if self.kind == "bp" and key in ("messages", "sweep_messages"):
            sweep = int(self.expected["sweeps"][index[0]]) if key == "sweep_messages" else None
            rest = index[1:] if key == "sweep_messages" else index
            pixel, text = self._message(rest[0])
            label = f", label {rest[1]}" if len(rest) >= 2 else ""
            prefix = f"sweep {sweep} " if sweep is not None else ""
            return sweep, pixel, f"{prefix}{text}{label}"
        if self.kind not in ("np", "bp") and index:
            return None, None, f"item {index[0]}" + (f", index {index[1:]}" if len(index) > 1
                                                     else "")
        return None, None, f"index {index}" if index else ""


def _compare_sweeps(name, expected, got, tolerance, locator):
    """BP's messages sweep by sweep: the first differing one, or the first one missing."""
    want = np.asarray(expected)
    have = np.asarray(got)
    if have.ndim != 3 or have.shape[1:] != want.shape[1:]:
        return Mismatch(name, "sweep_messages", None, None, f"shape {want.shape}",
                        f"shape {have.shape}")
    for t in range(max(len(want), len(have))):
        sweep = int(locator.expected["sweeps"][t]) if t < len(want) else None
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


def _compare(name, kind, key, expected, got, tolerance, locator):
    if kind == "bp" and key == "sweep_messages":
        return _compare_sweeps(name, expected, got, tolerance, locator)
    where = _first_difference(expected, got, tolerance)
    if where is None:
        return None
    if where == "shape":
        return Mismatch(name, key, None, None, f"shape {np.shape(expected)}",
                        f"shape {np.shape(got)}")
    step, pixel, detail = locator.locate(key, where)
    return Mismatch(name, key, step, pixel, _value(expected, where), _value(got, where), detail)


def _trace_step(name, expected, got, tolerance):
    """The earliest NP step at which any returned ``step_*`` / ``cand_*`` array differs."""
    starts = expected["cand_start"]
    pixels = expected["step_pixel"]
    found = []
    for key in sorted(k for k in expected if k.startswith(("step_", "cand_")) and k in got):
        e, g = np.asarray(expected[key]), np.asarray(got[key])
        if e.shape[1:] != g.shape[1:]:
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
        found.append((step, key, _row(e, row), _row(g, row), detail))
    if not found:
        return None
    step, key, want, have, detail = min(found, key=lambda item: (item[0], item[1]))
    if step < 0:
        return Mismatch(name, key, None, None, want, have)
    pixel = tuple(int(v) for v in pixels[step]) if step < len(pixels) else None
    where = f"step {step} pixel {pixel}" + (f", {detail}" if detail else "")
    return Mismatch(name, key, step, pixel, want, have, where)


def _row(array, row):
    return array[row].tolist() if row < len(array) else "nothing"


def _sweeps_of(got, expected):
    """The returned per-sweep messages at the exported sweeps (a port may return all sweeps)."""
    messages = np.asarray(got["sweep_messages"])
    sweeps = expected["sweeps"]
    if messages.ndim == 3 and len(messages) != len(sweeps) and len(messages) >= sweeps.max(
            initial=0):
        return messages[sweeps - 1]
    return messages


def _check_case(meta, arrays, got, tolerance):
    name, kind = meta["name"], meta["kind"]
    role = {key: meta["arrays"][key]["role"] for key in arrays}
    expected = {k: v for k, v in arrays.items() if role[k] in ("output", "trace")}
    if kind in ("np", "bp"):
        missing = [k for k in _RUN_REQUIRED if k not in got]
    else:
        missing = [k for k in expected if role[k] == "output" and k not in got]
    if missing:
        return Mismatch(name, missing[0], None, None, "an array", "nothing")
    got = {k: np.asarray(v) for k, v in got.items() if k in expected}
    if kind == "bp" and "sweep_messages" in got:
        got["sweep_messages"] = _sweeps_of(got, expected)
    locator = _Locator(kind, {**expected, "order": arrays.get("order")})
    if kind == "np":
        if any(k.startswith(("step_", "cand_")) for k in got):
            mismatch = _trace_step(name, expected, got, tolerance)
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
        if key not in got:
            continue
        mismatch = _compare(name, kind, key, expected[key], got[key], tolerance, locator)
        if mismatch is not None:
            return mismatch
    return None


def _inputs(meta, arrays) -> tuple[dict, dict]:
    inputs = {k: v for k, v in arrays.items() if meta["arrays"][k]["role"] in ("input", "prepared")}
    return inputs, dict(meta["options"], method=meta["kind"], seed=meta["seed"])


def _looser(a: str, b: str) -> str:
    return max(a, b, key=TOLERANCE_NAMES.index)


def check_function(function, directory, *, case: str | None = None,
                   tolerance: str = "exact") -> CheckReport:
    """Run ``function`` on every exported case (or the one named) and report the first mismatch.

    An exception raised by ``function`` is a mismatch (the case and the
    exception). See the module's docstring for the calling convention and the
    order of comparison.

    Parameters
    ----------
    function : callable
        ``function(inputs, options) -> dict of str to ndarray or None``
        (:func:`resolve_function` turns ``MODULE:FUNCTION`` into one).
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.
    case : str, optional
        Check only this case; default: every case, in manifest order.
    tolerance : {"exact", "float64", "float32"}, default "exact"
        For float arrays (:data:`TOLERANCES`); a case that is not under the
        contract is compared at least as loosely as its own tolerance.

    Returns
    -------
    CheckReport
        The first mismatch (None if all agree) and the cases checked and
        skipped.

    Raises
    ------
    ValueError
        For an unknown case or tolerance, or a foreign folder.
    FileNotFoundError
        For a missing folder or manifest.

    Examples
    --------
    Eqs. 5–7's cases, against refsynth's fast code and against a port of
    Eq. 7 that forgot the evidence (it skips the other kinds):

    >>> import tempfile
    >>> from refsynth.oracle import build_cases, export_cases, refsynth_fast
    >>> from refsynth.oracle.cases import select_cases
    >>> folder = tempfile.mkdtemp()
    >>> export_cases(folder, select_cases(build_cases(), ["eq[567]*"]))
    ['eq5-ties', 'eq5-eps0', 'eq6-h', 'eq6-v', 'eq7']
    >>> print(check_function(refsynth_fast, folder))
    PASS 5 cases at tolerance exact
    >>> def no_evidence(inputs, options):
    ...     if options["method"] == "eq7":
    ...         return {"log_phi": np.zeros(inputs["distances"].shape)}
    >>> print(check_function(no_evidence, folder))
    FAIL case eq7: log_phi item 0, index (0,): expected -2.4803499999999996, got 0.0
    """
    if tolerance not in TOLERANCES:
        raise ValueError(f"The tolerance must be one of {', '.join(TOLERANCE_NAMES)}, "
                         f"got {tolerance!r}")
    manifest = load_manifest(directory)
    names = [c["name"] for c in manifest["cases"]]
    if case is not None:
        if case not in names:
            raise ValueError(f"No case {case!r} in '{directory}'; the cases are "
                             + ", ".join(names))
        names = [case]
    report = CheckReport(None, tolerance=tolerance)
    for name in names:
        meta, arrays = load_case(directory, name)
        try:
            got = function(*_inputs(meta, arrays))
        except Exception as error:   # a port's bug is a finding, not a crash of the checker
            report.mismatch = Mismatch(name, "(the function raised)", None, None, "a result",
                                       f"{type(error).__name__}: {error}")
            return report
        if got is None:
            report.skipped.append(name)
            continue
        if not isinstance(got, dict):
            report.mismatch = Mismatch(name, "(the result)", None, None, "a dict of arrays",
                                       type(got).__name__)
            return report
        level = _looser(tolerance, meta.get("tolerance", "exact"))
        mismatch = _check_case(meta, arrays, got, level)
        report.checked.append(name)
        if mismatch is not None:
            report.mismatch = mismatch
            return report
    return report
