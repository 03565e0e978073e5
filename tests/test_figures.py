"""``python -m refsynth figures``: every figure written, deterministically."""

import argparse
import io
from pathlib import Path

import numpy as np
import pytest

import refsynth
from refsynth.cli.figures import add_figures_parser
from refsynth.evaluation import aggregate
from refsynth.plotting import figures as figures_module
from refsynth.plotting.figures import (
    FIGURES,
    PIPELINE_FIGURES,
    confidence_figure,
    fill_order_image,
    mar_curve_figure,
    ordering_figure,
    scenes_figure,
)

REPO_FIGURES = Path(__file__).resolve().parents[1] / "figures"


def _png(fig) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=50)
    return buffer.getvalue()


def _figures(argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command", required=True)
    add_figures_parser(sub)
    args = parser.parse_args(["figures", *argv])
    return args.func(args)


def test_the_committed_figures_are_exactly_the_commands_files():
    """figures/ holds what `figures` writes, and nothing it does not write."""
    committed = sorted(p.name for p in REPO_FIGURES.glob("*.png"))
    assert committed == sorted(FIGURES)


def test_quick_run_writes_every_figure_but_the_main_demos(tmp_path, capsys):
    assert _figures(["--out", str(tmp_path), "--quick"]) == 0
    out = capsys.readouterr().out
    for name in FIGURES:
        if name in PIPELINE_FIGURES:  # the main demo's scans take a minute: not in --quick
            assert not (tmp_path / name).exists()
            continue
        assert (tmp_path / name).stat().st_size > 5_000, name
        assert f"wrote {tmp_path / name}" in out


def test_the_main_demos_figures_are_copied_from_its_run(tmp_path, monkeypatch):
    """figures/ takes model_view.png and the panorama's figures from `demo`'s own run."""
    calls = []

    def story(out, seed=0, progress=None):
        calls.append(seed)
        progress("position 1: scan", 0.0)
        progress("position 1: scan", 0.1)
        for name in (*PIPELINE_FIGURES, "room.ply", "story.json"):
            (out / name).write_bytes(name.encode())
        return {}

    monkeypatch.setattr(figures_module, "run_pipeline_demo", story)
    said = []
    written = figures_module._pipeline_figures(tmp_path, said.append)
    assert calls == [0] and said == ["  demo: position 1: scan"]
    assert [p.name for p in written] == list(PIPELINE_FIGURES)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(PIPELINE_FIGURES)
    assert (tmp_path / "model_view.png").read_bytes() == b"model_view.png"


def test_figures_rejects_a_file_as_the_output_folder(tmp_path):
    target = tmp_path / "file.png"
    target.write_bytes(b"")
    with pytest.raises(NotADirectoryError, match="--out must be a folder"):
        _figures(["--out", str(target), "--quick"])
    with pytest.raises(ValueError, match="--jobs must be at least 1"):
        _figures(["--out", str(tmp_path), "--jobs", "0"])


def test_fill_order_image_ranks_the_synthesized_pixels():
    order = np.array([[1, 1], [0, 1], [1, 0]])
    when = fill_order_image((2, 2), order)
    assert np.isnan(when[0, 0])
    assert (when[1, 1], when[0, 1], when[1, 0]) == (0.0, 0.5, 1.0)


def _tiny():
    rng = np.random.default_rng(0)
    image = rng.random((16, 16))
    truth = 1.0 + np.tile(np.arange(16.0), (16, 1)) / 8
    known = np.zeros((16, 16), dtype=bool)
    known[:, ::4] = True
    partial = np.where(known, truth, np.nan)
    return image, truth, partial


def test_figure_functions_are_deterministic():
    image, truth, partial = _tiny()
    np_result = refsynth.synthesize(image, partial, seed=0)
    bp_result = refsynth.synthesize(image, partial, method="bp", iterations=3)
    onion = refsynth.synthesize(image, partial, seed=0, ordering="onion")
    rows = [dict(scene="s", units="m", method=m, unknown_percent=u, mar=v, mar_sd=sd)
            for m, sd in (("np", 0.1), ("nearest", None)) for u, v in ((50.0, 1.0), (75.0, 2.0))]
    makers = [
        lambda: ordering_figure(truth, [("x", partial, {"priority": np_result, "onion": onion})]),
        lambda: scenes_figure([("x", truth, partial, {"NP": np_result.range,
                                                      "BP": bp_result.range})]),
        lambda: mar_curve_figure(rows),
        lambda: confidence_figure([("x", truth, partial, bp_result)], bins=4),
    ]
    for make in makers:
        assert _png(make()) == _png(make())


def test_mar_curve_accepts_aggregated_rows():
    runs = [dict(scene="s", scene_spec="s", size="8x8", units="m", sampling=f"x{u}",
                 unknown_percent=float(u), known=1, evaluated=1, method="np", seed=seed,
                 mar=u / 100 + seed, rmse=0.0, bad1=0.0, bad3=0.0, seconds=0.0)
            for u in (50, 78) for seed in (0, 1)]
    fig = mar_curve_figure(aggregate(runs), title="t")
    line = fig.axes[0].lines[0]
    np.testing.assert_allclose(np.asarray(line.get_ydata(), dtype=float), [1.0, 1.28])



def _bars(fig):
    return [im.colorbar.ax.get_ylabel() for ax in fig.axes for im in ax.images
            if im.colorbar is not None]


def test_the_figures_colour_bars_carry_units_and_measured_pixels_are_grey():
    image, truth, partial = _tiny()
    known = np.isfinite(partial)
    np_result = refsynth.synthesize(image, partial, seed=0)
    bp_result = refsynth.synthesize(image, partial, method="bp", iterations=3)
    fig = ordering_figure(truth, [("x", partial, {"priority": np_result})], units="m")
    assert _bars(fig) == ["fill order (0 first, 1 last)", "range (m)", "|residual| (m)"]
    for ax in (fig.axes[0], fig.axes[2]):  # fill order and residual: measured pixels grey
        overlay = ax.images[1].get_array()
        assert np.array_equal(overlay[..., 3] > 0, known)
        assert [t.get_text() for t in ax.get_legend().get_texts()] == ["measured"]
    fig = scenes_figure([("a", truth, partial, {"NP": np_result.range}),
                         ("b", truth, partial, {"NP": np_result.range})],
                        units="disparity (px)")
    assert _bars(fig) == ["disparity (px)"] * 2  # one per row
    fig = confidence_figure([("room", truth, partial, bp_result),
                             ("moto", truth, partial, bp_result)], bins=4,
                            units=["m", "disparity (px)"])
    assert _bars(fig) == ["range (m)", "|error| (m)", "confidence (0 to 1)",
                          "disparity (px)", "|error| (disparity px)",
                          "confidence (0 to 1)"]
    assert fig.axes[3].get_ylabel() == "MAR of the decile (m)"
    with pytest.raises(ValueError, match="`units`"):
        confidence_figure([("room", truth, partial, bp_result)], units=["m", "px"])
