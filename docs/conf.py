"""Sphinx configuration of refsynth's documentation.

Build: ``python -m sphinx -W -b html docs docs/_build`` (the ``docs`` extra).

Three parts of the site are generated here, into ``docs/_generated/``, at every
build:

* ``api/<subpackage>.rst``: one page per subpackage, its docstring (the
  section of the paper it implements) and an autosummary table of its
  ``__all__``, read from the subpackage *namespace* — ``refsynth.synthesis``,
  not the module a name happens to live in — so the reference follows the
  package's public API as it is.
* ``figures.md``: every PNG of ``figures/``, which the gallery page includes.
* ``tutorials/``: the course's tutorials. With ``REFSYNTH_NOTEBOOKS=DIR``
  (a folder written by ``python -m refsynth notebooks --out DIR``), the
  executed notebooks, outputs and figures included; otherwise the Jupytext
  scripts of ``tutorials/``, shown without outputs. Nothing is executed
  during the build (``nb_execution_mode = "off"``).
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import re
import shutil
from pathlib import Path

import sphinx.ext.autosummary as autosummary_module

import refsynth

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
GENERATED = DOCS / "_generated"
project = "refsynth"
author = "The refsynth developers"
copyright = "The refsynth developers"  # noqa: A001 (Sphinx's name)
version = release = refsynth.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_nb",
]

# -- the API reference ---------------------------------------------------------

#: The public subpackages, in the order of the pipeline (DESIGN.md), and the shared readers.
SUBPACKAGES = [
    ("refsynth.acquisition", "Acquisition: the rig, its protocols, sampling (§3.1, §4)"),
    ("refsynth.registration", "Registration: panorama and laser scan (Appendix A)"),
    ("refsynth.synthesis", "Synthesis: NP and BP (§3.2)"),
    ("refsynth.evaluation", "Evaluation: MAR, baselines, experiments (§3.3)"),
    ("refsynth.model", "The 3-D model (stage 3)"),
    ("refsynth.oracle", "The oracle: golden cases for ports"),
    ("refsynth.scenes", "Scenes: the synthetic room, the rig, Middlebury"),
    ("refsynth.plotting", "Plotting: the paper's figures"),
    ("refsynth.io", "File readers and writers"),
]


def public_names(module) -> list[str]:
    """``__all__``, or (for a module without one) its public names defined in it."""
    names = getattr(module, "__all__", None)
    if names is None:
        names = [name for name, value in vars(module).items() if not name.startswith("_")
                 and getattr(value, "__module__", None) == module.__name__]
    return sorted(names, key=str.lower)


def write_api_pages() -> list[str]:
    """One page per importable subpackage; returns the page names, in order."""
    folder = GENERATED / "api"
    folder.mkdir(parents=True, exist_ok=True)
    pages = []
    for name, title in SUBPACKAGES:
        try:
            module = importlib.import_module(name)
        except ImportError:  # a subpackage that has not landed yet
            continue
        heading = f"``{name}`` — {title}"
        lines = [
            heading, "=" * len(heading), "",
            f".. automodule:: {name}", "   :no-members:", "",
            f".. currentmodule:: {name}", "",
            "Public API", "----------", "",
            ".. autosummary::", "   :toctree: generated", "",
            *(f"   {entry}" for entry in public_names(module)), "",
        ]
        submodules = [info.name for info in pkgutil.iter_modules(getattr(module, "__path__", []))
                      if not info.name.startswith("_")]
        if submodules:
            lines += ["Modules, beside the paper", "-------------------------", "",
                      "Where each name is defined, and each module's account of its section "
                      "of the paper (the names above are the API; module paths may change).", ""]
            names = set(public_names(module))
            for submodule in submodules:
                title = f"``{name}.{submodule}``"
                lines += [title, "~" * len(title), "",
                          f".. automodule:: {name}.{submodule}", "   :no-members:"]
                if submodule in names:  # e.g. refsynth.synthesis.canny, module and function
                    lines.append("   :no-index:")
                lines.append("")
        page = name.replace(".", "_")
        text = "\n".join(lines)
        target = folder / f"{page}.rst"
        if not target.is_file() or target.read_text(encoding="utf-8") != text:
            target.write_text(text, encoding="utf-8")
        pages.append(page)
    index = ["API reference", "=============", "",
             "Each page documents one subpackage through its namespace: "
             "``from refsynth.synthesis import synthesize``. The front door, "
             ":func:`refsynth.synthesize`, is :func:`refsynth.synthesis.synthesize`.", "",
             ".. toctree::", "   :maxdepth: 1", "", *(f"   {page}" for page in pages), ""]
    (folder / "index.rst").write_text("\n".join(index), encoding="utf-8")
    return pages


def copy_tutorials() -> None:
    """The gallery's sources: the executed notebooks if given, else the percent scripts."""
    folder = GENERATED / "tutorials"
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    executed = os.environ.get("REFSYNTH_NOTEBOOKS")
    if executed:
        notebooks = sorted(Path(executed).glob("[0-9][0-9]_*.ipynb"))
        if not notebooks:
            raise RuntimeError(f"REFSYNTH_NOTEBOOKS={executed}: no NN_*.ipynb there; build "
                               "them with python -m refsynth notebooks --out DIR")
        for notebook in notebooks:
            shutil.copyfile(notebook, folder / notebook.name)
        return
    for script in sorted((ROOT / "tutorials").glob("[0-9][0-9]_*.py")):
        shutil.copyfile(script, folder / script.name)


def write_gallery() -> None:
    """``_generated/figures.md``: every PNG of ``figures/``, for the gallery page to include.

    The image paths are relative to ``docs/gallery.md``, which includes the file (and
    ``exclude_patterns`` keeps the file from being a page of its own).
    """
    lines = []
    for png in sorted((ROOT / "figures").glob("*.png")):
        lines += [f"### `{png.name}`", "", f"![{png.stem}](../figures/{png.name})", ""]
    GENERATED.mkdir(parents=True, exist_ok=True)
    target = GENERATED / "figures.md"
    text = "\n".join(lines)
    if not target.is_file() or target.read_text(encoding="utf-8") != text:
        target.write_text(text, encoding="utf-8")


write_api_pages()
copy_tutorials()
write_gallery()

#: Stopgap: modules whose docstring docutils cannot parse yet, shown as plain text.
#: Remove an entry once its docstring is fixed (none left).
LITERAL_DOCSTRINGS: set[str] = set()


def literal_docstring(app, what, name, obj, options, lines):
    if what == "module" and name in LITERAL_DOCSTRINGS and lines:
        lines[:] = ["::", "", *(f"    {line}" for line in lines), ""]


#: ``|x|`` in running text is an absolute value in these docstrings, but docutils reads
#: it as a substitution reference ("Undefined substitution referenced"); inline
#: literals, roles such as :math:`...` and math or literal blocks are left alone.
BARS = re.compile(r"(?<![\\|])\|(?=[^\s|])([^|`]*?[^\s|\\])\|(?!\|)")
VERBATIM = re.compile(r"(``.*?``|:[a-z:]+:`[^`]*`|`[^`]*`)")


def escape_bars(app, what, name, obj, options, lines):
    block_indent = None  # indentation of the math/literal block being skipped
    in_doctest = False  # inside a ">>>" block: left as written
    for index, line in enumerate(lines):
        if in_doctest or (block_indent is None and line.lstrip().startswith(">>>")):
            in_doctest = bool(line.strip())
            continue
        indent = len(line) - len(line.lstrip())
        if block_indent is not None:
            if not line.strip() or indent > block_indent:
                continue
            block_indent = None
        stripped = line.strip()
        if stripped.startswith(".. math::") or stripped.endswith("::"):
            block_indent = indent
            if stripped.startswith(".."):
                continue
        parts = VERBATIM.split(line)
        lines[index] = "".join(part if k % 2 else BARS.sub(r"\\|\1\\|", part)
                               for k, part in enumerate(parts))


def setup(app):
    app.connect("autodoc-process-docstring", literal_docstring)
    app.connect("autodoc-process-docstring", escape_bars)


autosummary_generate = True
# The tables' one-line summaries end at the first full stop; "Eq. 2" is not one.
autosummary_module.WELL_KNOWN_ABBREVIATIONS = (
    *autosummary_module.WELL_KNOWN_ABBREVIATIONS,
    "Eq.", "Eqs.", "Fig.", "Figs.", "App.", "e.g.", "cf.", "vs.",
)
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # numpydoc's Parameters section states the types and shapes
autoclass_content = "class"
numpydoc_show_class_members = False  # the Attributes sections list them
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# -- the tutorials (myst-nb) ---------------------------------------------------

nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
nb_execution_mode = "off"
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3

# -- the site --------------------------------------------------------------------

root_doc = "index"
#: Never sources: the build's own outputs (a build into ``docs/_build`` puts myst-nb's
#: notebooks in ``docs/jupyter_execute``, which a second build would otherwise read as pages).
exclude_patterns = ["_build", "jupyter_execute", "**/jupyter_execute", "_generated/figures.md",
                    "Thumbs.db", ".DS_Store", "**/.ipynb_checkpoints", "*.py"]
html_theme = "alabaster"
html_title = f"refsynth {release}"
html_static_path: list[str] = []
