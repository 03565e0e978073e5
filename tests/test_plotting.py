"""Figures: the paper's layout, returned as matplotlib Figures."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from refsynth.plotting.layouts import comparison_figure, methods_figure, result_figure


def _arrays():
    rng = np.random.default_rng(0)
    truth = rng.random((16, 16)) + 2
    partial = np.where(rng.random((16, 16)) < 0.4, truth, np.nan)
    return rng.random((16, 16)), rng.random((16, 16)) > 0.8, partial, truth


def test_result_figure_has_the_papers_six_panels():
    image, edges, partial, truth = _arrays()
    fig = result_figure(image, edges, partial, truth + 0.1, truth, units="m", title="t")
    assert isinstance(fig, Figure)
    titles = [ax.get_title() for ax in fig.axes]
    for needle in ("intensity", "Canny", "partial range", "synthesized", "ground truth",
                   "MAR 0.1 m"):
        assert any(needle in t for t in titles), titles


def test_result_figure_without_truth_has_four_panels_and_colour_input():
    image, edges, partial, truth = _arrays()
    fig = result_figure(np.stack([image] * 3, axis=2), edges, partial, truth)
    assert sum(1 for ax in fig.axes if ax.get_title()) == 4


def test_comparison_figure_reports_each_methods_mar():
    _, _, partial, truth = _arrays()
    fig = comparison_figure(truth, {"s": partial}, {("s", "exact"): truth, ("s", "off"): truth + 1})
    titles = [ax.get_title() for ax in fig.axes]
    assert "exact: MAR 0" in titles and "off: MAR 1" in titles


def test_methods_figure_has_result_residual_and_confidence_per_method():
    _, _, partial, truth = _arrays()
    conf = np.ones_like(truth)
    fig = methods_figure(truth, partial, {"NP": (truth, conf), "BP": (truth + 0.5, conf)},
                         units="m")
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles.count("confidence") == 2
    assert "|residual|, MAR 0 m" in titles and "|residual|, MAR 0.5 m" in titles


def test_result_figure_stacks_the_panels_of_a_panorama():
    rng = np.random.default_rng(1)
    truth = rng.random((20, 90)) + 2
    partial = np.where(rng.random((20, 90)) < 0.4, truth, np.nan)
    fig = result_figure(rng.random((20, 90)), rng.random((20, 90)) > 0.8, partial, truth, truth)
    boxes = [ax.get_position() for ax in fig.axes if ax.get_title()]
    assert len(boxes) == 6
    assert len({round(b.x0, 2) for b in boxes}) == 1  # one column


# ----------------------------------------------------------------------------- read at a glance

from matplotlib import colormaps  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from refsynth.plotting.layouts import (  # noqa: E402
    ERROR_CMAP,
    MEASURED_COLOUR,
    RANGE_CMAP,
    error_top,
    range_scale,
    unit_label,
)


def _drawn(fig):
    """The figure drawn on Agg (its layout done): the RGBA buffer, rows from the top."""
    FigureCanvasAgg(fig).draw()
    return np.asarray(fig.canvas.buffer_rgba())


def _rgba_at(fig, buffer, ax, row, col):
    """The drawn colour at the centre of image pixel (row, col) of ``ax``."""
    x, y = ax.transData.transform((col, row))
    return tuple(buffer[int(round(buffer.shape[0] - y)), int(round(x))])


def _colour_bars(fig):
    """{panel title: the label of the colour bar of its image} for every image with a bar."""
    return {ax.get_title(): im.colorbar.ax.get_ylabel()
            for ax in fig.axes for im in ax.images if im.colorbar is not None}


def _ramp_case():
    truth = 1.0 + np.add.outer(np.arange(8.0), np.arange(8.0)) / 10
    known = np.zeros((8, 8), dtype=bool)
    known[:, ::3] = True
    partial = np.where(known, truth, np.nan)
    return truth, known, partial


def test_measured_pixels_are_grey_labelled_and_in_no_colour_map():
    truth, known, partial = _ramp_case()
    result = np.where(known, truth, truth + 0.5)
    fig = result_figure(truth / 3, np.zeros((8, 8), bool), partial, result, truth, units="m")
    buffer = _drawn(fig)
    residual = fig.axes[5]
    assert residual.get_title().startswith("|residual|")
    grey = tuple(round(255 * c) for c in MEASURED_COLOUR) + (255,)
    assert _rgba_at(fig, buffer, residual, 2, 0) == grey  # column 0 is measured
    assert _rgba_at(fig, buffer, residual, 2, 1) != grey  # column 1 is synthesized
    assert [t.get_text() for t in residual.get_legend().get_texts()] == ["measured"]
    for name in (ERROR_CMAP, RANGE_CMAP, "turbo"):
        colours = colormaps[name](np.linspace(0, 1, 256))[:, :3]
        assert np.abs(colours - MEASURED_COLOUR).max(axis=1).min() > 0.2, name


def test_every_colour_bar_names_its_unit():
    truth, known, partial = _ramp_case()
    result = np.where(known, truth, truth + 0.5)
    image = truth / 3
    bars = _colour_bars(result_figure(image, known, partial, result, truth, units="m"))
    assert bars == {"synthesized range": "range (m)",
                    "|residual|, MAR 0.5 m": "|residual| (m)"}
    bars = _colour_bars(result_figure(image, known, partial, result, truth,
                                      units="disparity (px)"))
    assert set(bars.values()) == {"disparity (px)", "|residual| (disparity px)"}
    assert _colour_bars(result_figure(image, known, partial, result)) == {
        "synthesized range": "range (range units)"}  # synth --figure of a unit it does not know
    conf = np.full((8, 8), 0.5)
    bars = _colour_bars(methods_figure(truth, partial, {"NP": (result, conf)}, units="m"))
    assert sorted(bars.values()) == ["confidence (0 to 1)", "range (m)", "|residual| (m)"]
    bars = _colour_bars(comparison_figure(truth, {"s": partial}, {("s", "NP"): result},
                                          units="m"))
    assert list(bars.values()) == ["range (m)"]


def test_the_figures_have_their_panels_and_colour_bars():
    truth, known, partial = _ramp_case()
    conf = np.ones((8, 8))
    assert len(result_figure(truth, known, partial, truth, truth).axes) == 6 + 2
    assert len(result_figure(truth, known, partial, truth).axes) == 4 + 1
    methods = {"NP": (truth, conf), "BP": (truth, conf)}
    assert len(methods_figure(truth, partial, methods).axes) == 2 * 3 + 2 * 3
    results = {("s", "NP"): truth, ("s", "BP"): truth}
    assert len(comparison_figure(truth, {"s": partial, "t": partial}, results).axes) == 2 * 4 + 1


def test_one_outlier_does_not_stretch_the_colour_bars():
    truth = 1.0 + np.add.outer(np.arange(40.0), np.arange(40.0)) / 40
    known = np.zeros((40, 40), dtype=bool)
    known[:, ::4] = True
    partial = np.where(known, truth, np.nan)
    result = np.where(known, truth, truth + 0.1)
    result[20, 21] = 500.0  # one wild pixel
    fig = result_figure(truth, known, partial, result, truth, units="m")
    synthesized, residual = fig.axes[3].images[0], fig.axes[5].images[0]
    assert synthesized.norm.vmax < 3.5 and synthesized.colorbar.extend in ("max", "both")
    assert residual.norm.vmax == pytest.approx(0.1) and residual.colorbar.extend == "max"
    # without the outlier nothing is clipped, and the bars end square
    result[20, 21] = truth[20, 21] + 0.1
    fig = result_figure(truth, known, partial, result, truth, units="m")
    assert fig.axes[5].images[0].colorbar.extend == "neither"
    assert error_top(np.array([np.nan])) == 1.0
    assert range_scale(np.append(np.ones(999), 1e6))["vmax"] == 1.0
    assert unit_label("|residual|", "") == "|residual| (range units)"


@pytest.mark.parametrize("shape", [(20, 90), (12, 12)])
def test_panels_with_and_without_colour_bars_are_aligned(shape):
    """Every image panel of a column has the same left edge and width (constrained layout)."""
    rng = np.random.default_rng(2)
    truth = rng.random(shape) + 2
    partial = np.where(rng.random(shape) < 0.4, truth, np.nan)
    fig = result_figure(rng.random(shape), rng.random(shape) > 0.8, partial, truth + 0.1, truth)
    _drawn(fig)
    columns = {}
    for ax in fig.axes:
        if ax.get_title():
            box = ax.get_position()
            columns.setdefault(round(box.x0 + box.width / 2, 1), []).append(box)
    assert sum(len(boxes) for boxes in columns.values()) == 6
    for boxes in columns.values():
        assert max(b.width for b in boxes) - min(b.width for b in boxes) < 1e-3
        assert max(b.x0 for b in boxes) - min(b.x0 for b in boxes) < 1e-3


def test_pixels_without_truth_are_named_beside_the_measured_ones():
    truth, known, partial = _ramp_case()
    result = np.where(known, truth, truth + 0.5)
    fig = result_figure(truth, known, partial, result, truth, units="m")
    assert [t.get_text() for t in fig.axes[5].get_legend().get_texts()] == ["measured"]
    truth = truth.copy()
    truth[4, 4] = np.nan  # an occlusion: no ground truth there
    fig = result_figure(truth, known, partial, result, truth, units="m")
    labels = [t.get_text() for t in fig.axes[5].get_legend().get_texts()]
    assert labels == ["measured", "white: no truth"]
