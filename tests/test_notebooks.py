"""Every tutorial executes as a notebook, with its figures inline; the ``notebooks`` command.

The notebooks are executed as ``python -m refsynth notebooks`` executes them
(:func:`refsynth.cli.notebooks.execute_tutorial`, nbclient, a fresh
``python3`` kernel), once per session (see ``tutorial_runs.py``); the
printed numbers of the same run are checked in ``test_tutorials.py``.
Without the ``course`` extra these tests are skipped.
"""

import argparse
import os
import subprocess
import sys

import pytest
from tutorial_runs import (
    BUDGET_SECONDS,
    TUTORIALS,
    TUTORIALS_DIR,
    course_installed,
    run_as_notebook,
)

from refsynth.cli.notebooks import (
    INSTALL_HINT,
    add_notebooks_parser,
    error_outputs,
    find_tutorials,
    image_outputs,
    require_course_packages,
)

#: The tutorials execute (``-m "not slow"`` leaves them out).
pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("tutorial_runs_started")]

needs_course = pytest.mark.skipif(
    not course_installed(), reason='needs the course extra: pip install -e ".[course]"')

TINY = '''# %% [markdown]
# # A tiny tutorial
# %%
import matplotlib.pyplot as plt
from _course import IN_KERNEL, save

fig, ax = plt.subplots()
ax.plot([0, 1], [1, 0])
save(fig, "99_line.png")
print(f"in a kernel: {IN_KERNEL}")
'''


def _parser():
    parser = argparse.ArgumentParser(prog="refsynth")
    add_notebooks_parser(parser.add_subparsers(dest="command", required=True))
    return parser


def test_there_are_tutorials():
    assert TUTORIALS


@needs_course
@pytest.mark.parametrize("path", TUTORIALS, ids=lambda p: p.stem)
def test_tutorial_runs_as_a_notebook_with_inline_figures(path):
    source = path.read_text(encoding="utf-8")
    assert "from _course import" in source, (
        f"{path.name} does not use tutorials/_course.py's save(): its figures cannot show inline")
    run = run_as_notebook(path.name)
    assert not error_outputs(run.notebook), error_outputs(run.notebook)
    images = image_outputs(run.notebook)
    assert images, f"{path.name}: no inline figure (image/png output)"
    assert len(images) == len(run.pngs()), "every figure written to a file is shown inline"
    assert run.seconds <= BUDGET_SECONDS, f"{path.name} took {run.seconds:.1f} s"


@needs_course
def test_notebooks_command_writes_executed_notebooks(tmp_path, capsys):
    import nbformat

    tutorials = tmp_path / "tutorials"
    tutorials.mkdir()
    (tutorials / "99_tiny.py").write_text(TINY, encoding="utf-8")
    (tutorials / "_course.py").write_bytes((TUTORIALS_DIR / "_course.py").read_bytes())
    out = tmp_path / "notebooks"
    args = _parser().parse_args(["notebooks", "--out", str(out), "--tutorials", str(tutorials),
                                 "--only", "99"])
    assert args.func(args) == 0
    assert "1 inline figures" in capsys.readouterr().out
    notebook = nbformat.read(out / "99_tiny.ipynb", as_version=4)
    assert len(image_outputs(notebook)) == 1 and not error_outputs(notebook)
    assert "in a kernel: True" in "".join(
        o.get("text", "") for c in notebook.cells for o in c.get("outputs", []))
    assert (out / "_course.py").is_file()  # the notebooks re-run where they are
    assert (out / "tutorial-output" / "99_line.png").is_file()


@needs_course
def test_notebooks_command_reports_a_failing_cell_in_one_line(tmp_path):
    tutorials = tmp_path / "tutorials"
    tutorials.mkdir()
    (tutorials / "98_broken.py").write_text("# %%\nraise RuntimeError('boom')\n",
                                            encoding="utf-8")
    args = _parser().parse_args(["notebooks", "--out", str(tmp_path / "out"),
                                 "--tutorials", str(tutorials)])
    with pytest.raises(ValueError, match=r"98_broken.py: cell 0 raised RuntimeError: boom") as info:
        args.func(args)
    assert "\n" not in str(info.value)
    assert (tmp_path / "out" / "98_broken.ipynb").is_file()  # with the error in it


def test_find_tutorials_selects_by_name_stem_or_number(tmp_path):
    for name in ("00_a.py", "01_b.py", "_course.py", "notes.py"):
        (tmp_path / name).write_text("", encoding="utf-8")
    assert [p.name for p in find_tutorials(tmp_path)] == ["00_a.py", "01_b.py"]
    assert [p.name for p in find_tutorials(tmp_path, ["01"])] == ["01_b.py"]
    assert [p.name for p in find_tutorials(tmp_path, ["01_b", "00_a.py"])] == ["00_a.py", "01_b.py"]
    with pytest.raises(ValueError, match=r"--only '07' matches no tutorial \(have: 00_a, 01_b\)"):
        find_tutorials(tmp_path, ["07"])
    with pytest.raises(ValueError, match="no tutorials"):
        find_tutorials(tmp_path / "solutions-elsewhere")


def test_missing_course_packages_give_one_line_naming_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "nbclient", None)  # import nbclient -> ImportError
    with pytest.raises(ImportError) as info:
        require_course_packages()
    message = str(info.value)
    assert "nbclient" in message and INSTALL_HINT in message and "\n" not in message


def test_missing_course_packages_exit_2_from_the_command_line(monkeypatch, capsys):
    from refsynth.cli import main as cli_main

    parser = cli_main.build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    if "notebooks" not in commands.choices:
        pytest.skip("the notebooks subcommand is not wired into refsynth.cli.main yet")
    monkeypatch.setitem(sys.modules, "jupytext", None)
    assert cli_main.main(["notebooks", "--out", "unused"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("refsynth notebooks: error:") and INSTALL_HINT in err
    assert "\n" not in err


def test_course_helper_is_plain_python_outside_a_kernel(tmp_path):
    code = ("import matplotlib, _course; "
            "print(_course.IN_KERNEL, matplotlib.get_backend().lower())")
    env = {k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "DISPLAY")}
    env.update(REFSYNTH_TUTORIAL_OUT=str(tmp_path / "out"), PYTHONPATH=str(TUTORIALS_DIR))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["False", "agg"]
    assert (tmp_path / "out").is_dir()


@needs_course
def test_notebooks_command_reports_a_cell_over_the_timeout(tmp_path):
    tutorials = tmp_path / "tutorials"
    tutorials.mkdir()
    (tutorials / "97_slow.py").write_text("# %%\nimport time\ntime.sleep(30)\n", encoding="utf-8")
    args = _parser().parse_args(["notebooks", "--out", str(tmp_path / "out"),
                                 "--tutorials", str(tutorials), "--timeout", "1"])
    with pytest.raises(ValueError, match=r"97_slow.py: CellTimeoutError: .*after 1 seconds"):
        args.func(args)
