"""Figures: the paper's layout, returned as matplotlib Figures."""

import numpy as np
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
