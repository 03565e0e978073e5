"""``oracle check`` cannot pass a broken port: misbehaving ports are each case's FAIL.

Each port below is a small module written beside the cases and checked from the command
line (``python -m refsynth oracle check my_port:check``), as a porter would: a port that
exits (any code, 0 too), raises, returns the wrong things or loops forever is reported as
that case's failure, the exit status is 1, and the summary line says how many passed and
failed; a module that does not import is one line naming it (exit 2).
"""

from __future__ import annotations

import itertools
import textwrap
from pathlib import Path

import numpy as np
import pytest

import refsynth.cli.main as cli_main
from refsynth.oracle import build_cases, check_function, export_cases, refsynth_reference
from refsynth.oracle.cases import select_cases
from refsynth.oracle.worker import check_timeout

_NAMES = (f"port_{i}" for i in itertools.count())


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("ports") / "cases"
    export_cases(root, select_cases(build_cases(), ["eq7", "eq5-ties", "np-8x8-noise"]))
    return root


def check(folder, tmp_path, monkeypatch, capsys, source: str, *options: str):
    """Write ``source`` as a fresh module beside the cases, run ``oracle check`` on it."""
    name = next(_NAMES)
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    code = cli_main.main(["oracle", "check", f"{name}:check", "--dir", str(folder), *options])
    captured = capsys.readouterr()
    return code, captured.out.strip().splitlines(), captured.err.strip().splitlines()


REFERENCE = "        from refsynth.oracle import refsynth_reference\n"


@pytest.mark.parametrize("body, finding", [
    ("import sys\n    sys.exit(0)", "the function exited (SystemExit: 0;"),
    ("import sys\n    sys.exit(3)", "the function exited (SystemExit: 3;"),
    ("raise SystemExit", "the function exited (SystemExit: None;"),
    ("raise RuntimeError('boom')", "the function raised RuntimeError: boom (port_"),
    ("return 'range'", "the function returned a str 'range', not a dict of arrays"),
    ("return [1, 2]", "the function returned a list, not a dict of arrays"),
    ("return {1: 2}", "the keys must be the arrays' names"),
    ("import os\n    os._exit(0)", "the function ended the worker process (exit status 0)"),
    ("import os, signal\n    os.kill(os.getpid(), signal.SIGKILL)",
     "the function ended the worker process (killed by SIGKILL)"),
    ("raise KeyboardInterrupt", "the function raised KeyboardInterrupt (port_"),
    ("class Odd(Exception):\n        def __str__(self):\n            raise ValueError\n"
     "    raise Odd()", "the function raised Odd: <Odd that cannot be shown>"),
])
def test_a_port_that_misbehaves_fails_every_case_and_exits_1(folder, tmp_path, monkeypatch,
                                                             capsys, body, finding):
    code, out, err = check(folder, tmp_path, monkeypatch, capsys,
                           f"def check(inputs, options):\n    {body}\n")
    assert code == 1 and not err
    assert [line.split(":")[0] for line in out[:-1]] == [
        "FAIL case np-8x8-noise", "FAIL case eq5-ties", "FAIL case eq7"]
    assert all(finding in line for line in out[:-1]), out
    assert out[-1] == "FAIL 3 of 3 cases at tolerance exact: 0 passed, 3 failed"


@pytest.mark.parametrize("value, finding", [
    ("None", "log_phi: expected an array of numbers, got None"),
    ("'abc'", "log_phi: expected an array of numbers, got a str 'abc'"),
    ("['a', 'b']", "log_phi: expected an array of numbers, got a list"),
    ("[[1.0], [1.0, 2.0]]", "log_phi: expected an array of numbers, got a list (ValueError"),
    ("{'x': 1}", "log_phi: expected an array of numbers, got a dict"),
    ("np.zeros(3)", "log_phi: expected 'shape (8, 6)', got 'shape (3,)'"),
    ("np.zeros((8, 6), complex)", "log_phi: expected an array of numbers, got an array of "
     "complex128"),
])
def test_wrong_arrays_are_that_cases_failure_and_the_others_still_run(
        folder, tmp_path, monkeypatch, capsys, value, finding):
    code, out, err = check(folder, tmp_path, monkeypatch, capsys, REFERENCE + f"""
        import numpy as np

        def check(inputs, options):
            if options["method"] == "eq7":
                return {{"log_phi": {value}}}
            return refsynth_reference(inputs, options)
    """)
    assert code == 1 and not err
    assert out[0].startswith("FAIL case eq7: ") and finding in out[0], out
    assert out[1:] == ["FAIL 1 of 3 cases at tolerance exact: 2 passed, 1 failed"]


def test_a_port_that_loops_forever_is_stopped_at_the_time_limit(folder, tmp_path, monkeypatch,
                                                                capsys):
    code, out, err = check(folder, tmp_path, monkeypatch, capsys, REFERENCE + """
        def check(inputs, options):
            if options["method"] == "eq5":
                while True:
                    pass
            return refsynth_reference(inputs, options)
    """, "--timeout", "1.5")
    assert code == 1 and not err
    assert out == ["FAIL case eq5-ties: no result within the time limit of 1.5 s (the call "
                   "was stopped; --timeout sets the limit)",
                   "FAIL 1 of 3 cases at tolerance exact: 2 passed, 1 failed"]


def test_a_port_that_handles_nothing_fails(folder, tmp_path, monkeypatch, capsys):
    code, out, _ = check(folder, tmp_path, monkeypatch, capsys,
                         "def check(inputs, options):\n    return None\n")
    assert code == 1
    assert out == ["FAIL the function handled none of the 3 cases (it returned None for "
                   "each): 0 passed, 0 failed, 3 skipped (not handled)"]


def test_a_correct_port_passes_with_a_summary(folder, tmp_path, monkeypatch, capsys):
    code, out, _ = check(folder, tmp_path, monkeypatch, capsys, REFERENCE + """
        def check(inputs, options):
            return refsynth_reference(inputs, options)
    """, "--case", "eq7", "--timeout", "30")
    assert (code, out) == (0, ["PASS 1 cases at tolerance exact: 1 passed, 0 failed"])


@pytest.mark.parametrize("source, finding", [
    ("def check(inputs, options)\n    return None\n", "SyntaxError: expected ':' (port_"),
    ("raise RuntimeError('at import')\n", "RuntimeError: at import (port_"),
    ("import sys\nsys.exit(0)\n", "SystemExit: 0"),
    ("import no_such_module_xyz\n", "ModuleNotFoundError: No module named 'no_such_module_xyz'"),
    ("x = 1\n", "has no callable 'check'"),
    ("import os\nos._exit(4)\n", "ended while importing module 'port_"),
])
def test_a_module_that_does_not_import_is_one_line_exit_2(folder, tmp_path, monkeypatch,
                                                          capsys, source, finding):
    code, out, err = check(folder, tmp_path, monkeypatch, capsys, source)
    assert code == 2 and not out
    assert len(err) == 1 and err[0].startswith("refsynth oracle: error:"), err
    assert finding in err[0] and "port_" in err[0], err


def test_a_module_that_hangs_at_import_is_one_line_exit_2(folder, tmp_path, monkeypatch, capsys):
    code, out, err = check(folder, tmp_path, monkeypatch, capsys, "while True:\n    pass\n",
                           "--timeout", "1")
    assert code == 2 and not out
    assert len(err) == 1 and "Importing module 'port_" in err[0] and "time limit of 1 s" in err[0]


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "abc", "1e9"])
def test_a_bad_timeout_is_a_usage_error(folder, value, capsys):
    code = cli_main.main(["oracle", "check", "refsynth.oracle:refsynth_fast", "--dir",
                          str(folder), "--timeout", value])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--timeout" in err[0] and "seconds" in err[0]


def test_check_timeout_names_the_argument():
    assert check_timeout(0.5) == 0.5 and check_timeout(None) is None
    for bad in (0, -1.0, float("nan"), float("inf"), 1e9):
        with pytest.raises(ValueError, match="timeout"):
            check_timeout(bad)
    for bad in ("5", True, [1]):
        with pytest.raises(TypeError, match="timeout"):
            check_timeout(bad)


def test_the_api_catches_the_same_in_process_and_in_the_worker(folder):
    def exits(inputs, options):
        raise SystemExit(0)

    for timeout in (None, 30):
        report = check_function(exits, folder, case="eq7", timeout=timeout)
        assert not report.passed and report.mismatch.key == "(the function exited)"
        assert "SystemExit: 0" in str(report)
    with pytest.raises(TypeError, match="function"):
        check_function(42, folder)
    with pytest.raises(ValueError, match="MODULE:FUNCTION"):
        check_function("nocolon", folder)


def test_the_port_cannot_change_the_golden_arrays(folder):
    """The worker gets copies: a port that writes into its inputs changes nothing here."""

    def scribbles(inputs, options):
        out = refsynth_reference(inputs, options)
        for value in inputs.values():
            value[...] = 0
        return out

    for timeout in (30, None):
        assert check_function(scribbles, folder, timeout=timeout).passed
    assert np.any(np.load(folder / "cases" / "eq7.npz")["distances"] != 0)


def test_a_case_folder_that_is_a_file_is_one_line(tmp_path, capsys):
    (tmp_path / "cases").write_text("")
    code = cli_main.main(["oracle", "check", "refsynth.oracle:refsynth_fast", "--dir",
                          str(tmp_path / "cases")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "is a file, not a case folder" in err[0]


def test_the_worker_also_runs_when_started_afresh(folder, tmp_path, monkeypatch):
    """``spawn`` (macOS' and Windows' default): the module is imported in a new interpreter,
    and the time limit and the failures hold there too."""
    import refsynth.oracle.worker as worker

    monkeypatch.setattr(worker, "start_method", lambda target: "spawn")
    (tmp_path / "spawned_port.py").write_text(textwrap.dedent("""
        import sys
        from refsynth.oracle import refsynth_reference

        def check(inputs, options):
            if options["method"] == "eq5":
                while True:
                    pass
            if options["method"] == "np":
                sys.exit(0)
            return refsynth_reference(inputs, options)
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    report = check_function("spawned_port:check", folder, timeout=10)
    assert report.checked == ["np-8x8-noise", "eq5-ties", "eq7"]
    assert [m.key for m in report.failures] == ["(the function exited)", "(time limit)"]


@pytest.mark.parametrize("timeout", [None, 30])
def test_a_port_gets_copies_of_the_case_arrays(timeout):
    from refsynth.oracle.worker import Runner

    def scribbles(inputs, options):
        inputs["x"][...] = 0
        options["method"] = "changed"
        return {"y": np.ones(2)}

    inputs, options = {"x": np.arange(3.0)}, {"method": "eq7"}
    with Runner(scribbles, timeout) as runner:
        outcome = runner.call(inputs, options, ["y"])
    assert outcome.kind == "result" and outcome.value["y"].tolist() == [1.0, 1.0]
    assert inputs["x"].tolist() == [0.0, 1.0, 2.0] and options == {"method": "eq7"}
