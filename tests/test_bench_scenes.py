"""A smoke test of ``benchmarks/bench_scenes.py`` on a tiny scene folder the test writes."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from PIL import Image


@pytest.fixture(scope="module")
def bench(benchmark_script):
    return benchmark_script("bench_scenes")


def _scene(folder, name, *, kind="depth", step=False):
    """A 40 × 48 two-plane scene whose intensity follows its range; 0 = no depth in a corner."""
    path = folder / name
    path.mkdir()
    rows, cols = np.mgrid[0:40, 0:48]
    depth = 2.0 + 0.02 * cols + (1.0 if step else 0.0) * (cols >= 24)
    stored = np.round(depth * 1000).astype(np.uint16)
    stored[:4, :4] = 0
    grey = (60 + 150 * (cols >= 24) + 10 * np.sin(rows)).astype(np.uint8)
    Image.fromarray(np.stack([grey] * 3, axis=-1)).save(path / "rgb.png")
    Image.fromarray(stored).save(path / "depth.png")
    meta = {"image": "rgb.png", "truth": "depth.png", "scale": 1000, "invalid": [0],
            "kind": kind}
    if kind == "disparity":
        meta["units"] = "disparity (px)"
    (path / "scene.json").write_text(json.dumps(meta))
    return path


@pytest.fixture()
def folder(tmp_path):
    _scene(tmp_path, "plane")
    _scene(tmp_path, "step", step=True)
    (tmp_path / "notes").mkdir()          # no scene.json: skipped
    return tmp_path


def test_table_json_and_resume(bench, folder, tmp_path, capsys):
    out = io.StringIO()
    target = tmp_path / "runs.json"
    argv = [str(folder), "--size", "24x20", "--samplings", "x63,distance60",
            "--methods", "np,nearest,linear", "--seeds", "0,1", "--json", str(target),
            "--quiet"]
    assert bench.main(argv, out=out) == 0
    text = out.getvalue()
    assert "skipped" in capsys.readouterr().err
    lines = [line for line in text.splitlines() if line.startswith("| plane") or
             line.startswith("| step")]
    assert len(lines) == 4                               # 2 scenes x 2 samplings
    assert all(" ± " in line.split("|")[4] for line in lines)   # np: two seeds
    payload = json.loads(target.read_text())
    runs = payload["runs"]
    # np twice (two seeds), the deterministic fills once, per scene x sampling
    assert len(runs) == 2 * 2 * (2 + 1 + 1)
    assert {r["method"] for r in runs} == {"np", "nearest", "linear"}
    case = next(c for c in payload["summary"]["cases"]
                if c["scene"] == "plane" and c["sampling"] == "distance60")
    # a plane sampled by columns inside it: the linear fill is exact up to the millimetre
    # storage and the resize (x63 leaves the last columns to extrapolate), the best fill
    assert case["best_classical"] == "linear" and case["methods"]["linear"]["mar"] < 1e-3
    nearest = case["methods"]["nearest"]
    assert nearest["ratio"] == pytest.approx(nearest["mar"] / case["methods"]["linear"]["mar"])
    np_entry = case["methods"]["np"]
    assert np_entry["seeds"] == [0, 1] and np_entry["sd"] is not None
    assert payload["summary"]["aggregate"]["np"]["all"]["cases"] == 4
    # the measured MAR is Eq. 13 on the unknown pixels with truth: nearest on a 0.02 m/px slope
    assert 0.005 < nearest["mar"] < 0.2
    # --resume runs nothing new when every run is there, and adds a seed's runs otherwise
    before = target.read_text()
    assert bench.main(argv + ["--resume"], out=io.StringIO()) == 0
    assert json.loads(target.read_text())["runs"] == json.loads(before)["runs"]
    three = [("0,1,2" if item == "0,1" else item) for item in argv]
    assert bench.main(three + ["--resume"], out=io.StringIO()) == 0
    assert len(json.loads(target.read_text())["runs"]) == len(runs) + 2 * 2


def test_variant_and_disparity_scene(bench, tmp_path):
    _scene(tmp_path, "mb_disp", kind="disparity")
    out = io.StringIO()
    assert bench.main([str(tmp_path), "--size", "24x20", "--samplings", "distance60",
                       "--methods", "onion,nearest", "--seeds", "0", "--quiet",
                       "--variant", "onion=np:ordering=onion,use_edges=false"], out=out) == 0
    assert "| mb_disp | distance60 |" in out.getvalue()
    assert bench.VARIANTS["onion"] == {"ordering": "onion", "use_edges": False}
    assert bench.group_of("mb_disp") == "tabletop" and bench.group_of("nyu_x") == "indoor"


@pytest.mark.parametrize("argv, message", [
    (["--size", "24x20"], "no scenes"),
    (["--methods", "np,splines"], "unknown"),
    (["--samplings", "q5"], "sampling"),
    (["--scenes", "nowhere"], "names no scene"),
    (["--variant", "x=lbp:a=1"], "METHOD must be np or bp"),
])
def test_bad_arguments_exit_2_with_one_line(bench, folder, capsys, argv, message):
    full = argv if argv[0] == "--size" else [str(folder), *argv]
    assert bench.main(full, out=io.StringIO()) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("bench_scenes.py: ") and message in err[-1]


# ----------------------------------------------------------------------------- diagnose_distance.py


@pytest.fixture(scope="module")
def diagnose(benchmark_script):
    return benchmark_script("diagnose_distance")


def test_gap_widths_by_hand(diagnose):
    known = np.array([[1, 0, 0, 1, 0, 1, 0, 0, 0],
                      [0, 0, 1, 1, 1, 1, 1, 1, 1]], bool)
    assert diagnose.gap_widths(known).tolist() == [[0, 2, 2, 0, 1, 0, 3, 3, 3],
                                                   [2, 2, 0, 0, 0, 0, 0, 0, 0]]


def test_trace_equals_synthesize_and_points_at_filled_sources(diagnose):
    rows, cols = np.mgrid[0:14, 0:18]
    truth = 2.0 + 0.1 * cols + 0.5 * (cols >= 9)
    intensity = np.where(cols >= 9, 0.8, 0.2) + 0.05 * np.sin(rows)
    known = (cols % 3 == 0)
    partial = np.where(known, truth, np.nan)
    for options in ({}, {"ordering": "onion", "range_copy": "value"}):
        trace = diagnose.traced_synthesize(intensity, partial, seed=1, **options)  # checks bits
        assert len(trace.target) == int((~known).sum())
        # every source was filled before its target: measured, or an earlier step
        step = trace.step[trace.source[:, 0], trace.source[:, 1]]
        order = np.arange(len(trace.target))
        assert np.all(trace.source_known == (step < 0))
        assert np.all((step < 0) | (step < order))
        assert np.all(trace.range[known] == truth[known])


def test_shape_prototype_is_exact_on_a_plane(diagnose):
    # a plane: every chord is exact, so the shape copy gives the truth (NP alone does not)
    rows, cols = np.mgrid[0:16, 0:20]
    truth = 2.0 + 0.05 * cols + 0.01 * rows
    intensity = 0.5 + 0.3 * np.sin(rows + 0.7 * cols)
    known = np.zeros(truth.shape, bool)
    known[:, [0, 2, 5, 7, 10, 13, 15, 19]] = True
    scene = type("S", (), {"intensity": intensity, "range": truth})()
    filled = diagnose.prototype("shape")(scene, known, 0)
    assert np.abs(filled - truth).max() < 1e-5         # the range grid of the contract
