"""Shared test configuration: hypothesis profiles, the Agg backend, the benchmarks' loader,
and how pytest-xdist shares the tests among its workers."""

import importlib.util
import os
from pathlib import Path

import matplotlib
import pytest
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

settings.register_profile(
    "ci",
    deadline=None,
    derandomize=True,
    database=None,
    max_examples=40,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "dev",
    deadline=None,
    max_examples=60,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


@pytest.fixture(scope="session")
def benchmark_script():
    """``load(name)``: ``benchmarks/<name>.py`` as a module (the benchmarks are scripts)."""
    folder = Path(__file__).resolve().parents[1] / "benchmarks"

    def load(name: str):
        spec = importlib.util.spec_from_file_location(name, folder / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture(scope="session")
def tutorial_runs_started(request):
    """Start the tutorial runs the session's selected tests need (``tutorial_runs.py``),
    two at a time, ahead of the tests; at the end, drop those never started."""
    import tutorial_runs

    tutorial_runs.prefetch(request.session.items)
    yield
    tutorial_runs.cancel_pending()


#: Files whose tests share one session's tutorial runs (``tutorial_runs.py``): one worker.
_SHARED_RUNS = {"test_tutorials.py", "test_notebooks.py"}


#: The longest files, started first so that no worker is left with one at the end.
_LONGEST = ("test_notebooks.py", "test_tutorials.py", "test_docs.py", "test_demo_story.py",
            "test_demo_active.py", "test_reference.py", "test_oracle.py")


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook reads the groups
def pytest_collection_modifyitems(config, items):
    """Give each test an ``xdist_group``: its file, so that a worker runs a file's tests
    together and builds its module fixtures once; the tutorials' and the notebooks' tests
    one group, so that one worker runs each tutorial once for both (``--dist loadgroup``).
    The longest files go first, each file's tests in their order."""
    first = {name: k for k, name in enumerate(_LONGEST)}
    items.sort(key=lambda item: first.get(item.path.name, len(first)))
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            name = item.nodeid.split("::")[0]
            item.add_marker(pytest.mark.xdist_group(
                "tutorial-runs" if item.path.name in _SHARED_RUNS else name))
