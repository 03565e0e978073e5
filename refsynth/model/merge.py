r"""Several scan positions in one world frame: poses, merging, fusion of the overlap (stage 3).

A large indoor space "cannot be entirely perceived from a single vantage
point" (the paper's footnote 1): the robot scans from several positions and
stage 3 puts the models together.

Poses
-----
A :class:`Pose` is where a scan was taken, in refsynth's frame (x right,
y up, z forward): the position ``(x, z)`` on the floor, an optional height
``y``, and the ``heading``, the rotation about the vertical axis that takes
the scanner's pan angle 0 to the world's, in the sense of the pan angles
(from z towards x). A point ``p`` of the scan goes to

.. math:: \mathbf{p}_w = R_y(\text{heading})\,\mathbf{p} + (x, y, z), \qquad
          R_y(\eta) = \begin{pmatrix}\cos\eta & 0 & \sin\eta\\ 0&1&0\\
          -\sin\eta & 0 & \cos\eta\end{pmatrix}

so that a pan angle ``φ`` of the scan is the world azimuth ``φ + heading``.
(The issue's "x, y, heading; optionally z" is the same pose in a z-up floor
plan: its y is our z, its z our y.) Anything 4×4 (``[[R, t], [0, 1]]``, e.g.
what :func:`refine_poses` returns) is accepted where a pose is.

Fusion
------
Where scans overlap, the merged model would be twice as dense and carry two
slightly different copies of each surface. :func:`merge_models` cuts space
into cubes of side ``voxel`` and gives each cube to one scan: the scan of
the cube's most confident point (ties: the point nearer to its own scanner,
whose samples are denser and less noisy; then the earlier scan). A point
stays if its scan owns its cube; a triangle stays if its scan owns the cube
of its centroid (if no point lies in that cube: of its first vertex), and keeps its three
vertices — so that the meshes of two scans meet at the cubes' borders
instead of leaving a gap a triangle wide. One scan alone is never thinned;
there is no averaging, which would blur depth edges and mix two exposures'
colours.

References
----------
Torres-Méndez & Dudek (2008; in full in :mod:`refsynth.model`), §1 (stage 3
and footnote 1), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from refsynth._checks import check_real
from refsynth.model.build import Model
from refsynth.model.pose_refinement import IcpResult, apply_transform, icp

__all__ = ["Pose", "pose_matrix", "transform_model", "merge_models", "refine_poses",
           "point_spacing"]


@dataclass(frozen=True)
class Pose:
    """A scan position: floor position ``(x, z)``, heading about y (radians), height ``y``.

    Examples
    --------
    >>> pose = Pose(x=1.0, z=2.0, heading=np.pi / 2)
    >>> np.round(pose.apply([0.0, 0.0, 1.0]), 12) + 0.0   # pan angle 0 looks along +x
    array([2., 0., 2.])
    >>> Pose.from_matrix(pose.matrix()) == pose
    True
    """

    x: float = 0.0
    z: float = 0.0
    heading: float = 0.0
    y: float = 0.0

    def __post_init__(self):
        for name in ("x", "z", "heading", "y"):
            object.__setattr__(self, name, check_real(name, getattr(self, name)))

    def matrix(self) -> np.ndarray:
        """The 4×4 transform from the scan's frame to the world's."""
        c, s = math.cos(self.heading), math.sin(self.heading)
        return np.array([[c, 0.0, s, self.x], [0.0, 1.0, 0.0, self.y],
                         [-s, 0.0, c, self.z], [0.0, 0.0, 0.0, 1.0]])

    def apply(self, points) -> np.ndarray:
        """Scan points (..., 3) in the world frame."""
        points = np.asarray(points, dtype=np.float64)
        return apply_transform(self.matrix(), points.reshape(-1, 3)).reshape(points.shape)

    @classmethod
    def from_matrix(cls, transform) -> Pose:
        """The pose nearest a 4×4 transform: its translation and the heading of its z axis."""
        transform = pose_matrix(transform)
        heading = math.atan2(transform[0, 2], transform[2, 2])
        x, y, z = (float(v) for v in transform[:3, 3])
        return cls(x=x, z=z, heading=heading, y=y)


def pose_matrix(pose) -> np.ndarray:
    """A :class:`Pose` or a 4×4 rigid transform as a float64 4×4 array (validated, stage 3).

    Parameters
    ----------
    pose : Pose or array_like of shape (4, 4)
        A scan position (stage 3), or ``[[R, t], [0, 1]]`` with ``R`` a
        rotation.

    Returns
    -------
    ndarray of shape (4, 4), float64
        The transform from the scan's frame to the world's.

    Raises
    ------
    ValueError
        If ``pose`` is not a 4×4 rigid transform.

    Examples
    --------
    >>> pose_matrix(Pose(x=1.0, z=2.0))[:3, 3].tolist()
    [1.0, 0.0, 2.0]
    """
    if isinstance(pose, Pose):
        return pose.matrix()
    matrix = np.asarray(pose, dtype=np.float64)
    if matrix.shape != (4, 4) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"A pose must be a Pose or a finite 4x4 matrix, got {matrix.shape}")
    rotation = matrix[:3, :3]
    if (not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6)
            or not np.allclose(matrix[3], [0, 0, 0, 1]) or np.linalg.det(rotation) < 0):
        raise ValueError("A pose matrix must be rigid: [[R, t], [0, 0, 0, 1]] with R a rotation")
    return matrix


def transform_model(model: Model, pose) -> Model:
    """``model`` with its vertices moved into the world frame by ``pose`` (stage 3).

    Parameters
    ----------
    model : Model
        In its scanner's frame.
    pose : Pose or array_like of shape (4, 4)
        Where it was scanned from (see :func:`pose_matrix`).

    Returns
    -------
    Model
        A new model; only the vertices differ.

    Examples
    --------
    >>> from refsynth.model import PinholeCamera, build_model
    >>> model = build_model(np.full((2, 2), 3.0), PinholeCamera(100.0, 0.5, 0.5))
    >>> moved = transform_model(model, Pose(x=1.0))
    >>> (moved.vertices - model.vertices).tolist()[0], moved.n_faces
    ([1.0, 0.0, 0.0], 2)
    """
    if not isinstance(model, Model):
        raise TypeError(f"The parameter `model` must be a Model, got {type(model).__name__}")
    return Model(vertices=apply_transform(pose_matrix(pose), model.vertices),
                 colours=model.colours, confidence=model.confidence,
                 synthesized=model.synthesized, faces=model.faces, pixels=model.pixels,
                 source=model.source, uncertainty=model.uncertainty)


def point_spacing(points, samples: int = 2000) -> float:
    """The median distance from a point to its nearest neighbour (an even subsample's).

    The sample spacing that sets :func:`merge_models`' default fusion voxel (stage 3).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        The points (a model's vertices).
    samples : int, default 2000
        At most this many points, evenly spaced in ``points``, are measured.

    Returns
    -------
    float
        In the points' unit.

    Examples
    --------
    >>> point_spacing(np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 2.0, 0.0]]))
    0.5
    """
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 2:
        raise ValueError("The parameter `points` must hold at least 2 points")
    tree = cKDTree(points)
    probe = points[np.linspace(0, len(points) - 1, min(samples, len(points))).astype(np.int64)]
    distance, _ = tree.query(probe, k=2)
    return float(np.median(distance[:, 1]))


def _check_inputs(models, poses) -> tuple[list[Model], list[np.ndarray]]:
    models, poses = list(models), list(poses)
    if not models or len(models) != len(poses):
        raise ValueError(
            f"The parameters `models` and `poses` must be non-empty and of one length, "
            f"got {len(models)} and {len(poses)}"
        )
    for model in models:
        if not isinstance(model, Model):
            raise TypeError(f"The parameter `models` must hold Models, got {type(model).__name__}")
    return models, [pose_matrix(pose) for pose in poses]


def merge_models(models, poses, *, voxel: float | None = None) -> Model:
    """Several scans' models in one world frame, the overlap fused (stage 3; module docstring).

    Parameters
    ----------
    models : sequence of Model
        Each in its scanner's frame (:func:`refsynth.model.build.build_model`).
    poses : sequence of Pose or 4×4 arrays
        Where each was scanned from.
    voxel : float, optional
        The fusion cube's side, in the models' unit; default three times the first
        model's :func:`point_spacing` (so that fusion acts where the scans'
        samples are as close as one scan's own).

    Returns
    -------
    Model
        Vertices of scan 0, then scan 1, … (those that stay), with
        ``Model.source`` saying which; ``pixels`` as in the inputs when all
        have them.

    Examples
    --------
    >>> from refsynth.model import PinholeCamera, build_model
    >>> model = build_model(np.full((4, 4), 3.0), PinholeCamera(4.0, 1.5, 1.5))
    >>> merged = merge_models([model, model], [Pose(), Pose()])
    >>> len(model.vertices), len(merged.vertices), np.unique(merged.source).tolist()
    (16, 16, [0])
    """
    models, matrices = _check_inputs(models, poses)
    world = [transform_model(m, t) for m, t in zip(models, matrices)]
    vertices = np.concatenate([m.vertices for m in world])
    source = np.concatenate([np.full(m.n_vertices, k, dtype=np.int64)
                             for k, m in enumerate(world)])
    if voxel is None:
        voxel = 3.0 * point_spacing(models[0].vertices) if models[0].n_vertices > 1 else 1.0
    voxel = check_real("voxel", voxel, positive=True)
    offsets = np.cumsum([0] + [m.n_vertices for m in world])
    faces = np.concatenate([m.faces + offsets[k] for k, m in enumerate(world)]).reshape(-1, 3)
    keep = np.ones(len(vertices), dtype=bool)
    if len(world) > 1 and len(vertices):
        keep, faces = _fuse(world, matrices, vertices, source, faces, voxel)
    pixels = (np.concatenate([m.pixels for m in world])
              if all(m.pixels is not None for m in world) else None)
    uncertainty = (np.concatenate([m.uncertainty for m in world])
                   if all(m.uncertainty is not None for m in world) else None)
    merged = Model(
        vertices=vertices,
        colours=np.concatenate([m.colours for m in world]),
        confidence=np.concatenate([m.confidence for m in world]),
        synthesized=np.concatenate([m.synthesized for m in world]),
        faces=faces.astype(np.int64), pixels=pixels, source=source, uncertainty=uncertainty,
    )
    return merged.subset(keep)


def _fuse(world, matrices, vertices, source, faces, voxel):
    """The vertices that stay and the triangles that stay (module docstring, Fusion)."""
    confidence = np.concatenate([m.confidence for m in world])
    centres = np.stack([t[:3, 3] for t in matrices])
    distance = np.linalg.norm(vertices - centres[source], axis=1)
    cube = _VoxelGrid(vertices, voxel)
    cell = cube.keys(vertices)
    order = np.lexsort((source, distance, -confidence, cell))
    first = np.ones(len(order), dtype=bool)
    first[1:] = cell[order][1:] != cell[order][:-1]
    cells, owners = cell[order][first], source[order][first]  # sorted by cell
    keep = source == owners[np.searchsorted(cells, cell)]
    if len(faces):  # a triangle stays where its scan owns the cube of its centroid
        face_cell = cube.keys(vertices[faces].mean(axis=1))
        at = np.clip(np.searchsorted(cells, face_cell), 0, len(cells) - 1)
        first_vertex = owners[np.searchsorted(cells, cell[faces[:, 0]])]
        owner = np.where(cells[at] == face_cell, owners[at], first_vertex)
        faces = faces[owner == source[faces[:, 0]]]
        keep[faces.ravel()] = True  # with its three vertices
    return keep, faces


class _VoxelGrid:
    """Cubes of side ``voxel`` over the bounding box of ``points``, numbered by one int64."""

    def __init__(self, points: np.ndarray, voxel: float):
        self.origin, self.voxel = points.min(axis=0), voxel
        self.extent = np.floor((points.max(axis=0) - self.origin) / voxel).astype(np.int64) + 1
        if float(np.prod(self.extent.astype(np.float64))) >= 2.0**62:
            raise ValueError(f"The parameter `voxel` ({voxel}) is too small for the models' "
                             "extent")

    def keys(self, points: np.ndarray) -> np.ndarray:
        cells = np.floor((points - self.origin) / self.voxel).astype(np.int64)
        cells = np.clip(cells, 0, self.extent - 1)
        return (cells[:, 0] * self.extent[1] + cells[:, 1]) * self.extent[2] + cells[:, 2]


def refine_poses(models, poses, *, voxel: float | None = None, dof: int = 6,
                 **options) -> tuple[list[np.ndarray], list[IcpResult | None]]:
    """Refine the poses of scans 1, 2, … by ICP against the model merged so far (stage 3).

    Scan 0 stays where its pose puts it (it defines the world frame). Scan
    ``k`` is aligned by :func:`refsynth.model.pose_refinement.icp` (point-to-plane),
    starting from its pose, to :func:`merge_models` of scans ``0 … k − 1``
    with their refined poses.

    Parameters
    ----------
    models, poses
        As for :func:`merge_models`.
    voxel : float, optional
        Passed to :func:`merge_models` for the model so far.
    dof : {6, 4}, default 6
        6: a rigid motion; 4: heading and translation only.
    **options
        Further keyword arguments of :func:`refsynth.model.pose_refinement.icp`
        (``max_distance``, ``max_iterations``, ``max_points`` …).

    Returns
    -------
    transforms : list of ndarray of shape (4, 4)
        The refined poses (scan 0's unchanged).
    results : list of IcpResult or None
        ICP's report per scan (None for scan 0).

    Examples
    --------
    >>> from refsynth.model import PinholeCamera, build_model
    >>> rows, cols = np.mgrid[0:12, 0:12]
    >>> model = build_model(3.0 + 0.3 * np.sin(rows) + 0.2 * np.cos(1.3 * cols),
    ...                     PinholeCamera(6.0, 5.5, 5.5))
    >>> transforms, results = refine_poses([model, model], [Pose(), Pose(x=0.05)])
    >>> bool(np.allclose(transforms[1], np.eye(4))), results[0], results[1].converged
    (True, None, True)
    """
    models, matrices = _check_inputs(models, poses)
    refined, results = [matrices[0]], [None]
    for k in range(1, len(models)):
        so_far = merge_models(models[:k], refined, voxel=voxel)
        result = icp(models[k].vertices, so_far.vertices, matrices[k], dof=dof, **options)
        refined.append(result.transform)
        results.append(result)
    return refined, results
