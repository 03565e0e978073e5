"""The documentation: the site builds twice in a row with warnings as errors; the README is short.

The build needs the ``docs`` extra (sphinx, numpydoc, myst-nb, jupytext) and
is skipped without it. It runs in a copy of what a fresh clone holds (``docs/``,
``tutorials/``, ``figures/``), into ``docs/_build`` as the README says, twice:
a second build in the same clone once failed because myst-nb's
``docs/jupyter_execute/`` was read as pages. The tutorials are rendered from
their scripts, not executed (their execution is tested in
``test_notebooks.py``). The README's and the docs' checks need nothing but
the repository.
"""

import importlib.util
import os
import re
import resource
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS_PACKAGES = ("sphinx", "numpydoc", "myst_nb", "jupytext")
MISSING = [name for name in DOCS_PACKAGES if importlib.util.find_spec(name) is None]
#: What the build writes: never sources, never committed.
BUILD_OUTPUTS = ("_build", "_generated", "jupyter_execute")
#: The pages of the manual (docs/<name>.md or .rst), each in the index's toctrees.
PAGES = ("getting_started", "own_data", "acquisition", "registration", "model", "course",
         "paper_map", "departures", "results", "active_scanning", "performance", "gallery",
         "oracle", "citing")
#: Version history and issue numbers, which belong in CHANGELOG.md only (the pattern of
#: the project's marker count).
HISTORY = re.compile(r"\b0\.\d+(?:\.\d+)?'s\b|\bissue #\d+|#\d+'s\b|\([Ii]ssue #?\d+\)"
                     r"|\b[Uu]ntil 0\.\d|\bsince 0\.\d|\bin 0\.\d+(?:\.\d+)?\b")


def fresh_clone(tmp_path: Path) -> Path:
    """The files of a clone that the build reads, without any build output."""
    clone = tmp_path / "clone"
    ignore = shutil.ignore_patterns(*BUILD_OUTPUTS, "__pycache__", ".ipynb_checkpoints")
    for name in ("docs", "tutorials", "figures"):
        shutil.copytree(ROOT / name, clone / name, ignore=ignore)
    return clone


def cpu_seconds_of_children() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def build(clone: Path) -> tuple[subprocess.CompletedProcess, float]:
    """``python -m sphinx -W -b html docs docs/_build`` in the clone, importing this refsynth.

    Returns the process and its CPU seconds (not wall time: the machine may be shared).
    """
    env = {key: value for key, value in os.environ.items() if key != "REFSYNTH_NOTEBOOKS"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    start = cpu_seconds_of_children()
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "docs", "docs/_build"],
        capture_output=True, text=True, timeout=900, cwd=clone, env=env)
    return proc, cpu_seconds_of_children() - start


@pytest.mark.slow
@pytest.mark.skipif(bool(MISSING), reason=f"needs the docs extra ({', '.join(MISSING)} missing): "
                    'pip install -e ".[docs]"')
def test_docs_build_twice_in_a_fresh_clone_without_warnings(tmp_path):
    clone = fresh_clone(tmp_path)
    first, first_seconds = build(clone)
    assert first.returncode == 0, first.stderr[-6000:]
    # the build's own output beside the sources, which the second build must not read
    assert (clone / "docs" / "jupyter_execute").is_dir()
    second, second_seconds = build(clone)
    assert second.returncode == 0, "second build: " + second.stderr[-6000:]

    html = clone / "docs" / "_build"
    assert (html / "index.html").is_file()
    for page in PAGES:
        assert (html / f"{page}.html").is_file(), page
    api = html / "_generated" / "api"
    for subpackage in ("acquisition", "registration", "synthesis", "evaluation", "scenes",
                       "plotting", "io"):
        assert (api / f"refsynth_{subpackage}.html").is_file(), subpackage
    synthesize = (api / "generated" / "refsynth.synthesis.synthesize.html").read_text("utf-8")
    assert "partial_range" in synthesize and "Parameters" in synthesize
    tutorials = sorted(p.stem for p in (ROOT / "tutorials").glob("[0-9][0-9]_*.py"))
    built = sorted(p.stem for p in (html / "_generated" / "tutorials").glob("*.html"))
    assert built == tutorials
    # the gallery shows every figure of figures/
    gallery = (html / "gallery.html").read_text("utf-8")
    for png in (ROOT / "figures").glob("*.png"):
        assert f"_images/{png.name}" in gallery, png.name
        assert (html / "_images" / png.name).is_file(), png.name
    assert first_seconds + second_seconds < 120, (
        f"the docs took {first_seconds:.0f} and {second_seconds:.0f} CPU seconds to build")


def test_every_page_is_in_the_index():
    index = (ROOT / "docs" / "index.rst").read_text(encoding="utf-8")
    for page in PAGES:
        assert list((ROOT / "docs").glob(f"{page}.*")), page
        assert re.search(rf"^   {page}$", index, flags=re.M), page


def test_the_build_outputs_are_excluded_and_ignored():
    conf = (ROOT / "docs" / "conf.py").read_text(encoding="utf-8")
    excluded = re.search(r"^exclude_patterns = \[(.*?)\]", conf, flags=re.M | re.S).group(1)
    for name in ("_build", "jupyter_execute"):
        assert f'"{name}"' in excluded, name
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    paths = ["docs/_build/index.html", "docs/_generated/api/index.rst",
             "docs/jupyter_execute/x.ipynb", "notebooks/01_np_range_synthesis.ipynb",
             "tutorial-output/01.png"]
    proc = subprocess.run(["git", "check-ignore", *paths], cwd=ROOT, capture_output=True,
                          text=True)
    assert sorted(proc.stdout.split()) == sorted(paths), proc.stdout


def test_the_readme_is_one_screen_per_task():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    lines = text.splitlines()
    assert len(lines) <= 300, len(lines)
    # the two commands come first
    assert lines[3:5] == ['python -m pip install -e . && python -m refsynth demo',
                          'python -m pip install -e ".[test]" && python -m pytest']
    # a table of contents whose links reach headings of the README
    headings = {re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-")
                for h in re.findall(r"^## (.+)$", text, flags=re.M)}
    anchors = re.findall(r"\]\(#([^)]+)\)", text)
    assert len(anchors) >= 5
    assert set(anchors) <= headings, set(anchors) - headings
    # filling one's own data is found from the table of contents
    assert "## Fill your own depth map" in text


def test_the_readme_links_and_commands_exist():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", text):
        assert (ROOT / target).exists(), target
    from refsynth.cli.main import build_parser

    parser = build_parser()
    commands = set(parser._subparsers._group_actions[0].choices)  # noqa: SLF001
    named = set(re.findall(r"python -m refsynth ([a-z]+)", text))
    assert named and named <= commands, named - commands


@pytest.mark.parametrize("pattern", ["README.md", "docs/*.md", "docs/*.rst",
                                     "tutorials/*.py", "tutorials/solutions/*.py"])
def test_no_version_history_outside_the_changelog(pattern):
    found = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
             for path in sorted(ROOT.glob(pattern))
             for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             if HISTORY.search(line)]
    assert not found, "\n".join(found)


def _table_rows(text: str, header: str) -> dict[str, list[str]]:
    """The rows of the Markdown table whose header line starts with ``header``, by first cell."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        rows[cells[0].strip("`")] = cells[1:]
    return rows


def _literal(cell: str):
    import ast

    return ast.literal_eval(cell.strip("`"))


def test_own_data_lists_every_option_of_synthesize():
    import inspect

    from refsynth import synthesize

    text = (ROOT / "docs" / "own_data.md").read_text(encoding="utf-8")
    rows = _table_rows(text, "| option | default |")
    keywords = [name for name, parameter in inspect.signature(synthesize).parameters.items()
                if parameter.kind is inspect.Parameter.KEYWORD_ONLY]
    assert len(keywords) == 14, keywords
    assert list(rows) == keywords


def test_own_data_shows_every_reading_with_both_presets_as_they_are():
    from refsynth import Readings
    from refsynth.synthesis.readings import BP_READINGS, NP_READINGS

    text = (ROOT / "docs" / "own_data.md").read_text(encoding="utf-8")
    rows = _table_rows(text, "| reading | method |")
    assert list(rows) == list(Readings.names())
    paper, default = Readings.paper(), Readings.refsynth()
    for name, (method, in_paper, in_refsynth, *_) in rows.items():
        assert _literal(in_paper) == getattr(paper, name), name
        assert _literal(in_refsynth) == getattr(default, name), name
        used = {m for m, names in (("NP", NP_READINGS), ("BP", BP_READINGS)) if name in names}
        assert set(method.split(", ")) == used, name


def test_departures_name_every_departure_by_its_reading():
    from refsynth import Readings

    text = (ROOT / "docs" / "departures.md").read_text(encoding="utf-8")
    lines = text.splitlines()
    start = lines.index(next(line for line in lines if line.startswith("| reading |")))
    paper, default = Readings.paper(), Readings.refsynth()
    named = set()
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        first, in_paper, in_refsynth = line.strip("|").split("|")[:3]
        names = re.findall(r"`(\w+)`", first)        # "`sigma_i`, `sigma_s`", "`channels` (NP)"
        assert names, line
        for name, a, b in zip(names, re.findall(r"`([^`]+)`", in_paper),
                              re.findall(r"`([^`]+)`", in_refsynth), strict=True):
            assert _literal(a) == getattr(paper, name), name
            assert _literal(b) == getattr(default, name), name
            named.add(name)
    assert named == set(Readings.names()), set(Readings.names()) ^ named


def _dotted(name: str):
    """The object a dotted name (``refsynth.a.b.f``) names: imported module, then attributes."""
    import importlib

    parts = name.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            target = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            target = getattr(target, part)
        return target
    raise ImportError(name)


def test_every_function_the_paper_map_names_exists():
    text = (ROOT / "docs" / "paper_map.md").read_text(encoding="utf-8")
    table = text[text.index("| paper | reference |"):text.index("## Modules")]
    names = set(re.findall(r"`(refsynth(?:\.\w+)+)`", table))
    assert len(names) > 40, len(names)
    for name in sorted(names):
        try:
            _dotted(name)
        except (ImportError, AttributeError) as error:
            raise AssertionError(f"docs/paper_map.md names {name}, which does not exist: "
                                 f"{error}") from None
    for path in set(re.findall(r"`(tests/[\w.*]+\.py)`", table)):
        assert list(ROOT.glob(path)), path


def test_the_readme_shows_the_paper_preset_from_python_and_the_command_line():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert 'readings="paper"' in text and "--readings paper" in text
    assert "--png-scale 1000" in text and "--partial" in text


def test_the_oracle_page_gives_the_versions_and_the_case_count_as_they_are():
    from refsynth.oracle.cases import CASE_SET_VERSION, build_cases
    from refsynth.oracle.export import CONTRACT_VERSION
    from refsynth.oracle.files import FORMAT_VERSION

    text = (ROOT / "docs" / "oracle.md").read_text(encoding="utf-8")
    manifest = (f'"version": {FORMAT_VERSION}, "contract": {CONTRACT_VERSION}, '
                f'"case_set": {CASE_SET_VERSION}')
    assert manifest in text
    counts = {int(n) for n in re.findall(r"\b(\d+) cases, about", text)}
    assert counts == {len(build_cases())}, counts
    # the cases the page names after the contract (the contract's own are its helper's)
    rest = text[text.index("## The golden cases"):]
    named = re.findall(r"`((?:np|bp|eq\d+(?:_\d+)?)-[\w.-]+)`", rest)
    assert len(named) >= 8, named
    for name in named:
        assert name in {case.name for case in build_cases()}, name
