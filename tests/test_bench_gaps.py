"""A smoke test of ``benchmarks/bench_gaps.py`` on a tiny scene folder the test writes."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from PIL import Image

from refsynth.evaluation.metrics import evaluate
from refsynth.synthesis.gap_readings import gap_gate
from refsynth.synthesis.median_pass import median_pass


@pytest.fixture(scope="module")
def bench(benchmark_script):
    return benchmark_script("bench_gaps")


@pytest.fixture()
def folder(tmp_path):
    """A 40 × 48 plane scene with a step, its intensity following its range."""
    path = tmp_path / "step"
    path.mkdir()
    rows, cols = np.mgrid[0:40, 0:48]
    depth = 2.0 + 0.01 * cols + 1.0 * (cols >= 24)
    grey = (60 + 150 * (cols >= 24) + 10 * np.sin(rows)).astype(np.uint8)
    Image.fromarray(np.stack([grey] * 3, axis=-1)).save(path / "rgb.png")
    Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(path / "depth.png")
    (path / "scene.json").write_text(json.dumps(
        {"image": "rgb.png", "truth": "depth.png", "scale": 1000, "kind": "depth"}))
    return tmp_path


def test_table_arrays_and_resume(bench, folder, tmp_path):
    arrays = tmp_path / "arrays"
    arrays.mkdir()
    target = tmp_path / "runs.json"
    argv = [str(folder), "--size", "24x20", "--samplings", "x63", "--bases", "np",
            "--jumps", "0.1", "--medians", "5", "--arrays", str(arrays), "--json", str(target),
            "--quiet", "--mar"]
    out = io.StringIO()
    assert bench.main(argv, out=out) == 0
    line = next(x for x in out.getvalue().splitlines() if x.startswith("| step"))
    header = next(x for x in out.getvalue().splitlines() if x.startswith("| scene"))
    cells = dict(zip([c.strip() for c in header.split("|")], [c.strip() for c in line.split("|")]))
    runs = json.loads(target.read_text())["runs"]
    assert {r["method"] for r in runs} == {"np-copy", "np-gate", "np", "np-clip", "np-jump0.1",
                                           "np-median5",
                                           "row-linear", "nearest", "linear", "colorization",
                                           "joint-bilateral"}
    mar = {r["method"]: r["mar"] for r in runs}
    assert float(cells["np"]) == pytest.approx(mar["np"], rel=1e-3)
    # the gate takes the line in the smooth gaps, so it is never worse than the copy here;
    # jump 0.1 is the default's; the median after the gate is the default
    assert mar["np-gate"] <= mar["np-copy"] + 1e-12
    assert mar["np-jump0.1"] == mar["np"]
    estimate = np.load(arrays / "step_x63_24x20_np-copy_0.npy")
    scene = bench.scenes.load(str(folder / "step"), "24x20")
    known = bench.known_mask(scene, "x63")
    partial = np.where(known, scene.range, np.nan)
    edges = bench.synthesis_edges(bench.validate_inputs(scene.intensity, partial)[0], sigma=0.8)
    gated = gap_gate(estimate, partial, edges=edges)
    assert mar["np"] == pytest.approx(
        evaluate(median_pass(gated, partial), scene.range, known)["mar"], rel=1e-12)
    assert mar["np-median5"] == pytest.approx(
        evaluate(median_pass(gated, partial, 5), scene.range, known)["mar"], rel=1e-12)
    assert (arrays / "step_x63_24x20_np-copy_0.npy").is_file()
    assert (arrays / "step_x63_24x20_linear.npy").is_file()
    # a second run reuses the arrays: the same MARs
    target.unlink()
    assert bench.main(argv, out=io.StringIO()) == 0
    again = {r["method"]: r["mar"] for r in json.loads(target.read_text())["runs"]}
    assert again == mar
    assert bench.main(argv + ["--resume"], out=io.StringIO()) == 0
    assert len(json.loads(target.read_text())["runs"]) == len(runs)


@pytest.mark.parametrize("bad", [["--bases", "np,xx"], ["--jumps", "-1"], ["--resume"],
                                 ["--medians", "4"], ["--medians", "x"],
                                 ["--arrays", "/nonexistent/folder"]])
def test_bad_arguments_exit_2(bench, folder, bad, capsys):
    assert bench.main([str(folder), *bad], out=io.StringIO()) == 2
    err = capsys.readouterr().err
    assert err.startswith("bench_gaps.py: ") and err.count("\n") == 1


def test_windows_rows_are_the_default_with_either_side(bench, folder, tmp_path):
    from refsynth import synthesize
    from refsynth.synthesis.window_reading import choose_neighbourhood

    arrays = tmp_path / "arrays"
    arrays.mkdir()
    target = tmp_path / "runs.json"
    argv = [str(folder), "--size", "48x40", "--samplings", "distance60", "--bases", "np",
            "--windows", "--arrays", str(arrays), "--json", str(target), "--quiet"]
    assert bench.main(argv, out=io.StringIO()) == 0
    mar = {r["method"]: r["mar"] for r in json.loads(target.read_text())["runs"]}
    scene = bench.scenes.load(str(folder / "step"), "48x40")
    known = bench.known_mask(scene, "distance60")
    partial = np.where(known, scene.range, np.nan)
    assert choose_neighbourhood(partial) == 3        # narrow gaps: the default is 3 x 3
    assert mar["np-narrow"] == mar["np"]
    assert not (arrays / "step_distance60_48x40_np-narrow_0.npy").exists()
    fixed = np.load(arrays / "step_distance60_48x40_np-fixed_0.npy")
    np.testing.assert_array_equal(fixed, synthesize(
        scene.intensity, partial, seed=0, readings={"gaps": "copy", "median": 0,
                                                    "window": "fixed"}).range)
    edges = bench.synthesis_edges(bench.validate_inputs(scene.intensity, partial)[0], sigma=0.8)
    assert mar["np-fixed"] == pytest.approx(evaluate(
        median_pass(gap_gate(fixed, partial, edges=edges), partial), scene.range, known)["mar"],
        rel=1e-12)
