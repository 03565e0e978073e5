"""A rendered view of a stage 3 model: an oblique perspective, coloured by intensity or confidence.

The model of :mod:`refsynth.model` (stage 3 of the paper, §1) is drawn by
matplotlib alone, without a 3-D toolkit: its triangles are projected through
a virtual pinhole camera placed obliquely above the scene and painted far to
near (the painter's algorithm) as one
:class:`~matplotlib.collections.PolyCollection`. Each triangle takes the
mean of its vertices' colours — the registered intensity, the confidence
(1 where measured; NP's Eq. 11 confidence or BP's belief, Eq. 8, elsewhere)
through a colour map, or the share of its vertices that were synthesized
(grey: measured, orange: synthesized) — darkened by a Lambertian term
towards the viewer so that the shape reads. Triangles
stretched across a depth jump, if the mesh kept them, show as the curtain
they are.

The view keeps refsynth's frame the right way round (x right, y up, z
forward: the scanner's own images are not mirrored). A room seen from above
hides behind its ceiling: ``clip_above`` cuts the model at a height, as a
doll's house.

A model holds only what a scan position saw. Seen from above, the surfaces
that stood in an object's shadow from every position (the floor and the
wall behind a box whose top is near the scanner's height) have no
triangles, and show as blank holes; ``markers`` draws the scan positions and
``note`` says so under the panels (the demo does both).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §1 (stage 3), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.collections import PolyCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from refsynth.model import Model

__all__ = ["oblique_eye", "view_coordinates", "draw_model", "draw_markers", "model_view_figure",
           "COLOURINGS"]

#: What :func:`draw_model` can colour the model by.
COLOURINGS = ("intensity", "confidence", "synthesized")
_SYNTHESIZED_COLOURS = np.array([[0.55, 0.55, 0.55], [0.95, 0.45, 0.1]])  # measured, synthesized


def oblique_eye(points, *, azimuth: float = math.radians(-30.0),
                elevation: float = math.radians(40.0), distance: float = 1.2):
    """An eye above and behind ``points`` (N, 3) looking at their median: ``(eye, target)``.

    ``azimuth`` turns the eye about the vertical from behind (−z) in the
    pan angles' sense; ``elevation`` raises it; ``distance`` is in units of
    the points' bounding-box diagonal.
    """
    points = np.asarray(points, dtype=np.float64)
    target = np.median(points, axis=0)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) or 1.0
    back = np.array([-math.sin(azimuth), 0.0, -math.cos(azimuth)]) * math.cos(elevation)
    direction = back + np.array([0.0, math.sin(elevation), 0.0])
    return target + distance * diagonal * direction, target


def view_coordinates(points, eye, target, up=(0.0, 1.0, 0.0)):
    """Points (N, 3) → ``(u, v, depth)`` through a unit-focal pinhole at ``eye`` facing ``target``.

    ``u`` grows to the right and ``v`` upwards on the picture; ``depth`` is
    along the viewing direction (NaN-free; <= 0 behind the eye).
    """
    eye, target, up = (np.asarray(a, dtype=np.float64) for a in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(up, forward)  # refsynth's frame: up × forward points right
    if np.linalg.norm(right) < 1e-9:
        raise ValueError("The view direction must not be parallel to `up`")
    right /= np.linalg.norm(right)
    true_up = np.cross(forward, right)
    relative = np.asarray(points, dtype=np.float64) - eye
    depth = relative @ forward
    safe = np.where(depth > 0, depth, 1.0)
    return relative @ right / safe, relative @ true_up / safe, depth


def _face_colours(model: Model, faces: np.ndarray, colour: str, cmap) -> np.ndarray:
    if colour == "intensity":
        return model.colours[faces].mean(axis=1) / 255.0
    if colour == "confidence":
        return colormaps[cmap](Normalize(0.0, 1.0)(model.confidence[faces].mean(axis=1)))[:, :3]
    share = model.synthesized[faces].mean(axis=1)[:, None]  # of the three vertices
    return (1 - share) * _SYNTHESIZED_COLOURS[0] + share * _SYNTHESIZED_COLOURS[1]


def draw_model(ax, model: Model, *, colour: str = "intensity", eye=None, target=None,
               clip_above: float | None = None, shade: bool = True, cmap: str = "viridis",
               title: str | None = None):
    """Draw ``model``'s triangles on ``ax`` as seen from ``eye``; returns the PolyCollection.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    model : refsynth.model.Model
        With faces (a point cloud has nothing to paint).
    colour : {"intensity", "confidence", "synthesized"}, default "intensity"
    eye, target : array_like of shape (3,), optional
        Default :func:`oblique_eye` of the (clipped) vertices.
    clip_above : float, optional
        Leave out triangles with a vertex higher (y) than this.
    shade : bool, default True
        Darken triangles seen edge-on: ``0.45 + 0.55 |n · view|``.
    cmap : str, default "viridis"
        For ``colour="confidence"``.
    title : str, optional
    """
    if not isinstance(model, Model):
        raise TypeError(f"The parameter `model` must be a Model, got {type(model).__name__}")
    if colour not in COLOURINGS:
        raise ValueError(f"The parameter `colour` must be one of {COLOURINGS}, got {colour!r}")
    faces = model.faces
    if clip_above is not None:
        faces = faces[(model.vertices[faces, 1] <= clip_above).all(axis=1)]
    if len(faces) == 0:
        raise ValueError("The model has no triangles to draw (after clipping)")
    if eye is None or target is None:
        eye, target = oblique_eye(model.vertices[np.unique(faces)])
    u, v, depth = view_coordinates(model.vertices, eye, target)
    faces = faces[(depth[faces] > 1e-6).all(axis=1)]
    order = np.argsort(-depth[faces].mean(axis=1), kind="stable")  # far to near
    faces = faces[order]
    colours = _face_colours(model, faces, colour, cmap)
    if shade:
        corner = model.vertices[faces]
        normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
        view = corner.mean(axis=1) - np.asarray(eye, dtype=np.float64)
        cosine = np.abs(np.einsum("ij,ij->i", normal, view)) / np.maximum(
            np.linalg.norm(normal, axis=1) * np.linalg.norm(view, axis=1), 1e-300)
        colours = colours * (0.45 + 0.55 * cosine)[:, None]
    polygons = np.stack([u[faces], v[faces]], axis=-1)
    collection = PolyCollection(polygons, facecolors=np.clip(colours, 0, 1), edgecolors="face",
                                linewidths=0.2, antialiaseds=False)
    ax.add_collection(collection)
    for axis, limits in ((0, ax.set_xlim), (1, ax.set_ylim)):
        low, high = np.percentile(polygons[..., axis], [0.5, 99.5])
        pad = 0.03 * (high - low) or 1.0
        limits(low - pad, high + pad)
    ax.set_aspect("equal")
    ax.set_axis_off()
    if title:
        ax.set_title(title, fontsize=9)
    return collection


def draw_markers(ax, markers: Mapping[str, Sequence[float]], eye, target, *,
                 fontsize: float = 8) -> None:
    """Mark labelled points (e.g. the scan positions) on a view of :func:`draw_model`.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        A view drawn by :func:`draw_model` from ``eye`` towards ``target``.
    markers : mapping of label to a point (x, y, z)
        In the model's frame; a point behind the eye is left out.
    eye, target : array_like of shape (3,)
        The view's.
    fontsize : float, default 8
    """
    for label, point in markers.items():
        u, v, depth = view_coordinates(np.asarray(point, dtype=np.float64)[None], eye, target)
        if depth[0] <= 0:
            continue
        ax.plot(u, v, marker="v", markersize=7, color="crimson", markeredgecolor="white",
                markeredgewidth=0.8, linestyle="none", zorder=5)
        ax.annotate(label, (float(u[0]), float(v[0])), xytext=(0, 6),
                    textcoords="offset points", ha="center", va="bottom", fontsize=fontsize,
                    color="crimson", zorder=5)


def model_view_figure(model: Model, *, colours=("intensity", "confidence"), eye=None,
                      target=None, clip_above: float | None = None, title: str | None = None,
                      size: tuple[float, float] | None = None,
                      markers: Mapping[str, Sequence[float]] | None = None,
                      note: str | None = None) -> Figure:
    """The model from one oblique viewpoint, once per colouring, side by side.

    Parameters
    ----------
    model : refsynth.model.Model
    colours : sequence of {"intensity", "confidence", "synthesized"}
    eye, target, clip_above
        As for :func:`draw_model` (one viewpoint for every panel).
    title : str, optional
    size : pair of float, optional
        Figure size in inches; default 5 per panel by 4.
    markers : mapping of label to a point (x, y, z), optional
        Drawn on every panel (:func:`draw_markers`), e.g. the scan positions.
    note : str, optional
        A caption under the panels, e.g. what a blank region is.

    Returns
    -------
    matplotlib.figure.Figure
    """
    colours = list(colours)
    if not colours:
        raise ValueError("The parameter `colours` must name at least one colouring")
    if eye is None or target is None:
        faces = model.faces
        if clip_above is not None:
            faces = faces[(model.vertices[faces, 1] <= clip_above).all(axis=1)]
        eye, target = oblique_eye(model.vertices[np.unique(faces)] if len(faces)
                                  else model.vertices)
    fig = Figure(figsize=size or (5.0 * len(colours), 4.0), layout="constrained")
    axes = fig.subplots(1, len(colours), squeeze=False)[0]
    names = {"intensity": "coloured by intensity", "confidence": "coloured by confidence",
             "synthesized": "measured (grey) / synthesized (orange)"}
    for ax, colour in zip(axes, colours):
        draw_model(ax, model, colour=colour, eye=eye, target=target, clip_above=clip_above,
                   title=names[colour])
        if markers:
            draw_markers(ax, markers, eye, target)
        if colour == "confidence":
            fig.colorbar(ScalarMappable(Normalize(0, 1), colormaps["viridis"]), ax=ax,
                         shrink=0.7, label="confidence (0 to 1; 1 = measured)")
    if title:
        fig.suptitle(title, fontsize=10)
    if note:
        fig.supxlabel(note, fontsize=8, wrap=True)
    return fig
