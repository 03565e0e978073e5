"""The rendered view of a stage 3 model (refsynth.plotting.model_view), on the Agg backend."""

import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from refsynth.model import CylindricalCamera, build_model
from refsynth.plotting.model_view import (
    draw_model,
    model_view_figure,
    oblique_eye,
    view_coordinates,
)


@pytest.fixture(scope="module")
def model():
    shape = (20, 126)
    r = np.full(shape, 4.0)
    r[8:14, 20:40] = 2.0
    confidence = np.where(np.arange(shape[1]) % 3 == 0, 1.0, 0.5)[None].repeat(shape[0], 0)
    return build_model(r, CylindricalCamera.panorama(20.0, shape),
                       intensity=np.linspace(0, 1, r.size).reshape(shape),
                       confidence=confidence)


def test_the_view_is_not_mirrored():
    u, v, depth = view_coordinates(np.array([[1.0, 0.0, 5.0], [0.0, 1.0, 5.0]]),
                                   eye=[0.0, 0.0, 0.0], target=[0.0, 0.0, 1.0])
    assert u[0] > 0 and v[1] > 0 and np.all(depth == 5.0)  # +x right, +y up


def test_oblique_eye_is_above_and_behind(model):
    eye, target = oblique_eye(model.vertices)
    assert eye[1] > target[1] and eye[2] < target[2]


def test_draw_model_paints_every_visible_triangle(model):
    fig = Figure()
    ax = fig.subplots()
    collection = draw_model(ax, model, colour="confidence")
    assert isinstance(collection, PolyCollection)
    assert len(collection.get_paths()) == model.n_faces
    clipped = draw_model(fig.subplots(), model, clip_above=0.0)
    assert 0 < len(clipped.get_paths()) < model.n_faces


@pytest.mark.parametrize("colours", [("intensity", "confidence"), ("synthesized",)])
def test_model_view_figure_has_one_panel_per_colouring(model, colours, tmp_path):
    fig = model_view_figure(model, colours=colours, title="a room")
    assert isinstance(fig, Figure)
    panels = [ax for ax in fig.axes
              if any(isinstance(c, PolyCollection) and len(c.get_paths()) == model.n_faces
                     for c in ax.collections)]
    assert len(panels) == len(colours)
    fig.savefig(tmp_path / "view.png", dpi=50)
    assert (tmp_path / "view.png").stat().st_size > 1000


def test_draw_model_checks_its_inputs(model):
    ax = Figure().subplots()
    with pytest.raises(ValueError, match="`colour`"):
        draw_model(ax, model, colour="depth")
    with pytest.raises(TypeError, match="`model`"):
        draw_model(ax, "model")
    with pytest.raises(ValueError, match="no triangles"):
        draw_model(ax, model, clip_above=-100.0)
    with pytest.raises(ValueError, match="`colours`"):
        model_view_figure(model, colours=())


def test_the_view_marks_the_scan_positions_and_says_what_a_blank_is(model):
    eye, target = oblique_eye(model.vertices)
    fig = model_view_figure(model, colours=("intensity", "confidence"), eye=eye, target=target,
                            markers={"scan 1": (0.0, 0.0, 0.0), "behind": tuple(2 * eye - target)},
                            note="Blank: not seen")
    for ax in fig.axes[:2]:
        assert [t.get_text() for t in ax.texts] == ["scan 1"]  # a point behind the eye is left out
        (line,) = ax.lines
        u, v, _ = view_coordinates(np.zeros((1, 3)), eye, target)
        assert (line.get_xdata()[0], line.get_ydata()[0]) == pytest.approx((u[0], v[0]))
    assert fig.get_supxlabel() == "Blank: not seen"
    bar_labels = [ax.get_ylabel() for ax in fig.axes[2:]]
    assert bar_labels == ["confidence (0 to 1; 1 = measured)"]
