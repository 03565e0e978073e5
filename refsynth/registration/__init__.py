r"""Registration: a panorama with depth (Appendix A of the paper, Eqs. 14–21).

Before range can be synthesized, the camera's pictures and the laser's partial
scan must become one intensity image and one range image on a common grid.

A.1 The cylindrical panorama (Eqs. 14–18)
    :mod:`~refsynth.registration.cylinder`
        Eq. 14: points, image coordinates and whole views on the cylinder of
        radius ``f`` (``cylindrical_warp`` and its inverse).
    :mod:`~refsynth.registration.translation`
        Eqs. 15–17: the translation between two overlapping views by
        Gauss–Newton (whole-pixel search, scale space, photometric terms).
    :mod:`~refsynth.registration.mosaicking`
        Eq. 18: hat weights, blending, the mosaic (180° or 360°).
    :mod:`~refsynth.registration.interpolation`
        The NaN-aware image sampling under every warp.

A.2 Laser–camera registration (Eqs. 19–21)
    :mod:`~refsynth.registration.range_image`
        Eq. 19: the spherical scan as a cylindrical range image of radius ``f``.
    :mod:`~refsynth.registration.warp`
        Eqs. 20–21: the warp from the range image to the mosaic, its fits, and
        laser points placed on the mosaic (``warp_forward``).
    :mod:`~refsynth.registration.edge_matching`
        Depth ("3-D") and intensity ("2-D") edges and their correspondences.
    :mod:`~refsynth.registration.alignment`
        The global warp from edge matches, the local stretch, the range
        resampled on the mosaic.
    :mod:`~refsynth.registration.pipeline`
        All of Appendix A in one call: ``register`` and ``register_scan``.
    :mod:`~refsynth.registration.scoring`
        A registration scored against the test rig's ground truth (§4.1).
    :mod:`~refsynth.registration.examples`
        The small rig (two views and a scan) the Examples register.

The command line's side (``python -m refsynth register``) is in
:mod:`refsynth.cli.register`.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A, doi:10.1007/s11263-007-0108-2.
"""

from refsynth.registration.alignment import align_global, refine_local, resample_range
from refsynth.registration.cylinder import (
    cylinder_coordinates,
    cylindrical_unwarp,
    cylindrical_warp,
    perspective_coordinates,
    project_to_cylinder,
)
from refsynth.registration.edge_matching import (
    RangeEdges,
    intensity_edges,
    match_edges,
    match_segments,
    range_edges,
)
from refsynth.registration.examples import example_registration, example_rig
from refsynth.registration.mosaicking import Mosaic, blend, hat_weight, hat_weights, mosaic
from refsynth.registration.pipeline import Registration, register, register_scan
from refsynth.registration.range_image import (
    CylindricalRange,
    cartesian_to_spherical,
    scan_to_cylinder,
    spherical_to_cartesian,
    spherical_to_cylindrical,
)
from refsynth.registration.scoring import mosaic_position, registration_errors
from refsynth.registration.translation import align_translation, gauss_newton_step
from refsynth.registration.warp import Warp, eq20_warp, fit_warp, fit_warp_eq20, warp_forward

__all__ = [
    # A.1, Eq. 14
    "project_to_cylinder",
    "cylinder_coordinates",
    "perspective_coordinates",
    "cylindrical_warp",
    "cylindrical_unwarp",
    # A.1, Eqs. 15–17
    "gauss_newton_step",
    "align_translation",
    # A.1, Eq. 18
    "hat_weight",
    "hat_weights",
    "blend",
    "Mosaic",
    "mosaic",
    # A.2, Eq. 19
    "spherical_to_cartesian",
    "cartesian_to_spherical",
    "spherical_to_cylindrical",
    "CylindricalRange",
    "scan_to_cylinder",
    # A.2, Eqs. 20–21
    "Warp",
    "fit_warp",
    "eq20_warp",
    "fit_warp_eq20",
    "warp_forward",
    # A.2, edges and alignment
    "RangeEdges",
    "range_edges",
    "intensity_edges",
    "match_edges",
    "match_segments",
    "align_global",
    "refine_local",
    "resample_range",
    # Appendix A in one call
    "Registration",
    "register",
    "register_scan",
    # scoring on the test rig
    "mosaic_position",
    "registration_errors",
    # the Examples' rig
    "example_rig",
    "example_registration",
]
