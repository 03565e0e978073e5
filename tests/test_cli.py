"""The command line: ``python -m refsynth demo | synth``; errors exit 2 with one line."""

import subprocess
import sys

import numpy as np
import pytest

from refsynth.cli.main import main
from refsynth.evaluation.baselines import BASELINES
from refsynth.io import write_pfm
from refsynth.plotting.demo import DEMO_METHODS
from refsynth.synthesis.readings import Readings


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


@pytest.mark.parametrize("method", ["np", "bp"])
def test_synth_range_copy_reaches_both_methods(files, method):
    import refsynth

    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    for copy in ("value", "offset"):
        out = files / f"{method}-{copy}.npy"
        assert main(["synth", str(files / "image.npy"), str(files / "partial.npy"), "--out",
                     str(out), "--method", method, "--range-copy", copy]) == 0
        want = refsynth.synthesize(image, partial, method=method,
                                   readings={"range_copy": copy}).range
        np.testing.assert_array_equal(np.load(out), want)


def test_synth_is_deterministic(files):
    a, b = files / "a.npy", files / "b.npy"
    for out in (a, b):
        main(["synth", str(files / "image.npy"), str(files / "partial.npy"), "--out", str(out)])
    np.testing.assert_array_equal(np.load(a), np.load(b))


@pytest.mark.slow  # python -m refsynth in a subprocess
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


@pytest.mark.slow  # python -m refsynth in a subprocess
def test_unknown_command_exits_2():
    proc = subprocess.run([sys.executable, "-m", "refsynth", "frobnicate"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2


# ----------------------------------------------------------------------------- the front door


def _run(argv, capsys):
    """``main(argv)`` in-process: (status, stdout, stderr lines)."""
    status = main(argv)
    captured = capsys.readouterr()
    return status, captured.out, captured.err.strip().splitlines()


def _fails_with(argv, capsys, needle):
    status, _, err = _run(argv, capsys)
    assert status == 2 and len(err) == 1 and needle in err[0], err
    assert "Traceback" not in err[0]
    return err[0]


@pytest.fixture
def no_work(monkeypatch):
    """Make any synthesis or evaluation grid fail the test: the checks must come first."""
    def forbidden(*args, **kwargs):
        raise AssertionError("the work started before the checks failed")

    monkeypatch.setattr("refsynth.cli.synth.synthesize", forbidden)
    monkeypatch.setattr("refsynth.cli.evaluate.run_cases", forbidden)
    monkeypatch.setattr("refsynth.cli.figures.make_figures", forbidden)
    monkeypatch.setattr("refsynth.cli.demo.run_demo", forbidden)


@pytest.fixture
def png_files(files):
    """An 8-bit image and 16-bit and 8-bit PNG ranges (0 = unknown) beside ``files``."""
    from PIL import Image

    image = (np.load(files / "image.npy") * 255).astype(np.uint8)
    Image.fromarray(image).save(files / "image.png")
    known = (np.arange(24) % 4 == 0)[None, :].repeat(20, 0)
    values = 1000 + 7 * np.arange(20)[:, None] + np.arange(24)[None, :]
    Image.fromarray(np.where(known, values, 0).astype(np.uint16)).save(files / "range16.png")
    Image.fromarray(np.where(known, 100 + np.arange(24)[None, :], 0).astype(np.uint8)).save(
        files / "range8.png")
    return files


@pytest.mark.parametrize("name", ["range16.png", "range8.png"])
def test_synth_reads_a_png_range_as_its_integers_and_keeps_the_unit(png_files, capsys, name):
    """A PNG range is read as its integers: never divided by 65535 (16-bit) or 255 (8-bit)."""
    from refsynth.io import read_array

    stored = read_array(png_files / name, raw=True).astype(np.float64)
    known = stored > 0
    for out in ("dense.npy", "dense.pfm", "dense.png"):
        status, printed, _ = _run(["synth", str(png_files / "image.png"), str(png_files / name),
                                   "--out", str(png_files / out)], capsys)
        assert status == 0 and f"wrote {png_files / out}:" in printed
        dense = read_array(png_files / out, raw=True).astype(np.float64)
        np.testing.assert_array_equal(dense[known], stored[known])
        assert stored[known].min() <= dense.min() and dense.max() <= stored[known].max()


def test_synth_png_scale_divides_on_input_and_multiplies_on_output(png_files, capsys):
    from refsynth.io import read_array

    stored = read_array(png_files / "range16.png", raw=True).astype(np.float64)
    known = stored > 0
    args = ["synth", str(png_files / "image.png"), str(png_files / "range16.png"),
            "--png-scale", "1000"]
    assert _run([*args, "--out", str(png_files / "metres.npy")], capsys)[0] == 0
    np.testing.assert_allclose(np.load(png_files / "metres.npy")[known], stored[known] / 1000)
    assert _run([*args, "--out", str(png_files / "again.png")], capsys)[0] == 0
    again = read_array(png_files / "again.png", raw=True).astype(np.float64)
    np.testing.assert_array_equal(again[known], stored[known])


@pytest.mark.parametrize("name", ["dense.pfm", "dense.PFM", "dense.png", "sub/dir/dense.npy"])
def test_synth_out_writes_the_format_its_suffix_names(files, capsys, name):
    """``--out x.pfm`` writes x.pfm (not x.pfm.npy) and prints what it wrote."""
    from refsynth.io import read_array

    out = files / name
    status, printed, _ = _run(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                               "--out", str(out), "--png-scale", "100"]
                              if name.endswith("png") else
                              ["synth", str(files / "image.npy"), str(files / "partial.npy"),
                               "--out", str(out)], capsys)
    assert status == 0 and printed.startswith(f"wrote {out}:")
    assert sorted(p.name for p in out.parent.iterdir() if p.name.startswith("dense")) == [
        out.name]
    dense = read_array(out, raw=True)
    if name.endswith("png"):
        dense = dense / 100.0
    partial = np.load(files / "partial.npy")
    known = np.isfinite(partial)
    np.testing.assert_allclose(dense[known], partial[known], rtol=1e-6)


@pytest.mark.parametrize(("option", "value", "needle"), [
    ("--out", "dense.tif", "--out must end in .npy, .pfm, .png"),
    ("--out", "dense", "--out must end in"),
    ("--out", "", "--out must name a file"),
    ("--out", "partial.npy/x.npy", "is not a folder"),
    ("--confidence", "c.txt", "--confidence must end in"),
    ("--figure", "fig.txt", "--figure must end in"),
    ("--figure", "partial.npy/fig.png", "is not a folder"),
    ("--confidence", "o.npy", "name the same file"),
])
def test_synth_bad_output_paths_fail_before_the_work(files, capsys, no_work, monkeypatch,
                                                      option, value, needle):
    monkeypatch.chdir(files)
    argv = ["synth", "image.npy", "partial.npy", "--out", "o.npy", option, value]
    _fails_with(argv, capsys, needle)
    assert not (files / "o.npy").exists() and not (files / "dense").exists()


def test_synth_writes_the_confidence_map(files, capsys):
    from refsynth.io import read_array

    for name in ("conf.npy", "conf.png"):
        status, printed, _ = _run(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                                   "--out", str(files / "o.npy"), "--confidence",
                                   str(files / name)], capsys)
        assert status == 0 and f"wrote {files / name}" in printed
        confidence = read_array(files / name)
        known = np.isfinite(np.load(files / "partial.npy"))
        assert np.all(confidence[known] == 1.0)
        assert np.all((confidence >= 0) & (confidence <= 1)) and confidence[~known].max() < 1


def test_synth_exposes_bp_and_its_options(files, capsys, monkeypatch):
    seen = {}
    real = __import__("refsynth.cli.synth", fromlist=["synthesize"]).synthesize

    def spy(*args, **kwargs):
        seen.update(kwargs, **kwargs["readings"].as_dict())   # the readings, flat
        return real(*args, **kwargs)

    monkeypatch.setattr("refsynth.cli.synth.synthesize", spy)
    argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"),
            "--out", str(files / "bp.npy"), "--method", "bp", "--candidates", "4",
            "--proximity", "0.5", "--sigma-i", "0.2", "--sigma-s", "0.3", "--iterations", "7"]
    assert _run(argv, capsys)[0] == 0
    assert (seen["method"], seen["candidates"], seen["proximity"], seen["sigma_i"],
            seen["sigma_s"], seen["iterations"]) == ("bp", 4, 0.5, 0.2, 0.3, 7)
    assert seen["epsilon"] is None and seen["ordering"] is None  # NP's options left unset
    assert np.all(np.isfinite(np.load(files / "bp.npy")))


@pytest.mark.parametrize("method", ["np", "bp"])
def test_synth_passes_eq2s_readings_on_only_when_given(files, capsys, monkeypatch, method):
    seen = []
    real = __import__("refsynth.cli.synth", fromlist=["synthesize"]).synthesize

    def spy(*args, **kwargs):
        seen.append(kwargs["readings"])
        return real(*args, **kwargs)

    monkeypatch.setattr("refsynth.cli.synth.synthesize", spy)
    base = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--method", method]
    assert _run([*base, "--out", str(files / "a.npy")], capsys)[0] == 0
    assert seen[0] == Readings.refsynth()     # no flag: the default preset, unchanged
    assert _run([*base, "--out", str(files / "b.npy"), "--channels", "mean", "--range-weight",
                 "0.5", "--missing-range", "ignore", "--grey"], capsys)[0] == 0
    assert seen[1] == Readings.refsynth().replace(channels="mean", range_weight=0.5,
                                                  missing_range="ignore", colour=False)
    # the same call through the library gives the same bits
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    direct = real(image, partial, method=method, seed=0,
                  readings={"channels": "mean", "range_weight": 0.5, "missing_range": "ignore",
                            "colour": False}).range
    np.testing.assert_array_equal(np.load(files / "b.npy"), direct)


def test_synth_bp_with_proposals_is_the_librarys(files, capsys):
    argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--method", "bp",
            "--proposals", "np", "--proposal-runs", "2", "--seed", "3",
            "--out", str(files / "p.npy")]
    assert _run(argv, capsys)[0] == 0
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    direct = __import__("refsynth").synthesize(
        image, partial, method="bp", seed=3, readings={"proposals": "np", "proposal_runs": 2}).range
    np.testing.assert_array_equal(np.load(files / "p.npy"), direct)


def test_synth_bp_with_the_observation_departures_is_the_librarys(files, capsys):
    argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--method", "bp",
            "--observation", "colorization", "--training-radius", "gap",
            "--compatibility", "overlap-centres", "--out", str(files / "d.npy")]
    assert _run(argv, capsys)[0] == 0
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    options = dict(observation="colorization", training_radius="gap",
                   compatibility="overlap-centres")
    library = __import__("refsynth").synthesize
    direct = library(image, partial, method="bp", seed=0, readings=options).range
    np.testing.assert_array_equal(np.load(files / "d.npy"), direct)
    # the flags reach the fill: without them BP is Fig. 6's, another result here
    assert not np.array_equal(direct, library(image, partial, method="bp", seed=0).range)


def test_synth_bp_on_nps_fill_is_the_librarys_and_follows_the_seed(files, capsys):
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    library = __import__("refsynth").synthesize
    for seed in ("0", "4"):
        argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--method", "bp",
                "--observation", "np", "--seed", seed, "--out", str(files / f"n{seed}.npy")]
        assert _run(argv, capsys)[0] == 0
        direct = library(image, partial, method="bp", readings={"observation": "np"},
                         seed=int(seed)).range
        np.testing.assert_array_equal(np.load(files / f"n{seed}.npy"), direct)


def test_synth_bp_offset_tolerance_is_the_librarys(files, capsys):
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--method", "bp",
            "--offset-tolerance", "0.5", "--out", str(files / "t.npy")]
    assert _run(argv, capsys)[0] == 0
    direct = __import__("refsynth").synthesize(image, partial, method="bp",
                                               readings={"offset_tolerance": 0.5}).range
    np.testing.assert_array_equal(np.load(files / "t.npy"), direct)


def test_synth_refuses_a_bad_reading_in_one_line(files, capsys, no_work):
    _fails_with(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(files / "o.npy"), "--channels", "max"], capsys,
                "argument --channels: invalid choice: 'max'")


@pytest.mark.parametrize("method", ["np", "bp"])
def test_synth_readings_paper_is_the_librarys_paper_preset(files, capsys, method):
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    library = __import__("refsynth").synthesize
    argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--method", method,
            "--readings", "paper", "--out", str(files / "paper.npy")]
    assert _run(argv, capsys)[0] == 0
    paper = library(image, partial, method=method, seed=0, readings="paper").range
    np.testing.assert_array_equal(np.load(files / "paper.npy"), paper)
    # the preset reaches the fill: the default preset gives another range here
    assert not np.array_equal(paper, library(image, partial, method=method, seed=0).range)


def test_synth_a_flag_overrides_one_reading_of_the_preset(files, capsys):
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--readings",
            "paper", "--range-copy", "offset", "--out", str(files / "o.npy")]
    assert _run(argv, capsys)[0] == 0
    readings = Readings.paper().replace(range_copy="offset")
    direct = __import__("refsynth").synthesize(image, partial, readings=readings).range
    np.testing.assert_array_equal(np.load(files / "o.npy"), direct)


def test_synth_median_is_the_librarys_reading(files, capsys):
    image, partial = np.load(files / "image.npy"), np.load(files / "partial.npy")
    library = __import__("refsynth").synthesize
    for size in (0, 5):
        argv = ["synth", str(files / "image.npy"), str(files / "partial.npy"), "--median",
                str(size), "--out", str(files / f"m{size}.npy")]
        assert _run(argv, capsys)[0] == 0
        direct = library(image, partial, readings={"median": size}).range
        np.testing.assert_array_equal(np.load(files / f"m{size}.npy"), direct)


def test_synth_window_is_the_librarys_reading(tmp_path, capsys):
    g = np.random.default_rng(1)
    image = g.random((12, 20))
    partial = np.where(np.arange(20) % 3 == 0, 2.0 + g.random((12, 20)), np.nan)  # gaps of 2
    np.save(tmp_path / "image.npy", image)
    np.save(tmp_path / "partial.npy", partial)
    library = __import__("refsynth").synthesize
    for flags, side in (([], 3), (["--window", "fixed"], 5), (["--neighbourhood", "5"], 5)):
        out = tmp_path / f"w{len(flags)}{side}.npy"
        argv = ["synth", str(tmp_path / "image.npy"), str(tmp_path / "partial.npy"), *flags,
                "--out", str(out)]
        assert _run(argv, capsys)[0] == 0
        np.testing.assert_array_equal(np.load(out), library(image, partial,
                                                            neighbourhood=side).range)
    assert not np.array_equal(np.load(tmp_path / "w03.npy"), np.load(tmp_path / "w25.npy"))


@pytest.mark.parametrize(("value", "needle"), [
    ("4", "`median` must be 0 or an odd number from 3 to 15, got 4"),
    ("three", "argument --median: invalid integer 'three'")])
def test_synth_refuses_a_bad_median_in_one_line(files, capsys, no_work, value, needle):
    _fails_with(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(files / "o.npy"), "--median", value], capsys, needle)


def test_synth_refuses_an_unknown_preset_in_one_line(files, capsys, no_work):
    _fails_with(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(files / "o.npy"), "--readings", "printed"], capsys,
                "argument --readings: invalid choice: 'printed'")


def test_synth_help_names_no_version_and_points_to_the_departures():
    import re

    text = _subcommands()["synth"].format_help()
    assert "departures page" in text and "--readings" in text
    history = r"refsynth \d|\b0\.\d+-0\.\d+|\b0\.\d+(\.\d+)?'s\b|\bsince 0\.|README"
    assert not re.search(history, text), re.search(history, text)


@pytest.mark.parametrize(("extra", "needle"), [
    (["--method", "bp", "--epsilon", "0.2"], "--epsilon applies to --method np only"),
    (["--method", "bp", "--ordering", "onion"], "--ordering applies to --method np only"),
    (["--method", "bp", "--no-isophotes"], "--no-isophotes applies to --method np only"),
    (["--candidates", "4"], "--candidates applies to --method bp only"),
    (["--proposals", "np"], "--proposals applies to --method bp only"),
    (["--method", "bp", "--proposal-runs", "2"], "--proposal-runs needs --proposals"),
    (["--method", "bp", "--proposals", "np", "--proposal-runs", "0"],
     "--proposal-runs must be >= 1, got 0"),
    (["--iterations", "3"], "--iterations applies to --method bp only"),
    (["--observation", "colorization"], "--observation applies to --method bp only"),
    (["--training-radius", "gap"], "--training-radius applies to --method bp only"),
    (["--compatibility", "overlap-centres"], "--compatibility applies to --method bp only"),
    (["--offset-tolerance", "0.125"], "--offset-tolerance applies to --method bp only"),
])
def test_synth_refuses_an_option_of_the_other_method(files, capsys, no_work, extra, needle):
    _fails_with(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(files / "o.npy"), *extra], capsys, needle)


@pytest.mark.parametrize(("extra", "needle"), [
    (["--radius", "1e4"], "--radius 10000 is larger than the 24x20 image needs"),
    (["--neighbourhood", "101"], "--neighbourhood 101 is larger than the 24x20 image needs"),
    (["--radius", "inf"], "argument --radius: invalid number 'inf'"),
    (["--seed", "-1"], "--seed must be >= 0"),
    (["--seed", "٣"], "argument --seed: invalid integer"),
    (["--png-scale", "10"], "--png-scale applies to an image RANGE or a .png --out only"),
    (["--method", "bp", "--offset-tolerance", "0.1"],
     "--offset-tolerance must be a power of two from 2**-16 to 1 (e.g. 0.125), got 0.1"),
])
def test_synth_refuses_values_beyond_use_before_the_work(files, capsys, no_work, extra, needle):
    """Unchecked, radius=1e4 on a small image would try to allocate 149 GiB."""
    _fails_with(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(files / "o.npy"), *extra], capsys, needle)


def test_synth_radius_up_to_the_image_diagonal_is_accepted(tmp_path, capsys):
    """The largest --radius and --neighbourhood an image can use run; one more is refused.

    A 9x12 image (the bound's arithmetic is the same at any size; the fill's cost is not):
    ceil(hypot(11, 8)) = 14 reaches every pixel, 2 * 12 - 1 = 23 covers the image.
    """
    rng = np.random.default_rng(0)
    np.save(tmp_path / "image.npy", rng.random((12, 9)))
    np.save(tmp_path / "partial.npy", np.where(np.arange(9) % 4 == 0, 2.0 + rng.random((12, 9)),
                                               np.nan))
    base = ["synth", str(tmp_path / "image.npy"), str(tmp_path / "partial.npy"),
            "--out", str(tmp_path / "o.npy")]
    assert _run([*base, "--radius", "14", "--neighbourhood", "23"], capsys)[0] == 0
    assert np.all(np.isfinite(np.load(tmp_path / "o.npy")))
    _fails_with([*base, "--radius", "15"], capsys,
                "--radius 15 is larger than the 9x12 image needs: 14 already reaches")
    _fails_with([*base, "--neighbourhood", "25"], capsys,
                "--neighbourhood 25 is larger than the 9x12 image needs: 23 already covers")


def test_synth_refuses_a_complex_range(files, capsys, no_work):
    """A complex .npy range is refused (unchecked, it passes with only a ComplexWarning)."""
    np.save(files / "complex.npy", np.load(files / "partial.npy") + 0j)
    _fails_with(["synth", str(files / "image.npy"), str(files / "complex.npy"),
                 "--out", str(files / "o.npy")], capsys, "must hold real numbers")


def test_synth_png_out_needs_whole_numbers_or_a_scale(files, capsys, no_work):
    np.save(files / "metres.npy", np.load(files / "partial.npy") + 0.25)
    base = ["synth", str(files / "image.npy"), str(files / "metres.npy"),
            "--out", str(files / "o.png")]
    _fails_with(base, capsys, "give --png-scale")
    _fails_with([*base, "--png-scale", "1e5"], capsys, "outside a 16-bit PNG's 1..65535")


@pytest.mark.slow  # python -m refsynth in a subprocess
def test_version_and_help(capsys):
    import refsynth

    status, out, _ = _run(["--version"], capsys)
    assert status == 0 and out.strip() == f"refsynth {refsynth.__version__}"
    proc = subprocess.run([sys.executable, "-m", "refsynth", "--version"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.strip() == f"refsynth {refsynth.__version__}"


def _subcommands():
    import argparse

    from refsynth.cli.main import build_parser

    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def _help_entries(parser) -> dict[str, str]:
    """Each option's entry in ``--help``, by its first option string, whitespace collapsed."""
    import re

    entries: dict[str, str] = {}
    current = None
    for line in parser.format_help().splitlines():
        match = re.match(r"^  (-[-\w]+)", line)
        if match:
            current = match.group(1)
            entries[current] = line
        elif current and line.startswith("   "):
            entries[current] += " " + line
        else:
            current = None
    return {key: " ".join(text.split()) for key, text in entries.items()}


@pytest.mark.parametrize("command", ["demo", "synth", "evaluate", "figures", "scan",
                                     "register", "model", "notebooks"])
def test_every_option_says_what_it_means_and_its_default(command):
    """--help shows each option's meaning and default."""
    parser = _subcommands()[command]
    entries = _help_entries(parser)
    for action in parser._actions:
        if not action.option_strings or action.dest == "help":
            continue
        entry = entries[action.option_strings[0]]
        words = entry.split()
        assert action.help and len(words) > 2, f"{command}: {entry!r} says nothing"
        if action.default not in (None, False):
            assert "default" in entry.lower(), f"{command}: {entry!r} gives no default"


@pytest.mark.parametrize("argv", [
    [], ["frobnicate"], ["synth"], ["synth", "a", "b"], ["synth", "--radius", "x"],
    ["evaluate", "--jobs", "two"], ["demo", "--size"], ["figures", "--bogus"],
    ["evaluate", "--grid", "huge"],
])
def test_usage_errors_are_one_line_and_exit_2(capsys, argv):
    """One line: no argparse usage block before the error."""
    status, out, err = _run(argv, capsys)
    assert status == 2 and out == "" and len(err) == 1, err
    assert err[0].startswith("python -m refsynth") and ": error: " in err[0]


@pytest.mark.slow  # python -m refsynth in a subprocess
def test_usage_errors_from_the_module_entry_point_are_one_line():
    proc = subprocess.run([sys.executable, "-m", "refsynth", "synth", "--radius", "x"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith(
        "python -m refsynth synth: error: ")


def test_a_memory_error_is_one_line(files, capsys, monkeypatch):
    def exhausted(*args, **kwargs):
        raise MemoryError("Unable to allocate 149. GiB for an array")

    monkeypatch.setattr("refsynth.cli.synth.synthesize", exhausted)
    _fails_with(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                 "--out", str(files / "o.npy")], capsys, "not enough memory: Unable to allocate")


# ----------------------------------------------------------------------------- progress


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class _Stream:
    def __init__(self, tty):
        self.tty, self.text = tty, ""

    def isatty(self):
        return self.tty

    def write(self, text):
        self.text += text

    def flush(self):
        pass


def test_progress_writes_a_line_every_few_seconds_with_the_time_left_when_not_a_tty():
    """Progress goes to stderr when it is not a terminal too, one line every few seconds."""
    from refsynth.cli.synth import LOG_INTERVAL, pixel_progress

    clock, stream = _Clock(), _Stream(tty=False)
    report = pixel_progress("synthesizing", stream=stream, clock=clock)
    for done in range(10, 1001, 10):
        clock.now += 0.25
        report(done, 1000)
    report(1000, 1000)  # reported twice at the end: one line only
    lines = stream.text.splitlines()
    assert LOG_INTERVAL == 5.0 and len(lines) == 5  # at 5, 10, 15, 20 s, and the end
    assert lines[0] == "synthesizing:  20 % (200/1000), 0:05 elapsed, ~0:20 left"
    assert lines[-1] == "synthesizing: 100 % (1000/1000), 0:25 elapsed"
    assert "\r" not in stream.text


def test_progress_is_silent_for_a_short_run_when_not_a_tty():
    from refsynth.cli.synth import pixel_progress

    clock, stream = _Clock(), _Stream(tty=False)
    report = pixel_progress("synthesizing", stream=stream, clock=clock)
    for done in (1, 2, 3):
        clock.now += 0.5
        report(done, 3)
    assert stream.text == ""


def test_progress_updates_one_line_in_place_on_a_tty():
    from refsynth.cli.synth import pixel_progress

    clock, stream = _Clock(), _Stream(tty=True)
    report = pixel_progress("bp", stream=stream, clock=clock)
    for done in range(1, 6):
        clock.now += 1.0
        report(done, 5)
    assert stream.text.count("\r") == 5 and stream.text.endswith("\n")
    assert stream.text.count("\n") == 1 and "~0:04 left" in stream.text


def test_synth_reports_progress_on_stderr_when_it_is_not_a_terminal(files, capsys, monkeypatch):
    monkeypatch.setattr("refsynth.cli.synth.LOG_INTERVAL", 0.0)
    status, _, err = _run(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                           "--out", str(files / "o.npy")], capsys)
    assert status == 0 and err and all(line.startswith("synthesizing: ") for line in err)
    assert err[-1].startswith("synthesizing: 100 % (360/360)")


def test_synth_bp_reports_pixels_worth_of_its_work_with_a_rate(files, capsys, monkeypatch):
    """BP reports within its stages, with a rate, not only at its five stages' ends."""
    monkeypatch.setattr("refsynth.cli.synth.LOG_INTERVAL", 0.0)
    status, _, err = _run(["synth", str(files / "image.npy"), str(files / "partial.npy"),
                           "--method", "bp", "--out", str(files / "o.npy")], capsys)
    assert status == 0 and len(err) > 5 and all(line.startswith("synthesizing: ") for line in err)
    assert all(" px/s" in line for line in err) and any("left" in line for line in err)
    assert err[-1].startswith("synthesizing: 100 % (360/360)")


# ----------------------------------------------------------------------------- demo, figures


def test_demo_refuses_an_output_file_and_absurd_sizes_before_the_work(files, capsys, no_work):
    _fails_with(["demo", "--out", str(files / "image.npy")], capsys, "--out must be a folder")
    _fails_with(["demo", "--size", "100000", "--out", str(files / "d")], capsys,
                "would need about")


def test_figures_without_scikit_image_says_what_to_install_before_the_work(
        files, capsys, no_work, monkeypatch):
    """Without scikit-image ``figures`` fails before the work, not half-way."""
    monkeypatch.setitem(sys.modules, "skimage", None)
    line = _fails_with(["figures", "--out", str(files / "figs")], capsys, "needs scikit-image")
    assert 'pip install "refsynth[data]"' in line and 'pip install -e ".[data]"' in line
    assert not (files / "figs").exists()


def test_evaluate_motorcycle_without_scikit_image_fails_before_the_work(capsys, no_work,
                                                                       monkeypatch):
    monkeypatch.setitem(sys.modules, "skimage", None)
    line = _fails_with(["evaluate", "--scene", "motorcycle", "--size", "32", "--sampling", "x78",
                        "--methods", "nearest"], capsys, "the Motorcycle scene")
    assert "refsynth[data]" in line
