r"""Scoring registration against the test rig's ground truth, in mosaic pixels (Appendix A; §4.1).

The rig of :mod:`refsynth.scenes.rig` and :mod:`refsynth.scenes.rig_views`
keeps what it really did — the true pan angle and vertical jitter of every
view, the true 3-D point behind every laser sample — so a registration can be
scored where it matters:

- :func:`mosaic_position`: where a 3-D point truly lands in a mosaic built
  from the views (Eq. 14 with the true poses and the mosaic's placement).
- :func:`registration_errors`: the misalignment of range edges against the
  intensity edges they should lie on, for each stage of laser–camera
  registration (nominal geometry, the global warp of Eq. 21, the local
  stretch).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §4.1, Appendix A, Eqs. 14 and 21,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from refsynth.registration.edge_matching import range_edges
from refsynth.registration.warp import warp_forward

if TYPE_CHECKING:
    from refsynth.registration.mosaicking import Mosaic
    from refsynth.scenes.rig import LaserScan
    from refsynth.scenes.rig_views import RigViews

__all__ = ["mosaic_position", "registration_errors"]


def mosaic_position(points: np.ndarray, mosaic: Mosaic, views: RigViews) -> np.ndarray:
    """Where 3-D points truly appear in a mosaic built from ``views``.

    A point at pan angle ``ψ`` and scanline ``v`` (Eq. 14, camera centre at
    the origin) appears in view ``k``'s cylindrical frame at
    ``(c_x + f (ψ − ψ_k), c_y + v − J_k)`` (true pan ``ψ_k`` and jitter
    ``J_k``), and the mosaic puts that frame at ``offsets[k]``. The view
    whose centre is nearest in pan is used, so the position carries that
    view's placement error (the mosaic's own, as its pixels do).

    Parameters
    ----------
    points : ndarray of shape (..., 3)
        World points (m).
    mosaic : Mosaic
        Built from ``views.images``.
    views : RigViews
        The rendered views, with their true pan angles and jitter.

    Returns
    -------
    ndarray of shape (..., 2)
        ``(col, row)`` in mosaic pixels.

    Examples
    --------
    >>> from refsynth.registration.mosaicking import mosaic
    >>> from refsynth.registration.examples import example_rig
    >>> views, _ = example_rig()
    >>> result = mosaic(views.images, views.focal, views.pan_angles[1] - views.pan_angles[0])
    >>> mosaic_position(np.array([[0.0, 0.0, 2.0], [0.0, -0.1, 2.0]]), result, views).shape
    (2, 2)
    """
    points = np.asarray(points, dtype=np.float64)
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    psi = np.arctan2(x, z)
    v = -views.focal * y / np.hypot(x, z)  # scanline, down
    nearest = np.abs(_wrap(psi[..., None] - views.true_pan)).argmin(axis=-1)
    height, width = mosaic.view_shape
    col = (
        mosaic.offsets[nearest, 0] + (width - 1) / 2
        + views.focal * _wrap(psi - views.true_pan[nearest])
    )
    row = mosaic.offsets[nearest, 1] + (height - 1) / 2 + v - views.jitter[nearest]
    return np.stack([col, row], axis=-1)


def registration_errors(
    registration, scan: LaserScan, views: RigViews, *, stages: dict | None = None
) -> dict:
    """Laser–camera registration error against the rig's ground truth, in mosaic pixels.

    For each depth edge of the registered range image
    (:func:`refsynth.registration.edge_matching.range_edges`), the sample on its near
    side (the occluding surface the edge belongs to) is mapped onto the
    mosaic by each stage of the registration and compared with where its
    3-D point truly appears (:func:`mosaic_position`). The *edge
    misalignment* is the error along the edge's normal — horizontal for a
    vertical edge, vertical for a horizontal one — the distance between the
    range edge and the intensity edge it should lie on.

    Parameters
    ----------
    registration : refsynth.registration.pipeline.Registration
        What :func:`refsynth.registration.pipeline.register` returned for ``scan`` and ``views``.
    scan : LaserScan
        The scan that was registered (its true points).
    views : RigViews
        The views the mosaic was built from.
    stages : dict, optional
        More mappings to score: name → function ``(phi, h, r) -> (N, 2)``
        mosaic positions of laser samples (e.g. the exact Eq. 20).

    Returns
    -------
    dict
        For each stage — ``"nominal"`` (the rig's nominal geometry),
        ``"global"`` (Eq. 21), ``"local"`` (after the stretch) — a dict
        with ``mean`` and ``rms`` of the edge misalignment over all depth
        edges, ``mean_u`` over vertical and ``mean_v`` over horizontal
        edges, and ``samples`` (mean 2-D error over every scanned sample
        inside the mosaic, edges or not); plus ``n_u`` and ``n_v``.

    Examples
    --------
    >>> from refsynth.registration.examples import example_registration
    >>> views, scan, result = example_registration()
    >>> errors = registration_errors(result, scan, views)
    >>> sorted(errors), sorted(errors["global"])
    (['global', 'local', 'n_u', 'n_v', 'nominal'], ['mean', 'mean_u', 'mean_v', 'rms', 'samples'])
    """
    cylinder = registration.cylinder
    found = range_edges(cylinder)
    row, col = cylinder.index(found.phi, found.h)
    # the two samples across each edge; keep the nearer one
    c0 = np.where(found.axis == 0, np.floor(col + 1e-9), np.round(col)).astype(int)
    r0 = np.where(found.axis == 1, np.floor(row + 1e-9), np.round(row)).astype(int)
    c1, r1 = c0 + (found.axis == 0), r0 + (found.axis == 1)
    first_nearer = cylinder.range[r0, c0] <= cylinder.range[r1, c1]
    cols, rows = np.where(first_nearer, c0, c1), np.where(first_nearer, r0, r1)

    def samples(cols, rows):
        slice_index = np.round((cylinder.phi[cols] - scan.phi[0]) / (scan.phi[1] - scan.phi[0]))
        slice_index = slice_index.astype(int)
        wanted = np.arctan2(views.focal, cylinder.h[rows])
        mirror = np.clip(np.searchsorted(scan.theta, wanted), 1, scan.theta.size - 1)
        left_closer = wanted - scan.theta[mirror - 1] < scan.theta[mirror] - wanted
        mirror = np.where(left_closer, mirror - 1, mirror)
        h = views.focal / np.tan(scan.theta[mirror])
        truth = mosaic_position(scan.points[slice_index, mirror], registration.mosaic, views)
        return scan.phi[slice_index], h, scan.r[slice_index, mirror], truth

    phi, h, r, truth = samples(cols, rows)
    every_row, every_col = np.nonzero(np.isfinite(cylinder.range))
    all_phi, all_h, all_r, all_truth = samples(every_col, every_row)
    height, width = registration.mosaic.weight.shape
    inside = (all_truth[:, 0] >= 0) & (all_truth[:, 0] < width)
    inside &= (all_truth[:, 1] >= 0) & (all_truth[:, 1] < height)
    vertical, horizontal = found.axis == 0, found.axis == 1
    mappings = {
        name: (lambda p, q, _, w=warp, d=displacement: warp_forward(w, d, p, q))
        for name, warp, displacement in [
            ("nominal", registration.initial, None),
            ("global", registration.warp, None),
            ("local", registration.warp, registration.displacement),
        ]
    }
    mappings.update(stages or {})
    out: dict = {"n_u": int(vertical.sum()), "n_v": int(horizontal.sum())}
    for name, mapping in mappings.items():
        error = mapping(phi, h, r) - truth
        normal = np.abs(np.where(vertical, error[:, 0], error[:, 1]))
        everywhere = mapping(all_phi[inside], all_h[inside], all_r[inside])
        out[name] = {
            "mean": float(normal.mean()),
            "rms": float(np.sqrt(np.mean(normal**2))),
            "mean_u": float(normal[vertical].mean()) if vertical.any() else float("nan"),
            "mean_v": float(normal[horizontal].mean()) if horizontal.any() else float("nan"),
            "samples": float(np.mean(np.hypot(*(everywhere - all_truth[inside]).T))),
        }
    return out


def _wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi
