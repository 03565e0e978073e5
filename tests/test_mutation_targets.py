"""benchmarks/mutation_check.py's mutants still point at the code (each original line once).

A mutant whose original line is gone is skipped by the script ("the code moved on"), and
the equation it guarded is then unchecked without anyone noticing; a speed pass that
rewrites a line must re-point its mutant. This test says so at once.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _mutations():
    spec = importlib.util.spec_from_file_location(
        "mutation_check", ROOT / "benchmarks" / "mutation_check.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("mutation_check", module)  # its dataclasses look themselves up
    spec.loader.exec_module(sys.modules["mutation_check"])
    return sys.modules["mutation_check"].MUTATIONS


def test_every_mutant_original_occurs_exactly_once_in_its_file():
    stale = {m.id: (ROOT / m.file).read_text(encoding="utf-8").count(m.original)
             for m in _mutations()}
    assert {k: v for k, v in stale.items() if v != 1} == {}
