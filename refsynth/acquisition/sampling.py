"""Known-range masks: how much of the range image the sensor measured (§3.1.1, §3.3).

Every function here returns a boolean mask of shape (H, W) with ``True`` where
the range is *known* (measured) and ``False`` where it must be synthesized.
Apply a mask to a dense range image with
``partial = np.where(mask, range_image, np.nan)``.

- :func:`stripes` is the sampling of the paper's experiments (§3.3): stripes
  of known range of width ``rw`` and of unknown range of width ``xw``, along
  the x-axis only (vertical stripes, as a sweeping 2-D lidar gives) or along
  both axes (a grid of known lines, Table 1).
- :func:`x_stripes_for_fraction` picks ``xw`` so that vertical stripes leave
  a requested fraction of the image unknown (Table 4: 62–85 % unknown).
- :func:`distance_driven` is the heuristic of Fig. 2 (§3.1.1): the pan unit
  scans vertical slices more densely where the scene is far.
- :func:`unknown_fraction` is the "% of area with missing range" of the
  tables.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.1.1 (Fig. 2) and §3.3 (Table 1,
Table 4), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth._checks import check_fraction, check_int, check_real, is_int

__all__ = [
    "stripes",
    "stripe_gap_for_fraction",
    "x_stripes_for_fraction",
    "distance_driven",
    "column_range_profile",
    "unknown_fraction",
]

AXES = ("x", "y", "xy")


# ----------------------------------------------------------------------------- validation


def _check_shape(shape) -> tuple[int, int]:
    """``(H, W)`` from a pair of positive integers (a mask's shape, rows first)."""
    if (
        not isinstance(shape, (tuple, list))
        or len(shape) != 2
        or not all(is_int(n) and n > 0 for n in shape)
    ):
        raise ValueError(
            f"The parameter `shape` must be a pair of positive integers, got {shape!r}"
        )
    return int(shape[0]), int(shape[1])


def _check_phase(phase) -> tuple[int, int]:
    """Return ``(row_phase, col_phase)`` from an int or a pair of ints."""
    if is_int(phase):
        return int(phase), int(phase)
    if isinstance(phase, (tuple, list)) and len(phase) == 2 and all(is_int(p) for p in phase):
        return int(phase[0]), int(phase[1])
    raise ValueError(
        "The parameter `phase` must be an integer or a pair of integers (row_phase, col_phase), "
        f"got {phase!r}"
    )


def _check_mask(name: str, mask) -> np.ndarray:
    """``mask`` itself if it is a non-empty boolean ndarray (``True`` = known)."""
    if not isinstance(mask, np.ndarray):
        raise TypeError(f"The parameter `{name}` must be a numpy array, got {type(mask).__name__}")
    if mask.dtype != bool:
        raise TypeError(f"The parameter `{name}` must be a boolean array, got dtype {mask.dtype}")
    if mask.size == 0:
        raise ValueError(f"The parameter `{name}` must not be empty, got shape {mask.shape}")
    return mask


# ----------------------------------------------------------------------------- stripes


def _stripe_line(n: int, rw: int, xw: int, phase: int) -> np.ndarray:
    """Known (True) / unknown (False) along one axis of length ``n``."""
    return (np.arange(n) - phase) % (rw + xw) < rw


def stripes(
    shape: tuple[int, int],
    rw: int,
    xw: int,
    axes: str = "xy",
    phase: int | tuple[int, int] = 0,
) -> np.ndarray:
    """Stripes of known range of width ``rw`` and unknown range of width ``xw`` (§3.3).

    Along one axis, index ``i`` (a column for the x-axis, a row for the
    y-axis) is known when

    .. math:: (i - \\mathrm{phase}) \\bmod (rw + xw) < rw,

    so known stripes of width ``rw`` and unknown stripes of width ``xw``
    alternate with period ``rw + xw``, and with ``phase = 0`` the image starts
    with a complete known stripe.

    Parameters
    ----------
    shape : pair of int
        ``(H, W)`` of the mask.
    rw : int
        Width in pixels of each stripe of known range, >= 1.
    xw : int
        Width in pixels of each stripe of unknown range, >= 1.
    axes : {"xy", "x", "y"}
        ``"x"``: the pattern varies along x (columns): vertical stripes, whole
        columns known, like a sweeping 2-D lidar (Table 4, Fig. 17).
        ``"y"``: the pattern varies along y: horizontal stripes, whole rows
        known. ``"xy"`` (the paper's Table 1): a pixel is known when its
        column is in a known x-stripe *or* its row is in a known y-stripe, so
        the known part is a grid of lines and the unknown part is a grid of
        ``xw × xw`` holes.
    phase : int or pair of int
        Shift of the pattern in pixels, towards larger indices. An int shifts
        both axes; a pair is ``(row_phase, col_phase)`` (for ``axes="x"`` only
        ``col_phase`` is used, for ``axes="y"`` only ``row_phase``). Any
        integer is allowed; it acts modulo ``rw + xw``.

    Returns
    -------
    mask : ndarray of shape (H, W), bool
        ``True`` where the range is known.

    Raises
    ------
    ValueError
        If ``shape``, ``rw``, ``xw``, ``axes`` or ``phase`` is out of range.
    TypeError
        If ``rw`` or ``xw`` is not an integer.

    Notes
    -----
    When the width (height) is a multiple of ``rw + xw``, the unknown
    fraction is exactly ``xw / (rw + xw)`` for ``"x"`` (``"y"``) and
    ``(xw / (rw + xw))²`` for ``"xy"``; otherwise it depends on the phase.

    Table 1 of the paper (128 × 128 USF images) lists rw/xw = 24/80 → 39 %,
    10/20 → 39 %, 5/25 → 61 % and 3/28 → 76.5 % of the area without range.
    With ``phase=0`` (known stripe first, which gives the *smallest* unknown
    fraction of all phases for these settings) the grid leaves 39.06 %,
    39.06 %, 64.75 % and 77.94 % unknown: the first two match; no phase gives
    the last two (5/25 ranges over 64.75–71.19 %, 3/28 over 77.94–82.13 %),
    so the paper's 61 % and 76.5 % were measured on a pattern we cannot
    reconstruct from the text (for instance a different image crop).

    References
    ----------
    Torres-Méndez & Dudek (2008), §3.3, Table 1 and Table 4,
    doi:10.1007/s11263-007-0108-2.

    Examples
    --------
    >>> stripes((1, 6), rw=1, xw=2, axes="x").astype(int)
    array([[1, 0, 0, 1, 0, 0]])
    >>> stripes((4, 4), rw=1, xw=1, axes="xy").astype(int)
    array([[1, 1, 1, 1],
           [1, 0, 1, 0],
           [1, 1, 1, 1],
           [1, 0, 1, 0]])
    """
    height, width = _check_shape(shape)
    rw = check_int("rw", rw, minimum=1)
    xw = check_int("xw", xw, minimum=1)
    if not isinstance(axes, str) or axes not in AXES:
        raise ValueError(f"The parameter `axes` must be one of {AXES}, got {axes!r}")
    row_phase, col_phase = _check_phase(phase)

    known_cols = _stripe_line(width, rw, xw, col_phase)
    known_rows = _stripe_line(height, rw, xw, row_phase)
    if axes == "x":
        return np.broadcast_to(known_cols[None, :], (height, width)).copy()
    if axes == "y":
        return np.broadcast_to(known_rows[:, None], (height, width)).copy()
    return known_rows[:, None] | known_cols[None, :]


def stripe_gap_for_fraction(
    width: int, unknown_fraction: float, *, rw: int = 3, phase: int = 0
) -> int:
    """The unknown-stripe width ``xw`` whose vertical stripes best hit a target fraction.

    The x-stripe samplings of §3.3 are given by their unknown fraction
    (Table 4: 62 %, 78 %, 85 %); this finds the stripe layout.

    Parameters
    ----------
    width : int
        Number of columns ``W``, >= 1.
    unknown_fraction : float
        Target fraction of unknown columns, in (0, 1).
    rw : int, default 3
        Width of each known stripe (columns per scanned slice group).
    phase : int, default 0
        Column phase, as in :func:`stripes`.

    Returns
    -------
    xw : int
        The ``xw`` in ``1 … width`` whose mask ``stripes((H, width), rw, xw,
        axes="x", phase=phase)`` has the unknown fraction closest to the
        target (the smallest such ``xw`` on a tie).

    Raises
    ------
    ValueError
        If ``width``, ``rw`` or ``unknown_fraction`` is out of range.

    Examples
    --------
    >>> xw = stripe_gap_for_fraction(450, 0.78)
    >>> xw, round(unknown_fraction(stripes((4, 450), 3, xw, axes="x")), 4)
    (11, 0.7822)
    """
    width = check_int("width", width, minimum=1)
    rw = check_int("rw", rw, minimum=1)
    phase = check_int("phase", phase)
    target = check_fraction("unknown_fraction", unknown_fraction)
    xw = np.arange(1, width + 1)  # candidates; xw >= width leaves at most rw known columns
    known = (np.arange(width)[None, :] - phase) % (rw + xw[:, None]) < rw
    achieved = 1.0 - known.mean(axis=1)
    return int(xw[np.argmin(np.abs(achieved - target))])


def x_stripes_for_fraction(
    shape: tuple[int, int], unknown_fraction: float, *, rw: int = 3, phase: int = 0
) -> np.ndarray:
    """Vertical stripes leaving (as nearly as possible) a given fraction unknown (§3.3).

    The x-axis sampling of the Middlebury experiments (Table 4: 62 %, 78 %,
    85 % unknown on 450 × 375 images): known stripes of ``rw`` columns,
    unknown stripes of ``xw`` columns, with ``xw`` chosen by
    :func:`stripe_gap_for_fraction`. Read the fraction achieved with
    :func:`unknown_fraction`.

    Parameters
    ----------
    shape : pair of int
        ``(H, W)`` of the mask.
    unknown_fraction : float
        Target fraction of unknown pixels, in (0, 1).
    rw : int, default 3
        Columns per known stripe. The paper does not give its ``rw`` for
        Table 4; 3 columns keeps a 3 × 3 window inside one known stripe while
        leaving fine control of the fraction (with ``rw = 3`` the achievable
        fractions near 85 % are about 0.7 % apart; targets below
        ``1 / (rw + 1)`` = 25 % cannot be reached, since ``xw >= 1``).
    phase : int, default 0
        Column phase, as in :func:`stripes`.

    Returns
    -------
    mask : ndarray of shape (H, W), bool
        ``True`` on the known columns.

    References
    ----------
    Torres-Méndez & Dudek (2008), §3.3, Table 4, doi:10.1007/s11263-007-0108-2.

    Examples
    --------
    >>> mask = x_stripes_for_fraction((4, 40), 0.75, rw=2)
    >>> unknown_fraction(mask)
    0.75
    """
    height, width = _check_shape(shape)
    xw = stripe_gap_for_fraction(width, unknown_fraction, rw=rw, phase=phase)
    return stripes((height, width), rw, xw, axes="x", phase=phase)


# ----------------------------------------------------------------------------- Fig. 2


def column_range_profile(coarse_range: np.ndarray) -> np.ndarray:
    """One representative range per column: the median of its finite values.

    The coarse profile by which :func:`distance_driven` spaces its slices
    (§3.1.1, Fig. 2).

    Parameters
    ----------
    coarse_range : ndarray of shape (H, W) or (W,)
        A coarse range image (distances: larger is farther), or already a
        per-column profile. Non-finite values (NaN, ±inf) are treated as
        missing.

    Returns
    -------
    profile : ndarray of shape (W,), float64
        The median of each column's finite values; a column with none takes
        the value linearly interpolated from the nearest columns that have
        some (constant beyond the first and last of them).

    Raises
    ------
    ValueError
        If the array is not 1-D or 2-D, has no finite value, or has a finite
        value <= 0.

    Examples
    --------
    >>> coarse = np.array([[2.0, np.nan, 6.0], [4.0, np.nan, 8.0], [3.0, np.nan, np.inf]])
    >>> column_range_profile(coarse)
    array([3., 5., 7.])
    """
    if not isinstance(coarse_range, np.ndarray):
        raise TypeError(
            f"The parameter `coarse_range` must be a numpy array, got {type(coarse_range).__name__}"
        )
    if not np.issubdtype(coarse_range.dtype, np.number) or np.issubdtype(
        coarse_range.dtype, np.complexfloating
    ):
        raise TypeError(
            f"The parameter `coarse_range` must be a real array, got dtype {coarse_range.dtype}"
        )
    if coarse_range.ndim not in (1, 2) or coarse_range.size == 0:
        raise ValueError(
            "The parameter `coarse_range` must be a non-empty 1-D (W,) or 2-D (H, W) array, "
            f"got shape {coarse_range.shape}"
        )
    values = coarse_range.astype(np.float64)
    finite = np.isfinite(values)
    if not finite.any():
        raise ValueError("The parameter `coarse_range` must have at least one finite value")
    if np.any(values[finite] <= 0):
        raise ValueError(
            "The parameter `coarse_range` must hold distances > 0 where finite, "
            f"got minimum {values[finite].min()}"
        )
    if values.ndim == 1:
        values = values[None, :]
        finite = finite[None, :]
    has_data = finite.any(axis=0)
    profile = np.full(values.shape[1], np.nan)
    # the median of the finite values only; columns without any are filled below
    profile[has_data] = np.nanmedian(np.where(finite, values, np.nan)[:, has_data], axis=0)
    columns = np.arange(values.shape[1])
    return np.interp(columns, columns[has_data], profile[has_data])


def distance_driven(
    coarse_range: np.ndarray,
    known_fraction: float = 0.4,
    *,
    height: int | None = None,
    min_step: float = 1.0,
    max_step: float | None = None,
    phase: int = 0,
) -> np.ndarray:
    """Vertical range slices spaced by the distance of the scene (§3.1.1, Fig. 2).

    "The farther we are from an object, the smaller it looks, so dense
    sampling is needed […]; the closer we are to an object, the larger it
    looks, so sparse subsampling is enough." The pan unit scans whole
    columns (vertical laser slices); the number of slices per column, the
    sampling density ``ρ(c)``, grows in proportion to the scene's distance
    ``d(c)`` in that column, so that the slices fall at roughly equal metric
    spacing on the surfaces:

    .. math::

        \\rho(c) = \\operatorname{clip}\\bigl(k\\, d(c),\\;
                   1/\\mathrm{max\\_step},\\; 1/\\mathrm{min\\_step}\\bigr),
        \\qquad \\sum_c \\rho(c) = \\mathrm{known\\_fraction} \\cdot W,

    with ``k`` found by bisection. Column ``c`` is scanned when the running
    sum ``F(c) = Σ_{c' <= c} ρ(c')``, counted from column ``phase``, passes an
    integer, so the local spacing between scanned columns is about
    ``1 / ρ(c)``: short where far, long where close.

    Parameters
    ----------
    coarse_range : ndarray of shape (H, W) or (W,)
        A coarse estimate of the distance (larger = farther; pass
        ``1 / disparity`` for stereo data): a range image, whose columns are
        summarised by the median of their finite values (NaN and ±inf are
        ignored, see :func:`column_range_profile`), or a per-column profile
        of length ``W``, which needs ``height``.
    known_fraction : float, default 0.4
        Fraction of columns to scan, in (0, 1); the paper scans about 30–50 %
        of the slices per pose (§4). Reached to within one column.
    height : int, optional
        Number of rows of the mask; required for a 1-D profile, must be None
        for a 2-D ``coarse_range`` (the mask then has its shape).
    min_step : float, default 1.0
        Smallest spacing between scanned columns, >= 1 (the densest sampling
        scans every ``min_step``-th column).
    max_step : float, optional
        Largest spacing between scanned columns (the sparsest sampling);
        default ``W``, i.e. no bound beyond the image.
    phase : int, default 0
        A column that is always scanned, ``0 <= phase < W``; the pattern is
        laid out from it in both directions.

    Returns
    -------
    mask : ndarray of shape (H, W), bool
        ``True`` on the scanned columns.

    Raises
    ------
    ValueError
        If ``known_fraction`` cannot be reached with the step bounds
        (``known_fraction`` must lie in ``[1 / max_step, 1 / min_step]``,
        up to one column), or any argument is out of range.

    Notes
    -----
    The method is deterministic: there is nothing random in it. For a range
    that grows monotonically across the image, the spacing between
    consecutive scanned columns shrinks monotonically up to the rounding to
    whole columns: a later gap is never more than one column wider than an
    earlier one.

    References
    ----------
    Torres-Méndez & Dudek (2008), §3.1.1, Fig. 2, doi:10.1007/s11263-007-0108-2.

    Examples
    --------
    >>> far_on_the_right = np.linspace(2.0, 8.0, 40)
    >>> mask = distance_driven(far_on_the_right, 0.4, height=1)
    >>> np.flatnonzero(mask[0]).tolist()
    [0, 6, 10, 13, 16, 19, 21, 23, 25, 28, 30, 31, 33, 35, 37, 38]
    """
    profile = column_range_profile(coarse_range)
    if np.ndim(coarse_range) == 2:
        if height is not None:
            raise ValueError(
                "The parameter `height` must be None for a 2-D `coarse_range` "
                f"(the mask takes its shape), got {height!r}"
            )
        height = coarse_range.shape[0]
    elif height is None:
        raise ValueError(
            "The parameter `height` is required for a 1-D `coarse_range` profile, got None"
        )
    height = check_int("height", height, minimum=1)
    width = profile.size
    known_fraction = check_fraction("known_fraction", known_fraction)
    min_step = check_real("min_step", min_step, minimum=1)
    max_step = float(width) if max_step is None else check_real("max_step", max_step, minimum=1)
    if max_step < min_step:
        raise ValueError(
            f"The parameter `max_step` must be >= `min_step` ({min_step}), got {max_step}"
        )
    phase = check_int("phase", phase, minimum=0)
    if phase >= width:
        raise ValueError(f"The parameter `phase` must be a column index < {width}, got {phase}")

    target = known_fraction * width
    lo_density, hi_density = 1.0 / max_step, 1.0 / min_step
    if not lo_density * width - 1 <= target <= hi_density * width + 1:
        raise ValueError(
            f"The parameter `known_fraction` must lie in [1/max_step, 1/min_step] = "
            f"[{lo_density:.4g}, {hi_density:.4g}] to be reachable, got {known_fraction}"
        )

    def total(k: float) -> float:
        return float(np.clip(k * profile, lo_density, hi_density).sum())

    # bisection for k in Σ clip(k d, 1/max_step, 1/min_step) = target (monotone in k)
    k_lo, k_hi = 0.0, hi_density / profile.min()
    for _ in range(200):
        k_mid = 0.5 * (k_lo + k_hi)
        if total(k_mid) < target:
            k_lo = k_mid
        else:
            k_hi = k_mid
    density = np.clip(k_hi * profile, lo_density, hi_density)

    # running sum counted from column `phase`, where it is 0: a column is scanned
    # when the sum passes an integer between it and its left neighbour
    # (the 1e-9 makes a sum that lands on an integer up to rounding count as passing it)
    cumulative = np.cumsum(density)
    running = cumulative - cumulative[phase] + 1e-9
    previous = np.concatenate([[running[0] - density[0]], running[:-1]])
    known_cols = np.floor(running) > np.floor(previous)
    return np.broadcast_to(known_cols[None, :], (height, width)).copy()


# ----------------------------------------------------------------------------- fractions


def unknown_fraction(mask: np.ndarray) -> float:
    """The fraction of pixels whose range is unknown (``False`` in ``mask``).

    The "% of area with missing range" of Tables 1 and 4, as a number in
    [0, 1].

    Parameters
    ----------
    mask : ndarray, bool
        ``True`` = known.

    Returns
    -------
    float

    Examples
    --------
    >>> unknown_fraction(np.array([[True, False], [False, False]]))
    0.75
    """
    mask = _check_mask("mask", mask)
    return float(1.0 - np.count_nonzero(mask) / mask.size)
