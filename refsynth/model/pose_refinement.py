r"""Rigid refinement of a scan's pose: point-to-plane ICP on a k-d tree (stage 3).

Odometry tells where the robot scanned from only roughly; merging scans
(:mod:`refsynth.model.merge`) needs their poses to a fraction of the point
spacing. Iterative closest points (Besl & McKay 1992) with the
point-to-plane error of Chen & Medioni (1992) moves a scan's points ``p``
by a rigid motion ``T = (R, t)`` to minimise

.. math:: E(T) = \sum_i w_i \big( \mathbf{n}_i \cdot
          (R\,\mathbf{p}_i + \mathbf{t} - \mathbf{q}_i) \big)^2

over pairs ``(p_i, q_i)``, ``q_i`` the model's point nearest to ``T p_i``
(:class:`scipy.spatial.cKDTree`) and ``n_i`` the model's normal there
(:func:`estimate_normals`: the least-variance axis of the ``k`` nearest
neighbours). Each iteration linearises the rotation, ``R ≈ I + [ω]_×``, so
that the residual is ``(p × n)·ω + n·t + n·(p − q)`` and the update solves a
6×6 (or, with ``dof=4``, a 4×4: heading and translation only) least-squares
system; the rotation is then made exact (Rodrigues) and composed with ``T``.

Pairs are kept when ``|T p − q|`` is within a distance that starts at
``max_distance`` and shrinks to three times the median pair distance
(never below ``min_distance``); their weights are Tukey's biweight of the
point-to-plane residual at 4.685 robust standard deviations (1.4826 · MAD).
It stops when the update moves no point of the scan by more than
``tolerance`` (relative to the scan's median range), or when the pairs flip
between two sets and the transform comes back to within that of where it
was two iterations before, or after ``max_iterations``.

References
----------
P. J. Besl and N. D. McKay, "A method for registration of 3-D shapes",
IEEE PAMI 14(2) (1992). Y. Chen and G. Medioni, "Object modelling by
registration of multiple range images", Image and Vision Computing 10(3) (1992).
K.-L. Low, "Linear least-squares optimization for point-to-plane ICP surface
registration", UNC TR04-004 (2004).

L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §1 (stage 3; footnote 1: a large space
"cannot be perceived from a single vantage point"), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from refsynth._checks import check_int, check_real

__all__ = ["IcpResult", "icp", "estimate_normals", "rotation_about", "apply_transform",
           "alignment_error"]


def _check_cloud(name: str, points, minimum: int = 1) -> np.ndarray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3 or len(array) < minimum:
        raise ValueError(
            f"The parameter `{name}` must be an (N, 3) array with N >= {minimum}, "
            f"got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"The parameter `{name}` must be finite")
    return array


def _check_transform(name: str, transform) -> np.ndarray:
    array = np.asarray(transform, dtype=np.float64)
    if array.shape != (4, 4) or not np.all(np.isfinite(array)):
        raise ValueError(f"The parameter `{name}` must be a finite 4x4 matrix, got {array.shape}")
    return array


def apply_transform(transform, points) -> np.ndarray:
    """``R p + t`` for points (N, 3) and a 4×4 rigid transform ``[[R, t], [0, 1]]``.

    Parameters
    ----------
    transform : ndarray of shape (4, 4)
        ``[[R, t], [0, 0, 0, 1]]`` (not validated).
    points : ndarray of shape (N, 3)
        The points to move.

    Returns
    -------
    ndarray of shape (N, 3), float64
        ``points @ R.T + t``.

    Examples
    --------
    >>> shift = np.eye(4)
    >>> shift[:3, 3] = [1.0, 0.0, 2.0]
    >>> apply_transform(shift, np.zeros((2, 3))).tolist()
    [[1.0, 0.0, 2.0], [1.0, 0.0, 2.0]]
    """
    transform = _check_transform("transform", transform)
    points = np.asarray(points, dtype=np.float64)
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    out = np.empty(np.broadcast_shapes(points.shape, (3,)))
    for i, (a, b, c, t) in enumerate(transform[:3]):  # elementwise: no BLAS, same bits anywhere
        out[..., i] = a * x + b * y + c * z + t
    return out


def rotation_about(axis, angle: float) -> np.ndarray:
    """The 3×3 rotation by ``angle`` (radians, right-hand rule in the coordinates) about ``axis``.

    Rodrigues' formula ``I + sin θ K + (1 − cos θ) K²``, ``K = [k]_×``.
    """
    axis = np.asarray(axis, dtype=np.float64)
    norm = float(np.linalg.norm(axis))
    if norm == 0:
        return np.eye(3)
    k = axis / norm
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross


def estimate_normals(points, k: int = 10, tree: cKDTree | None = None,
                     index=None) -> np.ndarray:
    """Unit normals: the least-variance axis of each point's ``k`` nearest neighbours.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        The points (a model's vertices).
    k : int, default 10
        Neighbours per normal (the point itself included).
    tree : scipy.spatial.cKDTree, optional
        Of ``points``, if already built.
    index : array_like of int, optional
        Only the normals of ``points[index]`` (their neighbours are sought
        among all the points); default all.

    Returns
    -------
    ndarray of shape (N, 3) or (len(index), 3)
        The sign is arbitrary (point-to-plane ICP does not need it).

    Examples
    --------
    >>> grid = np.stack(np.meshgrid(np.arange(4.0), np.arange(4.0)), axis=-1).reshape(-1, 2)
    >>> plane = np.column_stack([grid, np.full(16, 3.0)])
    >>> np.abs(estimate_normals(plane, k=5)).round(12)[:2].tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    """
    points = _check_cloud("points", points, minimum=3)
    k = check_int("k", k, minimum=3)
    tree = cKDTree(points) if tree is None else tree
    probe = points if index is None else points[np.asarray(index, dtype=np.int64)]
    _, neighbours = tree.query(probe, k=min(k, len(points)))
    local = points[neighbours] - points[neighbours].mean(axis=1, keepdims=True)
    covariance = np.einsum("nki,nkj->nij", local, local)
    _, vectors = np.linalg.eigh(covariance)
    return vectors[:, :, 0]


@dataclass(frozen=True)
class IcpResult:
    """What :func:`icp` returns.

    Attributes
    ----------
    transform : ndarray of shape (4, 4)
        The refined rigid transform taking the source into the target's frame.
    iterations : int
        The updates made.
    converged : bool
        The last update moved no point by more than the tolerance (or the
        iterations settled into a cycle of two within it).
    rms : float
        RMS point-to-plane residual of the final inlier pairs.
    inliers : int
        Pairs used in the last iteration.

    Examples
    --------
    >>> x, z = (np.mgrid[0:6, 0:6] / 3.0).reshape(2, -1)
    >>> surface = np.column_stack([x, np.sin(3 * x) * np.cos(2 * z), z + 3.0])
    >>> result = icp(surface, surface)
    >>> result.converged, result.inliers, result.transform.shape
    (True, 36, (4, 4))
    """

    transform: np.ndarray
    iterations: int
    converged: bool
    rms: float
    inliers: int


def _subsample(points: np.ndarray, max_points: int) -> np.ndarray:
    if len(points) <= max_points:
        return points
    return points[np.linspace(0, len(points) - 1, max_points).round().astype(np.int64)]


def icp(source, target, initial=None, *, target_normals=None, max_iterations: int = 60,
        max_distance: float | None = None, min_distance: float = 0.0, dof: int = 6,
        max_points: int = 20000, tolerance: float = 1e-6, k: int = 10) -> IcpResult:
    """Align ``source`` to ``target`` by point-to-plane ICP, from ``initial``.

    Parameters
    ----------
    source : ndarray of shape (N, 3)
        The scan's points in its own frame.
    target : ndarray of shape (M, 3)
        The model so far, in the world frame.
    initial : ndarray of shape (4, 4), optional
        The odometry's estimate of the source's pose; default identity.
    target_normals : ndarray of shape (M, 3), optional
        Default :func:`estimate_normals` of ``target``, computed for the
        target points that are paired, when they first are.
    max_iterations : int, default 60
        Stop after this many updates, converged or not.
    max_distance : float, optional
        The first iterations' largest pair distance; default 10 % of the
        source's median range from its origin.
    min_distance : float, default 0
        The pair distance is never cut below this.
    dof : {6, 4}, default 6
        6: any rigid motion; 4: heading (about y) and translation only.
    max_points : int, default 20000
        The source is evenly subsampled to at most this many points.
    tolerance : float, default 1e-6
        Relative to the source's median range.
    k : int, default 10
        Neighbours per normal.

    Returns
    -------
    IcpResult

    Examples
    --------
    >>> rows, cols = np.mgrid[0:8, 0:8] / 4.0
    >>> x, z = rows.ravel(), cols.ravel()
    >>> surface = np.column_stack([x, np.sin(3 * x) * np.cos(2 * z), z + 3.0])
    >>> initial = np.eye(4)
    >>> initial[0, 3] = 0.05
    >>> result = icp(surface, surface, initial)
    >>> error = alignment_error(surface, result.transform, np.eye(4))
    >>> result.converged, bool(np.median(error) < 1e-6)
    (True, True)
    """
    source = _check_cloud("source", source)
    target = _check_cloud("target", target, minimum=3)
    transform = np.eye(4) if initial is None else _check_transform("initial", initial).copy()
    max_iterations = check_int("max_iterations", max_iterations, minimum=1)
    max_points = check_int("max_points", max_points, minimum=6)
    if isinstance(dof, (bool, np.bool_)) or dof not in (6, 4):
        raise ValueError(f"The parameter `dof` must be 6 or 4, got {dof!r}")
    tolerance = check_real("tolerance", tolerance, positive=True)
    min_distance = check_real("min_distance", min_distance, minimum=0.0)
    tree = cKDTree(target)
    if target_normals is None:  # estimated as pairs first need them
        normals = np.full(target.shape, np.nan)
    else:
        normals = _check_cloud("target_normals", target_normals, minimum=len(target))
    points = _subsample(source, max_points)
    scale = float(np.median(np.linalg.norm(points, axis=1))) or 1.0
    cutoff = 0.1 * scale if max_distance is None else check_real(
        "max_distance", max_distance, positive=True)
    columns = slice(None) if dof == 6 else [1, 3, 4, 5]
    converged, rms, inliers, iterations, history = False, float("nan"), 0, 0, []
    while iterations < max_iterations:
        iterations += 1
        moved = apply_transform(transform, points)
        distance, nearest = tree.query(moved, distance_upper_bound=cutoff)
        pair = np.isfinite(distance)
        if pair.sum() < 6:
            break
        matched = nearest[pair]
        missing = np.unique(matched[np.isnan(normals[matched, 0])])
        if missing.size:
            normals[missing] = estimate_normals(target, k=k, tree=tree, index=missing)
        p, q, n = moved[pair], target[matched], normals[matched]
        residual = np.einsum("ij,ij->i", n, p - q)
        sigma = 1.4826 * np.median(np.abs(residual - np.median(residual)))
        weight = np.ones_like(residual)
        if sigma > 0:
            u = residual / (4.685 * sigma)
            weight = np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0)
        jacobian = np.hstack([np.cross(p, n), n])[:, columns]
        normal_matrix = jacobian.T @ (jacobian * weight[:, None])
        try:
            step = np.linalg.solve(normal_matrix, -jacobian.T @ (weight * residual))
        except np.linalg.LinAlgError:
            break
        full = np.zeros(6)
        full[columns] = step
        omega, t = full[:3], full[3:]
        update = np.eye(4)
        update[:3, :3] = rotation_about(omega, float(np.linalg.norm(omega)))
        update[:3, 3] = t
        transform = update @ transform
        rms = float(np.sqrt(np.sum(weight * residual**2) / max(np.sum(weight), 1e-300)))
        inliers = int(np.count_nonzero(weight))
        shift = np.max(np.linalg.norm(apply_transform(update, p) - p, axis=1))
        if len(history) == 2:  # the pairs may flip between two sets: a cycle of two
            base = points[pair]
            shift = min(shift, np.max(np.linalg.norm(
                apply_transform(transform, base) - apply_transform(history[0], base), axis=1)))
        history = [*history[-1:], transform]
        cutoff = max(min(cutoff, 3.0 * float(np.median(distance[pair]))), min_distance,
                     1e-9 * scale)
        if shift <= tolerance * scale:
            converged = True
            break
    return IcpResult(transform=transform, iterations=iterations, converged=converged,
                     rms=rms, inliers=inliers)


def alignment_error(points, estimated, true) -> np.ndarray:
    """Per point, how far the estimated pose puts it from where the true pose does.

    ``|T_est p − T_true p|`` for the scan's own points ``p`` (N, 3); its median
    is the alignment error the tests and benchmarks report.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        The scan's points in its own frame.
    estimated : ndarray of shape (4, 4)
        The estimated pose (e.g. :attr:`IcpResult.transform`).
    true : ndarray of shape (4, 4)
        The true pose.

    Returns
    -------
    ndarray of shape (N,)
        Distances, in the points' unit.

    Examples
    --------
    >>> shift = np.eye(4)
    >>> shift[0, 3] = 0.05
    >>> alignment_error(np.ones((2, 3)), shift, np.eye(4)).round(12).tolist()
    [0.05, 0.05]
    """
    points = _check_cloud("points", points)
    return np.linalg.norm(apply_transform(estimated, points) - apply_transform(true, points),
                          axis=1)
