"""A smoke test of ``benchmarks/compare_trees.py`` (the alternating runs the README quotes)."""

import io
from pathlib import Path

import pytest

pytest.importorskip("skimage")  # the Motorcycle

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def compare_trees(benchmark_script):
    return benchmark_script("compare_trees")


def test_a_tree_against_itself_runs_abba_with_the_same_bits(compare_trees):
    out = io.StringIO()
    result = compare_trees.compare(ROOT, ROOT, (24, 20), 1, out=out)
    text = out.getvalue()
    assert [line[0] for line in text.splitlines()[1:5]] == list("ABBA")
    assert len(result["times"]["A"]) == len(result["times"]["B"]) == 2
    assert result["same"] and "the same bits in every run" in text
    assert "B against A: mean " in text


def test_a_folder_without_refsynth_is_refused_before_any_run(compare_trees, tmp_path, capsys):
    assert compare_trees.main([str(tmp_path), str(ROOT)]) == 2
    assert "holds no refsynth/__init__.py" in capsys.readouterr().err


def test_different_outputs_are_reported(compare_trees, monkeypatch):
    digests = iter(["a" * 64, "b" * 64])
    monkeypatch.setattr(compare_trees, "run_once",
                        lambda tree, case, method: (1.0, next(digests, "b" * 64)))
    out = io.StringIO()
    assert not compare_trees.compare(ROOT, ROOT, (24, 20), 1, out=out)["same"]
    assert "DIFFER (2 hashes)" in out.getvalue()
