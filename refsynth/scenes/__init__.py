"""Scenes with registered intensity and ground-truth range (§3.3, §4; §4.1 and Appendix A).

The data every experiment runs on, and the synthetic rig registration is
scored on.

§3.3 and §4: scenes for range synthesis
    :mod:`~refsynth.scenes.scene`
        :class:`Scene`: an intensity image, its ground-truth range, units, a
        name.
    :mod:`~refsynth.scenes.synthetic`
        :func:`synthetic_room`: a ray-cast indoor scene in metres, the
        stand-in for the USF range database and the authors' lab scans;
        :func:`room_geometry`: its room for a seed (what the simulated rig of
        :mod:`refsynth.acquisition` scans).
    :mod:`~refsynth.scenes.middlebury`
        :func:`motorcycle` (Middlebury 2014, resized to the paper's
        450 × 375, Table 4) and :func:`load_middlebury` (any image +
        disparity from disk).
    :mod:`~refsynth.scenes.rgbd`
        :func:`load_rgbd`: any image with its depth or disparity from disk
        (PNG of stored integers with their scale and invalid values,
        ``.npy``, ``.pfm``), an optional crop, and Table 4's protocol
        (centred crop to the target's aspect, area resize);
        :func:`load_rgbd_folder`: a folder described by a ``scene.json``.
    :mod:`~refsynth.scenes.resize`
        Exact area-averaging resizes for non-integer factors, and the masked
        one for disparity maps with holes.

One room model, one ray caster
    :mod:`~refsynth.scenes.room`
        :class:`RoomGeometry` (a room box, yawed furniture boxes, a distant
        light, a texture) and :func:`cast_rays` (slab intersection, albedo,
        Lambertian shading), shared by the synthetic scenes and the rig.

§3.1, §4.1 and Appendix A: the registration test rig
    :mod:`~refsynth.scenes.rig`
        :func:`rig_room`: a furnished room 5–8 m around the rig;
        :func:`laser_scan`: the partial spherical scan from ``ΔY`` below the
        camera; the rig's constants.
    :mod:`~refsynth.scenes.rig_views`
        :func:`render_views` (views every 18° with pose errors, jitter,
        vignetting, noise) and :func:`texture_views` (views cut from a
        photograph on the cylinder).

The same bits on every machine
    :mod:`~refsynth.scenes.portable`
        What the ray casters, textures and poses use instead of BLAS products,
        ``np.linalg.norm``, ``hypot`` and numpy's SIMD trigonometry: explicit
        3-term dot products, rotations and norms, and portable ``sin``,
        ``cos``, ``tan``, ``arctan``, ``arctan2``. The resizes sum in a fixed
        order. Every scene is bit-identical under any BLAS kernel, thread
        count and SIMD width (``tests/test_determinism_scenes.py``).

Scoring a registration against the rig's ground truth needs the registration
stage and lives there: :mod:`refsynth.registration.scoring`.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3, §4, §4.1, Appendix A,
doi:10.1007/s11263-007-0108-2.
"""

from refsynth.scenes.middlebury import MOTORCYCLE_CROP, load_middlebury, motorcycle
from refsynth.scenes.resize import MIN_DISPARITY_COVERAGE, resize_area, resize_disparity
from refsynth.scenes.rgbd import (
    TABLE4_SIZE,
    centre_crop,
    load_rgbd,
    load_rgbd_folder,
    read_scene_metadata,
)
from refsynth.scenes.rig import (
    CAMERA_STEP,
    DELTA_Y,
    FOCAL,
    LASER_PAN_STEP,
    MIRROR_STEP,
    LaserScan,
    RigTexture,
    cast_rig_rays,
    laser_scan,
    rig_room,
)
from refsynth.scenes.rig_views import RigViews, render_views, texture_views, view_width
from refsynth.scenes.room import (
    AMBIENT,
    Intersections,
    RayHits,
    RoomGeometry,
    Texture,
    cast_rays,
    intersect,
    ray_box,
    shading,
)
from refsynth.scenes.scene import Scene
from refsynth.scenes.synthetic import SyntheticTexture, room_geometry, synthetic_room

__all__ = [
    # §3.3, §4: scenes for range synthesis
    "Scene",
    "synthetic_room",
    "room_geometry",
    "SyntheticTexture",
    "motorcycle",
    "MOTORCYCLE_CROP",
    "load_middlebury",
    "load_rgbd",
    "load_rgbd_folder",
    "read_scene_metadata",
    "centre_crop",
    "TABLE4_SIZE",
    "resize_area",
    "resize_disparity",
    "MIN_DISPARITY_COVERAGE",
    # the room model and the ray caster
    "RoomGeometry",
    "Texture",
    "Intersections",
    "RayHits",
    "cast_rays",
    "intersect",
    "ray_box",
    "shading",
    "AMBIENT",
    # §3.1, §4.1, Appendix A: the registration test rig
    "rig_room",
    "RigTexture",
    "cast_rig_rays",
    "LaserScan",
    "laser_scan",
    "view_width",
    "RigViews",
    "render_views",
    "texture_views",
    "FOCAL",
    "DELTA_Y",
    "CAMERA_STEP",
    "LASER_PAN_STEP",
    "MIRROR_STEP",
]
