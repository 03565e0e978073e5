"""Comparison fills that are not in the paper.

These are what users reach for today to fill a partial depth map; refsynth's
results tables put them beside NP and BP so that the comparison is honest.
Each function takes the same inputs as :func:`refsynth.synthesize` and returns
the dense range (measured pixels unchanged).

- :func:`nearest_fill`: the nearest measured pixel's range;
- :func:`linear_fill`: piecewise-linear over a Delaunay triangulation;
- :func:`harmonic_fill`: the Laplace equation;
- :func:`colorization_fill`: Levin, Lischinski & Weiss's colorization by
  optimization, as the NYU Depth V2 toolbox fills depth with it
  (``fill_depth_colorization.m``);
- :func:`joint_bilateral_fill`: joint-bilateral normalised convolution
  (known mask × spatial Gaussian × intensity Gaussian).

The first three ignore the intensity; the last two are guided by it.

References
----------
Torres-Méndez & Dudek (2008), §3.3, doi:10.1007/s11263-007-0108-2 (the
experiments these baselines are set beside).

A. Levin, D. Lischinski and Y. Weiss, "Colorization using optimization",
ACM Transactions on Graphics 23(3):689–694 (SIGGRAPH 2004),
doi:10.1145/1015706.1015780.

N. Silberman, D. Hoiem, P. Kohli and R. Fergus, "Indoor Segmentation and
Support Inference from RGBD Images", ECCV 2012 (the NYU Depth V2 dataset and
its toolbox, ``fill_depth_colorization.m``).

J. Kopf, M. F. Cohen, D. Lischinski and M. Uyttendaele, "Joint Bilateral
Upsampling", ACM Transactions on Graphics 26(3):96 (SIGGRAPH 2007),
doi:10.1145/1276377.1276497; H. Knutsson and C.-F. Westin, "Normalized and
Differential Convolution", CVPR 1993, doi:10.1109/CVPR.1993.341081.
"""

from __future__ import annotations

import numpy as np
from scipy import interpolate, ndimage, sparse
from scipy.sparse import linalg as sparse_linalg

from refsynth._checks import BT601, check_int, check_real, grey
from refsynth.synthesis.api import validate_inputs
from refsynth.synthesis.completion import OFFSETS

__all__ = [
    "nearest_fill",
    "linear_fill",
    "harmonic_fill",
    "colorization_affinities",
    "colorization_fill",
    "joint_bilateral_fill",
    "BASELINES",
]


def nearest_fill(intensity: np.ndarray, partial_range: np.ndarray) -> np.ndarray:
    """Copy each unknown pixel's range from the nearest measured pixel (Euclidean).

    The intensity is validated but not used. Ties between equally near
    measured pixels are resolved as ``scipy.ndimage.distance_transform_edt``
    resolves them (deterministically).

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        Validated (as by :func:`refsynth.synthesize`) but not used.
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range; the NaN pixels are filled.

    Returns
    -------
    ndarray of shape (H, W), float64
        Each unknown pixel holds its nearest measured pixel's range.

    Notes
    -----
    Disparity and indoor range are piecewise constant, so this fill, which
    never interpolates across a depth edge, is a strong baseline on MAR.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, np.nan, 4.0]] * 2)
    >>> nearest_fill(np.zeros((2, 4)), partial)[0].tolist()
    [1.0, 1.0, 4.0, 4.0]
    """
    _, range_values = validate_inputs(intensity, partial_range)
    unknown = ~np.isfinite(range_values)
    _, (rows, cols) = ndimage.distance_transform_edt(unknown, return_indices=True)
    return range_values[rows, cols]


def linear_fill(intensity: np.ndarray, partial_range: np.ndarray) -> np.ndarray:
    """Piecewise-linear interpolation over a Delaunay triangulation of the known pixels.

    ``scipy.interpolate.griddata(method="linear")``; pixels outside the convex
    hull of the known pixels take the nearest known value. The intensity is
    validated but not used.

    Parameters
    ----------
    intensity, partial_range : ndarray
        As for :func:`nearest_fill`, whose values this fill keeps outside the hull.

    Returns
    -------
    ndarray of shape (H, W), float64
        Linear between the known pixels inside their convex hull.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, 3.0]] * 3)
    >>> linear_fill(np.zeros((3, 3)), partial)[1].tolist()
    [1.0, 2.0, 3.0]
    """
    _, range_values = validate_inputs(intensity, partial_range)
    known = np.isfinite(range_values)
    out = nearest_fill(intensity, partial_range)
    points = np.argwhere(known)
    targets = np.argwhere(~known)
    if points.shape[0] >= 3 and np.linalg.matrix_rank(points - points[0]) == 2:
        values = interpolate.griddata(points, range_values[known], targets, method="linear")
        inside = np.isfinite(values)
        out[targets[inside, 0], targets[inside, 1]] = values[inside]
    return out


def harmonic_fill(intensity: np.ndarray, partial_range: np.ndarray) -> np.ndarray:
    """The harmonic (Laplace) fill: ``∇²R = 0`` on the unknown pixels, known ones fixed.

    The 4-neighbour discrete Laplacian, with reflecting (Neumann) image
    borders, solved as one sparse linear system (``scipy.sparse.linalg.spsolve``).
    The intensity is validated but not used.

    Parameters
    ----------
    intensity, partial_range : ndarray
        As for :func:`nearest_fill`; at least one pixel must be measured (it is
        checked), which makes the sparse system non-singular.

    Returns
    -------
    ndarray of shape (H, W), float64
        Each unknown pixel the mean of its (up to four) neighbours.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[0.0, np.nan, np.nan, 3.0]] * 2)
    >>> np.round(harmonic_fill(np.zeros((2, 4)), partial)[0], 6).tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    _, range_values = validate_inputs(intensity, partial_range)
    H, W = range_values.shape
    known = np.isfinite(range_values)
    index = np.full(H * W, -1, dtype=np.int64)
    unknown = np.flatnonzero(~known)
    index[unknown] = np.arange(unknown.size)
    values = np.where(known, range_values, 0.0).ravel()
    rows, cols = np.divmod(unknown, W)
    diag = np.zeros(unknown.size)
    rhs = np.zeros(unknown.size)
    a_rows, a_cols = [], []
    for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        r, c = rows + dr, cols + dc
        inside = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        diag += inside
        nb = (r * W + c)[inside]
        me = np.flatnonzero(inside)
        is_known = known.ravel()[nb]
        rhs[me[is_known]] += values[nb[is_known]]
        a_rows.append(me[~is_known])
        a_cols.append(index[nb[~is_known]])
    a_rows, a_cols = np.concatenate(a_rows), np.concatenate(a_cols)
    matrix = sparse.csr_matrix(
        (np.concatenate([diag, -np.ones(a_rows.size)]),
         (np.concatenate([np.arange(unknown.size), a_rows]),
          np.concatenate([np.arange(unknown.size), a_cols]))),
        shape=(unknown.size, unknown.size),
    )
    # every 4-connected unknown region borders a known pixel (there is one), so the
    # system is non-singular
    out = values.copy()
    out[unknown] = sparse_linalg.spsolve(matrix.tocsc(), rhs)
    return out.reshape(H, W)


#: The eight offsets of a 3×3 window around its centre, as (row, col), in raster order
#: (the portable solve's, :data:`refsynth.synthesis.completion.OFFSETS`).
_WINDOW_3X3 = OFFSETS


def colorization_affinities(grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The normalised 3×3 affinities of Levin et al. (2004) as the NYU toolbox computes them.

    Parameters
    ----------
    grey : ndarray of shape (H, W), float64
        The guide image, in [0, 1].

    Returns
    -------
    weights : ndarray of shape (8, H, W)
        ``weights[k, r, c]`` is the weight of neighbour ``(r, c) + offsets[k]``
        in the row of pixel ``(r, c)``; 0 outside the image; each pixel's
        weights sum to 1.
    offsets : ndarray of shape (8, 2), int
        The neighbour offsets (row, col), in raster order.

    Notes
    -----
    For a pixel ``r`` with intensity :math:`Y_r` and its in-image neighbours
    :math:`s \\in N(r)` (3×3 window):

    .. math::

        w_{rs} \\propto \\exp\\bigl(-(Y_r - Y_s)^2 / c_r\\bigr),\\qquad
        c_r = \\max\\bigl(0.6\\,\\sigma_r^2,\\; -\\min_s (Y_r - Y_s)^2 / \\ln 0.01,\\;
              2\\cdot 10^{-6}\\bigr),

    with :math:`\\sigma_r^2` the variance of the window (centre included,
    population variance) and :math:`\\sum_s w_{rs} = 1`. ``c_r`` plays the
    part of Levin et al.'s :math:`2\\sigma_r^2`; the middle bound (the
    toolbox's) makes the most similar neighbour weigh at least 0.01 before
    normalisation.

    Examples
    --------
    >>> weights, offsets = colorization_affinities(np.array([[0.0, 0.5], [0.5, 1.0]]))
    >>> weights.shape, offsets.shape, weights.sum(axis=0).round(12).tolist()
    ((8, 2, 2), (8, 2), [[1.0, 1.0], [1.0, 1.0]])
    """
    H, W = grey.shape
    padded = np.pad(grey, 1, constant_values=np.nan)
    neighbours = np.stack([padded[1 + dr:1 + dr + H, 1 + dc:1 + dc + W] for dr, dc in _WINDOW_3X3])
    inside = np.isfinite(neighbours)
    values = np.where(inside, neighbours, 0.0)
    count = inside.sum(axis=0) + 1.0
    mean = (values.sum(axis=0) + grey) / count
    variance = (np.where(inside, (neighbours - mean) ** 2, 0.0).sum(axis=0)
                + (grey - mean) ** 2) / count
    diff2 = np.where(inside, (values - grey) ** 2, np.inf)
    closest = diff2.min(axis=0)
    csig = np.maximum(0.6 * variance, -closest / np.log(0.01))
    csig = np.maximum(csig, 2e-6)
    weights = np.where(inside, np.exp(-np.where(inside, diff2, 0.0) / csig), 0.0)
    weights /= weights.sum(axis=0)
    return weights, np.array(_WINDOW_3X3)


def colorization_fill(
    intensity: np.ndarray, partial_range: np.ndarray, *, alpha: float = 1.0
) -> np.ndarray:
    """Fill the range by Levin et al.'s colorization, as the NYU Depth V2 toolbox does for depth.

    The range is propagated along the intensity image: each pixel's range
    should be the affinity-weighted mean of its 3×3 neighbours', where
    neighbours of similar intensity weigh more (Levin, Lischinski & Weiss
    2004); known pixels pull towards their measurement with weight
    ``alpha``. One sparse linear system over all pixels, solved directly with
    ``scipy.sparse.linalg.spsolve``.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The guide. Colour is reduced to grey with MATLAB's ``rgb2gray``
        weights (0.2989, 0.5870, 0.1140), as the toolbox does; integer images
        are scaled to [0, 1] (the toolbox expects [0, 1]).
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range; the NaN pixels are filled.
    alpha : float, default 1
        Weight of the data term on the known pixels (the toolbox's
        ``alpha``), > 0.

    Returns
    -------
    ndarray of shape (H, W), float64
        Measured pixels are returned unchanged (the toolbox returns the
        solution there too, which the soft data term moves slightly; refsynth's
        baselines keep measurements, as :func:`refsynth.synthesize` does).

    Notes
    -----
    With the affinities :math:`w_{rs}` of :func:`colorization_affinities`
    (rows sum to 1), the known mask :math:`K` and the measured range
    :math:`d`, the fill :math:`x` solves

    .. math:: \\bigl((I - W) + \\alpha\\,\\mathrm{diag}(K)\\bigr)\\, x = \\alpha\\, K d,

    i.e. ``(A + G) \\ (vals .* imgDepth(:))`` in ``fill_depth_colorization.m``,
    solved for the correction to the nearest-neighbour fill (the same
    solution, but exact where the range is constant).
    The toolbox first divides the depth by its maximum and clips it to 1;
    the system is linear, so that scaling changes nothing and is left out.
    A constant range is reproduced exactly: the rows of ``I − W`` sum to 0.

    References
    ----------
    A. Levin, D. Lischinski and Y. Weiss, "Colorization using optimization",
    ACM TOG 23(3):689–694 (SIGGRAPH 2004), doi:10.1145/1015706.1015780.
    N. Silberman, D. Hoiem, P. Kohli and R. Fergus, ECCV 2012: the NYU Depth
    V2 toolbox, ``fill_depth_colorization.m`` (the window, the variance rule
    and ``alpha = 1`` are its).

    Examples
    --------
    >>> import numpy as np
    >>> image = np.array([[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]] * 3)
    >>> partial = np.array([[2.0, np.nan, np.nan, np.nan, np.nan, 5.0]] * 3)
    >>> np.round(colorization_fill(image, partial)[1], 2).tolist()
    [2.0, 2.0, 2.0, 5.0, 5.0, 5.0]
    """
    image, range_values = validate_inputs(intensity, partial_range)
    alpha = check_real("alpha", alpha, positive=True)
    guide = grey(image, BT601)  # MATLAB's rgb2gray, as the toolbox applies it
    H, W = guide.shape
    n = H * W
    known = np.isfinite(range_values)
    weights, offsets = colorization_affinities(guide)
    index = np.arange(n).reshape(H, W)
    rows, cols, vals = [index.ravel()], [index.ravel()], [np.ones(n) + alpha * known.ravel()]
    for k, (dr, dc) in enumerate(offsets):
        r0, r1 = max(0, -dr), H - max(0, dr)
        c0, c1 = max(0, -dc), W - max(0, dc)
        rows.append(index[r0:r1, c0:c1].ravel())
        cols.append(index[r0 + dr:r1 + dr, c0 + dc:c1 + dc].ravel())
        vals.append(-weights[k, r0:r1, c0:c1].ravel())
    matrix = sparse.csc_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
    )
    # solve for the correction y to the nearest fill x0 (x = x0 + y): the right-hand side
    # α K (d − x0) − (I − W) x0 = −Σ_s w_rs (x0_r − x0_s) is exactly 0 where x0 is
    # locally constant, so a constant range comes back exactly, however ill-conditioned
    # the system (weak links across strong intensity edges)
    start = nearest_fill(intensity, partial_range)
    rhs = np.zeros((H, W))
    for k, (dr, dc) in enumerate(offsets):
        r0, r1 = max(0, -dr), H - max(0, dr)
        c0, c1 = max(0, -dc), W - max(0, dc)
        rhs[r0:r1, c0:c1] -= weights[k, r0:r1, c0:c1] * (
            start[r0:r1, c0:c1] - start[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
        )
    out = start + sparse_linalg.spsolve(matrix, rhs.ravel()).reshape(H, W)
    out[known] = range_values[known]
    return out


def _largest_gap(known: np.ndarray) -> float:
    """The largest Euclidean distance from an unknown pixel to its nearest known one."""
    return float(ndimage.distance_transform_edt(~known).max())


def joint_bilateral_fill(
    intensity: np.ndarray,
    partial_range: np.ndarray,
    *,
    sigma_spatial: float | None = None,
    sigma_intensity: float = 0.1,
    radius: int | None = None,
) -> np.ndarray:
    """Joint-bilateral normalised convolution: known range × spatial × intensity Gaussians.

    Each unknown pixel ``p`` takes the weighted mean of the known range in a
    square window around it, weighted by distance and by similarity of
    intensity to ``p`` (the joint, or cross, bilateral filter of Kopf et al.
    2007 used as a normalised convolution, Knutsson & Westin 1993, with the
    known mask as the certainty).

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The guide; integer images are scaled to [0, 1].
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range; the NaN pixels are filled.
    sigma_spatial : float, optional
        σ of the spatial Gaussian, in pixels. Default: half the largest gap
        ``g`` (the largest distance from an unknown pixel to the nearest known
        one), at least 1, so that the known pixels nearest to the middle of
        the widest gap still weigh ``exp(−2)`` of a neighbour's.
    sigma_intensity : float, default 0.1
        σ of the intensity Gaussian, on the [0, 1] intensity scale; the
        squared difference is the mean over colour channels. Small values
        stop the fill from blending across intensity edges.
    radius : int, optional
        Half-width of the square window, in pixels. Default
        ``ceil(max(g, 2 σ_spatial))``: every unknown pixel then has a known
        pixel in its window.

    Returns
    -------
    ndarray of shape (H, W), float64
        Measured pixels unchanged. Where every weight in the window is 0
        (no known pixel in it, or all of them too unlike ``p`` in intensity
        for floating point), the nearest-neighbour fill's value.

    Notes
    -----
    .. math::

        R(p) = \\frac{\\sum_{q \\in W_p} K(q)\\, G_s(\\lVert p - q\\rVert)\\,
                      G_i(I_p - I_q)\\, R(q)}
                     {\\sum_{q \\in W_p} K(q)\\, G_s(\\lVert p - q\\rVert)\\,
                      G_i(I_p - I_q)},
        \\qquad G_\\sigma(x) = \\exp\\bigl(-x^2 / 2\\sigma^2\\bigr),

    with ``K`` the known mask. Computed with one shifted copy of the arrays
    per window offset ((2·radius + 1)² of them), all pixels at once, as the
    weighted mean of ``R(q) − R_0(p)`` added to ``R_0(p)``, ``R_0`` the
    nearest-neighbour fill: the same value, but exact where the known range
    within reach is constant.

    References
    ----------
    J. Kopf, M. F. Cohen, D. Lischinski and M. Uyttendaele, "Joint Bilateral
    Upsampling", ACM TOG 26(3):96 (SIGGRAPH 2007), doi:10.1145/1276377.1276497.
    H. Knutsson and C.-F. Westin, "Normalized and Differential Convolution",
    CVPR 1993, doi:10.1109/CVPR.1993.341081.

    Examples
    --------
    >>> import numpy as np
    >>> image = np.array([[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]] * 3)
    >>> partial = np.array([[2.0, np.nan, np.nan, np.nan, np.nan, 5.0]] * 3)
    >>> np.round(joint_bilateral_fill(image, partial, sigma_intensity=0.01)[1], 9).tolist()
    [2.0, 2.0, 2.0, 5.0, 5.0, 5.0]
    """
    image, range_values = validate_inputs(intensity, partial_range)
    known = np.isfinite(range_values)
    gap = _largest_gap(known)
    if sigma_spatial is None:
        sigma_spatial = max(1.0, gap / 2.0)
    sigma_spatial = check_real("sigma_spatial", sigma_spatial, positive=True)
    sigma_intensity = check_real("sigma_intensity", sigma_intensity, positive=True)
    if radius is None:
        radius = int(np.ceil(max(gap, 2.0 * sigma_spatial)))
    radius = check_int("radius", radius, minimum=1)

    H, W = known.shape
    certainty = known.astype(np.float64)
    # weighted mean of the deviations from the nearest fill, added back at the end: the
    # same mean, but exact where the known range in reach is constant
    reference = nearest_fill(intensity, partial_range)
    values = np.where(known, range_values, 0.0)
    numerator = np.zeros((H, W))
    denominator = np.zeros((H, W))
    for dr in range(-radius, radius + 1):
        r0, r1 = max(0, -dr), min(H, H - dr)  # p's rows whose q = p + (dr, dc) is inside
        if r0 >= r1:
            continue
        for dc in range(-radius, radius + 1):
            c0, c1 = max(0, -dc), min(W, W - dc)
            if c0 >= c1:
                continue
            q_rows, q_cols = slice(r0 + dr, r1 + dr), slice(c0 + dc, c1 + dc)
            spatial = np.exp(-(dr * dr + dc * dc) / (2.0 * sigma_spatial**2))
            difference = np.mean(
                (image[r0:r1, c0:c1] - image[q_rows, q_cols]) ** 2, axis=2
            )
            weight = certainty[q_rows, q_cols] * spatial * np.exp(
                -difference / (2.0 * sigma_intensity**2)
            )
            numerator[r0:r1, c0:c1] += weight * (
                values[q_rows, q_cols] - reference[r0:r1, c0:c1]
            )
            denominator[r0:r1, c0:c1] += weight
    out = range_values.copy()
    unknown = ~known
    reached = unknown & (denominator > 0)
    out[reached] = reference[reached] + numerator[reached] / denominator[reached]
    fallback = unknown & ~reached
    out[fallback] = reference[fallback]
    return out


#: The comparison fills by name, as the command line and the benchmarks use them.
BASELINES = {
    "nearest": nearest_fill,
    "linear": linear_fill,
    "harmonic": harmonic_fill,
    "colorization": colorization_fill,
    "joint-bilateral": joint_bilateral_fill,
}
