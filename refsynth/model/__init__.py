r"""Stage 3, the 3-D model: dense range + intensity → coloured points and a mesh, poses merged.

The paper divides 3-D environment modelling into three stages (§1): "(1)
sensor data acquisition and data registration; (2) depth inference or shape
recovery; and (3) data integration for model representation". This
subpackage is the third: it starts where :func:`refsynth.synthesize` ends.

:mod:`~refsynth.model.cameras`
    Back-projection and projection for the cylindrical panorama (Eqs. 14,
    19: column ↔ pan angle, row ↔ height on the cylinder of radius ``f``;
    range = Euclidean distance) and the pinhole camera (range = depth,
    ``z = f B / (d + d_offs)`` from a disparity).
:mod:`~refsynth.model.mesh`
    Two triangles per 2×2 cell, none across a depth discontinuity (a jump
    of more than ``max_jump`` × the nearer range per pixel), as MVE's
    depth-map triangulation.
:mod:`~refsynth.model.build`
    :func:`build_model`: one scan position's :class:`Model`, coloured by the
    registered intensity, with each point's confidence and whether it was
    measured or synthesized.
:mod:`~refsynth.model.ply`
    :func:`write_ply` (binary little-endian or ASCII) and :func:`read_ply`.
:mod:`~refsynth.model.merge`
    :class:`Pose`, :func:`merge_models` (one world frame, the overlap fused
    in a voxel grid keeping the most confident scan) and
    :func:`refine_poses` (ICP).
:mod:`~refsynth.model.pose_refinement`
    Point-to-plane ICP on :class:`scipy.spatial.cKDTree`.

The numeric contract
--------------------
The mesh's decisions (which triangles stay) depend only on the range values
given, so they are the same on every machine. Fusion (which cube a point
falls in) and ICP (which points pair, the normals' ``eigh``) depend on
computed coordinates (libm's sines, LAPACK): they are reproducible on one
machine but not promised bit-identical across machines.

Examples
--------
>>> import numpy as np
>>> from refsynth.model import CylindricalCamera, build_model
>>> camera = CylindricalCamera.centred(300.0, (4, 6))
>>> model = build_model(np.full((4, 6), 5.0), camera)
>>> model.n_vertices, model.n_faces
(24, 30)

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §1 (the three stages) and Appendix A
(Eqs. 14, 19), doi:10.1007/s11263-007-0108-2.
"""

from refsynth.model.build import Model, build_model, intensity_colours
from refsynth.model.cameras import CylindricalCamera, PinholeCamera, disparity_to_depth
from refsynth.model.merge import (
    Pose,
    merge_models,
    point_spacing,
    pose_matrix,
    refine_poses,
    transform_model,
)
from refsynth.model.mesh import DEFAULT_MAX_JUMP, depth_discontinuity, grid_faces
from refsynth.model.ply import read_ply, write_ply
from refsynth.model.pose_refinement import (
    IcpResult,
    alignment_error,
    apply_transform,
    estimate_normals,
    icp,
)

__all__ = [
    # cameras (Eqs. 14, 19; pinhole)
    "CylindricalCamera",
    "PinholeCamera",
    "disparity_to_depth",
    # the mesh
    "grid_faces",
    "depth_discontinuity",
    "DEFAULT_MAX_JUMP",
    # one scan position
    "Model",
    "build_model",
    "intensity_colours",
    # files
    "write_ply",
    "read_ply",
    # several positions
    "Pose",
    "pose_matrix",
    "transform_model",
    "merge_models",
    "refine_poses",
    "point_spacing",
    "icp",
    "IcpResult",
    "estimate_normals",
    "apply_transform",
    "alignment_error",
]
