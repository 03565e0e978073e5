"""``oracle check MODULE:FUNCTION``: run a function on the golden cases, report each mismatch.

The function under test is called once per case as ``function(inputs, options)``:

- ``inputs`` holds the case's ``input`` and ``prepared`` arrays (a port with another random
  generator uses ``tie`` and ``draws`` instead of its own; a port may also start from the
  quantised ``q_intensity``/``q_range``; a BP run's ``sweeps`` lists the sweeps whose
  ``sweep_messages`` and ``sweep_change`` are compared);
- ``options`` holds the case's options — for a whole run every option of
  :func:`refsynth.synthesize` that the method takes, defaults filled in — plus ``method``
  (the case's kind: ``"np"``, ``"bp"``, ``"eq2"`` …) and ``seed``.

It returns a dict of arrays, or None for a kind of case it does not handle (the case is
skipped). A whole run must return at least ``range``, ``confidence`` and ``order``; any other
output or trace array it returns (NP's ``step_*``/``cand_*``, BP's ``unary``, ``log_psi``,
``messages``, ``sweep_messages`` …) is compared too. An equation case must return every
output of that case.

**Nothing a function does passes a case it should fail.** Before anything runs, every case
file is checked against the manifest's SHA-256 and read back (:mod:`refsynth.oracle.files`):
a changed, truncated or malformed folder is an error naming the file, never a mismatch. The
function then runs in a worker process (:mod:`refsynth.oracle.worker`) with a time limit per
case (:data:`~refsynth.oracle.worker.DEFAULT_TIMEOUT`, 120 s): a call that exits
(``sys.exit``, any code), raises, returns something other than a dict of numeric arrays or
None, overruns the limit or ends the worker is that case's failure, and the next case runs.

Comparison (:mod:`refsynth.oracle.compare`, :data:`TOLERANCES`): integer, boolean and index
arrays are always compared exactly. Float arrays are compared exactly too by default (the
numeric contract makes them exact), or within a stated tolerance: ``float64`` (rtol 1e-9,
atol 1e-12) or ``float32`` (rtol 1e-4, atol 1e-6). A case that is not under the contract
(Eq. 13 and the registration stage, ``tolerance: float64`` in its JSON) is compared at least
that loosely. NaN must match NaN. Each failing case reports its *first* difference, where it
starts, not its consequences, and a step's decision before the arrays that follow from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from refsynth.oracle.compare import TOLERANCE_NAMES, TOLERANCES, Mismatch, compare_case
from refsynth.oracle.files import load_case, load_cases, load_manifest
from refsynth.oracle.worker import DEFAULT_TIMEOUT, Runner, check_timeout, resolve_function

__all__ = ["Mismatch", "CheckReport", "resolve_function", "load_manifest", "load_case",
           "check_function", "call_arguments", "TOLERANCES", "TOLERANCE_NAMES",
           "DEFAULT_TIMEOUT"]

#: The failures' keys (:attr:`Mismatch.key`) for what an :class:`~refsynth.oracle.worker.Outcome`
#: reports.
_OUTCOME_KEYS = {"raised": "(the function raised)", "exited": "(the function exited)",
                 "result-type": "(the result)", "array": "(the result)",
                 "timeout": "(time limit)", "died": "(the worker process died)"}


@dataclass
class CheckReport:
    """What :func:`check_function` found: each failing case's first mismatch, and the counts.

    ``passed`` is True when no case failed and at least one was checked;
    ``str()`` gives what ``oracle check`` prints: one ``FAIL case …`` line per
    failing case, then the summary line (``PASS …`` or ``FAIL …``, with
    ``N passed, M failed``).

    Attributes
    ----------
    failures : list of Mismatch
        One per failing case, in manifest order.
    checked : list of str
        The cases the function returned a result for (or failed on), in
        manifest order.
    skipped : list of str
        The cases the function returned None for (kinds it does not handle).
    tolerance : str, default "exact"
        The tolerance asked for (a key of :data:`TOLERANCES`).

    Examples
    --------
    >>> report = CheckReport(checked=["eq7"], skipped=["eq13"])
    >>> report.passed, str(report)
    (True, 'PASS 1 cases at tolerance exact: 1 passed, 0 failed, 1 skipped (not handled)')
    """

    failures: list = field(default_factory=list)
    checked: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    tolerance: str = "exact"

    @property
    def mismatch(self) -> Mismatch | None:
        """The first failing case's mismatch (None if no case failed)."""
        return self.failures[0] if self.failures else None

    @property
    def passed(self) -> bool:
        return not self.failures and bool(self.checked)

    def summary(self) -> str:
        """The one summary line: verdict, then ``N passed, M failed`` (and skipped)."""
        failed = len(self.failures)
        counts = f"{len(self.checked) - failed} passed, {failed} failed"
        if self.skipped:
            counts += f", {len(self.skipped)} skipped (not handled)"
        if failed:
            return (f"FAIL {failed} of {len(self.checked)} cases at tolerance "
                    f"{self.tolerance}: {counts}")
        if not self.checked:
            return (f"FAIL the function handled none of the {len(self.skipped)} cases (it "
                    f"returned None for each): {counts}")
        return f"PASS {len(self.checked)} cases at tolerance {self.tolerance}: {counts}"

    def __str__(self) -> str:
        return "\n".join([f"FAIL {mismatch}" for mismatch in self.failures] + [self.summary()])


def call_arguments(meta: dict, arrays: dict) -> tuple[dict, dict]:
    """A case's ``(inputs, options)`` as the function under test receives them.

    ``inputs``: the ``input`` and ``prepared`` arrays; ``options``: the case's
    options plus ``method`` (its kind) and ``seed``.
    """
    inputs = {k: v for k, v in arrays.items()
              if meta["arrays"][k]["role"] in ("input", "prepared")}
    return inputs, dict(meta["options"], method=meta["kind"], seed=meta["seed"])


def _looser(a: str, b: str) -> str:
    return max(a, b, key=TOLERANCE_NAMES.index)


def _check_spec(function) -> None:
    if isinstance(function, str):
        if function.count(":") != 1 or not all(function.split(":")):
            raise ValueError(f"The function must be given as MODULE:FUNCTION, got {function!r}")
    elif not callable(function):
        raise TypeError("The parameter `function` must be a callable or 'MODULE:FUNCTION', "
                        f"got {type(function).__name__}")


def _failure(name: str, outcome) -> Mismatch:
    return Mismatch(name, _OUTCOME_KEYS.get(outcome.kind, "(the result)"), None, None,
                    "a result", outcome.kind, message=outcome.text)


def check_function(function, directory, *, case: str | None = None,
                   tolerance: str = "exact",
                   timeout: float | None = DEFAULT_TIMEOUT) -> CheckReport:
    """Run ``function`` on every exported case (or the one named) and report each failure.

    See the module's docstring for the calling convention, what counts as a
    failure, and the order of comparison.

    Parameters
    ----------
    function : callable or str
        ``function(inputs, options) -> dict of str to ndarray or None``, or
        ``"MODULE:FUNCTION"`` (imported in the worker process).
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.
    case : str, optional
        Check only this case; default: every case, in manifest order.
    tolerance : {"exact", "float64", "float32"}, default "exact"
        For float arrays (:data:`TOLERANCES`); a case that is not under the
        contract is compared at least as loosely as its own tolerance.
    timeout : float or None, default DEFAULT_TIMEOUT (120 s)
        Seconds each case's call may take, in a worker process; None runs
        the function in this process, without a limit (for a debugger).

    Returns
    -------
    CheckReport
        Each failing case's first mismatch, and the cases checked and
        skipped.

    Raises
    ------
    ValueError
        For an unknown case, tolerance or time limit; a folder whose files do
        not match their checksums or are malformed (naming the file); a
        ``MODULE:FUNCTION`` whose module does not import (naming it).
    FileNotFoundError
        For a missing folder, manifest or case file.

    Examples
    --------
    Eqs. 5–7's cases, against refsynth's fast code and against a port of
    Eq. 7 that forgot the evidence (it skips the other kinds):

    >>> import tempfile
    >>> import numpy as np
    >>> from refsynth.oracle import build_cases, export_cases, refsynth_fast
    >>> from refsynth.oracle.cases import select_cases
    >>> folder = tempfile.mkdtemp()
    >>> export_cases(folder, select_cases(build_cases(), ["eq[567]*"]))
    ['eq5-ties', 'eq5-eps0', 'eq6-h', 'eq6-v', 'eq7']
    >>> print(check_function(refsynth_fast, folder))
    PASS 5 cases at tolerance exact: 5 passed, 0 failed
    >>> def no_evidence(inputs, options):
    ...     if options["method"] == "eq7":
    ...         return {"log_phi": np.zeros(inputs["distances"].shape)}
    >>> print(check_function(no_evidence, folder))
    FAIL case eq7: log_phi item 0, index (0,): expected -2.4803499999999996, got 0.0
    FAIL 1 of 1 cases at tolerance exact: 0 passed, 1 failed, 4 skipped (not handled)
    """
    if tolerance not in TOLERANCES:
        raise ValueError(f"The tolerance must be one of {', '.join(TOLERANCE_NAMES)}, "
                         f"got {tolerance!r}")
    timeout = check_timeout(timeout)
    _check_spec(function)
    cases = load_cases(directory, case)          # every checksum, before anything runs
    report = CheckReport(tolerance=tolerance)
    with Runner(function, timeout) as runner:
        for meta, arrays in cases:
            name = meta["name"]
            wanted = [k for k in arrays if meta["arrays"][k]["role"] in ("output", "trace")]
            outcome = runner.call(*call_arguments(meta, arrays), wanted)
            if outcome.kind == "none":
                report.skipped.append(name)
                continue
            report.checked.append(name)
            if outcome.kind != "result":
                report.failures.append(_failure(name, outcome))
                continue
            level = _looser(tolerance, meta.get("tolerance", "exact"))
            try:
                mismatch = compare_case(meta, arrays, outcome.value, level)
            except Exception as error:   # arrays the comparison cannot line up
                mismatch = Mismatch(name, "(the result)", None, None, None, None,
                                    message="the returned arrays could not be compared: "
                                    f"{type(error).__name__}: {error}")
            if mismatch is not None:
                report.failures.append(mismatch)
    return report

