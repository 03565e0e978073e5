r"""Camera views + a partial laser scan → registered intensity and range (Appendix A).

The whole of Appendix A in one call, :func:`register` (and
:func:`register_scan`, its front end for ``refsynth.synthesize``):

1. the cylindrical panorama of the views (A.1, Eqs. 14–18,
   :mod:`refsynth.registration.mosaicking`);
2. the scan as a cylindrical range image (A.2, Eq. 19,
   :mod:`refsynth.registration.range_image`);
3. the global warp of Eq. 21 (:mod:`refsynth.registration.warp`) from the
   rig's nominal geometry, refined on edge correspondences, and the local
   stretch (:mod:`refsynth.registration.alignment`);
4. the range resampled on the mosaic's grid, both cropped to the rectangle
   every view covers.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), Appendix A, Eqs. 14–21,
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from refsynth._checks import check_real
from refsynth.registration.alignment import align_global, refine_local, resample_range
from refsynth.registration.edge_matching import intensity_edges
from refsynth.registration.mosaicking import Mosaic, mosaic
from refsynth.registration.range_image import CylindricalRange, scan_to_cylinder
from refsynth.registration.warp import Warp, warp_forward

__all__ = ["Registration", "register", "register_scan"]


@dataclass(frozen=True, eq=False)
class Registration:
    """What :func:`register` returns: everything between the views + scan and synthesis.

    Attributes
    ----------
    intensity : ndarray of shape (H, W) or (H, W, C)
        The mosaic cropped to the largest rectangle every pixel of which is
        covered (finite everywhere).
    partial_range : ndarray of shape (H, W)
        The registered range on the same grid; NaN where not scanned.
    crop : tuple of int
        ``(row0, row1, col0, col1)`` of the crop in the mosaic.
    mosaic : Mosaic
    cylinder : CylindricalRange
        The scan on the cylinder (Eq. 19), one column per smallest gap
        between its slices: what the warp is fitted to.
    measured : CylindricalRange
        The scan on the cylinder at the rig's slice step (``slice_step`` of
        :func:`register`; ``cylinder`` without it): a column per pan
        position, NaN where no slice was taken; ``partial_range`` is
        resampled from it.
    initial : Warp
        The warp from the rig's nominal geometry.
    warp : Warp
        The global warp (Eq. 21) after :func:`~refsynth.registration.alignment.align_global`.
    displacement : ndarray of shape (2, H_m, W_m) or None
        The local field of :func:`~refsynth.registration.alignment.refine_local`
        on the whole mosaic.
    global_info : dict
        What :func:`~refsynth.registration.alignment.align_global` reports
        (``shift``, ``matches``, ``misalignment``).
    history : list of dict
        The local refinement's iterations (misalignment before → after).

    Examples
    --------
    >>> from refsynth.registration.examples import example_registration
    >>> views, scan, result = example_registration()  # register(..., refine=False)
    >>> result.displacement is None, result.warp.a == result.initial.a, sorted(result.global_info)
    (True, True, ['matches', 'misalignment', 'shift'])
    """

    intensity: np.ndarray
    partial_range: np.ndarray
    crop: tuple[int, int, int, int]
    mosaic: Mosaic
    cylinder: CylindricalRange
    initial: Warp
    warp: Warp
    displacement: np.ndarray | None
    global_info: dict = field(default_factory=dict)
    history: list = field(default_factory=list)
    measured: CylindricalRange | None = None

    def forward(self, phi, h) -> np.ndarray:
        """Mosaic ``(u, v)`` (full mosaic, not the crop) of laser points ``(φ, h)``."""
        phi, h = np.broadcast_arrays(np.asarray(phi, float), np.asarray(h, float))
        out = warp_forward(self.warp, self.displacement, phi.ravel(), h.ravel())
        return out.reshape(*phi.shape, 2)


def _covered_rectangle(weight: np.ndarray) -> tuple[int, int, int, int]:
    """The rows and columns, as ``(row0, row1, col0, col1)``, all of whose pixels are covered.

    Rows: those covered across the whole covered column span; columns: the
    longest run of fully covered columns within those rows.
    """
    covered = weight > 0
    columns = np.nonzero(covered.any(axis=0))[0]
    full_rows = np.nonzero(covered[:, columns[0] : columns[-1] + 1].all(axis=1))[0]
    if full_rows.size == 0:  # fall back: the rows covered in most columns
        counts = covered.sum(axis=1)
        full_rows = np.nonzero(counts >= np.percentile(counts[counts > 0], 50))[0]
    row0, row1 = int(full_rows[0]), int(full_rows[-1]) + 1
    # the longest contiguous run of rows in [row0, row1) that are fully covered
    runs = np.split(full_rows, np.nonzero(np.diff(full_rows) > 1)[0] + 1)
    longest = max(runs, key=len)
    row0, row1 = int(longest[0]), int(longest[-1]) + 1
    good = covered[row0:row1].all(axis=0)
    idx = np.nonzero(good)[0]
    runs = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1)
    longest = max(runs, key=len)
    return row0, row1, int(longest[0]), int(longest[-1]) + 1


def register(
    images,
    pan_angles,
    focal: float,
    scan,
    *,
    refine: bool = True,
    fit_scale: bool = False,
    search: int = 12,
    jump: float = 0.2,
    full_circle: bool = False,
    slice_step: float | None = None,
) -> Registration:
    """Camera views + a partial spherical scan → registered intensity and range (App. A).

    1. The cylindrical mosaic of the views (Eqs. 14–18,
       :func:`~refsynth.registration.mosaicking.mosaic`), started from the
       known pan angles.
    2. The scan on the cylinder of radius ``f`` (Eq. 19,
       :func:`~refsynth.registration.range_image.scan_to_cylinder`).
    3. The global warp (Eq. 21) from the rig's nominal geometry (``a = f``,
       ``b = −1``, the laser's azimuth 0 at the camera's pan angle 0, the
       horizon at view 0's centre row), refined on edge correspondences
       (:func:`~refsynth.registration.alignment.align_global`).
    4. With ``refine``, the local stretch
       (:func:`~refsynth.registration.alignment.refine_local`).
    5. The range resampled on the mosaic's grid
       (:func:`~refsynth.registration.alignment.resample_range`), and both
       cropped to the fully covered rectangle.

    Parameters
    ----------
    images : sequence of ndarray of shape (H, W) or (H, W, 3)
        The camera views in pan order (every 18° in the paper).
    pan_angles : array_like of shape (N,)
        Their nominal pan angles, radians, in the laser's azimuth frame.
    focal : float
        Focal length, pixels.
    scan : tuple ``(r, theta, phi)``
        The spherical scan (see
        :func:`~refsynth.registration.range_image.scan_to_cylinder`); NaN =
        not measured.
    refine : bool, default True
        Run the local stretch (App. A.2) after the global warp.
    fit_scale : bool, default False
        Also fit ``a``, ``b`` of Eq. 21 to the automatic edge matches. Off
        by default: both images are cylinders of radius ``f`` with pixels
        of one size, so ``a = f`` and ``b = −1`` up to the encoders'
        calibration, and in a partial scan the horizontal depth edges are
        mostly tops of furniture, whose height ``h`` correlates with their
        parallax ``f ΔY / ρ``, which biases ``b`` (by 4–7 % on the rig).
    search : int, default 12
        Chamfer search of the offsets (px).
    jump : float, default 0.2
        Depth discontinuity threshold (the scan's unit).
    full_circle : bool, default False
        The views cover 360°.
    slice_step : float, optional
        The rig's pan step between two adjacent slice positions, radians
        (0.36° on the paper's rig, §4; ``Scan.slice_step`` of a scan folder).
        The registered range is resampled from the scan at that step, so a
        column is measured only where a slice was taken and the slices not
        scanned stay NaN. Default: the smallest gap between the scan's
        slices, which is the rig's step only if two adjacent positions were
        scanned somewhere (not so for every n-th slice: each slice is then
        stretched across its gap, and range is made up).

    Returns
    -------
    Registration

    Examples
    --------
    >>> from refsynth.registration.examples import example_rig
    >>> views, scan = example_rig()
    >>> result = register(views.images, views.pan_angles, views.focal,
    ...                   (scan.r, scan.theta, scan.phi), refine=False)
    >>> result.intensity.shape == result.partial_range.shape, result.crop
    (True, (1, 79, 1, 106))
    """
    focal = check_real("focal", focal, positive=True)
    if slice_step is not None:
        slice_step = check_real("slice_step", slice_step, positive=True, maximum=np.pi)
    angles = np.asarray(pan_angles, dtype=np.float64)
    if angles.ndim != 1 or not np.all(np.isfinite(angles)):
        raise ValueError("The parameter `pan_angles` must be a 1-D array of finite angles")
    if angles.size != len(images):
        raise ValueError(
            f"The parameter `pan_angles` must have one angle per image ({len(images)}), "
            f"got {angles.size}"
        )
    if not isinstance(scan, (tuple, list)) or len(scan) != 3:
        raise TypeError("The parameter `scan` must be a tuple (r, theta, phi)")
    steps = np.diff(angles)
    if full_circle:
        steps = np.append(steps, 2 * np.pi - (angles[-1] - angles[0]))
    pano = mosaic(images, focal, steps, start_angle=float(angles[0]), full_circle=full_circle)
    height = pano.image.shape[0]
    h_top = pano.horizon_row + 4.0  # rows of the mosaic, in h, with a margin
    h_range = (pano.horizon_row - height - 4.0, h_top)
    cylinder = scan_to_cylinder(*scan, focal, h_range=h_range)
    measured = cylinder
    if slice_step is not None:
        measured = scan_to_cylinder(*scan, focal, h_range=h_range, phi_step=slice_step)
    initial = Warp(focal, -1.0, float(pano.column_of(0.0)), pano.horizon_row)
    edges = intensity_edges(pano.image)
    warp, global_info = align_global(
        pano.image, cylinder, initial, search=search, fit_scale=fit_scale, edges=edges, jump=jump
    )
    displacement, history = None, []
    if refine:
        displacement, history = refine_local(pano.image, cylinder, warp, edges=edges, jump=jump)
    full_range = resample_range(measured, warp, pano.weight.shape, displacement)
    crop = _covered_rectangle(pano.weight)
    window = (slice(crop[0], crop[1]), slice(crop[2], crop[3]))
    return Registration(
        intensity=pano.image[window].copy(), partial_range=full_range[window].copy(), crop=crop,
        mosaic=pano, cylinder=cylinder, initial=initial, warp=warp, displacement=displacement,
        global_info=global_info, history=history, measured=measured,
    )


def register_scan(images, pan_angles, focal: float, scan, **options):
    """Camera views + partial scan → ``(intensity, partial_range, info)`` for ``synthesize()``.

    App. A (Eqs. 14–21), as :func:`register` computes it.

    A thin front end to :func:`register` (same parameters): the intensity is
    the cropped mosaic (finite everywhere), the partial range is on the same
    grid with NaN where the laser did not scan, and ``info`` is the
    :class:`Registration`.

    Parameters
    ----------
    images : sequence of ndarray of shape (H, W) or (H, W, 3)
        The camera views in pan order.
    pan_angles : array_like of shape (N,)
        Their nominal pan angles, radians.
    focal : float
        Focal length, pixels.
    scan : tuple ``(r, theta, phi)``
        The spherical scan; NaN = not measured.
    **options
        The keyword arguments of :func:`register` (``refine``,
        ``fit_scale``, ``search``, ``jump``, ``full_circle``,
        ``slice_step``: give the rig's step, or the unscanned columns
        between slices farther apart are filled from their neighbours).

    Returns
    -------
    intensity : ndarray of shape (H', W') or (H', W', C)
        :attr:`Registration.intensity`.
    partial_range : ndarray of shape (H', W')
        :attr:`Registration.partial_range`.
    info : Registration
        Everything else.

    Examples
    --------
    >>> from refsynth.registration.examples import example_rig
    >>> views, scan = example_rig()
    >>> intensity, partial, info = register_scan(
    ...     views.images, views.pan_angles, views.focal, (scan.r, scan.theta, scan.phi))
    >>> intensity.shape == partial.shape and bool(np.isfinite(intensity).all())
    True
    """
    result = register(images, pan_angles, focal, scan, **options)
    return result.intensity, result.partial_range, result
