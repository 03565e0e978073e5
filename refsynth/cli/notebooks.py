"""``python -m refsynth notebooks``: the course's tutorials as executed Jupyter notebooks.

The tutorials are Jupytext "percent" scripts in ``tutorials/`` (reviewable
diffs; each also runs as plain Python). This command turns each into a
notebook with jupytext, executes it in a fresh ``python3`` kernel with
nbclient, and writes ``OUT/<name>.ipynb`` with its outputs: the printed
numbers and every figure inline (``image/png``). It needs the ``course``
extra (``pip install -e ".[course]"``: jupytext, nbclient, ipykernel).

The kernels run in ``OUT``; the tutorials' shared helper ``_course.py`` is
copied there, so the notebooks can be re-run where they are, and the figure
files they write go to ``OUT/tutorial-output/``.

:func:`add_notebooks_parser` adds the subcommand to the main parser of
:mod:`refsynth.cli.main`. User errors (missing packages, an unknown
``--only``, a tutorial that fails) are raised as ImportError / ValueError
with a one-line message; the main entry point prints it and exits with
status 2.

Examples::

    python -m refsynth notebooks --out notebooks
    python -m refsynth notebooks --out notebooks --only 01 --only 02_belief_propagation
"""

from __future__ import annotations

import argparse
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from refsynth._files import write_atomic
from refsynth.cli.arguments import add_subcommand

__all__ = [
    "COURSE_PACKAGES",
    "NotebookRun",
    "add_notebooks_parser",
    "default_tutorials_dir",
    "execute_tutorial",
    "find_tutorials",
    "image_outputs",
    "error_outputs",
    "require_course_packages",
]

#: The ``course`` extra's packages, as imported.
COURSE_PACKAGES = ("jupytext", "nbclient", "ipykernel")

#: The tutorials' shared helper, copied beside the notebooks.
HELPER = "_course.py"

INSTALL_HINT = 'pip install -e ".[course]"'


@dataclass(frozen=True)
class NotebookRun:
    """One executed tutorial.

    Attributes
    ----------
    source : pathlib.Path
        The percent script.
    notebook : nbformat.NotebookNode
        The executed notebook (outputs included).
    path : pathlib.Path or None
        Where it was written, if it was.
    seconds : float
        Wall time of the execution (kernel start included).
    """

    source: Path
    notebook: object
    path: Path | None
    seconds: float

    @property
    def images(self) -> int:
        """Number of inline ``image/png`` outputs."""
        return len(image_outputs(self.notebook))


def require_course_packages() -> None:
    """Raise ImportError (one line, naming the extra) unless the course packages import."""
    missing = []
    for name in COURSE_PACKAGES:
        try:
            __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise ImportError(
            f"the notebooks command needs {', '.join(missing)}: {INSTALL_HINT}"
        )


def default_tutorials_dir() -> Path:
    """The ``tutorials/`` folder of the refsynth checkout (or of the current directory)."""
    import refsynth

    checkout = Path(refsynth.__file__).resolve().parent.parent / "tutorials"
    return checkout if checkout.is_dir() else Path("tutorials")


def find_tutorials(folder: str | Path, only: list[str] | None = None) -> list[Path]:
    """The tutorials in ``folder`` (``NN_name.py``, in order), optionally a selection.

    Parameters
    ----------
    folder : str or pathlib.Path
        Where the percent scripts are.
    only : list of str, optional
        Names to keep: a file name (``01_np_range_synthesis.py``), its stem,
        or its number (``01``).

    Raises
    ------
    ValueError
        If the folder holds no tutorial, or a name in ``only`` matches none.
    """
    folder = Path(folder)
    tutorials = sorted(p for p in folder.glob("[0-9][0-9]_*.py") if p.is_file())
    if not tutorials:
        raise ValueError(f"no tutorials (NN_name.py) in {folder}; pass --tutorials DIR")
    if not only:
        return tutorials
    chosen = []
    for name in only:
        matches = [p for p in tutorials if name in (p.name, p.stem, p.stem[:2])]
        if not matches:
            known = ", ".join(p.stem for p in tutorials)
            raise ValueError(f"--only {name!r} matches no tutorial (have: {known})")
        chosen.extend(p for p in matches if p not in chosen)
    return sorted(chosen)


def image_outputs(notebook) -> list[dict]:
    """Every output of ``notebook`` that carries an inline PNG (``image/png``)."""
    return [output for cell in notebook.cells if cell.cell_type == "code"
            for output in cell.get("outputs", [])
            if "image/png" in output.get("data", {})]


def error_outputs(notebook) -> list[dict]:
    """Every error output of ``notebook``, and every stream written to stderr."""
    return [output for cell in notebook.cells if cell.cell_type == "code"
            for output in cell.get("outputs", [])
            if output.get("output_type") == "error"
            or (output.get("output_type") == "stream" and output.get("name") == "stderr")]


def _first_error(notebook) -> str:
    for index, cell in enumerate(notebook.cells):
        for output in cell.get("outputs", []):
            if output.get("output_type") == "error":
                return f"cell {index} raised {output['ename']}: {output['evalue']}"
    return "a cell failed"


def execute_tutorial(
    source: str | Path,
    out: str | Path,
    *,
    timeout: int = 600,
    write: bool = True,
    env: dict | None = None,
) -> NotebookRun:
    """Convert one percent script to a notebook, execute it in ``out`` and write it there.

    Parameters
    ----------
    source : str or pathlib.Path
        The tutorial (a Jupytext percent script).
    out : str or pathlib.Path
        The kernel's working folder, where ``<stem>.ipynb`` is written; the
        tutorials' ``_course.py`` is copied there.
    timeout : int, default 600
        Seconds any one cell may take.
    write : bool, default True
        Write the executed notebook (also when a cell fails, with the error
        in it).
    env : dict, optional
        The kernel's environment (default: this process's).

    Returns
    -------
    NotebookRun

    Raises
    ------
    ValueError
        If a cell raises, takes longer than ``timeout``, or the kernel dies
        (one line: the tutorial, the cell, the exception).
    """
    require_course_packages()
    import jupytext
    import nbformat
    from nbclient import NotebookClient
    from nbclient.exceptions import CellExecutionError, CellTimeoutError, DeadKernelError

    source, out = Path(source), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    helper = source.parent / HELPER
    if helper.is_file() and helper.resolve() != (out / HELPER).resolve():
        write_atomic(out / HELPER, helper.read_bytes())
    notebook = jupytext.read(source, fmt="py:percent")
    notebook.metadata["kernelspec"] = {
        "display_name": "Python 3", "language": "python", "name": "python3"}
    notebook.metadata.pop("jupytext", None)  # a plain .ipynb, not paired with the script
    client = NotebookClient(notebook, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(out)}})
    path = out / f"{source.stem}.ipynb" if write else None
    start = time.perf_counter()
    try:
        # the kernel's own log (e.g. jupyter_client's TCP notice) is not the tutorial's output
        client.execute(stderr=subprocess.DEVNULL, **({} if env is None else {"env": env}))
    except (CellExecutionError, CellTimeoutError, DeadKernelError) as error:
        if path is not None:
            _write_notebook(nbformat, notebook, path)
        if isinstance(error, CellExecutionError):
            what = _first_error(notebook)
        else:  # a cell over --timeout, or a kernel that died
            what = f"{type(error).__name__}: {str(error).strip().splitlines()[0]}"
        where = f" (notebook with the error: {path})" if path is not None else ""
        raise ValueError(f"{source.name}: {what}{where}") from None
    seconds = time.perf_counter() - start
    if path is not None:
        _write_notebook(nbformat, notebook, path)
    return NotebookRun(source=source, notebook=notebook, path=path, seconds=seconds)


def _write_notebook(nbformat, notebook, path: Path) -> None:
    """``nbformat.write``'s text (ending in a newline), written all or nothing."""
    text = nbformat.writes(notebook)
    write_atomic(path, (text if text.endswith("\n") else text + "\n").encode("utf-8"))


def _cmd_notebooks(args) -> int:
    require_course_packages()
    folder = Path(args.tutorials) if args.tutorials else default_tutorials_dir()
    tutorials = find_tutorials(folder, args.only)
    out = Path(args.out)
    for source in tutorials:
        run = execute_tutorial(source, out, timeout=args.timeout)
        print(f"{run.path}: {len(run.notebook.cells)} cells, {run.images} inline figures, "
              f"{run.seconds:.1f} s", flush=True)
    return 0


def add_notebooks_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``notebooks`` (the tutorials, executed into notebooks) to a subparser set.

    Returns the subcommand's parser; its handler needs the course extra.
    """
    parser = add_subcommand(
        subparsers, "notebooks",
        help="build the course's executed Jupyter notebooks from tutorials/",
        description="Convert each tutorial (a Jupytext percent script) to a notebook, "
        "execute it with its figures inline, and write OUT/NAME.ipynb. "
        f"Needs the course extra: {INSTALL_HINT}.",
        func=_cmd_notebooks,
    )
    parser.add_argument("--out", required=True, help="folder for the notebooks")
    parser.add_argument("--only", action="append", metavar="NAME",
                        help="only this tutorial (file name, stem or number; repeatable)")
    parser.add_argument("--tutorials", metavar="DIR",
                        help="where the percent scripts are (default: the checkout's tutorials/)")
    parser.add_argument("--timeout", type=int, default=600,
                        help="seconds any one cell may take (default 600)")
    return parser
