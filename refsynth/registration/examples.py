"""The small rig the registration Examples run on (Appendix A; §4.1).

Every docstring example from the mosaic (Eq. 18) to the scoring needs
camera views and a laser scan of one room. They are made here, once: two
views 80 px high of :func:`refsynth.scenes.rig_room` and a full-height scan
of the same 80° of it, small enough to register in about a second.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §4.1, Appendix A,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from refsynth.registration.pipeline import Registration, register
from refsynth.scenes import LaserScan, RigViews, laser_scan, render_views, rig_room

__all__ = ["example_rig", "example_registration"]


def example_rig(seed: int = 0) -> tuple[RigViews, LaserScan]:
    """Two camera views and a laser scan of the rig's room, for examples and tests.

    Parameters
    ----------
    seed : int, default 0
        The room's seed (:func:`refsynth.scenes.rig_room`).

    Returns
    -------
    views : RigViews
        Two views, focal length 150 px, 80 px high, the first at pan −0.3 rad
        (:func:`refsynth.scenes.render_views`, one ray per pixel).
    scan : LaserScan
        The scan over azimuths ±0.7 rad, every 0.01 rad, mirror steps of
        0.005 rad, no stripes (:func:`refsynth.scenes.laser_scan`).

    Examples
    --------
    >>> views, scan = example_rig()
    >>> len(views.images), views.images[0].shape, scan.r.shape
    (2, (80, 60), (141, 245))
    """
    room = rig_room(seed)
    views = render_views(room, focal=150.0, n_views=2, start_angle=-0.3, height=80,
                         supersample=1)
    scan = laser_scan(room, phi_range=(-0.7, 0.7), pan_step=0.01, theta_step=0.005,
                      stripes=None)
    return views, scan


def example_registration(seed: int = 0) -> tuple[RigViews, LaserScan, Registration]:
    """:func:`example_rig` and its registration by the global warp alone (``refine=False``).

    Parameters
    ----------
    seed : int, default 0
        The room's seed.

    Returns
    -------
    views : RigViews
    scan : LaserScan
        As :func:`example_rig`.
    registration : Registration
        :func:`refsynth.registration.pipeline.register` of them, without the
        local stretch.

    Examples
    --------
    >>> views, scan, result = example_registration()
    >>> result.crop, result.displacement is None
    ((1, 79, 1, 106), True)
    """
    views, scan = example_rig(seed)
    result = register(views.images, views.pan_angles, views.focal,
                      (scan.r, scan.theta, scan.phi), refine=False)
    return views, scan, result
