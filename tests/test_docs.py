"""The documentation builds with warnings as errors (``python -m sphinx -W -b html docs X``).

Needs the ``docs`` extra (sphinx, numpydoc, myst-nb, jupytext); skipped
without it. The tutorials are rendered from their scripts, not executed (the
notebooks' execution is tested in ``test_notebooks.py``).
"""

import importlib.util
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS_PACKAGES = ("sphinx", "numpydoc", "myst_nb", "jupytext")
MISSING = [name for name in DOCS_PACKAGES if importlib.util.find_spec(name) is None]


@pytest.mark.slow
@pytest.mark.skipif(bool(MISSING), reason=f"needs the docs extra ({', '.join(MISSING)} missing): "
                    'pip install -e ".[docs]"')
def test_docs_build_without_warnings(tmp_path):
    env = {key: value for key, value in os.environ.items() if key != "REFSYNTH_NOTEBOOKS"}
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         str(ROOT / "docs"), str(tmp_path / "html")],
        capture_output=True, text=True, timeout=600, cwd=ROOT, env=env)
    seconds = time.perf_counter() - start
    assert proc.returncode == 0, proc.stderr[-6000:]
    html = tmp_path / "html"
    assert (html / "index.html").is_file()
    api = html / "_generated" / "api"
    for subpackage in ("acquisition", "registration", "synthesis", "evaluation", "scenes",
                       "plotting", "io"):
        assert (api / f"refsynth_{subpackage}.html").is_file(), subpackage
    synthesize = (api / "generated" / "refsynth.synthesis.synthesize.html").read_text("utf-8")
    assert "partial_range" in synthesize and "Parameters" in synthesize
    tutorials = sorted(p.stem for p in (ROOT / "tutorials").glob("[0-9][0-9]_*.py"))
    built = sorted(p.stem for p in (html / "_generated" / "tutorials").glob("*.html"))
    assert built == tutorials
    assert seconds < 90, f"the docs took {seconds:.0f} s to build"
