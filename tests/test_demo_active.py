"""``python -m refsynth demo --active``: active scanning beside the fixed strategies (§5)."""

import json

import numpy as np
import pytest

from refsynth.acquisition import ScanSettings
from refsynth.acquisition.slice_plan import plan_slices
from refsynth.cli.main import main
from refsynth.plotting.active_story import (
    ACTIVE_FILES,
    ACTIVE_FILLS,
    ACTIVE_STRATEGIES,
    run_active_demo,
)

pytestmark = pytest.mark.slow


#: The test's run: the stripes and the active scan at 30 % of the slices (a first pass of
#: 20 %, two rounds of 5 %), every fourth row and column of the panoramas.
STRATEGIES = ("stripes", "active")


@pytest.fixture(scope="module")
def story(tmp_path_factory):
    """The active demo's stages on less work (:data:`STRATEGIES`)."""
    out = tmp_path_factory.mktemp("active")
    stages = []
    summary = run_active_demo(out, fraction=0.3, shrink=4, strategies=STRATEGIES,
                              progress=lambda stage, done: stages.append((stage, done)))
    return out, summary, stages


def test_every_strategy_measures_its_fraction_of_the_slices(story):
    """150 of the 500 slices for the active scan; the stripes' pattern (4 wide, Table 4)
    comes to 156 at 30 % (200 at the demo's 40 %)."""
    out, summary, _ = story
    assert list(summary["slices"]) == list(STRATEGIES)
    counts = {"stripes": 156, "active": 150}
    for strategy, chosen in summary["slices"].items():
        assert len(chosen) == len(set(chosen)) == counts[strategy], strategy
        assert chosen == sorted(chosen) and 0 <= chosen[0] and chosen[-1] < 500
    assert summary["slices"]["stripes"] == plan_slices(ScanSettings("stripes", 0.3)).tolist()
    assert len(plan_slices(ScanSettings("stripes", 0.4))) == 200
    for row in summary["rows"]:
        assert row["slices"] == counts[row["strategy"]]


def test_the_rounds_are_the_first_pass_then_next_slices_choices(story):
    _, summary, _ = story
    rounds = summary["rounds"]
    first = plan_slices(ScanSettings("active", fraction=0.3)).tolist()
    assert rounds[0] == first and len(first) == 100
    assert [len(r) for r in rounds[1:]] == [25, 25]
    every = [i for r in rounds for i in r]
    assert len(every) == len(set(every)) == 150  # no slice scanned twice
    assert sorted(every) == summary["slices"]["active"]


def test_the_table_scores_bp_and_the_fills_on_each_strategy(story):
    out, summary, _ = story
    rows = summary["rows"]
    assert [(r["strategy"], r["method"]) for r in rows] == [
        (s, m) for s in STRATEGIES for m in ("BP", *ACTIVE_FILLS)]
    for row in rows:
        assert np.isfinite(row["mar"]) and row["mar"] > 0 and 40 < row["unknown"] < 80
    fixed = min(r["mar"] for r in rows if r["strategy"] != "active")
    active = next(r["mar"] for r in rows if (r["strategy"], r["method"]) == ("active", "BP"))
    assert summary["ratio"] == pytest.approx(active / fixed, rel=1e-12)
    saved = json.loads((out / "active.json").read_text())
    assert saved["rows"] == json.loads(json.dumps(rows)) and saved["ratio"] == summary["ratio"]
    assert saved["rounds"] == summary["rounds"]


def test_files_and_progress(story):
    out, summary, stages = story
    for name in ACTIVE_FILES:
        assert (out / name).is_file() and (out / name) in summary["files"]
    for strategy in STRATEGIES:
        assert (out / f"scan-{strategy}" / "manifest.json").is_file()
    assert not (out / "scan-distance").exists()
    from matplotlib.image import imread

    assert imread(out / "active_scan.png").shape[2] in (3, 4)
    done = [fraction for _, fraction in stages]
    assert done == sorted(done) and done[0] == 0.0 and stages[-1] == ("done", 1.0)


def test_another_fraction_in_the_same_folder_is_refused(story):
    out, _, _ = story
    with pytest.raises(ValueError, match="holds another scan"):
        run_active_demo(out, fraction=0.4, shrink=4)


@pytest.mark.parametrize("options, error, match", [
    ({"fraction": 0.2}, ValueError, "`fraction` must be in"),
    ({"fraction": 0.1}, ValueError, "`fraction` must be in"),
    ({"fraction": 1.5}, ValueError, "`fraction` must be <= 1.0"),
    ({"fraction": "0.4"}, TypeError, "`fraction` must be a real number"),
    ({"seed": -1}, ValueError, "`seed` must be an integer >= 0"),
    ({"shrink": 0}, ValueError, "`shrink` must be an integer >= 1"),
    ({"shrink": 2.0}, TypeError, "`shrink` must be an integer"),
    ({"strategies": ("stripes",)}, ValueError, "`strategies` must hold 'active'"),
    ({"strategies": ("active",)}, ValueError, "`strategies` must hold 'active'"),
    ({"strategies": ("active", "active")}, ValueError, "`strategies` must hold 'active'"),
    ({"strategies": ("even", "active")}, ValueError, "`strategies` must be one of"),
    ({"strategies": "active"}, TypeError, "`strategies` must be a sequence"),
])
def test_bad_options_are_refused_before_any_work(tmp_path, options, error, match):
    with pytest.raises(error, match=match):
        run_active_demo(tmp_path / "out", **options)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv", [["--active", "--quick"], ["--active", "--size", "32"],
                                  ["--active", "--pipeline"]])
def test_active_with_another_story_gives_one_line(tmp_path, capsys, argv):
    assert main(["demo", "--out", str(tmp_path / "d"), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--active (its own story) takes no" in err[0]


def test_the_cli_prints_the_rounds_the_table_and_the_ratio(tmp_path, capsys, monkeypatch):
    """``demo --active`` prints what run_active_demo returns (here made up), one row per
    strategy and fill."""
    import refsynth.cli.demo as cli_demo

    rows = [dict(strategy=s, slices=200, method=m, unknown=60.5, mar=0.01 * (k + 1),
                 rmse=0.09, seconds=1.0, bad1=0.0, bad3=0.0, n=10)
            for k, (s, m) in enumerate((s, m) for s in ACTIVE_STRATEGIES
                                       for m in ("BP", *ACTIVE_FILLS))]
    summary = dict(rows=rows, rounds=[list(range(0, 500, 5)), *[[1] * 25] * 4],
                   slices={}, ratio=0.891, files=[tmp_path / name for name in ACTIVE_FILES])
    seen = {}

    def fake(out, seed, progress):
        seen.update(out=out, seed=seed)
        return summary

    monkeypatch.setattr(cli_demo, "run_active_demo", fake)
    assert main(["demo", "--active", "--out", str(tmp_path), "--seed", "3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert seen == {"out": tmp_path, "seed": 3}
    assert out[0].startswith("refsynth demo --active: the simulated rig's room (seed 3)")
    assert "a first pass of 100 evenly spread slices, then 4 rounds of 25, 25, 25, 25" in out[1]
    table = [line.split() for line in out if line.split()[:2] in (
        ["stripes", "200"], ["distance", "200"], ["active", "200"])]
    assert [(r[0], r[2], r[4]) for r in table] == [
        (r["strategy"], r["method"], f"{r['mar']:.4f}") for r in rows]
    assert "active BP / the best fixed strategy and fill: 0.891" in out


def test_each_row_scores_its_own_fill_against_the_truth_on_the_unknown_pixels():
    """``_fills`` on a hand-built position: each row's MAR is Eq. 13 of that fill (BP with
    the demo's seed, the classical fills as :data:`BASELINES` give them) on the pixels the
    scan did not measure."""
    from refsynth.evaluation.baselines import BASELINES
    from refsynth.evaluation.metrics import evaluate
    from refsynth.plotting.active_story import _fills
    from refsynth.plotting.story import DEMO_POSES, ScanPosition
    from refsynth.synthesis.api import synthesize

    rows_, cols = np.mgrid[0:14, 0:18]
    truth = 2.0 + 0.05 * cols + np.where((cols > 8) & (rows_ > 4), -0.6, 0.0)
    intensity = np.where((cols > 8) & (rows_ > 4), 0.8, 0.3) + 0.01 * rows_
    partial = np.full(truth.shape, np.nan)
    partial[:, ::3] = truth[:, ::3]
    position = ScanPosition(1, DEMO_POSES[0], None, intensity=intensity, partial=partial,
                            truth=truth)
    rows = _fills("active", 6, position, seed=2)
    known = np.isfinite(partial)
    estimates = {"BP": synthesize(intensity, partial, method="bp", seed=2).range,
                 **{m: BASELINES[m](intensity, partial) for m in ACTIVE_FILLS}}
    assert [r["method"] for r in rows] == list(estimates)
    for row in rows:
        expected = evaluate(estimates[row["method"]], truth, known)
        assert row["mar"] == expected["mar"] and row["rmse"] == expected["rmse"]
        assert row["strategy"] == "active" and row["slices"] == 6
        assert row["unknown"] == pytest.approx(100 * 2 / 3)
    assert np.array_equal(position.results["bp"].range, estimates["BP"])
