"""Each tutorial run once per test session, for tests/test_tutorials.py and tests/test_notebooks.py.

With the ``course`` extra installed (jupytext, nbclient, ipykernel), a
tutorial runs as a notebook, exactly as ``python -m refsynth notebooks``
runs it; otherwise as plain Python. Either way its figures are written to
files (``REFSYNTH_TUTORIAL_OUT``) and its printed output is kept, so one run
serves the checks of the files, of the inline figures and of the numbers the
text relies on.
"""

from __future__ import annotations

import atexit
import functools
import os
import shutil
import subprocess
import sys
import tempfile
import time
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


@functools.cache
def run_as_python(name: str) -> TutorialRun:
    """``python tutorials/NAME.py`` in a fresh folder, figures to its ``figures/``."""
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


@functools.cache
def run_as_notebook(name: str) -> TutorialRun:
    """The tutorial as ``python -m refsynth notebooks`` executes it (nbclient, one kernel)."""
    from refsynth.cli.notebooks import execute_tutorial

    path = tutorial(name)
    work = _BASE / f"notebook-{path.stem}"
    figures = work / "figures"
    run = execute_tutorial(path, work / "kernel", env=_environment(figures))
    text = "".join(output.get("text", "") for cell in run.notebook.cells
                   if cell.cell_type == "code" for output in cell.get("outputs", [])
                   if output.get("output_type") == "stream" and output.get("name") == "stdout")
    return TutorialRun(path, "notebook", text, figures, run.seconds, run.notebook)


def run(name: str) -> TutorialRun:
    """The session's run of a tutorial: as a notebook if the course extra is installed."""
    return run_as_notebook(name) if course_installed() else run_as_python(name)
