"""The command line: ``python -m refsynth demo | synth``; errors exit 2 with one line."""

import subprocess
import sys

import numpy as np
import pytest

from refsynth.cli.main import main
from refsynth.evaluation.baselines import BASELINES
from refsynth.io import write_pfm
from refsynth.plotting.demo import DEMO_METHODS, run_pipeline_demo


def test_demo_prints_the_table_and_writes_figures(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--size", "32"]) == 0
    out = capsys.readouterr().out
    for needle in ("grid 5/25", "x-stripes 78%", "NP, no edges", "NP, onion order", "BP",
                   "nearest", "linear", "harmonic"):
        assert needle in out
    for name in ("demo_result.png", "demo_np_bp.png", "demo_comparison.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    mars = [float(line.split()[-3]) for line in out.splitlines() if line.startswith(("grid", "x-"))]
    assert len(mars) == 2 * (len(DEMO_METHODS) + len(BASELINES))
    assert all(0 <= m < 5 for m in mars)


def test_pipeline_demo_acquires_and_registers(tmp_path):
    """Simulated scan -> registration; synthesis itself is tested elsewhere."""
    pytest.importorskip("pty")
    summary = run_pipeline_demo(tmp_path, seed=0, methods=())
    h, w = summary["panorama"]
    assert w > 3 * h > 0
    assert 0.3 < summary["known"] < 0.5
    assert (tmp_path / "scan" / "scan.npz").is_file()
    a, b, _, _ = summary["warp"]
    assert a == pytest.approx(300.0) and b == pytest.approx(-1.0)


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(0)
    image = rng.random((20, 24))
    truth = np.where(np.arange(24) < 12, 2.0, 4.0)[None, :].repeat(20, 0)
    partial = np.where(np.arange(24) % 4 == 0, truth, np.nan)
    np.save(tmp_path / "image.npy", image)
    np.save(tmp_path / "partial.npy", partial)
    write_pfm(tmp_path / "full.pfm", truth.astype(np.float32))
    mask = (np.arange(24) % 4 == 0)[None, :].repeat(20, 0).astype(np.uint8)
    np.save(tmp_path / "mask.npy", mask)
    return tmp_path


def test_synth_writes_a_dense_range(files):
    out = files / "out.npy"
    fig = files / "fig.png"
    code = main(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(out), "--figure", str(fig), "--seed", "3"])
    assert code == 0
    result = np.load(out)
    partial = np.load(files / "partial.npy")
    assert np.all(np.isfinite(result))
    known = np.isfinite(partial)
    np.testing.assert_array_equal(result[known], partial[known])
    assert fig.stat().st_size > 10_000


def test_synth_with_a_mask_over_a_full_range(files):
    out = files / "out.npy"
    code = main(["synth", str(files / "image.npy"), str(files / "full.pfm"),
                 "--mask", str(files / "mask.npy"), "--out", str(out), "--no-edges",
                 "--ordering", "onion"])
    assert code == 0
    assert np.all(np.isfinite(np.load(out)))


def test_synth_with_bp(files):
    out = files / "bp.npy"
    assert main(["synth", str(files / "image.npy"), str(files / "partial.npy"), "--out", str(out),
                 "--method", "bp"]) == 0
    assert np.all(np.isfinite(np.load(out)))


def test_synth_is_deterministic(files):
    a, b = files / "a.npy", files / "b.npy"
    for out in (a, b):
        main(["synth", str(files / "image.npy"), str(files / "partial.npy"), "--out", str(out)])
    np.testing.assert_array_equal(np.load(a), np.load(b))


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["synth", "missing.npy", "partial.npy", "--out", "o.npy"], "image file not found"),
        (["synth", "image.npy", "missing.npy", "--out", "o.npy"], "range file not found"),
        (["synth", "image.npy", "partial.npy", "--out", "o.npy", "--radius", "0.1"], "`radius`"),
        (["synth", "image.npy", "partial.npy", "--out", "o.npy", "--neighbourhood", "4"],
         "`neighbourhood` must be odd"),
        (["synth", "image.npy", "image.npy", "--out", "o.npy"], "nothing to fill"),
        (["synth", "image.npy", "partial.npy", "--out", "o.npy", "--mask", "bad.txt"],
         "mask file not found"),
        (["demo", "--size", "4"], "--size must be at least 16"),
    ],
)
def test_errors_print_one_line_and_exit_2(files, args, needle):
    proc = subprocess.run([sys.executable, "-m", "refsynth", *args], cwd=files,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


def test_unknown_command_exits_2():
    proc = subprocess.run([sys.executable, "-m", "refsynth", "frobnicate"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
