"""The literal references are short and open few modules (the reader's budget).

A student follows a reference by opening the reference itself and then the refsynth
modules it imports directly (one level). Each reference is at most 400 lines, and the
refsynth modules it imports are at most 5, together at most 1,200 lines. Print the
figures with ``python tests/test_reference_budget.py``.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = {
    "np": "refsynth/synthesis/nonparametric/reference.py",
    "bp": "refsynth/synthesis/belief/reference.py",
}


def lines(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def module_path(name: str) -> Path:
    """The file of a refsynth module (a package's ``__init__.py``)."""
    base = ROOT.joinpath(*name.split("."))
    return base / "__init__.py" if base.is_dir() else base.with_suffix(".py")


def refsynth_imports(path: Path) -> set[str]:
    """The refsynth modules a module imports directly (absolute imports; the package's
    modules use no relative ones)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}: a relative import"
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
    return {n for n in names if n == "refsynth" or n.startswith("refsynth.")}


def budget(reference: str) -> tuple[int, dict[str, int]]:
    """The reference's own lines, and each refsynth module it imports with its lines."""
    path = ROOT / reference
    return lines(path), {m: lines(module_path(m)) for m in sorted(refsynth_imports(path))}


def test_the_counter_counts_a_hand_built_module(tmp_path, monkeypatch):
    module = tmp_path / "m.py"
    module.write_text("import numpy\nfrom refsynth.numeric import NO_RANGE\n"
                      "import refsynth.synthesis.canny\nfrom math import pi\n")
    assert refsynth_imports(module) == {"refsynth.numeric", "refsynth.synthesis.canny"}
    assert module_path("refsynth.synthesis") == ROOT / "refsynth/synthesis/__init__.py"
    assert module_path("refsynth.numeric") == ROOT / "refsynth/numeric.py"


@pytest.mark.parametrize("method", sorted(REFERENCES))
def test_each_reference_is_short_and_opens_at_most_5_modules_and_1200_lines(method):
    own, opened = budget(REFERENCES[method])
    assert own <= 400, own
    assert len(opened) <= 5, opened
    assert sum(opened.values()) <= 1200, opened


if __name__ == "__main__":
    for method, reference in sorted(REFERENCES.items()):
        own, opened = budget(reference)
        print(f"{method}: {reference} {own} lines; opens {len(opened)} refsynth modules, "
              f"{sum(opened.values())} lines: "
              + ", ".join(f"{m} {n}" for m, n in opened.items()))
