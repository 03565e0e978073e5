r"""A mesh over the image grid that does not bridge depth discontinuities (stage 3).

Neighbouring pixels of a range image are neighbouring points of a surface —
unless a depth discontinuity lies between them: a table in front of a wall
sees the wall just past its edge, and a triangle joining the two would hang
a *curtain* from the table to the wall. The mesh here is the one MVE builds
from a depth map (``mve::geom::depthmap_triangulate``), with the
discontinuity test expressed as a fraction of range:

1. **Cells.** Each 2×2 cell of pixels ``0 = (i, j)``, ``1 = (i, j+1)``,
   ``2 = (i+1, j)``, ``3 = (i+1, j+1)`` gives at most two triangles. With all
   four vertices valid, the cell is split along the diagonal whose two ranges
   differ less (``|r_0 − r_3| < |r_1 − r_2|``: triangles 0–1–3 and 0–3–2;
   otherwise, ties included, 0–1–2 and 1–3–2). With three valid vertices the
   cell gives the one triangle they make; with fewer, none. A vertex is
   valid where its range is finite and > 0 (and, optionally, where the
   caller's mask says so, e.g. confidence high enough).
2. **The rule.** An edge between neighbouring pixels ``p`` and ``q`` is a
   *depth discontinuity* when

   .. math:: |r_p - r_q| > \tau\, L_{pq}\, \min(r_p, r_q)

   where ``τ`` is ``max_jump`` (a fraction, default 0.05) and ``L`` is the
   edge's length in pixels: 1 along a row or a column, √2 along a diagonal.
   A triangle any of whose three edges is a discontinuity is dropped.
   ``τ r`` is MVE's ``dd_factor × footprint``: MVE's pixel footprint is the
   width ``r δ`` of a pixel at range ``r`` (``δ`` its angle, ``1 / f``), so
   ``τ = dd_factor · δ`` (MVE's usual ``dd_factor = 5`` at ``f = 300`` px is
   ``τ ≈ 0.017``). A smooth surface keeps its triangles while its range
   changes by less than ``τ`` per pixel, i.e. while it is seen at less than
   ``arctan(τ / δ)`` from face-on (86° for τ = 0.05, f = 300).
3. **Guarantees** (the tests check them). A constant-range image keeps all
   ``2 (H − 1) (W − 1)`` triangles. Every triangle of a cell has one edge
   along a row and one along a column; so if the pixels are split into two
   sets and any two neighbours from different sets differ in range by more
   than ``τ min(r_p, r_q)``, no triangle joins the sets — a step is never
   bridged.
4. **Wrap.** A 360° panorama (``wrap=True``) also joins its last column to
   its first.

Faces are returned as triples of flat pixel indices ``i W + j``, wound so
that ``(v_1 − v_0) × (v_2 − v_0)`` points towards the camera in refsynth's
frame (x right, y up, z forward).

References
----------
Torres-Méndez & Dudek (2008; in full in :mod:`refsynth.model`), §1 (stage 3),
doi:10.1007/s11263-007-0108-2.

S. Fuhrmann, F. Langguth and M. Goesele, "MVE — A Multi-View Reconstruction
Environment", Eurographics Workshop on Graphics and Cultural Heritage (2014)
(``libs/mve/depthmap.cc``: ``depthmap_triangulate``, ``dm_is_depthdisc``).
"""

from __future__ import annotations

import math

import numpy as np

from refsynth._checks import check_real

__all__ = ["grid_faces", "depth_discontinuity", "DEFAULT_MAX_JUMP"]

#: The default ``max_jump`` (τ): 5 % of the nearer range per pixel.
DEFAULT_MAX_JUMP = 0.05

# The cell's four triangles, MVE's numbering 1–4: (0,2,1), (0,3,1), (0,2,3), (1,2,3),
# wound here as (0,1,2), (0,1,3), (0,3,2), (1,3,2) so their normals face the camera
# in refsynth's y-up frame. EDGES names each triangle's three edges (see _edges).
_TRIANGLES = np.array([[0, 1, 2], [0, 1, 3], [0, 3, 2], [1, 3, 2]])
_EDGES = (("top", "left", "anti"), ("top", "right", "main"),
          ("left", "bottom", "main"), ("right", "bottom", "anti"))


def depth_discontinuity(r_p, r_q, max_jump: float, length: float = 1.0) -> np.ndarray:
    r"""Whether the edge between ranges ``r_p`` and ``r_q`` is a depth discontinuity.

    .. math:: |r_p - r_q| > \tau\, L\, \min(r_p, r_q)

    Parameters
    ----------
    r_p, r_q : array_like
        Ranges (> 0) of the two ends.
    max_jump : float
        ``τ``, the largest jump per pixel as a fraction of the nearer range.
    length : float, default 1
        ``L``, the edge's length in pixels (√2 for a diagonal).

    Examples
    --------
    >>> depth_discontinuity([2.0, 2.0], [2.09, 2.11], 0.05)
    array([False,  True])
    """
    r_p, r_q = np.asarray(r_p, dtype=np.float64), np.asarray(r_q, dtype=np.float64)
    return np.abs(r_p - r_q) > max_jump * length * np.minimum(r_p, r_q)


def _check_max_jump(max_jump) -> float | None:
    if max_jump is None:
        return None
    return check_real("max_jump", max_jump, positive=True)


def grid_faces(range_image, *, valid=None, max_jump: float | None = DEFAULT_MAX_JUMP,
               wrap: bool = False) -> np.ndarray:
    """Triangles over the pixel grid of a range image, none across a depth discontinuity.

    Parameters
    ----------
    range_image : ndarray of shape (H, W)
        Range (distance or depth); a pixel with a range that is not finite
        and > 0 is not a vertex.
    valid : ndarray of shape (H, W), bool, optional
        Also required of a vertex (e.g. ``confidence >= c_min``).
    max_jump : float or None, default 0.05
        ``τ`` of the rule (module docstring); None keeps every triangle of
        valid vertices (the curtain included).
    wrap : bool, default False
        Join the last column to the first (a 360° panorama).

    Returns
    -------
    ndarray of shape (M, 3), int64
        Flat pixel indices ``i W + j`` of each triangle, cells in raster order.

    Examples
    --------
    >>> step = np.array([[1.0, 1.0, 3.0], [1.0, 1.0, 3.0]])
    >>> grid_faces(step)
    array([[0, 1, 3],
           [1, 4, 3]])
    >>> len(grid_faces(step, max_jump=None))
    4
    """
    r = np.asarray(range_image, dtype=np.float64)
    if r.ndim != 2:
        raise ValueError(f"The parameter `range_image` must be 2-D, got shape {r.shape}")
    max_jump = _check_max_jump(max_jump)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r > 0)
    if valid is not None:
        valid = np.asarray(valid)
        if valid.dtype != np.bool_ or valid.shape != r.shape:
            raise ValueError(
                f"The parameter `valid` must be a bool array of shape {r.shape}, "
                f"got {valid.dtype} {valid.shape}"
            )
        ok &= valid
    height, width = r.shape
    index = np.arange(height * width, dtype=np.int64).reshape(height, width)
    if wrap:  # the first column again after the last
        r, ok, index = (np.concatenate([a, a[:, :1]], axis=1) for a in (r, ok, index))
    if r.shape[0] < 2 or r.shape[1] < 2:
        return np.zeros((0, 3), dtype=np.int64)
    corners = [(slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None)),
               (slice(1, None), slice(None, -1)), (slice(1, None), slice(1, None))]
    rc = [np.where(ok[c], r[c], 1.0) for c in corners]  # 1.0: a harmless stand-in
    okc = [ok[c] for c in corners]
    ic = np.stack([index[c] for c in corners], axis=-1)  # (H-1, W-1, 4)
    count = sum(o.astype(np.int8) for o in okc)
    full = count == 4
    main_first = full & (np.abs(rc[0] - rc[3]) < np.abs(rc[1] - rc[2]))
    three = count == 3
    use = np.stack([
        (three & ~okc[3]) | (full & ~main_first),   # 0-1-2
        (three & ~okc[2]) | main_first,             # 0-1-3
        (three & ~okc[1]) | main_first,             # 0-3-2
        (three & ~okc[0]) | (full & ~main_first),   # 1-3-2
    ], axis=-1)
    if max_jump is not None:
        jump = _edges(rc, max_jump)
        for t, names in enumerate(_EDGES):
            use[..., t] &= ~(jump[names[0]] | jump[names[1]] | jump[names[2]])
    triangles = ic[..., _TRIANGLES]  # (H-1, W-1, 4, 3)
    return triangles[use]


def _edges(rc: list[np.ndarray], max_jump: float) -> dict[str, np.ndarray]:
    """The discontinuity flag of each of a cell's six edges (rows, columns, diagonals)."""
    diagonal = math.sqrt(2.0)
    return {
        "top": depth_discontinuity(rc[0], rc[1], max_jump),
        "bottom": depth_discontinuity(rc[2], rc[3], max_jump),
        "left": depth_discontinuity(rc[0], rc[2], max_jump),
        "right": depth_discontinuity(rc[1], rc[3], max_jump),
        "main": depth_discontinuity(rc[0], rc[3], max_jump, diagonal),
        "anti": depth_discontinuity(rc[1], rc[2], max_jump, diagonal),
    }
