"""Canny edge detection on the intensity image (§3.2).

The paper finds intensity edges with the Canny detector (σ = 0.8) on the
intensity image and uses them twice: the edge count ``E`` in a neighbourhood
lowers the fill priority (Eq. 10, §3.2.4), and belief propagation does not
pass messages across edge pixels (§3.2.3).

This module is a numpy/scipy implementation of the detector of Canny (1986).
Its structure (mask-renormalised Gaussian smoothing, Sobel gradients,
non-maximum suppression interpolated along the gradient by octants,
hysteresis by connected components) follows ``skimage.feature.canny`` of
scikit-image, so that the two give (almost) the same edge maps for the same
parameters; scikit-image is the test oracle, not a dependency.

The numeric contract (:mod:`refsynth.numeric`): the detector runs on its
input brought to the ``2**-24`` grid of its span, ``rint(2**24 (I − min) /
span)``, with the thresholds divided by the span, so that an offset leaves the
edges unchanged bit for bit and an integer image gives the edges of the same
values as floats. (The grid is finer than Eq. 2's ``2**-16``: that one moves
the Motorcycle's grey levels by up to 8e-6 and flips 5 of its 53,800 edge
pixels against scikit-image, while ``2**-24`` leaves every map the tests
compare identical; an intensity on the ``2**-16`` grid, which is what
:func:`refsynth.synthesize` passes, is on this grid already.) Its Gaussian kernel comes from
:func:`~refsynth.numeric.portable_exp`, normalised by a left-to-right sum and
applied by an explicit loop over the taps (the same bits on every machine;
for σ = 0.8 the kernel equals scipy's).

References
----------
J. Canny, "A Computational Approach to Edge Detection", IEEE TPAMI
8(6):679–698 (1986), doi:10.1109/TPAMI.1986.4767851.

L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.2, doi:10.1007/s11263-007-0108-2.

S. van der Walt et al., "scikit-image: image processing in Python", PeerJ
2:e453 (2014), doi:10.7717/peerj.453 (``skimage/feature/_canny.py``).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage as ndi

from refsynth._checks import check_bool, check_real, check_real_array, grey, to_float
from refsynth.numeric import portable_exp

__all__ = ["to_grey", "sobel_gradients", "non_maximum_suppression", "hysteresis", "canny"]

# scipy's Gaussian kernel is cut at this many standard deviations (as in scikit-image).
_GAUSSIAN_TRUNCATE = 4.0

# The input is brought to this many bits of its span (offset invariance, see above).
_GRID_BITS = 24

# The 8-neighbourhood: hysteresis links pixels that touch by an edge or a corner.
_EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)


# --------------------------------------------------------------------------- helpers


def _as_image(name: str, value, *, two_d: bool = True) -> np.ndarray:
    """``value`` as an ndarray of a real (or bool) dtype, 2-D unless ``two_d`` is False."""
    array = np.asarray(value)
    if array.dtype != np.bool_:
        check_real_array(name, array)
    if two_d and array.ndim != 2:
        raise ValueError(f"The parameter `{name}` must be a 2-D array, got shape {array.shape}")
    return array


def _check_mask(mask, shape: tuple[int, ...]) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.dtype != np.bool_:
        raise TypeError(f"The parameter `mask` must be a boolean array, got dtype {mask.dtype}")
    if mask.shape != shape:
        raise ValueError(f"The parameter `mask` must have shape {shape}, got {mask.shape}")
    return mask


def _check_thresholds(low: float, high: float) -> None:
    if low > high:
        raise ValueError(
            f"The parameter `low_threshold` ({low}) must not exceed `high_threshold` ({high})"
        )


def _gaussian_kernel(sigma: float) -> np.ndarray:
    """scipy's 1-D Gaussian, cut at 4σ, from :func:`portable_exp` and a left-to-right sum."""
    radius = int(_GAUSSIAN_TRUNCATE * sigma + 0.5)
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    phi = portable_exp((-0.5 / (sigma * sigma)) * (x * x))
    total = 0.0
    for value in phi:
        total += value
    return phi / total


def _smooth(values: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing with zeros beyond the image, one axis after the other.

    The symmetric kernel is applied as scipy's ``correlate1d`` does —
    ``x₀ w₀ + Σ_j (x₋ⱼ + xⱼ) wⱼ`` from the outermost tap inwards — but as
    explicit elementwise steps, so no compiler can contract or reorder them.
    """
    if sigma <= 1e-15:  # scipy skips such an axis
        return values.copy()
    w = _gaussian_kernel(sigma)
    r = w.size // 2
    out = values
    for axis in (0, 1):
        moved = np.moveaxis(out, axis, -1)
        length = moved.shape[-1]
        padded = np.pad(moved, [(0, 0)] * (moved.ndim - 1) + [(r, r)])
        acc = padded[..., r : r + length] * w[r]
        for j in range(r, 0, -1):
            pair = padded[..., r - j : r - j + length] + padded[..., r + j : r + j + length]
            acc = acc + pair * w[r - j]
        out = np.moveaxis(acc, -1, axis)
    return out


# --------------------------------------------------------------------------- public API


def to_grey(image: np.ndarray) -> np.ndarray:
    """Return the intensity image as a grey (H, W) float64 array.

    Canny (§3.2) runs on the intensity image; this turns a colour image into
    one.

    Parameters
    ----------
    image : ndarray of shape (H, W), (H, W, 1) or (H, W, 3)
        Grey or RGB image of any real dtype. Integer images are scaled to
        [0, 1] by dividing by the dtype's maximum (255 for uint8); bool maps
        to 0/1; floating images are used as given (no rescaling).

    Returns
    -------
    grey : ndarray of shape (H, W), float64
        A new array (the input is never modified nor returned).

    Raises
    ------
    TypeError
        If ``image`` is not of a real numeric dtype.
    ValueError
        If ``image`` has any other shape.

    Notes
    -----
    A colour image is reduced to its luminance with the weights of
    ``skimage.color.rgb2gray`` (ITU-R BT.709):

    .. math:: Y = 0.2125 R + 0.7154 G + 0.0721 B

    Examples
    --------
    >>> to_grey(np.array([[[255, 255, 255], [0, 0, 0]]], dtype=np.uint8))
    array([[1., 0.]])
    """
    array = _as_image("image", image, two_d=False)
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[:, :, 0]
    if array.ndim != 2 and not (array.ndim == 3 and array.shape[2] == 3):
        raise ValueError(
            "The parameter `image` must have shape (H, W), (H, W, 1) or (H, W, 3), "
            f"got shape {array.shape}"
        )
    return grey(to_float(array))


def sobel_gradients(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Sobel derivatives of a 2-D image along rows and columns.

    Parameters
    ----------
    image : ndarray of shape (H, W)
        Real-valued image (converted to float64; integers are *not* rescaled
        here, the values are differentiated as given).

    Returns
    -------
    gy, gx : ndarray of shape (H, W), float64
        ``gy`` is the derivative along axis 0 (down the rows), ``gx`` along
        axis 1 (across the columns).

    Notes
    -----
    The operators are the unnormalised 3×3 Sobel kernels of
    ``scipy.ndimage.sobel`` (border mode ``"reflect"``), as in scikit-image's
    Canny: the central difference ``[-1, 0, 1]`` along the derivative axis
    times the smoothing ``[1, 2, 1]`` across it (correlation kernels, rows
    top to bottom):

    .. math::
        g_y: \begin{bmatrix} -1 & -2 & -1 \\ 0 & 0 & 0 \\ 1 & 2 & 1 \end{bmatrix},
        \qquad
        g_x: \begin{bmatrix} -1 & 0 & 1 \\ -2 & 0 & 2 \\ -1 & 0 & 1 \end{bmatrix}.

    They are not divided by 8, so on a linear ramp of slope ``s`` per pixel
    the interior response is ``8 s``. Canny's thresholds are defined on this
    scale (the same as scikit-image's).

    Examples
    --------
    >>> ramp = np.tile(np.arange(5.0), (5, 1))   # slope 1 across the columns
    >>> gy, gx = sobel_gradients(ramp)
    >>> float(gx[2, 2]), float(gy[2, 2])
    (8.0, 0.0)
    """
    array = _as_image("image", image).astype(np.float64)
    return ndi.sobel(array, axis=0), ndi.sobel(array, axis=1)


def non_maximum_suppression(
    magnitude: np.ndarray,
    gy: np.ndarray,
    gx: np.ndarray,
    *,
    mask: np.ndarray | None = None,
) -> np.ndarray:
    r"""Thin the gradient magnitude to ridges one pixel wide.

    A pixel survives if its magnitude is at least the magnitude interpolated
    at one pixel's distance along the gradient, on both sides.

    Parameters
    ----------
    magnitude : ndarray of shape (H, W)
        Gradient magnitude, usually ``hypot(gy, gx)``.
    gy, gx : ndarray of shape (H, W)
        Gradient along rows and along columns (see :func:`sobel_gradients`).
    mask : ndarray of shape (H, W), bool, optional
        Pixels to consider; the others are 0 in the output. The one-pixel
        image border is always 0 (its neighbours along the gradient do not
        exist).

    Returns
    -------
    ndarray of shape (H, W), float64
        ``magnitude`` at the local maxima with positive magnitude, 0 elsewhere.

    Notes
    -----
    The gradient direction falls into one of four octant pairs, chosen by
    whether ``gy`` and ``gx`` have the same sign and whether ``|gy|`` or
    ``|gx|`` dominates. Along it, the magnitude one pixel away lies between an
    axial neighbour and a diagonal neighbour; it is interpolated linearly with
    weight ``w = min(|gy|, |gx|) / max(|gy|, |gx|)`` on the diagonal one:

    .. math::
        M_\pm = w\, M(p \pm d) + (1 - w)\, M(p \pm a),
        \qquad \text{keep } p \iff M(p) \ge M_+ \text{ and } M(p) \ge M_- ,

    with ``a`` the axial and ``d`` the diagonal offset. "Same sign" treats 0
    as negative, and a tie ``|gy| = |gx|`` as ``gx``-dominant in the same-sign
    case and ``gy``-dominant otherwise — the case split of scikit-image's
    ``_nonmaximum_suppression_bilinear``. All of it is array arithmetic over
    the interior; there is no loop over pixels.

    Examples
    --------
    A blurred step across the columns: the magnitude is 4, 16, 12 on three
    columns, and only its ridge survives.

    >>> gy, gx = sobel_gradients(np.tile([0.0, 0.0, 1.0, 4.0, 4.0, 4.0], (5, 1)))
    >>> thin = non_maximum_suppression(np.hypot(gy, gx), gy, gx)
    >>> thin[2].tolist(), thin[0].tolist()   # the image border is always 0
    ([0.0, 0.0, 16.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    """
    magnitude = _as_image("magnitude", magnitude).astype(np.float64)
    gy = _as_image("gy", gy).astype(np.float64)
    gx = _as_image("gx", gx).astype(np.float64)
    for name, array in (("gy", gy), ("gx", gx)):
        if array.shape != magnitude.shape:
            raise ValueError(
                f"The parameter `{name}` must have the shape of `magnitude` {magnitude.shape}, "
                f"got {array.shape}"
            )
    mask = None if mask is None else _check_mask(mask, magnitude.shape)

    out = np.zeros_like(magnitude)
    rows, cols = magnitude.shape
    if rows < 3 or cols < 3:
        return out

    def shifted(dr: int, dc: int) -> np.ndarray:
        """The magnitude at offset (dr, dc) of every interior pixel."""
        return magnitude[1 + dr : rows - 1 + dr, 1 + dc : cols - 1 + dc]

    m = magnitude[1:-1, 1:-1]
    g_row = gy[1:-1, 1:-1]
    g_col = gx[1:-1, 1:-1]
    abs_row = np.abs(g_row)
    abs_col = np.abs(g_col)

    # Octant pair: same sign (0 counts as negative) and which component dominates.
    same_sign = (g_row > 0) == (g_col > 0)
    row_dominant = np.where(same_sign, abs_row > abs_col, abs_row >= abs_col)
    big = np.where(row_dominant, abs_row, abs_col)
    small = np.where(row_dominant, abs_col, abs_row)
    w = np.divide(small, big, out=np.zeros_like(big), where=big > 0)

    # The diagonal neighbour along +gradient is (+1, +1) for the same sign, (-1, +1)
    # otherwise; the axial one shares its row step (gy-dominant) or column step.
    diag_plus = np.where(same_sign, shifted(1, 1), shifted(-1, 1))
    diag_minus = np.where(same_sign, shifted(-1, -1), shifted(1, -1))
    axial_plus = np.where(
        row_dominant, np.where(same_sign, shifted(1, 0), shifted(-1, 0)), shifted(0, 1)
    )
    axial_minus = np.where(
        row_dominant, np.where(same_sign, shifted(-1, 0), shifted(1, 0)), shifted(0, -1)
    )

    keep = (m > 0) & (diag_plus * w + axial_plus * (1.0 - w) <= m)
    keep &= diag_minus * w + axial_minus * (1.0 - w) <= m
    if mask is not None:
        keep &= mask[1:-1, 1:-1]
    out[1:-1, 1:-1] = np.where(keep, m, 0.0)
    return out


def hysteresis(magnitude_nms: np.ndarray, low: float, high: float) -> np.ndarray:
    """Double thresholding with edge tracking.

    Parameters
    ----------
    magnitude_nms : ndarray of shape (H, W)
        Thinned gradient magnitude (see :func:`non_maximum_suppression`); 0
        marks suppressed pixels.
    low, high : float
        Thresholds on the magnitude, ``low <= high``.

    Returns
    -------
    ndarray of shape (H, W), bool
        The connected components (8-connectivity) of the *weak* pixels —
        positive and ``>= low`` — that contain at least one *strong* pixel,
        ``>= high``.

    Notes
    -----
    This is Canny's "recursively add weak pixels touching an edge" done in one
    pass with :func:`scipy.ndimage.label`, as scikit-image does.

    Examples
    --------
    >>> hysteresis(np.array([[0.0, 0.2, 0.5, 0.0, 0.2]]), 0.1, 0.4)
    array([[False,  True,  True, False, False]])
    """
    magnitude_nms = _as_image("magnitude_nms", magnitude_nms)
    low = check_real("low", low)
    high = check_real("high", high)
    if low > high:
        raise ValueError(f"The parameter `low` ({low}) must not exceed `high` ({high})")

    weak = (magnitude_nms > 0) & (magnitude_nms >= low)
    labels, count = ndi.label(weak, structure=_EIGHT_CONNECTED)
    if count == 0:
        return weak
    strong = weak & (magnitude_nms >= high)
    keep_label = np.zeros(count + 1, dtype=bool)
    keep_label[labels[strong]] = True
    keep_label[0] = False
    return keep_label[labels]


def canny(
    image: np.ndarray,
    *,
    sigma: float = 0.8,
    low_threshold: float | None = None,
    high_threshold: float | None = None,
    mask: np.ndarray | None = None,
    use_quantiles: bool = False,
) -> np.ndarray:
    """Canny edges of a grey intensity image (§3.2 of the paper).

    The paper detects intensity edges with Canny's detector with σ = 0.8 on
    the intensity image; the edges lower the fill priority (Eq. 10) and block
    belief-propagation messages (§3.2.3). Parameters and thresholds mean what
    they mean in ``skimage.feature.canny``.

    Parameters
    ----------
    image : ndarray of shape (H, W)
        Grey image of any real dtype (use :func:`to_grey` for colour).
        Integer images are scaled to [0, 1] by their dtype's maximum; floats
        are used as given (the default thresholds assume [0, 1]). Must be
        finite wherever ``mask`` is True.
    sigma : float, default 0.8
        Standard deviation, in pixels, of the Gaussian smoothing; 0 disables
        it. The paper's value is 0.8.
    low_threshold, high_threshold : float, optional
        Hysteresis thresholds on the Sobel gradient magnitude (unnormalised
        kernels, see :func:`sobel_gradients`). Given in the units of the
        image's dtype: for integer images they are divided by the dtype's
        maximum, like the image. Defaults: 0.1 and 0.2 of the [0, 1] range
        (10 % and 20 % of the dtype's maximum for integer images). With
        ``use_quantiles=True``, quantiles in [0, 1] of the magnitude image.
    mask : ndarray of shape (H, W), bool, optional
        Where to detect edges. Smoothing ignores the pixels outside it, and no
        edge is reported within one pixel of them.
    use_quantiles : bool, default False
        Read the thresholds as quantiles of the gradient magnitude.

    Returns
    -------
    edges : ndarray of shape (H, W), bool
        The edge map; the one-pixel image border is always False.

    Raises
    ------
    TypeError
        If ``image`` or ``mask`` has the wrong dtype, or a scalar parameter is
        not a real number (``use_quantiles`` not a bool).
    ValueError
        If ``image`` is not 2-D or not finite, ``sigma`` is negative or not
        finite, a threshold is not finite, a quantile is outside [0, 1],
        ``low_threshold > high_threshold``, or ``mask`` has the wrong shape.

    Notes
    -----
    0. Bring the image to the ``2**-24`` grid of its span over the valid
       pixels, ``rint(2**24 (I − min) / (max − min)) · 2**-24``, and divide
       the (absolute) thresholds by the span: an offset changes nothing, bit
       for bit (the numeric contract of :mod:`refsynth.numeric`).
    1. Smooth with a Gaussian of width ``sigma`` (kernel cut at 4σ, zeros
       beyond the image). Pixels outside ``mask`` (and outside the image)
       are left out by renormalising: ``G * (I · mask) / (G * mask + eps)``.
    2. Sobel gradients ``gy``, ``gx``; magnitude ``M = sqrt(gy² + gx²)``.
    3. Non-maximum suppression along the gradient, interpolating by octants
       (:func:`non_maximum_suppression`), over the mask eroded by one pixel
       (8-neighbourhood) — only there is the 3×3 Sobel stencil free of the
       outside; the image border is excluded the same way.
    4. Hysteresis (:func:`hysteresis`): keep the 8-connected components of
       the pixels ``>= low_threshold`` that contain a pixel
       ``>= high_threshold``.

    Differences from ``skimage.feature.canny`` (scikit-image 0.26): the
    computation is always in float64 (skimage keeps float32 images in
    float32); signed integer images are divided by the dtype's maximum
    (skimage maps them to [-1, 1] affinely); 64-bit integer images are
    accepted; non-finite values raise; ``mask`` must be bool; there are no
    ``mode``/``cval`` options (always ``"constant"``, 0).

    References
    ----------
    .. [1] J. Canny, "A Computational Approach to Edge Detection", IEEE TPAMI
       8(6):679–698 (1986), doi:10.1109/TPAMI.1986.4767851.
    .. [2] L. A. Torres-Méndez and G. Dudek (2008), §3.2,
       doi:10.1007/s11263-007-0108-2.
    .. [3] scikit-image, ``skimage/feature/_canny.py``, whose structure this
       follows.

    Examples
    --------
    A vertical step from 0 to 1 whose middle column is 0.5 gives one edge line
    down that column (the image border is never marked):

    >>> image = np.zeros((6, 7))
    >>> image[:, 3] = 0.5
    >>> image[:, 4:] = 1.0
    >>> canny(image).astype(int)
    array([[0, 0, 0, 0, 0, 0, 0],
           [0, 0, 0, 1, 0, 0, 0],
           [0, 0, 0, 1, 0, 0, 0],
           [0, 0, 0, 1, 0, 0, 0],
           [0, 0, 0, 1, 0, 0, 0],
           [0, 0, 0, 0, 0, 0, 0]])
    """
    array = _as_image("image", image)
    sigma = check_real("sigma", sigma, minimum=0.0)
    use_quantiles = check_bool("use_quantiles", use_quantiles)
    if mask is not None:
        mask = _check_mask(mask, array.shape)
    # thresholds are in the image's units: integers are scaled like the image (to_float)
    scale = float(np.iinfo(array.dtype).max) if np.issubdtype(array.dtype, np.integer) else 1.0

    thresholds = {}
    for name, value, default in (
        ("low_threshold", low_threshold, 0.1),
        ("high_threshold", high_threshold, 0.2),
    ):
        if value is None:
            thresholds[name] = default
            continue
        value = check_real(name, value)
        if use_quantiles:
            if not 0.0 <= value <= 1.0:
                raise ValueError(
                    f"The parameter `{name}` must be a quantile in [0, 1] when "
                    f"`use_quantiles` is True, got {value}"
                )
            thresholds[name] = value
        else:
            thresholds[name] = value / scale
    low, high = thresholds["low_threshold"], thresholds["high_threshold"]
    _check_thresholds(low, high)

    intensity = to_float(array)
    valid = np.ones(array.shape, dtype=bool) if mask is None else mask
    if not np.isfinite(intensity[valid]).all():
        raise ValueError("The parameter `image` must be finite (where `mask` is True)")
    if not valid.any():
        return np.zeros(array.shape, dtype=bool)

    # 0. The contract: the 2**-24 grid of the span; the thresholds follow the scale.
    floor = float(np.min(intensity[valid]))
    span = float(np.max(intensity[valid])) - floor
    span = span if span > 0 else 1.0
    levels = np.rint((np.where(valid, intensity, floor) - floor) / span * 2.0**_GRID_BITS)
    intensity = levels * 2.0**-_GRID_BITS
    if not use_quantiles:  # (a span of a few subnormals: no threshold can be reached)
        top = float(np.finfo(np.float64).max)
        low, high = min(low / span, top), min(high / span, top)

    # 1. Gaussian smoothing, renormalised by the smoothed mask (zeros outside image/mask).
    weight = valid.astype(np.float64)
    masked = np.where(valid, intensity, 0.0)
    bleed = _smooth(weight, sigma) + np.finfo(np.float64).eps
    smoothed = _smooth(masked, sigma) / bleed

    # 2. Sobel gradients and magnitude.
    gy, gx = sobel_gradients(smoothed)
    magnitude = np.sqrt(gy * gy + gx * gx)

    if use_quantiles:
        low, high = np.percentile(magnitude, [100.0 * low, 100.0 * high])

    # 3. Non-maximum suppression inside the mask eroded by one pixel (the image
    #    border counts as outside the mask).
    eroded = ndi.binary_erosion(valid, structure=_EIGHT_CONNECTED, border_value=0)
    thinned = non_maximum_suppression(magnitude, gy, gx, mask=eroded)

    # 4. Hysteresis.
    return hysteresis(thinned, low, high)
