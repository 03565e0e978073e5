"""``python -m refsynth figures``: every figure written, deterministically."""

import argparse
import io
from pathlib import Path

import numpy as np
import pytest

import refsynth
from refsynth.cli.figures import add_figures_parser
from refsynth.evaluation import aggregate
from refsynth.plotting.figures import (
    FIGURES,
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


def test_quick_run_writes_every_figure(tmp_path, capsys):
    assert _figures(["--out", str(tmp_path), "--quick"]) == 0
    out = capsys.readouterr().out
    for name in FIGURES:
        assert (tmp_path / name).stat().st_size > 5_000, name
        assert f"wrote {tmp_path / name}" in out


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

