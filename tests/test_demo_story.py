"""``python -m refsynth demo``: the paper's story by default, today's table with ``--quick``."""

import contextlib
import io
import json
from types import SimpleNamespace

import pytest

import refsynth.cli.demo as cli_demo
from refsynth.cli.main import main
from refsynth.plotting.story import STORY_FILES


def test_demo_quick_still_prints_the_table(tmp_path, capsys):
    assert main(["demo", "--quick", "--size", "24", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("refsynth demo: synthetic room 24x24, seed 0, range in m")
    for needle in ("grid 5/25", "x-stripes 78%", "NP, onion order", "BP", "nearest",
                   "colorization", "MAR (m)"):
        assert needle in out
    for name in ("demo_result.png", "demo_np_bp.png", "demo_comparison.png"):
        assert (tmp_path / name).is_file()


@pytest.mark.parametrize("argv, message", [
    (["--quick", "--pipeline"], "--pipeline (the default story) takes no --quick or --size"),
    (["--size", "32", "--pipeline"], "takes no --quick or --size"),
    (["--seed", "-1"], "--seed must be >= 0"),
])
def test_demo_option_errors_give_one_line(tmp_path, capsys, argv, message):
    assert main(["demo", "--out", str(tmp_path / "d"), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def _summary(out):
    """What run_pipeline_demo returns, for two positions (the numbers made up)."""
    points = {"measured": 0.09, "NP": 0.46, "BP": 0.48}
    triangles = {k: {"triangles": 100, "bridging": 0, "silhouette": 3}
                 for k in ("measured", "NP", "BP")}
    rows = [dict(position=k, method=m, unknown=60.0, mar=0.04, rmse=0.12, median_percent=0.5,
                 seconds=1.0, bad1=0.0, bad3=0.0, n=10)
            for k in (1, 2) for m in ("NP", "BP", "nearest", "colorization")]
    return dict(
        panorama=(228, 961), known=0.39, warp=(300.0, -1.0, 493.1, 119.5),
        positions=[dict(pose={"x": 0.0, "z": 0.0, "heading": 0.0}, panorama=(228, 961),
                        known=0.39, warp=(300.0, -1.0, 493.1, 119.5), scan=str(out / "scan")),
                   dict(pose={"x": 1.0, "z": 0.8, "heading": -20.0}, panorama=(222, 980),
                        known=0.38, warp=(300.0, -1.0, 487.3, 130.9),
                        scan=str(out / "scan-2"))],
        rows=rows,
        targets={"positions": [{"points_percent": points, "triangles": triangles}] * 2,
                 "alignment": [{"position": 2, "odometry_cm": 21.7, "refined_cm": 0.66,
                                "icp_iterations": 18, "converged": True}],
                 "merged": {"method": "BP", "vertices": 10, "triangles": 20, "fused_away": 5}},
        files=[out / "scan", out / "scan-2", *(out / name for name in STORY_FILES)],
        seconds={})


def test_demo_default_is_the_story_and_prints_every_output(tmp_path, capsys, monkeypatch):
    calls = []

    def story(out, seed=0, progress=None):
        calls.append((out, seed))
        progress("position 1: scan", 0.0)
        progress("done", 1.0)
        return _summary(out)

    monkeypatch.setattr(cli_demo, "run_pipeline_demo", story)
    for argv in ([], ["--pipeline"]):
        assert main(["demo", "--out", str(tmp_path), "--seed", "3", *argv]) == 0
        captured = capsys.readouterr()
        out = captured.out
        assert "scanned from 2 positions" in out and "position 2: x = 1 m, z = 0.8 m" in out
        assert "colorization" in out and "MAR (Eq. 13)" in out
        assert "bridging a true depth discontinuity" in out and "21.70 -> 0.66 cm" in out
        for name in ("scan/", "scan-2/", *STORY_FILES):
            assert str(tmp_path / name).rstrip("/") in out
        assert "demo:   0 % position 1: scan" in captured.err
        assert out.splitlines()[-1].startswith("next: python -m refsynth demo --active")
    assert calls == [(tmp_path, 3), (tmp_path, 3)]


def test_story_progress_says_how_long_is_left():
    stream, now = io.StringIO(), [0.0]
    report = cli_demo.story_progress(stream=stream, clock=lambda: now[0])
    report("position 1: scan", 0.0)
    now[0] = 30.0
    report("position 1: NP", 0.25)
    report("position 1: NP", 0.3)  # within the interval: not printed
    now[0] = 120.0
    report("done", 1.0)
    report.finish()
    lines = stream.getvalue().splitlines()
    assert lines == ["demo:   0 % position 1: scan, 0:00 elapsed",
                     "demo:  25 % position 1: NP, 0:30 elapsed, ~1:30 left",
                     "demo: 100 % done, 2:00 elapsed, ~0:00 left"]


@pytest.fixture(scope="module")
def story(tmp_path_factory):
    """One run of the whole default demo (about a minute on two cores), shared by the tests
    below: its folder, what it printed, and what :func:`run_pipeline_demo` returned to it."""
    pytest.importorskip("pty")
    out = tmp_path_factory.mktemp("story")
    returned = []

    def spy(*args, **kwargs):
        returned.append(real(*args, **kwargs))
        return returned[-1]

    real = cli_demo.run_pipeline_demo
    stdout, stderr = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stdout(stdout), \
            contextlib.redirect_stderr(stderr):
        patch.setattr(cli_demo, "run_pipeline_demo", spy)
        status = main(["demo", "--out", str(out)])
    assert status == 0, stderr.getvalue()[-4000:]
    (summary,) = returned
    return SimpleNamespace(out=out, stdout=stdout.getvalue(), stderr=stderr.getvalue(),
                           summary=summary)


@pytest.mark.slow
def test_the_story_end_to_end_meets_the_targets(story):
    """The whole default demo: the story's targets hold."""
    tmp_path = story.out
    for name in ("scan", "scan-2", *STORY_FILES):
        assert (tmp_path / name).exists(), name
        assert str(tmp_path / name) in story.stdout
    assert "left" in story.stderr
    record = json.loads((tmp_path / "story.json").read_text())
    assert {(row["position"], row["method"]) for row in record["rows"]} == {
        (k, m) for k in (1, 2) for m in ("NP", "BP", "nearest", "colorization")}
    assert all(0 < row["mar"] < 0.2 for row in record["rows"])
    targets = record["targets"]
    for position in targets["positions"]:
        assert position["points_percent"]["measured"] <= 1.0
        assert position["points_percent"]["NP"] <= 1.0 and position["points_percent"]["BP"] <= 1.0
        assert position["triangles"]["measured"]["bridging"] == 0
    (alignment,) = targets["alignment"]
    assert alignment["refined_cm"] <= 1.0 < alignment["odometry_cm"]


@pytest.mark.slow
def test_the_model_command_merges_the_storys_positions_into_the_same_model(story):
    again = story.out / "again.ply"
    assert main(["model", "--merge", str(story.out / "position-1.ply"),
                 str(story.out / "position-2.ply"), "--poses", str(story.out / "poses.json"),
                 "--out", str(again)]) == 0
    assert again.read_bytes() == (story.out / "room.ply").read_bytes()


@pytest.mark.slow
def test_the_story_acquires_and_registers(story):
    """Stage 1 of the same run: the simulated scan and its registration."""
    summary = story.summary
    h, w = summary["panorama"]
    assert w > 3 * h > 0
    assert 0.3 < summary["known"] < 0.5
    assert (story.out / "scan" / "scan.npz").is_file()
    a, b, _, _ = summary["warp"]
    assert a == pytest.approx(300.0) and b == pytest.approx(-1.0)
