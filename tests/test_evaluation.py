"""The experiments runner: specs, bookkeeping, aggregation, determinism, executors, CLI."""

import argparse
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from refsynth.cli.evaluate import add_evaluate_parser
from refsynth.evaluation import (
    DEFAULT_GRID,
    Case,
    aggregate,
    build_cases,
    findings,
    format_findings,
    format_paper_comparison,
    format_pivot,
    format_results,
    format_runtimes,
    format_winners,
    grid_cases,
    known_mask,
    load_scene,
    method_names,
    parse_list,
    parse_method,
    parse_sampling,
    parse_scene,
    parse_size,
    run_case,
    run_cases,
    score,
    without_timing,
)
from refsynth.io import write_pfm
from refsynth.scenes import Scene

#: A grid of a few seconds that still has every kind of method in it.
SMALL = dict(scenes=["synthetic"], sizes=["32"], samplings=["g3_8", "x78"],
             methods=["np", "bp", "nearest", "colorization", "joint-bilateral"])


def _evaluate(argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command", required=True)
    add_evaluate_parser(sub)
    args = parser.parse_args(["evaluate", *argv])
    return args.func(args)


# ----------------------------------------------------------------------------- specs


@pytest.mark.parametrize(("text", "expected"), [
    ("synthetic", "synthetic-0"), ("synthetic-7", "synthetic-7"), (" motorcycle ", "motorcycle"),
    ("motorcycle-crop", "motorcycle-crop"),
])
def test_parse_scene_names(text, expected):
    assert parse_scene(text) == expected


@pytest.mark.parametrize(("text", "expected"), [
    ("64", "64x64"), ("128", "128x128"), ("450x375", "450x375"), ("NATIVE", "native"),
])
def test_parse_size(text, expected):
    assert parse_size(text) == expected


@pytest.mark.parametrize(("text", "expected"), [
    ("g24_80", "g24_80"), ("G05_25", "g5_25"), ("x63", "x63"), ("x085", "x85"),
    ("distance", "distance"), ("distance70", "distance70"),
])
def test_parse_sampling(text, expected):
    assert parse_sampling(text) == expected


@pytest.mark.parametrize("name", ["np", "bp", "np-noedges", "np-noisophotes", "np-onion",
                                  "bp-noedges", "nearest", "linear", "harmonic",
                                  "colorization", "joint-bilateral"])
def test_parse_method_accepts_every_variant_and_baseline(name):
    assert parse_method(name) == name
    assert name in method_names()


@pytest.mark.parametrize(("parse", "text", "match"), [
    (parse_scene, "kitchen", "unknown scene 'kitchen'"),
    (parse_scene, "synthetic-x", "unknown scene"),
    (parse_scene, "", "non-empty"),
    (parse_scene, "nope.png:nope.pfm", "image file not found"),
    (parse_size, "12", "at least 16"),
    (parse_size, "450by375", "bad size '450by375'"),
    (parse_size, "-5", "bad size"),
    (parse_sampling, "g5-25", "unknown sampling 'g5-25'"),
    (parse_sampling, "g0_25", "RW >= 1"),
    (parse_sampling, "x100", "1..99"),
    (parse_sampling, "y50", "unknown sampling"),
    (parse_method, "np-fast", "unknown method 'np-fast'"),
])
def test_bad_specs_raise_one_line_errors(parse, text, match):
    with pytest.raises((ValueError, OSError), match=match) as info:
        parse(text)
    assert "\n" not in str(info.value)


def test_parse_list_keeps_order_drops_duplicates_and_rejects_empty_items():
    assert parse_list("x78, g5_25,x78", parse_sampling, "sampling") == ["x78", "g5_25"]
    with pytest.raises(ValueError, match="empty item in the method list"):
        parse_list("np,,bp", parse_method, "method")
    with pytest.raises(ValueError, match="empty scene list"):
        parse_list(" ", parse_scene, "scene")


def test_path_pair_scene_is_made_absolute(tmp_path, monkeypatch):
    image, disparity = _write_pair(tmp_path)
    monkeypatch.chdir(tmp_path)
    spec = parse_scene(f"{image.name}:{disparity.name}")
    assert spec == f"{image}:{disparity}"
    with pytest.raises(FileNotFoundError, match="disparity file not found"):
        parse_scene(f"{image.name}:missing.pfm")


def test_cases_run_np_over_seeds_and_the_rest_once():
    cases = build_cases(["synthetic"], ["32"], ["x78"],
                        ["np", "np-onion", "bp", "bp-fig6", "bp-obs-colorization", "nearest"],
                        seeds=3)
    # BP draws through NP's fill (its default observations): over seeds too
    assert [(c.method, c.seed) for c in cases] == [
        ("np", 0), ("np", 1), ("np", 2), ("np-onion", 0), ("np-onion", 1), ("np-onion", 2),
        ("bp", 0), ("bp", 1), ("bp", 2), ("bp-fig6", 0), ("bp-obs-colorization", 0),
        ("nearest", 0)]
    with pytest.raises(ValueError, match="no native size"):
        build_cases(["synthetic"], ["native"], ["x78"], ["np"])


def test_default_grid_covers_the_issue():
    from refsynth.evaluation.cases import OPTION_METHODS

    cases = grid_cases(DEFAULT_GRID)
    keys = {(c.scene, c.size, c.sampling, c.method) for c in cases}
    methods = [m for m in method_names() if m not in OPTION_METHODS]
    assert {"bp-obs-np", "bp-obs-colorization"} <= set(method_names())
    assert not {"bp-obs-np", "bp-obs-colorization"} & set(methods)
    for scene in ("synthetic-0", "motorcycle"):
        for sampling in ("g24_80", "g10_20", "g5_25", "g3_28", "x63", "x78", "x85", "distance"):
            for method in methods:
                assert (scene, "128x128", sampling, method) in keys
    for sampling in ("x63", "x78", "x85", "distance"):
        for method in methods:
            assert ("motorcycle", "450x375", sampling, method) in keys
    assert not {c.method for c in cases} & set(OPTION_METHODS)
    assert len(cases) == 630   # the Results page: the default grid's 630 cases
    assert len(cases) == len(set(cases))
    # chosen by name, the options: bp-obs-np (= bp) over seeds, BP on the colorization fill once
    named = grid_cases([("synthetic", "16", "x20", "bp,bp-obs-np,bp-obs-colorization")],
                       seeds=2)
    assert [(c.method, c.seed) for c in named] == [("bp", 0), ("bp", 1), ("bp-obs-np", 0),
                                                   ("bp-obs-np", 1),
                                                   ("bp-obs-colorization", 0)]


# ----------------------------------------------------------------------------- bookkeeping


def _hand_scene():
    """8×10, range 2 on the left and 4 on the right; truth missing in a block and a column."""
    intensity = np.where(np.arange(10) < 5, 0.2, 0.7)[None, :].repeat(8, 0)
    truth = np.where(np.arange(10) < 5, 2.0, 4.0)[None, :].repeat(8, 0)
    truth[2:4, 1:3] = np.nan  # unknown and without truth: never scored
    truth[:, 9] = np.nan  # a known stripe column without truth: not known after all
    return Scene(intensity=intensity, range=truth, units="m", name="hand")


def test_known_mask_drops_pixels_without_truth():
    scene = _hand_scene()
    known = known_mask(scene, "g1_2")
    assert known.dtype == bool and known.shape == (8, 10)
    assert not known[:, 9].any()  # column 9 is a known stripe column, but has no truth
    assert known[0, 0] and known[0, 3] and not known[1, 1]
    np.testing.assert_array_equal(known, (((np.arange(8) % 3) == 0)[:, None]
                                          | ((np.arange(10) % 3) == 0)[None, :])
                                  & np.isfinite(scene.range))


def test_score_counts_only_unknown_pixels_with_truth():
    scene = _hand_scene()
    known = known_mask(scene, "x50")
    result = score(scene, known, "nearest")
    expected_evaluated = np.count_nonzero(~known & np.isfinite(scene.range))
    assert result["evaluated"] == expected_evaluated
    assert result["known"] == np.count_nonzero(known)
    assert result["unknown_percent"] == pytest.approx(100 * (1 - known.mean()))
    # nearest copies across the step only where a pixel is nearer the other side
    estimate = np.where(known, scene.range, np.nan)
    from refsynth.evaluation.baselines import nearest_fill

    filled = nearest_fill(scene.intensity, estimate)
    scored = ~known & np.isfinite(scene.range)
    assert result["mar"] == pytest.approx(np.mean(np.abs(filled - scene.range)[scored]),
                                          rel=1e-12)
    assert result["bad1"] == pytest.approx(np.mean(np.abs(filled - scene.range)[scored] > 1))


def test_a_constant_scene_scores_zero_for_every_method():
    scene = Scene(intensity=np.random.default_rng(0).random((16, 16)),
                  range=np.full((16, 16), 3.0), units="m", name="flat")
    known = known_mask(scene, "g2_5")
    for method in method_names():
        result = score(scene, known, method, seed=1)
        assert result["mar"] == pytest.approx(0.0, abs=1e-12), method
        assert result["bad3"] == 0.0


def _write_pair(folder, width=40, height=24):
    """A PNG image and a PFM disparity (inf where unknown), a step at column 20."""
    image = np.where(np.arange(width) < 20, 60, 200).astype(np.uint8)[None, :].repeat(height, 0)
    disparity = np.where(np.arange(width) < 20, 10.0, 30.0)[None, :].repeat(height, 0)
    disparity[5:9, 3:7] = np.inf
    Image.fromarray(image).save(folder / "view.png")
    write_pfm(folder / "disp.pfm", disparity.astype(np.float32))
    return folder / "view.png", folder / "disp.pfm"


def test_run_case_on_a_path_pair_keeps_units_and_excludes_missing_truth(tmp_path):
    image, disparity = _write_pair(tmp_path)
    spec = parse_scene(f"{image}:{disparity}")
    row = run_case(Case(spec, "native", "x63", "nearest", 0))
    scene = load_scene(spec, "native")
    assert row["units"] == "disparity (px)" and row["size"] == "40x24"
    assert np.isnan(scene.range[5:9, 3:7]).all()
    known = known_mask(scene, "x63")
    assert row["evaluated"] == np.count_nonzero(~known & np.isfinite(scene.range))
    assert row["evaluated"] < np.count_nonzero(~known)
    half = run_case(Case(spec, "20x12", "x63", "nearest", 0))
    assert half["size"] == "20x12"
    assert np.nanmax(load_scene(spec, "20x12").range) == pytest.approx(15.0)  # disparity halves


def test_distance_sampling_is_denser_where_far():
    """Fig. 2 on disparity: small disparity (far) on the right gets more known columns."""
    width = 60
    disparity = np.linspace(40.0, 5.0, width)[None, :].repeat(10, 0)
    scene = Scene(intensity=np.zeros((10, width)), range=disparity, units="disparity (px)",
                  name="ramp")
    known = known_mask(scene, "distance")[0]
    assert known[30:].sum() > known[:30].sum()
    assert abs(known.mean() - 0.4) <= 1 / width + 1e-12
    assert abs(known_mask(scene, "distance70")[0].mean() - 0.3) <= 1 / width + 1e-12


# ----------------------------------------------------------------------------- aggregation


def _run(method, seed, mar, **extra):
    row = dict(scene="s", scene_spec="s", size="8x8", units="m", sampling="x78",
               unknown_percent=75.0, known=16, evaluated=48, method=method, seed=seed, mar=mar,
               rmse=2 * mar, bad1=0.5, bad3=0.0, seconds=1.0 + seed)
    row.update(extra)
    return row


def test_aggregate_gives_mean_and_spread_over_seeds():
    rows = aggregate([_run("np", 2, 3.0), _run("np", 0, 1.0), _run("bp", 0, 0.5),
                      _run("np", 1, 2.0)])
    np_row, bp_row = rows
    assert np_row["method"] == "np" and np_row["seeds"] == [0, 1, 2]
    assert np_row["mar"] == 2.0 and np_row["mar_sd"] == 1.0
    assert (np_row["mar_min"], np_row["mar_max"]) == (1.0, 3.0)
    assert np_row["mar_per_seed"] == [1.0, 2.0, 3.0]
    assert np_row["rmse"] == 4.0 and np_row["seconds"] == 2.0
    assert bp_row["mar_sd"] is None and bp_row["seeds"] == [0]
    assert "seconds" not in without_timing(rows)[0]


def test_findings_hold_tie_or_fail():
    rows = aggregate([
        _run("bp", 0, 1.0), _run("np", 0, 2.0), _run("np", 1, 2.2),
        _run("np-noedges", 0, 2.05), _run("np-noedges", 1, 2.15),
        _run("np-onion", 0, 1.0), _run("np-onion", 1, 1.0),
        _run("np", 0, 3.0, sampling="x85", unknown_percent=85.0),
        _run("np", 1, 3.0, sampling="x85", unknown_percent=85.0),
    ])
    verdicts = {(f["finding"], f["sampling"]): f["verdict"] for f in findings(rows)}
    assert verdicts[("BP < NP", "x78")] == "holds"
    assert verdicts[("NP < NP without edges", "x78")] == "tie"
    assert verdicts[("priority order < onion order", "x78")] == "fails"
    assert verdicts[("error grows with the unknown fraction (np)", "x78,x85")] == "holds"
    text = format_findings(findings(rows))
    assert "| BP < NP (Tables 1–4) | 1 / 0 / 0 | 1 / 0 / 0 |" in text
    assert "| priority order < onion order (Fig. 7) | 0 / 0 / 1 | 0 / 0 / 1 |" in text


def test_winners_name_the_best_method_and_the_best_baseline():
    rows = aggregate([_run("np", 0, 1.0), _run("bp", 0, 0.7), _run("nearest", 0, 0.9),
                      _run("colorization", 0, 0.8)])
    line = format_winners(rows).splitlines()[-1]
    assert line == ("| s | x78 | bp 0.700 | 1.000 | 0.700 | bp 0.700 | colorization 0.800 "
                    "| 0.900 |")


def test_tables_show_mean_spread_and_units():
    rows = aggregate([_run("np", 0, 1.0), _run("np", 1, 2.0), _run("bp", 0, 0.5)])
    text = format_results(rows)
    assert "### s (m)" in text and "1.500 ± 0.707" in text and "| 0.500 |" in text
    assert "seconds" in text and "seconds" not in format_results(rows, timing=False)


def test_pivot_and_runtime_tables():
    rows = aggregate([_run("np", 0, 1.0), _run("np", 1, 2.0), _run("bp", 0, 0.5),
                      _run("bp", 0, 0.25, sampling="x85", unknown_percent=85.0)])
    pivot = format_pivot(rows).splitlines()
    assert pivot[2] == "| sampling | unknown | np | bp |"
    assert pivot[4] == "| x78 | 75.0 % | 1.500 ± 0.707 | 0.500 |"
    assert pivot[5] == "| x85 | 85.0 % | – | 0.250 |"
    runtimes = format_runtimes(rows).splitlines()
    assert runtimes[2] == "| np | 1.50 s |" and runtimes[3] == "| bp | 1.00 s |"
    assert format_runtimes(without_timing(rows)) == ""


def test_paper_comparison_quotes_the_papers_numbers():
    rows = aggregate([_run(m, 0, v, scene="motorcycle-450x375", sampling=s)
                      for s in ("x63", "x78", "x85") for m, v in (("np", 1.0), ("bp", 0.5))])
    text = format_paper_comparison(rows)
    assert "6.42" in text and "3.90" in text and "7.98" in text and "1.000" in text
    assert "| 0.50 |" in text  # our BP/NP beside the paper's 0.61
    rooms = aggregate([_run(m, 0, v * (1 + k), scene=f"synthetic-room-{k}", sampling="g5_25",
                            scene_spec=f"synthetic-{k}",
                            size="128x128")
                       for k in range(2) for m, v in (("np", 0.1), ("np-noedges", 0.2),
                                                      ("bp", 0.3))])
    text = format_paper_comparison(rooms)
    assert "| image 2 | 13.48 / 3.03 / 1.63 | synthetic-room-1 | 0.400 | 0.200 | 0.600 |" in text
    assert "| Table 2: mean of 32 | – / 4.27 / 2.65 | mean of 2 rooms | 0.300 | 0.150 | 0.450 |" \
        in text


# ----------------------------------------------------------------------------- determinism


def test_two_runs_give_identical_rows_apart_from_timing():
    cases = build_cases(**SMALL, seeds=2)
    first = aggregate(run_cases(cases))
    second = aggregate(run_cases(cases))
    assert without_timing(first) == without_timing(second)
    assert json.dumps(without_timing(first)) == json.dumps(without_timing(second))


def test_two_cli_runs_write_byte_identical_files_without_timing(tmp_path, capsys):
    argv = ["--scene", "synthetic", "--size", "32", "--sampling", "g3_8,x78",
            "--methods", "np,bp,nearest", "--seeds", "2", "--no-timing", "--quiet"]
    for name in ("a", "b"):
        assert _evaluate([*argv, "--json", str(tmp_path / f"{name}.json"),
                          "--csv", str(tmp_path / f"{name}.csv")]) == 0
    out = capsys.readouterr().out
    for suffix in ("json", "csv"):
        assert (tmp_path / f"a.{suffix}").read_bytes() == (tmp_path / f"b.{suffix}").read_bytes()
    rows = json.loads((tmp_path / "a.json").read_text())
    assert len(rows) == 2 * 3 and all("seconds" not in row for row in rows)
    assert rows[0]["seeds"] == [0, 1] and rows[0]["units"] == "m"
    header = (tmp_path / "a.csv").read_text().splitlines()[0]
    assert header.startswith("scene,size,units,sampling,unknown_percent")
    assert "### synthetic-room-0 (m)" in out and "relative findings" in out


def test_local_processes_give_the_same_rows_as_one_process():
    cases = build_cases(**SMALL, seeds=2)
    one = aggregate(run_cases(cases, jobs=1))
    two = aggregate(run_cases(cases, jobs=2))
    assert without_timing(one) == without_timing(two)


_ORPHAN_SCRIPT = """
import os, sys, time
from refsynth.evaluation.runner import _executor
pool, _ = _executor(2, None)
pids = {pool.submit(os.getpid).result() for _ in range(8)}
busy = [pool.submit(time.sleep, 600) for _ in range(2)]
time.sleep(1.0)
print(" ".join(map(str, sorted(pids))), flush=True)
time.sleep(600)
"""


def _running(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"  # a zombie has ended
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_local_workers_end_when_the_runner_is_killed():
    # a kill runs no finally: the workers must notice their parent's end on their own
    import signal
    import time

    runner = subprocess.Popen([sys.executable, "-c", _ORPHAN_SCRIPT], stdout=subprocess.PIPE,
                              text=True)
    try:
        pids = [int(pid) for pid in runner.stdout.readline().split()]
        assert pids and all(_running(pid) for pid in pids)
    finally:
        runner.send_signal(signal.SIGKILL)
        runner.wait()
        runner.stdout.close()
    deadline = time.monotonic() + 30.0
    while any(_running(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = [pid for pid in pids if _running(pid)]
    for pid in left:  # do not leave them behind, whatever the outcome
        os.kill(pid, signal.SIGKILL)
    assert not left


def test_dask_cluster_gives_the_same_rows_as_local_runs():
    distributed = pytest.importorskip("dask.distributed")
    cases = build_cases(**SMALL, seeds=2)
    local = aggregate(run_cases(cases))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        remote = aggregate(run_cases(cases, scheduler=cluster.scheduler_address))
    assert without_timing(remote) == without_timing(local)


def test_progress_reports_every_case_once():
    cases = build_cases(["synthetic"], ["32"], ["x78"], ["nearest", "harmonic"])
    seen = []
    run_cases(cases, progress=lambda done, total, case, row, elapsed: seen.append(
        (done, total, case.method, row["method"])))
    assert seen == [(1, 2, "nearest", "nearest"), (2, 2, "harmonic", "harmonic")]


# ----------------------------------------------------------------------------- command line


@pytest.mark.parametrize(("argv", "error", "match"), [
    (["--scene", "kitchen"], ValueError, "unknown scene 'kitchen'"),
    (["--size", "4"], ValueError, "at least 16"),
    (["--sampling", "z9"], ValueError, "unknown sampling 'z9'"),
    (["--methods", "np,magic"], ValueError, "unknown method 'magic'"),
    (["--jobs", "0"], ValueError, "--jobs must be at least 1"),
    (["--seeds", "0"], ValueError, "--seeds must be at least 1"),
    (["--scene", "a.png:b.pfm"], OSError, "image file not found"),
])
def test_cli_user_errors_are_one_line(argv, error, match):
    with pytest.raises(error, match=match) as info:
        _evaluate([*argv, "--quiet"])
    assert "\n" not in str(info.value)


def test_cli_scheduler_without_dask_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    with pytest.raises(ImportError, match="pip install 'dask\\[distributed\\]'"):
        _evaluate(["--scene", "synthetic", "--size", "32", "--sampling", "x78",
                   "--methods", "nearest", "--scheduler", "tcp://127.0.0.1:1", "--quiet"])


def test_module_entry_point_exits_2_with_one_line(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "refsynth", "evaluate", "--sampling", "q1"],
        capture_output=True, text=True, timeout=60, cwd=tmp_path,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "refsynth evaluate: error: unknown sampling 'q1': expected gRW_XW (grid stripes, "
        "e.g. g5_25), xNN (x-stripes, NN % unknown, e.g. x78), distance or distanceNN"]


def test_load_reprints_saved_rows(tmp_path, capsys):
    argv = ["--scene", "synthetic", "--size", "32", "--sampling", "x78", "--methods",
            "nearest,np", "--seeds", "2", "--quiet", "--no-findings"]
    assert _evaluate([*argv, "--json", str(tmp_path / "rows.json")]) == 0
    printed = capsys.readouterr().out
    assert _evaluate(["--load", str(tmp_path / "rows.json"), "--quiet", "--no-findings",
                      "--csv", str(tmp_path / "rows.csv")]) == 0
    assert capsys.readouterr().out == printed
    assert (tmp_path / "rows.csv").read_text().count("\n") == 3
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(ValueError, match="not a list of rows"):
        _evaluate(["--load", str(tmp_path / "bad.json")])
    with pytest.raises(ValueError, match="--load prints saved rows"):
        _evaluate(["--load", str(tmp_path / "rows.json"), "--methods", "np"])


# ----------------------------------------------------------------------------- the front door


@pytest.mark.parametrize(("parse", "text", "match"), [
    (parse_sampling, "g1_99999999999999999999999", "both at most 100000"),
    (parse_sampling, "g100001_5", "both at most 100000"),
    (parse_scene, "synthetic-٣", "unknown scene"),
    (parse_scene, "synthetic-12345678901234567890", "unknown scene"),
    (parse_size, "٣٢", "bad size"),
    (parse_size, "1234567890x16", "bad size"),
    (parse_sampling, "x٧٨", "unknown sampling"),
])
def test_specs_accept_ascii_digits_of_sensible_length_only(parse, text, match):
    """Non-ASCII digits (``synthetic-٣``) and huge stripe widths are refused, in one line."""
    with pytest.raises(ValueError, match=match) as info:
        parse(text)
    assert "\n" not in str(info.value)


@pytest.fixture
def no_grid(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("the grid started before the checks failed")

    monkeypatch.setattr("refsynth.cli.evaluate.run_cases", forbidden)


@pytest.mark.parametrize(("argv", "match"), [
    (["--scene", ""], "empty scene list"),
    (["--size", ""], "empty size list"),
    (["--sampling", ""], "empty sampling list"),
    (["--methods", ""], "empty method list"),
    (["--sampling", "g1_99999999999999999999999"], "at most 100000"),
    (["--scene", "synthetic", "--size", "100000", "--sampling", "x78", "--methods", "nearest"],
     r"the case synthetic-room-0 100000x100000 x78 nearest seed 0 would need about 9\.1 TiB "
     "of memory"),
    (["--scene", "synthetic", "--json", "rows.txt"], "--json must end in .json"),
    (["--scene", "synthetic", "--csv", "rows.json"], "--csv must end in .csv"),
    (["--scene", "synthetic", "--json", "a.json/rows.json"], "a.json is not a folder"),
])
def test_cli_refuses_before_any_work(tmp_path, monkeypatch, no_grid, argv, match):
    """One line before any work: no traceback, no default grid for "", no failure after the work."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.json").write_text("[]")
    monkeypatch.setattr("refsynth.cli.arguments.physical_memory", lambda: 8 * 2**30)
    with pytest.raises((ValueError, OSError), match=match) as info:
        _evaluate([*argv, "--quiet"])
    assert "\n" not in str(info.value)


def test_cli_memory_estimate_counts_the_jobs(monkeypatch, no_grid):
    monkeypatch.setattr("refsynth.cli.arguments.physical_memory", lambda: 2**30)
    argv = ["--scene", "synthetic", "--size", "500", "--sampling", "x78", "--methods", "np"]
    with pytest.raises(ValueError, match=r"3 cases at once \(--jobs 4\)"):
        _evaluate([*argv, "--jobs", "4", "--quiet"])  # 3 seeds: 3 cases at most at once
    with pytest.raises(AssertionError, match="the grid started"):  # one at a time fits
        _evaluate([*argv, "--jobs", "1", "--quiet"])


@pytest.mark.parametrize(("content", "match"), [
    ("[" * 100_000 + "]" * 100_000, "nests too deeply"),
    ("[]", "holds no rows"),
    ('[{"scene": 1}]', "row 0 lacks"),
    ("[1]", "row 0 is a int"),
    ("\xff\xfe", "not UTF-8"),
])
def test_load_refuses_what_it_cannot_print(tmp_path, content, match):
    """Deeply nested JSON is refused in one line, not a RecursionError."""
    path = tmp_path / "rows.json"
    path.write_bytes(content.encode("latin-1") if content.startswith("\xff") else
                     content.encode())
    with pytest.raises(ValueError, match=match) as info:
        _evaluate(["--load", str(path)])
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_load_checks_the_type_of_every_field(tmp_path, capsys):
    argv = ["--scene", "synthetic", "--size", "16", "--sampling", "x78", "--methods",
            "nearest", "--quiet", "--no-findings", "--json", str(tmp_path / "rows.json")]
    assert _evaluate(argv) == 0
    rows = json.loads((tmp_path / "rows.json").read_text())
    for field, bad in [("mar", "0.5"), ("seeds", []), ("known", -1), ("units", None),
                       ("mar_per_seed", [0.1, 0.2]), ("surprise", 1)]:
        broken = [dict(rows[0], **{field: bad})]
        (tmp_path / "bad.json").write_text(json.dumps(broken))
        with pytest.raises(ValueError, match=f"row 0 .*(bad|unknown field|seeds but) "
                           f"|{field}") as info:
            _evaluate(["--load", str(tmp_path / "bad.json"), "--no-findings"])
        assert "\n" not in str(info.value)
    rows[0]["rmse"] = None  # NaN is written as null: read back as NaN
    (tmp_path / "nan.json").write_text(json.dumps(rows))
    assert _evaluate(["--load", str(tmp_path / "nan.json"), "--no-findings"]) == 0
    assert "nan" in capsys.readouterr().out


def test_progress_and_tables_use_one_scene_name_and_the_size_that_ran(capsys):
    """A 32x32 run is headed 32x32 (not "128×128"); progress names the scene as the table does."""
    argv = ["--scene", "synthetic", "--size", "32", "--sampling", "g5_25",
            "--methods", "np,bp", "--seeds", "1"]
    assert _evaluate(argv) == 0
    captured = capsys.readouterr()
    assert "128×128" not in captured.out and "### synthetic-room-0 (m)" in captured.out
    progress = [line for line in captured.err.splitlines() if line.startswith("[")]
    assert len(progress) == 2 and all("] synthetic-room-0 32x32 g5_25 " in line
                                      for line in progress)


def test_scene_labels_match_the_loaded_scenes_names(tmp_path):
    from refsynth.evaluation.cases import load_scene, scene_label

    image = tmp_path / "pair" / "im0.png"
    image.parent.mkdir()
    Image.fromarray(np.zeros((16, 20, 3), np.uint8)).save(image)
    np.save(image.parent / "disp.npy", np.ones((16, 20)))
    specs = [("synthetic-2", "16x16"), ("motorcycle", "32x32"), ("motorcycle-crop", "32x32"),
             ("motorcycle-crop", "native"),
             (parse_scene(f"{image}:{image.parent / 'disp.npy'}"), "native")]
    for scene, size in specs:
        assert scene_label(scene, size) == load_scene(scene, size).name


def test_a_complex_npy_disparity_is_refused(tmp_path):
    """A complex .npy is refused, not cast to real with only a ComplexWarning."""
    from refsynth.evaluation.cases import load_scene

    Image.fromarray(np.zeros((16, 20), np.uint8)).save(tmp_path / "im.png")
    np.save(tmp_path / "disp.npy", np.ones((16, 20)) + 1j)
    scene = parse_scene(f"{tmp_path / 'im.png'}:{tmp_path / 'disp.npy'}")
    with pytest.raises(ValueError, match="must hold real numbers, got dtype complex128"):
        load_scene(scene, "native")


def test_case_memory_scales_with_pixels_and_method():
    from refsynth.evaluation.cases import Case, case_memory

    small, large = (case_memory(Case("synthetic-0", size, "x78", "np", 0))
                    for size in ("100x100", "200x200"))
    assert large == 4 * small
    assert case_memory(Case("synthetic-0", "100x100", "x78", "bp", 0)) > small
    assert case_memory(Case("synthetic-0", "100x100", "x78", "nearest", 0)) < small
    assert case_memory(Case("motorcycle", "native", "x78", "np", 0)) == 741 * 500 * small / 1e4
