r"""From a dense range image and its intensity to a coloured 3-D model (stage 3).

:func:`build_model` is stage 3 for one scan position: every pixel with a
range becomes a vertex (:mod:`refsynth.model.cameras`: Eqs. 14 and 19 for the
panorama, the pinhole for Middlebury pairs), coloured by the registered
intensity, carrying its confidence (1 where the range was measured; NP's
Eq. 11 confidence or BP's belief, Eq. 8, where it was synthesized) and a
flag saying which of the two it is (from the partial range: a vertex not
known to be measured is flagged synthesized); the triangles of
:func:`refsynth.model.mesh.grid_faces` join the vertices without bridging
depth discontinuities. The result, a :class:`Model`, is what
:func:`refsynth.model.ply.write_ply` writes and
:func:`refsynth.model.merge.merge_models` merges.

References
----------
Torres-Méndez & Dudek (2008; in full in :mod:`refsynth.model`), §1 (stage 3:
"data integration for model representation"), §3.2 (Eqs. 8, 11: the
confidences), Appendix A (Eqs. 14, 19), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from refsynth._checks import check_image, check_real, check_real_array
from refsynth.model.cameras import check_range_image
from refsynth.model.mesh import DEFAULT_MAX_JUMP, grid_faces

__all__ = ["Model", "build_model", "intensity_colours"]


@dataclass(frozen=True, eq=False)
class Model:
    """A coloured point set with triangles: one scan position's model, or several merged (stage 3).

    Attributes
    ----------
    vertices : ndarray of shape (N, 3), float64
        ``(x, y, z)`` in refsynth's frame (x right, y up, z forward), the
        range image's unit.
    colours : ndarray of shape (N, 3), uint8
        RGB (grey intensities repeated).
    confidence : ndarray of shape (N,), float64
        In [0, 1]; 1 where measured.
    synthesized : ndarray of shape (N,), bool
        True where the range was synthesized (stage 2), False where measured.
    faces : ndarray of shape (M, 3), int64
        Vertex indices of each triangle; (0, 3) for a point cloud.
    pixels : ndarray of shape (N, 2), int64, or None
        The ``(row, col)`` each vertex came from (not written to PLY).
    source : ndarray of shape (N,), int64, or None
        For a merged model, which input model each vertex came from.
    uncertainty : ndarray of shape (N,), float64, or None
        Each vertex's expected absolute range error in the range's unit
        (:attr:`refsynth.SynthesisResult.uncertainty`; 0 where measured), or None when
        the model was built without one.

    Examples
    --------
    >>> from refsynth.model import PinholeCamera, build_model
    >>> model = build_model(np.full((2, 2), 3.0), PinholeCamera(100.0, 0.5, 0.5))
    >>> model.vertices.shape, model.faces.shape, model.colours.dtype
    ((4, 3), (2, 3), dtype('uint8'))
    """

    vertices: np.ndarray
    colours: np.ndarray
    confidence: np.ndarray
    synthesized: np.ndarray
    faces: np.ndarray
    pixels: np.ndarray | None = None
    source: np.ndarray | None = None
    uncertainty: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.vertices)
        shapes = {"vertices": (n, 3), "colours": (n, 3), "confidence": (n,),
                  "synthesized": (n,)}
        if self.uncertainty is not None:
            shapes["uncertainty"] = (n,)
        for name, shape in shapes.items():
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(
                    f"The model's `{name}` must have shape {shape}, "
                    f"got {np.shape(getattr(self, name))}"
                )
        faces = np.asarray(self.faces)
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"The model's `faces` must have shape (M, 3), got {faces.shape}")
        if faces.size and (faces.min() < 0 or faces.max() >= n):
            raise ValueError(f"The model's `faces` must index its {n} vertices")

    @property
    def n_vertices(self) -> int:
        """The number of vertices ``N``."""
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        """The number of triangles ``M``."""
        return len(self.faces)

    def subset(self, keep: np.ndarray) -> Model:
        """The vertices where ``keep`` (bool (N,)) and the triangles all of whose vertices stay."""
        keep = np.asarray(keep, dtype=bool)
        new_index = np.cumsum(keep) - 1
        faces = self.faces[keep[self.faces].all(axis=1)] if self.n_faces else self.faces
        return Model(
            vertices=self.vertices[keep], colours=self.colours[keep],
            confidence=self.confidence[keep], synthesized=self.synthesized[keep],
            faces=new_index[faces].astype(np.int64),
            pixels=None if self.pixels is None else self.pixels[keep],
            source=None if self.source is None else self.source[keep],
            uncertainty=None if self.uncertainty is None else self.uncertainty[keep],
        )


def intensity_colours(intensity) -> np.ndarray:
    """8-bit RGB of an intensity image: (H, W) grey or (H, W, 3) colour → (H, W, 3) uint8.

    The vertex colours of :func:`build_model` (stage 3).

    Integer images are first divided by their dtype's maximum (refsynth's
    convention; 8-bit values come back unchanged); floating images are taken
    in [0, 1] as given and clipped; NaN becomes 0. Values are scaled by 255
    and rounded to the nearest integer. A single channel (H, W) or (H, W, 1)
    is repeated in R, G and B.

    Parameters
    ----------
    intensity : ndarray of shape (H, W), (H, W, 1) or (H, W, 3)
        The intensity image the model's vertices take their colours from.

    Returns
    -------
    ndarray of shape (H, W, 3), uint8
        RGB.

    Examples
    --------
    >>> intensity_colours(np.array([[0.0, 0.5], [1.0, 2.0]]))[..., 0]
    array([[  0, 128],
           [255, 255]], dtype=uint8)
    """
    image = check_image("intensity", intensity)
    if image.ndim == 3 and image.shape[2] not in (1, 3):
        raise ValueError(
            "The parameter `intensity` must have 1 or 3 channels, got shape "
            f"{np.shape(intensity)}"
        )
    if image.ndim == 2:
        image = image[..., None]
    image = np.broadcast_to(image, (*image.shape[:2], 3))
    scaled = np.rint(np.clip(np.nan_to_num(image, nan=0.0), 0.0, 1.0) * 255.0)
    return scaled.astype(np.uint8)


def _check_shape(name: str, array: np.ndarray, shape) -> np.ndarray:
    if array.shape != shape:
        raise ValueError(f"The parameter `{name}` must have shape {shape}, got {array.shape}")
    return array


def build_model(range_image, camera, *, intensity=None, confidence=None, measured=None,
                max_jump: float | None = DEFAULT_MAX_JUMP, min_confidence: float = 0.0,
                wrap: bool | None = None, uncertainty=None,
                max_uncertainty: float | None = None, drop_uncertain: float = 0.0) -> Model:
    """One scan position's model: coloured points and a mesh that does not bridge depth jumps.

    Parameters
    ----------
    range_image : ndarray of shape (H, W)
        The dense range of stage 2 (``SynthesisResult.range``): Euclidean
        distance for a :class:`~refsynth.model.cameras.CylindricalCamera`,
        depth ``z`` for a :class:`~refsynth.model.cameras.PinholeCamera`.
        Pixels whose range is not finite and > 0 give no vertex.
    camera : CylindricalCamera or PinholeCamera
        The ray of each pixel: the panorama's cylinder of radius ``f``
        (Eqs. 14, 19) or a pinhole view (e.g. a Middlebury image).
    intensity : ndarray of shape (H, W) or (H, W, 3), optional
        The registered intensity, grey or RGB, integer or float
        (:func:`intensity_colours`); default mid-grey (128).
    confidence : ndarray of shape (H, W), optional
        In [0, 1] where there is range (``SynthesisResult.confidence``);
        default 1 everywhere.
    measured : ndarray of shape (H, W), bool, optional
        True where the range was measured (``np.isfinite(partial_range)``).
        Default: not known, so no vertex claims to be measured (every one is
        marked synthesized). A confidence of 1 does not say "measured": BP's
        belief and NP's confidence reach 1 at synthesized pixels too. For a
        range measured everywhere, pass ``np.ones(shape, bool)``.
    max_jump : float or None, default 0.05
        ``τ`` of the discontinuity rule (:mod:`refsynth.model.mesh`); None
        keeps every triangle.
    min_confidence : float, default 0
        Vertices whose confidence is below this are dropped, with their
        triangles.
    wrap : bool or None, default None
        Join the last column to the first; None: when a cylindrical camera's
        columns cover 360°. True requires that they do.
    uncertainty : ndarray of shape (H, W), optional
        Each pixel's expected absolute error in the range's unit
        (``SynthesisResult.uncertainty``), finite and >= 0 where there is range;
        carried by the vertices (``Model.uncertainty``). Default: none.
    max_uncertainty : float, optional
        Vertices whose uncertainty exceeds this (in the range's unit) are dropped, with
        their triangles; needs ``uncertainty``. Default: none dropped.
    drop_uncertain : float, default 0
        The fraction, in [0, 1], of the synthesized vertices (uncertainty > 0) to drop
        with their triangles, the most uncertain first (ties: in raster order): the
        ``round(drop_uncertain · n)`` of the ``n`` synthesized pixels with range (and
        ``min_confidence``). It uses the map's ranking only, which holds on the
        samplings where its scale does not (``docs/uncertainty.md``); needs
        ``uncertainty`` when > 0. With ``max_uncertainty`` too, a vertex that either
        drops goes.

    Returns
    -------
    Model
        Vertices in raster order of their pixels (``Model.pixels``).

    Examples
    --------
    >>> from refsynth.model.cameras import PinholeCamera
    >>> depth = np.array([[2.0, 2.0, 6.0], [2.0, 2.0, 6.0]])
    >>> model = build_model(depth, PinholeCamera(100.0, 1.0, 0.5))
    >>> model.n_vertices, model.n_faces
    (6, 2)
    """
    r = check_range_image(range_image)
    shape = r.shape
    if not (hasattr(camera, "back_project") and hasattr(camera, "covers_360")):
        raise TypeError(
            "The parameter `camera` must be a CylindricalCamera or a PinholeCamera, "
            f"got {type(camera).__name__}"
        )
    if intensity is None:
        colours = np.full((*shape, 3), 128, dtype=np.uint8)
    else:
        if np.shape(intensity)[:2] != shape:
            raise ValueError(
                f"The parameter `intensity` must have shape {shape} or {(*shape, 3)}, "
                f"got {np.shape(intensity)}"
            )
        colours = intensity_colours(intensity)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(r) & (r > 0)
    if confidence is None:
        conf = np.ones(shape)
    else:
        conf = check_real_array("confidence", np.asarray(confidence))
        conf = _check_shape("confidence", conf, shape).astype(np.float64)
        values = conf[valid]
        if not np.all(np.isfinite(values)) or values.min(initial=0) < 0 or values.max(
                initial=0) > 1:
            raise ValueError("The parameter `confidence` must lie in [0, 1] where there is range")
    if measured is None:  # not known: nothing is claimed to be measured
        measured = np.zeros(shape, dtype=bool)
    else:
        measured = _check_shape("measured", np.asarray(measured), shape)
        if measured.dtype != np.bool_:
            raise TypeError(f"The parameter `measured` must be a bool array, got {measured.dtype}")
    min_confidence = check_real("min_confidence", min_confidence, minimum=0.0, maximum=1.0)
    if min_confidence > 0:
        valid &= conf >= min_confidence
    unc = _check_uncertainty(uncertainty, max_uncertainty, shape, valid)
    drop_uncertain = check_real("drop_uncertain", drop_uncertain, minimum=0.0, maximum=1.0)
    if drop_uncertain > 0:
        if unc is None:
            raise ValueError("The parameter `drop_uncertain` needs `uncertainty` (the map "
                             "of SynthesisResult.uncertainty)")
        valid &= ~_most_uncertain(unc, valid & (unc > 0), drop_uncertain)
    if max_uncertainty is not None:
        valid &= unc <= max_uncertainty
    wrap = _check_wrap(wrap, camera, shape[1])
    faces = grid_faces(r, valid=valid, max_jump=max_jump, wrap=wrap)
    flat = np.flatnonzero(valid)
    vertex_of = np.full(r.size, -1, dtype=np.int64)
    vertex_of[flat] = np.arange(flat.size)
    points = camera.back_project(r).reshape(-1, 3)[flat]
    rows, cols = np.divmod(flat, shape[1])
    return Model(
        vertices=points,
        colours=colours.reshape(-1, 3)[flat],
        confidence=conf.ravel()[flat],
        synthesized=~measured.ravel()[flat],
        faces=vertex_of[faces],
        pixels=np.stack([rows, cols], axis=1),
        uncertainty=None if unc is None else unc.ravel()[flat],
    )


def _most_uncertain(uncertainty: np.ndarray, among: np.ndarray, fraction: float) -> np.ndarray:
    """The ``round(fraction · n)`` pixels of ``among`` (``n`` of them) with the largest
    uncertainty, ties in raster order: a bool mask of ``uncertainty``'s shape.

    Examples
    --------
    >>> unc = np.array([[0.0, 0.3, 0.1], [0.3, 0.2, 0.0]])
    >>> _most_uncertain(unc, unc > 0, 0.5).astype(int).tolist()
    [[0, 1, 0], [1, 0, 0]]
    """
    flat = np.flatnonzero(among)
    count = round(fraction * flat.size)
    order = np.argsort(-uncertainty.ravel()[flat], kind="stable")
    chosen = np.zeros(uncertainty.size, dtype=bool)
    chosen[flat[order[:count]]] = True
    return chosen.reshape(uncertainty.shape)


def _check_uncertainty(uncertainty, max_uncertainty, shape, valid) -> np.ndarray | None:
    """The uncertainty map as float64 (or None), checked with ``max_uncertainty``."""
    if max_uncertainty is not None:
        max_uncertainty = check_real("max_uncertainty", max_uncertainty, minimum=0.0)
        if uncertainty is None:
            raise ValueError("The parameter `max_uncertainty` needs `uncertainty` (the map "
                             "of SynthesisResult.uncertainty)")
    if uncertainty is None:
        return None
    unc = check_real_array("uncertainty", np.asarray(uncertainty))
    unc = _check_shape("uncertainty", unc, shape).astype(np.float64)
    values = unc[valid]
    if not (np.all(np.isfinite(values)) and values.min(initial=0) >= 0):
        raise ValueError("The parameter `uncertainty` must be finite and >= 0 where there is "
                         "range")
    return unc


def _check_wrap(wrap, camera, width: int) -> bool:
    closes = bool(camera.covers_360(width))
    if wrap is None:
        return closes
    if not isinstance(wrap, (bool, np.bool_)):
        raise TypeError(f"The parameter `wrap` must be True, False or None, got {wrap!r}")
    if wrap and not closes:
        raise ValueError(
            f"The parameter `wrap` is True but the camera's {width} columns do not cover 360°"
        )
    return bool(wrap)
