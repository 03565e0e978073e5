"""Each tutorial run once per test session, for tests/test_tutorials.py and tests/test_notebooks.py.

With the ``course`` extra installed (jupytext, nbclient, ipykernel), a
tutorial runs as a notebook, exactly as ``python -m refsynth notebooks``
runs it; otherwise as plain Python. Either way its figures are written to
files (``REFSYNTH_TUTORIAL_OUT``) and its printed output is kept, so one run
serves the checks of the files, of the inline figures and of the numbers the
text relies on.

Every run is a child process (the notebooks' too: a child executes the
notebook with :func:`refsynth.cli.notebooks.execute_tutorial` and writes it;
this process reads it back), so the runs the session's selected tests need
are started ahead, two at a time (:func:`prefetch`): the suite's machine has
two cores and a tutorial uses one.
"""

from __future__ import annotations

import atexit
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TUTORIALS_DIR = ROOT / "tutorials"
TUTORIALS = sorted(TUTORIALS_DIR.glob("[0-9][0-9]_*.py"))
SOLUTIONS = sorted((TUTORIALS_DIR / "solutions").glob("[0-9][0-9]_*.py"))
#: A runaway guard, not the budget: each tutorial is written to take <= 60 s on 2 quiet
#: cores (``python -m refsynth notebooks`` prints each one's time), but wall time on a
#: shared CI machine is no measurement, so the tests only catch a tutorial 5x over.
BUDGET_SECONDS = 300.0

_BASE = Path(tempfile.mkdtemp(prefix="refsynth-tutorials-"))
atexit.register(shutil.rmtree, _BASE, True)


def course_installed() -> bool:
    """True when jupytext, nbclient and ipykernel import (the ``course`` extra)."""
    from refsynth.cli.notebooks import require_course_packages

    try:
        require_course_packages()
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class TutorialRun:
    """One run of one tutorial."""

    path: Path
    mode: str  # "notebook" or "python"
    text: str  # what it printed
    figures: Path  # REFSYNTH_TUTORIAL_OUT
    seconds: float
    notebook: object | None = None

    def pngs(self) -> list[Path]:
        return sorted(self.figures.glob("*.png"))


def tutorial(name: str) -> Path:
    """The tutorial whose file name is ``name`` (or whose stem or number is)."""
    for path in TUTORIALS:
        if name in (path.name, path.stem, path.stem[:2]):
            return path
    raise LookupError(name)


def _environment(figures: Path) -> dict:
    env = dict(os.environ, REFSYNTH_TUTORIAL_OUT=str(figures), MPLBACKEND="Agg")
    env.pop("DISPLAY", None)
    return env


#: At most two runs at a time: two cores, one each.
_POOL = ThreadPoolExecutor(max_workers=2, thread_name_prefix="tutorial-run")
_FUTURES: dict[tuple[str, str], Future] = {}
_LOCK = threading.Lock()


def _once(kind: str, name: str, function) -> Future:
    """The session's one run of ``function(name)``, started now if not started yet."""
    with _LOCK:
        if (kind, name) not in _FUTURES:
            _FUTURES[kind, name] = _POOL.submit(function, name)
        return _FUTURES[kind, name]


def _python(name: str) -> TutorialRun:
    path = tutorial(name)
    work = _BASE / f"python-{path.stem}"
    figures = work / "figures"
    work.mkdir()
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                          env=_environment(figures), timeout=600, cwd=work)
    seconds = time.perf_counter() - start
    assert proc.returncode == 0, f"{path.name} failed:\n{proc.stderr[-4000:]}"
    return TutorialRun(path, "python", proc.stdout, figures, seconds)


#: The child that executes one notebook: warnings are errors, as in this session.
_EXECUTE = r"""
import json, os, sys, warnings
warnings.simplefilter("error")
warnings.filterwarnings("ignore", "mypy_extensions.TypedDict is deprecated", DeprecationWarning)
sys.path.insert(0, sys.argv[1])
from pathlib import Path
from refsynth.cli.notebooks import execute_tutorial
run = execute_tutorial(Path(sys.argv[2]), Path(sys.argv[3]), env=dict(os.environ))
print(json.dumps({"seconds": run.seconds, "notebook": str(run.path)}))
"""


def _notebook(name: str) -> TutorialRun:
    import nbformat

    path = tutorial(name)
    work = _BASE / f"notebook-{path.stem}"
    figures = work / "figures"
    proc = subprocess.run([sys.executable, "-c", _EXECUTE, str(ROOT), str(path),
                           str(work / "kernel")], capture_output=True, text=True,
                          env=_environment(figures), timeout=1800)
    if proc.returncode != 0:  # execute_tutorial's one line (the cell, the exception) is last
        raise ValueError(proc.stderr.strip().splitlines()[-1] if proc.stderr.strip()
                         else f"{path.name}: exit status {proc.returncode}")
    done = json.loads(proc.stdout.strip().splitlines()[-1])
    notebook = nbformat.read(done["notebook"], as_version=4)
    text = "".join(output.get("text", "") for cell in notebook.cells
                   if cell.cell_type == "code" for output in cell.get("outputs", [])
                   if output.get("output_type") == "stream" and output.get("name") == "stdout")
    return TutorialRun(path, "notebook", text, figures, done["seconds"], notebook)


def _solution(name: str) -> subprocess.CompletedProcess:
    (path,) = (p for p in SOLUTIONS if p.name == name)
    work = _BASE / f"solution-{path.stem}"
    work.mkdir()
    return subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                          timeout=300, cwd=work)


def run_as_python(name: str) -> TutorialRun:
    """``python tutorials/NAME.py`` in a fresh folder, figures to its ``figures/``."""
    return _once("python", tutorial(name).name, _python).result()


def run_as_notebook(name: str) -> TutorialRun:
    """The tutorial as ``python -m refsynth notebooks`` executes it (nbclient, one kernel)."""
    return _once("notebook", tutorial(name).name, _notebook).result()


def run(name: str) -> TutorialRun:
    """The session's run of a tutorial: as a notebook if the course extra is installed."""
    return run_as_notebook(name) if course_installed() else run_as_python(name)


def run_solution(name: str) -> subprocess.CompletedProcess:
    """``python tutorials/solutions/NAME.py`` in a fresh folder: its exit status and output."""
    return _once("solution", name, _solution).result()


#: What each test of test_notebooks.py and test_tutorials.py runs, given its ``path``.
_NEEDS = {
    "test_tutorial_runs_as_a_notebook_with_inline_figures": lambda path: [("notebook", path)],
    "test_tutorial_writes_its_figures": lambda path: [("run", path)],
    "test_tutorial_claims_hold": lambda path: [("run", path)],
    "test_a_tutorial_runs_as_plain_python": lambda path: [("python", PLAIN), ("run", PLAIN)],
    "test_solutions_run_and_their_answers_hold": lambda path: [("solution", path)],
}
#: The tutorial that also runs as plain Python in every case.
PLAIN = "03_registration.py"


def prefetch(items) -> None:
    """Start the runs the selected test ``items`` need, in their order, two at a time."""
    functions = {"notebook": _notebook, "python": _python, "solution": _solution}
    for item in items:
        needs = _NEEDS.get(getattr(item, "originalname", item.name))
        if needs is None:
            continue
        path = getattr(item, "callspec", None) and item.callspec.params.get("path")
        for kind, name in needs(path.name if path else None):
            if kind == "run":
                kind = "notebook" if course_installed() else "python"
            if kind == "notebook" and not course_installed():
                continue
            _once(kind, name, functions[kind])


def cancel_pending() -> None:
    """Drop the runs not started yet (a session stopped early need not wait for them)."""
    _POOL.shutdown(wait=False, cancel_futures=True)
