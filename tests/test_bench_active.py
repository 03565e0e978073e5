"""A smoke test of ``benchmarks/bench_active.py`` on a tiny scene folder the test writes."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest
from PIL import Image

from refsynth.acquisition.active import expected_gain, measured_columns, returning_pixels


@pytest.fixture(scope="module")
def bench(benchmark_script):
    return benchmark_script("bench_active")


@pytest.fixture()
def folder(tmp_path):
    """A 40 × 48 wall at 3 m (a slope) with a box at 1.5 m on its right, the box brighter."""
    path = tmp_path / "box"
    path.mkdir()
    rows, cols = np.mgrid[0:40, 0:48]
    box = (rows >= 10) & (rows < 30) & (cols >= 28) & (cols < 42)
    depth = np.where(box, 1.5, 3.0 + 0.01 * cols)
    grey = np.where(box, 200, 60).astype(np.uint8)
    Image.fromarray(np.stack([grey] * 3, axis=-1)).save(path / "rgb.png")
    Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(path / "depth.png")
    (path / "scene.json").write_text(json.dumps(
        {"image": "rgb.png", "truth": "depth.png", "scale": 1000, "kind": "depth"}))
    return tmp_path


def test_even_columns_are_spread_and_counted(bench):
    columns = bench.even_columns(48, 0.25)
    assert len(columns) == 12 and columns[0] == 0 and columns[-1] == 47
    assert np.all(np.diff(columns) >= 4)


def test_active_adds_its_step_per_call_on_the_uncertain_side(bench, folder):
    scene = bench.bench_scenes.load(str(folder / "box"), "48x40")
    masks, calls = bench.active_masks(scene, [20, 30], 5, "np", 0)
    assert len(calls) == 2
    first, last = (np.flatnonzero(masks[f].any(axis=0)) for f in (20, 30))
    assert len(first) == 10 and len(last) == 14 and set(first) <= set(last)
    added = sorted(set(last) - set(first))
    # mostly by the box's edges (columns 28 and 41), not on the bare wall
    assert sum(24 <= c <= 45 for c in added) >= 3, added


def test_the_cost_of_a_call_is_given_in_fills_of_the_run(bench, folder):
    out = io.StringIO()
    assert bench.main([str(folder), "--size", "48x40", "--fractions", "20,30", "--methods",
                       "np", "--strategies", "active", "--active-method", "np", "--quiet"],
                      out=out) == 0
    line = out.getvalue().strip().splitlines()[-1]
    assert line.startswith("next_slices: 2 calls, mean ") and "of the mean NP fill" in line


def test_the_truth_probe_chooses_where_the_truth_leaves_the_line(bench, folder):
    """``--active-error truth``: next_slices's greedy step with the truth in place of the
    fill and no uncertainty, on measured columns never; its first pick is the column whose
    measurement removes the most true error of the lines (whichever method fills)."""
    scene = bench.bench_scenes.load(str(folder / "box"), "48x40")
    masks, _ = bench.active_masks(scene, [20, 25], 5, "np", 0, error="truth")
    first, last = (set(np.flatnonzero(masks[f].any(axis=0))) for f in (20, 25))
    added = sorted(last - first)
    assert scene.has_truth.all()
    measured = masks[20].any(axis=0)
    truth = scene.range
    every = np.ones(truth.shape, dtype=bool)
    assert added == sorted(bench._greedy(truth, np.zeros_like(truth), measured, 2,
                                         every).tolist())
    gain = expected_gain(truth, np.zeros_like(truth), measured)
    assert gain.max() > 0 and int(np.argmax(gain)) in added
    assert not first & set(added)
    again, _ = bench.active_masks(scene, [20, 25], 5, "bp", 0, error="truth")
    assert np.array_equal(again[25], masks[25])


def test_the_truth_probe_counts_only_pixels_with_truth(bench):
    """Pixels without truth do not count (the MAR does not score them), and a line ending on
    one takes the nearest pixel's truth."""
    from types import SimpleNamespace

    truth = np.tile(np.where(np.arange(21) < 13, 1.0, 3.0), (4, 1))
    holed = truth.copy()
    holed[:, 14:17] = np.nan                      # no truth; the nearest truth is 3.0
    holed[0, 20] = np.nan                         # and none at one end of a line
    scene = SimpleNamespace(range=holed, has_truth=np.isfinite(holed))
    partial = np.full((4, 21), np.nan)
    partial[:, [0, 20]] = holed[:, [0, 20]]
    measured = measured_columns(partial)
    expected = bench._greedy(truth, np.zeros_like(truth), measured, 3, np.isfinite(holed))
    assert np.array_equal(bench.truth_slices(scene, partial, 3), expected)
    every = bench._greedy(truth, np.zeros_like(truth), measured, 3, np.ones((4, 21), bool))
    assert not np.array_equal(expected, every)    # the holes change the choice


def _holed_box(bench, folder):
    """The box scene with a narrow hole in its truth between two measured columns (a shadow
    by the box's left edge): the returning pixels count it, the pixels with truth do not."""
    from types import SimpleNamespace

    scene = bench.bench_scenes.load(str(folder / "box"), "48x40")
    measured = bench.even_columns(48, 0.20)
    left = int(measured[np.searchsorted(measured, 28) - 1])
    has_truth = scene.has_truth.copy()
    has_truth[5:35, left + 1:left + 4] = False
    scene = SimpleNamespace(name="holed", range=np.where(has_truth, scene.range, np.nan),
                            has_truth=has_truth, intensity=scene.intensity)
    partial = np.where(bench.column_mask((40, 48), measured) & has_truth, scene.range, np.nan)
    return scene, partial


def test_the_fill_error_probe_replaces_only_the_uncertainty(bench, folder):
    """``--active-error fill-error``: next_slices's fill and returning pixels, with the fill's
    true absolute error (the nearest truth where there is none) in place of its uncertainty."""
    from refsynth.synthesis.api import synthesize

    scene, partial = _holed_box(bench, folder)
    result = synthesize(scene.intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    counts = returning_pixels(partial, scene.intensity)
    error = np.abs(result.range - bench.nearest_truth(scene))
    assert np.isfinite(error).all() and error[~scene.has_truth].max() > 0
    picks = bench.probe_slices(scene, partial, 6, "fill-error", "np", 0)
    assert np.array_equal(picks, bench._greedy(
        result.range, np.where(np.isfinite(partial), 0.0, error), measured, 6, counts))
    assert not np.array_equal(picks, bench._greedy(result.range, result.uncertainty,
                                                   measured, 6, counts))


def test_the_truth_counts_probe_replaces_only_the_counted_pixels(bench, folder):
    """``--active-error truth-counts``: next_slices's fill and uncertainty, counting the
    pixels with truth (what the MAR scores) instead of the returning ones."""
    from refsynth.synthesis.api import synthesize

    scene, partial = _holed_box(bench, folder)
    result = synthesize(scene.intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    picks = bench.probe_slices(scene, partial, 3, "truth-counts", "np", 0)
    assert np.array_equal(picks, bench._greedy(result.range, result.uncertainty, measured, 3,
                                               scene.has_truth))
    returning = returning_pixels(partial, scene.intensity)
    assert not np.array_equal(picks, bench._greedy(result.range, result.uncertainty,
                                                   measured, 3, returning))


def _shadowed_box(bench, folder):
    """The box scene whose upper rows 10–19 returned nothing in the measured columns from 26
    on (a dark band across the box): the returning pixels leave them out between those
    columns, every unmeasured pixel counts them."""
    from types import SimpleNamespace

    scene = bench.bench_scenes.load(str(folder / "box"), "48x40")
    measured = bench.even_columns(48, 0.20)
    has_truth = scene.has_truth.copy()
    has_truth[10:20, measured[measured >= 26]] = False
    scene = SimpleNamespace(name="shadowed", range=np.where(has_truth, scene.range, np.nan),
                            has_truth=has_truth, intensity=scene.intensity)
    partial = np.where(bench.column_mask((40, 48), measured) & has_truth, scene.range, np.nan)
    return scene, partial


def test_the_no_uncertainty_ablation_takes_away_only_the_uncertainty(bench, folder):
    """``--active-error no-uncertainty``: next_slices's fill and returning pixels, an
    uncertainty of 0 (each gain the line's distance from the fill alone)."""
    from refsynth.synthesis.api import synthesize

    scene, partial = _holed_box(bench, folder)
    result = synthesize(scene.intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    counts = returning_pixels(partial, scene.intensity)
    picks = bench.probe_slices(scene, partial, 6, "no-uncertainty", "np", 0)
    assert np.array_equal(picks, bench._greedy(result.range, np.zeros((40, 48)), measured, 6,
                                               counts))
    assert not np.array_equal(picks, bench._greedy(result.range, result.uncertainty,
                                                   measured, 6, counts))


def test_the_no_bend_ablation_takes_away_only_the_bend(bench, folder):
    """``--active-error no-bend``: next_slices's fill, uncertainty and returning pixels,
    the bend all NaN (the scale of the line's error is the uncertainty alone). The wall is a
    plane: with the bend no pick goes to its bare left part, without it some do."""
    from refsynth.synthesis.api import synthesize

    scene, partial = _shadowed_box(bench, folder)
    result = synthesize(scene.intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    counts = returning_pixels(partial, scene.intensity)
    picks = bench.probe_slices(scene, partial, 9, "no-bend", "np", 0)
    assert np.array_equal(picks, bench._greedy(result.range, result.uncertainty, measured, 9,
                                               counts, np.full((40, 48), np.nan)))
    bent = bench._greedy(result.range, result.uncertainty, measured, 9, counts)
    assert np.all(bent > 20) and np.any(picks < 20), (bent, picks)


def test_the_all_pixels_ablation_counts_every_unmeasured_pixel(bench, folder):
    """``--active-error all-pixels``: next_slices's fill and uncertainty, counting every
    unmeasured pixel instead of the returning ones."""
    from refsynth.synthesis.api import synthesize

    scene, partial = _shadowed_box(bench, folder)
    result = synthesize(scene.intensity, partial, method="np", seed=0)
    measured = measured_columns(partial)
    counts = returning_pixels(partial, scene.intensity)
    assert not counts[10:20, 27:47].any() and counts[20:30, 27:31].all()
    picks = bench.probe_slices(scene, partial, 6, "all-pixels", "np", 0)
    every = np.broadcast_to(~measured[None, :], (40, 48))
    assert np.array_equal(picks, bench._greedy(result.range, result.uncertainty, measured, 6,
                                               every))
    assert not np.array_equal(picks, bench._greedy(result.range, result.uncertainty,
                                                   measured, 6, counts))


def test_the_target_ratio_skips_missing_runs(bench):
    """A missing rival run (here the first, even BP) is not the best, nor a missing active
    one inf."""
    rows = [dict(scene="s", strategy="even", fraction=40, method="linear", mar=0.2),
            dict(scene="s", strategy="distance", fraction=40, method="bp", mar=0.3),
            dict(scene="s", strategy="active", fraction=40, method="bp", mar=0.1),
            dict(scene="t", strategy="active", fraction=40, method="bp", mar=0.1)]
    ratios = bench.target_ratios(rows, ["s", "t", "u"], ["bp", "linear"])
    assert ratios["s"] == pytest.approx(0.5)
    assert math.isnan(ratios["t"]) and math.isnan(ratios["u"])


def test_the_yardstick_is_even_bp_at_more_columns_over_the_target_denominator(bench):
    """The yardstick divides BP on evenly spread columns at each larger fraction by the
    same best-of-fixed-fills at 40 % as the target, with a geometric mean over scenes."""
    rows = [dict(scene="s", strategy="even", fraction=40, method="linear", mar=0.2),
            dict(scene="s", strategy="distance", fraction=40, method="bp", mar=0.4),
            dict(scene="s", strategy="even", fraction=60, method="bp", mar=0.1),
            dict(scene="s", strategy="even", fraction=80, method="linear", mar=0.01),
            dict(scene="t", strategy="even", fraction=40, method="bp", mar=1.0),
            dict(scene="t", strategy="even", fraction=60, method="bp", mar=0.8),
            dict(scene="t", strategy="even", fraction=80, method="bp", mar=0.5)]
    ratios = bench.target_ratios(rows, ["s", "t"], ["bp", "linear"], strategy="even",
                                 fraction=60)
    assert ratios == {"s": pytest.approx(0.5), "t": pytest.approx(0.8)}
    lines = bench.yardstick(rows, ["s", "t"], ["bp", "linear"], [60, 80]).splitlines()
    assert lines[2].split() == ["columns", "scanned,", "%", "60", "80"]
    assert lines[3].split() == ["s", "0.500", "nan"]      # 80 %: linear is not BP
    assert lines[4].split() == ["t", "0.800", "0.500"]
    assert lines[5].split() == ["geometric", "mean", f"{math.sqrt(0.4):.3f}", "0.500"]


def test_the_yardstick_prints_only_with_even_runs_above_40(bench, folder):
    runs = {}
    for fractions in ("20,40", "20,40,45"):
        out = io.StringIO()
        assert bench.main([str(folder), "--size", "48x40", "--fractions", fractions,
                           "--methods", "bp,linear", "--strategies", "even",
                           "--quiet"], out=out) == 0
        runs[fractions] = out.getvalue()
    assert "yardstick" not in runs["20,40"]
    table = runs["20,40,45"].split("yardstick")[1].splitlines()
    assert table[1].split()[-1] == "45" and table[-1].split()[:2] == ["geometric", "mean"]


def test_an_active_run_alone_prints_no_ratio(bench, folder):
    out = io.StringIO()
    assert bench.main([str(folder), "--size", "48x40", "--fractions", "20,40", "--methods",
                       "bp", "--strategies", "active", "--active-method", "np",
                       "--quiet"], out=out) == 0
    text = out.getvalue()
    assert "n/a (no even or distance run)" in text
    assert "inf" not in text and "geometric mean" not in text


@pytest.mark.parametrize("error, header", [
    ("no-uncertainty", "with an uncertainty of 0 (an ablation)"),
    ("all-pixels", "counting every unmeasured pixel (an ablation)"),
    ("no-bend", "without the bend term (an ablation)"),
    ("truth", "with the truth in place of the fill (a probe)"),
    ("fill-error", "with the fill's true error in place of its uncertainty (a probe)"),
    ("truth-counts", "counting the pixels with truth (a probe)"),
])
def test_a_probe_says_so_and_prints_no_next_slices_cost(bench, folder, error, header):
    out = io.StringIO()
    assert bench.main([str(folder), "--size", "48x40", "--fractions", "20,25", "--methods",
                       "bp", "--strategies", "active", "--active-method", "np",
                       "--active-error", error, "--quiet"], out=out) == 0
    text = out.getvalue()
    assert header in text
    assert "next_slices:" not in text


def test_table_ratio_json_and_from_json(bench, folder, tmp_path):
    out, target = io.StringIO(), tmp_path / "runs.json"
    argv = [str(folder), "--size", "48x40", "--fractions", "20,40", "--methods",
            "bp,nearest", "--active-method", "np", "--json", str(target), "--quiet"]
    assert bench.main(argv, out=out) == 0
    text = out.getvalue()
    assert "target <= 0.8" in text and "geometric mean" in text
    # the calls' cost is given in fills of the active method only when the run made some
    assert "next_slices: 4 calls" in text and "of the mean NP fill" not in text
    rows = json.loads(target.read_text())["rows"]
    assert len(rows) == 4 * 2 * 2                      # strategies x fractions x methods
    again = io.StringIO()
    assert bench.main(["--size", "48x40", "--fractions", "20,40", "--methods", "bp,nearest",
                       "--from-json", str(target)], out=again) == 0
    assert again.getvalue() == text            # the saved runs' active method included


def test_from_json_a_later_file_replaces_an_earlier_run(bench, tmp_path):
    """Merging a probe after the runs it is compared with: its active rows are read, its
    header printed, and the rows no later file repeats are kept."""
    def row(strategy, mar):
        return dict(scene="s", units="m", strategy=strategy, fraction=40, columns_percent=40.0,
                    method="bp", mar=mar, seconds=1.0)
    first, probe = tmp_path / "a.json", tmp_path / "p.json"
    first.write_text(json.dumps(dict(rows=[row("even", 0.2), row("active", 0.18)],
                                     next_slices_seconds={"s": [1.0]},
                                     active_method="bp", active_error="uncertainty")))
    probe.write_text(json.dumps(dict(rows=[row("active", 0.1)], next_slices_seconds={},
                                     active_method="bp", active_error="truth-counts")))
    even = tmp_path / "even.json"                   # no active run: says nothing of them
    even.write_text(json.dumps(dict(rows=[dict(row("even", 0.15), fraction=60)],
                                    next_slices_seconds={}, active_method="bp",
                                    active_error="uncertainty")))
    out = io.StringIO()
    assert bench.main(["--from-json", f"{first},{probe},{even}", "--fractions", "40,60",
                       "--methods", "bp"], out=out) == 0
    text = out.getvalue()
    assert "counting the pixels with truth (a probe)" in text
    assert "      s  0.500" in text and "0.900" not in text
    assert "    bp      even    0.2000" in text
    assert text.split("yardstick")[1].splitlines()[2].split() == ["s", "0.750"]


@pytest.mark.parametrize("argv", [["--fractions", "20,42"], ["--methods", "magic"],
                                  ["--strategies", "random"], ["--step", "0"]])
def test_bad_options_exit_2(bench, folder, argv, capsys):
    assert bench.main([str(folder), "--quiet", *argv]) == 2
    assert capsys.readouterr().err.startswith("bench_active.py: ")


def test_geometric_mean_skips_the_missing_ratios(bench):
    assert bench.geometric_mean([0.5, math.nan, 2.0]) == pytest.approx(1.0)
    assert bench.geometric_mean([0.25, 0.81]) == pytest.approx(0.45)
    assert math.isnan(bench.geometric_mean([math.nan]))
    assert math.isnan(bench.geometric_mean([]))
