r"""Aligning the range image with the mosaic: global warp, local stretch (Appendix A.2).

The paper fits the global warp of Eq. 21 (:mod:`refsynth.registration.warp`)
from corresponding points; what it leaves (the paper: 5–7 px) is removed
locally: range edges (depth discontinuities) are matched to intensity edges
(:mod:`refsynth.registration.edge_matching`), and the range image is
"stretched" by a displacement field interpolated cubically between these
control points, until the misalignment falls below a threshold. Only the
partial range is needed.

- :func:`align_global`: Eq. 21 from automatic edge correspondences — a
  chamfer search of the offsets, then least squares on depth edges matched
  to intensity edges.
- :func:`refine_local`: the local stretch, a displacement field ``d`` on the
  mosaic.
- :func:`resample_range`: the range image on the mosaic's grid,
  ``R(x) = range(warp⁻¹(x + d(x)))``.

Readings and departures
-----------------------
- By default only ``α`` and ``β`` are fitted (``a = f``, ``b = −1`` from the
  geometry): with a partial scan the horizontal depth edges are mostly tops
  of furniture, whose height on the cylinder correlates with their parallax,
  and fitting ``b`` to them biases it by several per cent.
  :func:`refsynth.registration.warp.fit_warp` is the paper's four-parameter
  fit for given correspondences.
- The local stretch moves only ``v`` by default: in the paper's own sensor
  model (a vertical offset ``ΔY`` and a common pan axis, Eq. 20) ``u = a φ
  + α`` is exact and Eq. 21's error is vertical. The cubic interpolation of
  the control points is anchored at zero away from them, so that the stretch
  stays where edges asked for it.
- The stopping threshold is half the range image's sample spacing along
  each axis: below it a depth edge's position is not known.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A.2, Eq. 21,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from scipy import interpolate
from scipy import ndimage as ndi

from refsynth._checks import check_choice
from refsynth.registration.edge_matching import (
    RangeEdges,
    intensity_edges,
    match_edges,
    match_segments,
    range_edges,
)
from refsynth.registration.range_image import CylindricalRange
from refsynth.registration.warp import Warp, fit_line, warp_forward

__all__ = ["align_global", "refine_local", "resample_range"]


# ----------------------------------------------------------------------------- Eq. 21, globally


def _robust_line(x, y, name, slope: float, fit_slope: bool, rounds: int = 3):
    """Line fit with residuals beyond 3 × 1.4826 MAD (at least 0.5 px) trimmed.

    With ``fit_slope`` False, or when the kept points have a single ``x``,
    only the offset is fitted and ``slope`` is kept.
    """
    keep = np.ones(x.size, dtype=bool)
    for _ in range(rounds):
        s, c = slope, float(np.median(y[keep] - slope * x[keep]))
        if fit_slope:
            try:
                s, c = fit_line(x[keep], y[keep], name)
            except ValueError:
                pass
        residual = y - (s * x + c)
        spread = 1.4826 * np.median(np.abs(residual[keep] - np.median(residual[keep])))
        keep = np.abs(residual) <= max(3 * spread, 0.5)
    return s, c


def align_global(
    image: np.ndarray,
    cylinder: CylindricalRange,
    initial: Warp,
    *,
    search: int = 12,
    radii=(3, 2),
    fit_scale: bool = False,
    min_spread: float = 0.25,
    edges=None,
    jump: float = 0.2,
) -> tuple[Warp, dict]:
    r"""The global warp (Eq. 21) from automatic edge correspondences.

    1. Range edges (:func:`~refsynth.registration.edge_matching.range_edges`)
       are placed on the mosaic with ``initial``; the whole-pixel shift of
       ``(α, β)`` within ``±search`` px that brings them closest to
       intensity edges of the same orientation (mean truncated distance, a
       chamfer match) is applied.
    2. Each range edge is matched to the nearest compatible intensity edge
       along its normal (:func:`~refsynth.registration.edge_matching.match_edges`)
       within each radius of ``radii`` in turn, and Eq. 21 is refitted by
       least squares with outliers trimmed: ``u = a φ + α`` from the
       vertical edges, ``v = b h + β`` from the horizontal ones.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, 3)
        The mosaic.
    cylinder : CylindricalRange
        The (partial) range image on the cylinder (Eq. 19).
    initial : Warp
        From the rig's nominal geometry: ``(f, −1/h_step·h_step, column of
        φ = 0, horizon row)``.
    search : int, default 12
        The chamfer search range of the shift, ±px.
    radii : sequence of int, default (3, 2)
        The matching radius of each refitting round, px.
    fit_scale : bool, default False
        Also fit ``a`` and ``b`` (else keep those of ``initial`` and fit
        the offsets only; see :func:`~refsynth.registration.pipeline.register` for why that is the
        default).
    min_spread : float, default 0.25
        A scale (``a``, ``b``) is fitted only from matches spread over at
        least this fraction of the mosaic's width (height); otherwise only
        the offset (``α``, ``β``) is. Partial scans in stripes have few
        vertical depth edges, often all in one place.
    edges : tuple, optional
        ``intensity_edges(image)``, if already computed.
    jump : float, default 0.2
        Passed to :func:`~refsynth.registration.edge_matching.range_edges`.

    Returns
    -------
    warp : Warp
    info : dict
        ``shift`` (the chamfer shift), ``matches`` (per round), and
        ``misalignment`` (mean |offset| of the matches of the last round, px).

    Examples
    --------
    >>> from refsynth.registration.examples import example_registration
    >>> views, scan, result = example_registration()
    >>> warp, info = align_global(result.mosaic.image, result.cylinder, result.initial)
    >>> warp.a == result.initial.a, sorted(info)  # a is kept unless fit_scale
    (True, ['matches', 'misalignment', 'shift'])
    """
    edge_map, gx, gy = intensity_edges(image) if edges is None else edges
    found = range_edges(cylinder, jump=jump)
    if found.phi.size < 4:
        raise ValueError(
            f"The range image has {found.phi.size} depth edges; registration needs at least 4"
        )
    # 1. chamfer search on the offsets
    along_x = edge_map & (np.abs(gx) >= np.abs(gy))
    along_y = edge_map & (np.abs(gy) >= np.abs(gx))
    distance = [
        ndi.distance_transform_edt(~mask) if mask.any() else np.full(mask.shape, np.inf)
        for mask in (along_x, along_y)
    ]
    u, v = initial.apply(found.phi, found.h)
    shifts = np.arange(-search, search + 1)
    best, best_cost = (0, 0), np.inf
    height, width = edge_map.shape
    truncate = 4.0
    for dv in shifts:
        for du in shifts:
            cols = np.round(u + du).astype(int)
            rows = np.round(v + dv).astype(int)
            inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
            if inside.sum() < 4:
                continue
            cost_x = distance[0][rows[inside], cols[inside]]
            cost_y = distance[1][rows[inside], cols[inside]]
            cost = np.minimum(np.where(found.axis[inside] == 0, cost_x, cost_y), truncate)
            # points that fall off the mosaic count as unmatched
            total = (cost.sum() + truncate * (~inside).sum()) / inside.size
            if total < best_cost - 1e-12:
                best, best_cost = (int(du), int(dv)), total
    warp = Warp(initial.a, initial.b, initial.alpha + best[0], initial.beta + best[1])
    info: dict = {"shift": best, "matches": []}
    # 2. match and refit, with shrinking radii
    misalignment = np.nan
    for radius in radii:
        for _ in range(3):
            positions = warp_forward(warp, None, found.phi, found.h)
            offset = match_edges(positions, found.axis, edge_map, gx, gy, int(radius))
            matched = np.isfinite(offset)
            vertical = matched & (found.axis == 0)
            horizontal = matched & (found.axis == 1)
            info["matches"].append(int(matched.sum()))
            if not matched.any():
                break
            misalignment = float(np.mean(np.abs(offset[matched])))
            target_u = positions[vertical, 0] + offset[vertical]
            target_v = positions[horizontal, 1] + offset[horizontal]
            # a scale needs correspondences spread over the image; else fit the offset only
            spread_u = np.ptp(positions[vertical, 0]) if vertical.any() else 0.0
            spread_v = np.ptp(positions[horizontal, 1]) if horizontal.any() else 0.0
            scale_u = fit_scale and spread_u >= min_spread * edge_map.shape[1]
            scale_v = fit_scale and spread_v >= min_spread * edge_map.shape[0]
            a, alpha = warp.a, warp.alpha
            if vertical.any():
                a, alpha = _robust_line(found.phi[vertical], target_u, "φ", warp.a, scale_u)
            b, beta = warp.b, warp.beta
            if horizontal.any():
                b, beta = _robust_line(found.h[horizontal], target_v, "h", warp.b, scale_v)
            warp = Warp(a, b, alpha, beta)
    info["misalignment"] = misalignment
    return warp, info


# ----------------------------------------------------------------------------- local stretch


def _interpolate_field(centres, values, anchors, shape, spacing: float) -> np.ndarray:
    """Cubic (Clough–Tocher) interpolation of control values, anchored at 0.

    ``anchors`` are points known to need no correction (segments that
    matched where they are). More zero anchors are put on a grid of
    ``spacing`` px wherever no control point is within ``spacing``, so that
    a correction stays local to the edges that asked for it instead of
    spreading across the panorama.
    """
    step = 4
    grid_r, grid_c = np.mgrid[0 : shape[0] + step : step, 0 : shape[1] + step : step]
    far_r, far_c = np.mgrid[0 : shape[0] + spacing : spacing, 0 : shape[1] + spacing : spacing]
    far = np.column_stack([far_c.ravel(), far_r.ravel()])
    gap = np.min(np.hypot(*(far[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)), axis=1)
    points = np.vstack([centres, anchors.reshape(-1, 2), far[gap > spacing]])
    values = np.concatenate([values, np.zeros(len(points) - len(values))])
    coarse = interpolate.griddata(points, values, (grid_c, grid_r), method="cubic", fill_value=0.0)
    r, c = np.indices(shape, dtype=np.float64)
    return ndi.map_coordinates(coarse, [r / step, c / step], order=3, mode="nearest")


def _segment_means(found: RangeEdges, positions: np.ndarray, values: np.ndarray, keep):
    """Per segment with ``keep``: the mean position of its points and its value."""
    ids = np.unique(found.segment[keep])
    counts = np.bincount(found.segment, minlength=int(found.segment.max()) + 1)
    sums = np.zeros((counts.size, 2))
    np.add.at(sums, found.segment, positions)
    centres = sums[ids] / counts[ids, None]
    first = np.zeros(counts.size, dtype=np.int64)
    first[found.segment[::-1]] = np.arange(found.segment.size)[::-1]
    return centres, values[first[ids]]


def refine_local(
    image: np.ndarray,
    cylinder: CylindricalRange,
    warp: Warp,
    *,
    max_iter: int = 6,
    radius: int = 5,
    axes: str = "v",
    spacing: float = 24.0,
    support: float = 0.5,
    distinct: float = 0.7,
    edges=None,
    jump: float = 0.2,
) -> tuple[np.ndarray, list[dict]]:
    r"""Local alignment: stretch the range image onto the intensity edges (App. A.2).

    The range image is sampled at ``warp⁻¹(x + d(x))`` for each mosaic pixel
    ``x`` (:func:`resample_range`); the displacement field ``d`` starts at 0.
    Each iteration:

    1. places the range edges on the mosaic (solving ``x = warp(e) − d(x)``);
    2. matches each segment of range edges, as a whole, to the intensity
       edges of the same orientation along its normal within ``radius``
       px (:func:`~refsynth.registration.edge_matching.match_segments`); its
       offset is the misalignment at that control point;
    3. stops if no matched segment is misaligned by more than the
       threshold — half the range image's sample spacing along that axis,
       the resolution below which a depth edge's position is unknown;
    4. otherwise interpolates the offsets of the misaligned segments
       cubically (Clough–Tocher) between the control points — anchored at
       zero at the segments that match where they are and far from any
       control point (:func:`_interpolate_field`) — adds the result to
       ``d`` (the "stretch") and checks again for matchings.

    Parameters
    ----------
    image : ndarray of shape (H, W) or (H, W, 3)
        The mosaic.
    cylinder : CylindricalRange
        The (partial) range image.
    warp : Warp
        The global warp (:func:`align_global` or :func:`~refsynth.registration.warp.fit_warp`).
    max_iter : int, default 6
        At most this many stretches.
    radius : int, default 5
        Search radius (px).
    axes : {"v", "uv", "u"}, default "v"
        Which components of ``d`` to estimate. The paper's sensor model
        (Eq. 20) has the laser and the camera on one pan axis, a vertical
        offset ``ΔY`` apart: ``u = a φ + α`` is exact and what Eq. 21 leaves
        is vertical (``f ΔY / ρ`` varies with each point's distance), so by
        default only ``d_v`` is stretched. ``"uv"`` stretches both (for a
        rig whose axes are not aligned), ``"u"`` only ``d_u``; vertical
        depth edges in a partial scan are located to ±1 slice only, which
        limits ``d_u``.
    spacing : float, default 24
        Zero anchors are put this far apart away from the control points.
    support, distinct : float
        Passed to :func:`~refsynth.registration.edge_matching.match_segments`.
    edges, jump
        As in :func:`align_global` (:func:`~refsynth.registration.pipeline.register`
        passes both stages the same).

    Returns
    -------
    displacement : ndarray of shape (2, H, W)
        ``d = (d_u, d_v)`` in px.
    history : list of dict
        Per iteration: ``misalignment`` (mean |offset| over the points of
        the matched segments, px), ``matched`` (their fraction of all range
        edge points) and ``controls`` (control points that moved).

    Examples
    --------
    >>> from refsynth.registration.examples import example_registration
    >>> views, scan, result = example_registration()
    >>> displacement, history = refine_local(result.mosaic.image, result.cylinder, result.warp)
    >>> displacement.shape == (2,) + result.mosaic.image.shape, sorted(history[0])
    (True, ['controls', 'matched', 'misalignment'])
    """
    check_choice("axes", axes, ("v", "u", "uv"))
    edge_map, gx, gy = intensity_edges(image) if edges is None else edges
    found = range_edges(cylinder, jump=jump)
    shape = edge_map.shape
    threshold = (abs(warp.a) * cylinder.phi_step / 2, abs(warp.b) * cylinder.h_step / 2)
    displacement = np.zeros((2, *shape))
    history: list[dict] = []
    for _ in range(max_iter + 1):
        positions = warp_forward(warp, displacement, found.phi, found.h)
        offset, _ = match_segments(
            positions, found, edge_map, gx, gy, radius, support=support, distinct=distinct
        )
        matched = np.isfinite(offset)
        entry = {
            "misalignment": float(np.mean(np.abs(offset[matched]))) if matched.any() else np.nan,
            "matched": float(matched.mean()) if matched.size else 0.0,
            "controls": 0,
        }
        history.append(entry)
        if len(history) > max_iter:
            break
        update = np.zeros_like(displacement)
        for component in [("u", "v").index(axis) for axis in axes]:
            pick = matched & (found.axis == component)
            if not pick.any():
                continue
            target = positions.copy()
            target[:, component] += np.where(pick, offset, 0.0)
            # the range edge at `positions` must move to `target`: d(target) += positions − target
            centres, values = _segment_means(found, target, -offset, pick)
            moved = np.abs(values) > threshold[component]
            if not moved.any():
                continue
            entry["controls"] += int(moved.sum())
            update[component] = _interpolate_field(
                centres[moved], values[moved], centres[~moved], shape, spacing
            )
        if entry["controls"] == 0:
            break
        displacement += update
    return displacement, history


# ----------------------------------------------------------------------------- resampling


def resample_range(
    cylinder: CylindricalRange,
    warp: Warp,
    shape: tuple[int, int],
    displacement: np.ndarray | None = None,
) -> np.ndarray:
    """The range image on the mosaic's grid: ``R(x) = range(warp⁻¹(x + d(x)))``.

    Nearest-sample lookup: range is not interpolated across the jumps of
    depth edges, and unscanned slices stay NaN (App. A, the last step
    before synthesis).

    Parameters
    ----------
    cylinder : CylindricalRange
        The range image on the cylinder (Eq. 19).
    warp : Warp
        The global warp of Eq. 21, range cylinder → mosaic.
    shape : tuple of int
        ``(H, W)`` of the mosaic.
    displacement : ndarray of shape (2, H, W), optional
        The local field ``d = (d_u, d_v)`` of :func:`refine_local`, px;
        default none.

    Returns
    -------
    ndarray of shape ``shape``
        NaN where nothing was scanned.

    Examples
    --------
    >>> from refsynth.registration.range_image import CylindricalRange
    >>> cylinder = CylindricalRange(np.array([[5.0, 6.0], [2.0, np.nan]]), np.array([0.0, 0.01]),
    ...                             np.array([0.5, -0.5]), 100.0)
    >>> warp = Warp(a=100.0, b=-1.0, alpha=0.0, beta=0.5)
    >>> resample_range(cylinder, warp, (2, 2))
    array([[ 5.,  6.],
           [ 2., nan]])
    """
    rows, cols = np.indices(shape, dtype=np.float64)
    if displacement is not None:
        cols = cols + displacement[0]
        rows = rows + displacement[1]
    phi, h = warp.invert(cols, rows)
    row, col = cylinder.index(phi, h)
    r_i, c_i = np.round(row).astype(np.int64), np.round(col).astype(np.int64)
    inside = (r_i >= 0) & (r_i < cylinder.range.shape[0]) & (c_i >= 0)
    inside &= c_i < cylinder.range.shape[1]
    out = np.full(shape, np.nan)
    out[inside] = cylinder.range[r_i[inside], c_i[inside]]
    return out
