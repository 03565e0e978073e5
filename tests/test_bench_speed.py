"""A smoke test of ``benchmarks/bench_speed.py`` on tiny sizes."""

import io

import pytest

pytest.importorskip("skimage")  # the Motorcycle


@pytest.fixture(scope="module")
def bench(benchmark_script):
    return benchmark_script("bench_speed")


def test_the_table_has_every_method_and_size_and_the_linearity_line(bench):
    out = io.StringIO()
    results = bench.run([(32, 27), (40, 34)], ["np", "bp", "colorization", "nearest"],
                        rss=False, out=out)
    text = out.getvalue()
    rows = [line for line in text.splitlines() if line.startswith("| 32×27") or
            line.startswith("| 40×34")]
    assert len(rows) == 8
    assert "| 32×27 |" in rows[0] and "| np |" in rows[0]
    # colorization is the reference of both ratios, wall and CPU
    assert "| colorization | " in rows[2] and rows[2].count("| 1× |") == 2
    assert "| bp (" in rows[1] and " sweeps) |" in rows[1]
    for what in ("wall", "CPU"):
        assert (f"Linearity in {what} time (µs per unknown pixel, 32×27 → 40×34, "
                f"target ±25 %):") in text
    assert all(text.count(f"- {m}: ") == 2 for m in ("np", "bp", "colorization", "nearest"))
    assert set(results) == {(32, 27), (40, 34)}
    first = results[(32, 27)]
    assert first["unknown"] > 0 and first["seconds"]["np"] > 0 and first["cpu"]["np"] > 0
    assert 1 <= first["sweeps"]["bp"] <= 50


def test_peak_rss_is_read_in_a_fresh_subprocess(bench):
    peak, how = bench._peak_rss_mb("nearest", (32, 27))
    assert peak > 10 and how in ("VmHWM", "ru_maxrss")


def test_bad_options_are_refused(bench, capsys):
    for argv in (["--methods", "np,fast"], ["--repeat", "0"], ["--sizes", "4x4"],
                 ["--quick", "--sizes", "112x94"], ["--room"]):
        with pytest.raises(SystemExit) as exit_info:
            bench.main(argv)
        assert exit_info.value.code == 2
    assert "unknown method(s) fast" in capsys.readouterr().err


def test_memory_mode_prints_each_fill_beside_its_estimate(bench, capsys):
    """``--memory SIZE`` (item 3): NP and BP each in a fresh subprocess, the estimate that
    ``synthesize`` refuses a run by beside the measured peak and the RSS before the fill."""
    assert bench.main(["--memory", "32x27"]) == 0
    text = capsys.readouterr().out
    assert "Motorcycle 32×27" in text
    rows = {line.split("|")[1].strip(): line for line in text.splitlines()
            if line.startswith(("| np |", "| bp |"))}
    assert set(rows) == {"np", "bp"}
    for row in rows.values():
        estimate, before, peak, added = (float(v) for v in row.split("|")[2:6])
        assert estimate > 0 and 10 < before <= peak and added == pytest.approx(peak - before,
                                                                              abs=1)
        assert "| yes |" in row


def test_fill_solvers_on_the_room_put_the_default_fill_back(bench):
    """``--fill-solvers --room``: BP with the cascade is BP on the colorization fill's
    observations, and the default fill is restored after the
    Gauss-Seidel run."""
    import io

    import numpy as np

    import refsynth
    from refsynth.acquisition.sampling import stripes
    from refsynth.evaluation.metrics import mar
    from refsynth.scenes import synthetic_room
    from refsynth.synthesis.belief import observation as bp_observation
    from refsynth.synthesis.completion import portable_colorization

    out = io.StringIO()
    results = bench.fill_solvers_room(out=out, grids=((10, 20),))
    assert bp_observation.portable_colorization is portable_colorization
    assert set(results) == {("10/20", "direct"), ("10/20", "cascadic"),
                            ("10/20", "gauss-seidel")}
    scene = synthetic_room((128, 128), seed=0)
    known = stripes(scene.range.shape, 10, 20, axes="xy") & scene.has_truth
    partial = np.where(known, scene.range, np.nan)
    bp = refsynth.synthesize(scene.intensity, partial, method="bp",
                             readings={"observation": "colorization"}).range
    assert results[("10/20", "cascadic")]["bp"] == mar(bp, scene.range, known)
    assert "| 10/20 | 39.1 % | gauss-seidel |" in out.getvalue()


def test_np_steps_counts_every_step_and_leaves_the_fill_as_it_was(bench):
    """``--np-steps``: one count per synthesized pixel, kept within the candidates, and the
    shortlist put back afterwards (NP's result unchanged)."""
    import numpy as np

    import refsynth
    from refsynth.synthesis.filltable import FillTable

    init = FillTable.__init__
    out = io.StringIO()
    results = bench.np_steps([(32, 27)], out=out)
    assert FillTable.__init__ is init
    row = results[(32, 27)]
    assert row["unknown"] > 0 and row["steps"] == row["unknown"] and row["cpu"] > 0
    assert 1 <= row["kept"] <= row["candidates"] and 0 <= row["single"] <= 1
    assert row["many"] > 1 or row["single"] == 1
    image, partial, _ = bench._case((32, 27))
    assert int(np.isnan(partial).sum()) == row["unknown"]
    assert "| 32×27 |" in out.getvalue()
    assert np.isfinite(refsynth.synthesize(image, partial).range).all()


@pytest.mark.parametrize("observation", ["colorization", "np"])
def test_bp_stages_add_up_and_print_the_budget_of_six_times_the_colorization_fill(
        bench, observation):
    """``--bp-stages`` (``--observation np``: BP's default): six stages, none negative, the
    first named for its fill, and the budget line the arithmetic of the same numbers."""
    out = io.StringIO()
    results = bench.bp_stages([(32, 27)], out=out, observation=observation)
    row = results[(32, 27)]
    stages = list(row["stages"].values())
    assert len(stages) == 6 and all(t >= 0 for t in stages) and sum(stages) > 0
    assert row["colorization"] > 0
    assert (row["sweeps"] is None) == (observation == "np")
    own, fill = sum(stages[1:]), stages[0]
    text = out.getvalue()
    line = next(x for x in text.splitlines() if x.startswith("- 32×27: the colorization fill"))
    assert f"6× = {6 * row['colorization']:.3f} s" in line
    assert f"BP's own stages {own:.3f} s" in line
    assert f"leave {6 * row['colorization'] - own:.3f} s" in line
    assert f"took {fill:.3f} s" in line
    verdict = "within" if own + fill <= 6 * row["colorization"] else "over"
    assert line.endswith(f"{verdict} 6×")
    first = "NP's fill (the observations)" if observation == "np" else "observations' fill"
    assert f"| 32×27 | {first}" in text


def test_bp_targets_are_the_issues(bench):
    assert bench._bp_target((450, 375)) == 6.0 and bench._bp_target([900, 750]) == 5.0
    assert bench._bp_target((32, 27)) == 6.0


def test_bp_stages_refuse_an_unknown_observation(bench, capsys):
    with pytest.raises(ValueError, match="`observation` must be one of"):
        bench.bp_stages([(32, 27)], out=io.StringIO(), observation="nearest")
    with pytest.raises(SystemExit) as exit_:
        bench.main(["--observation", "np"])
    assert exit_.value.code == 2
    assert "--observation goes with --bp-stages" in capsys.readouterr().err
