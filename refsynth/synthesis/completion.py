r"""Levin et al.'s colorization fill of the range, solved portably (the numeric contract).

:func:`refsynth.evaluation.baselines.colorization_fill` solves Levin, Lischinski & Weiss's
system with SuperLU (``scipy.sparse.linalg.spsolve``), whose pivoting and BLAS kernels pick
the order of the floating-point sums: its last bits, and so a rounding of BP's observations to
the range's ``2**-16`` grid, may differ between machines. :func:`portable_colorization` solves
the *same* system — the same 3×3 affinities (:func:`portable_affinities`), the same data term
``alpha`` on the measured pixels, the same correction to the nearest fill — approximately, by
Gauss–Seidel sweeps that use only what :mod:`refsynth.numeric` allows:

- elementwise IEEE ``+ − × ÷``, comparisons, ``minimum``/``maximum`` and ``max`` (order-free);
- every neighbour sum written out as shifted slices added one at a time, in the raster order
  of the 3×3 window (no ``sum``, ``mean``, ``@``, ``dot``: no BLAS, no pairwise regrouping);
- ``exp`` and ``log`` through :func:`refsynth.numeric.portable_exp` / ``portable_log``;
- the nearest fill from ``scipy.ndimage.distance_transform_edt`` (integer geometry);
- a stopping rule on ``max |Δ|``, the same decision on every machine.

So the same call gives the same bits on any CPU, SIMD width, BLAS and thread count.

The sweeps are Gauss–Seidel over four colours, the pixels ``(r, c)`` grouped by
``(r mod 2, c mod 2)``: no two pixels of one colour are 3×3 neighbours, so each colour is
updated at once, vectorised. The off-diagonal weights are non-negative and sum to 1 in every
row, the measured rows are strictly dominant: where every pixel is linked through non-zero
weights to a measured one, the matrix is an irreducibly diagonally dominant M-matrix and
Gauss–Seidel converges (the bound ``max_sweeps`` holds in any case). Over-relaxation
(ω > 1) does not always converge here (it diverged on the Motorcycle at 85 % unknown with
ω = 1.6) and is not offered.

Measured on the Motorcycle's x-stripes (phase 1, 63 / 78 / 85 % unknown, MAR in disparity
px, the defaults; one run each on a shared 2-core machine, so the times are rough):

================================  =======================  =======================
\                                 450×375                  900×750
================================  =======================  =======================
MAR against the direct solve      0.002 / 0.015 / 0.046    0.011 / 0.033 / 0.080
MAR against the ground truth      0.406 / 0.700 / 0.910    0.393 / 0.710 / 1.021
the direct solve's                0.407 / 0.705 / 0.929    0.394 / 0.705 / 1.049
sweeps                            656 / 932 / 1068         1078 / 1450 / 1726
seconds, this fill                2.5 / 3.6 / 3.6          11.5 / 15.7 / 24.0
seconds, the direct solve         3.3 / 3.9 / 3.6          16.8 / 16.8 / 16.3
================================  =======================  =======================

BP with this fill as its observations (``observation="colorization"``, 450×375) scored MAR
0.307 / 0.512 / 0.758, against 0.307 / 0.515 / 0.764 with the direct solve. Run to
``tolerance=1e-13`` on small cases the sweeps meet the direct solve to within 1e-9 of the
range's span (``tests/test_completion.py``).

References
----------
A. Levin, D. Lischinski and Y. Weiss, "Colorization using optimization", ACM TOG 23(3):689–694
(SIGGRAPH 2004), doi:10.1145/1015706.1015780.
N. Silberman, D. Hoiem, P. Kohli and R. Fergus, ECCV 2012: the NYU Depth V2 toolbox,
``fill_depth_colorization.m`` (the window, the variance rule and ``alpha = 1``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import ndimage

from refsynth._checks import BT601, check_int, check_real, grey
from refsynth.numeric import portable_exp, portable_log
from refsynth.synthesis.limits import validate_inputs

__all__ = ["portable_affinities", "portable_colorization"]

#: The 3×3 window without its centre, (row, col) offsets in raster order.
OFFSETS = tuple((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0))

_PER_MILLE = 1000  # the total of a progress report
_BAND = 1 << 15  # pixels of a colour updated at once by a sweep (its operands stay in cache)


def _shifted(padded: np.ndarray, dr: int, dc: int, shape: tuple[int, int]) -> np.ndarray:
    """``padded[1 + r + dr, 1 + c + dc]`` for every ``(r, c)`` of ``shape`` (a view)."""
    H, W = shape
    return padded[1 + dr:1 + dr + H, 1 + dc:1 + dc + W]


def portable_affinities(guide: np.ndarray) -> np.ndarray:
    r"""The normalised 3×3 affinities of Levin et al. (2004), with a fixed order of every sum.

    The weights of :func:`refsynth.evaluation.baselines.colorization_affinities` (the NYU
    toolbox's rule), within a few ulp, computed from elementwise IEEE operations only: the
    window's mean, variance and the normalisation add the neighbours one at a time in the
    order of :data:`OFFSETS`, and the exponential is :func:`refsynth.numeric.portable_exp`.

    Parameters
    ----------
    guide : ndarray of shape (H, W), float64
        The grey guide, in [0, 1].

    Returns
    -------
    ndarray of shape (8, H, W)
        ``weights[k, r, c]`` is the weight of neighbour ``(r, c) + OFFSETS[k]`` in the row of
        pixel ``(r, c)``; 0 outside the image; each pixel's weights sum to 1 (to rounding).

    Notes
    -----
    :math:`w_{rs} \propto \exp(-(Y_r - Y_s)^2 / c_r)` with
    :math:`c_r = \max(0.6\,\sigma_r^2,\ -\min_s (Y_r - Y_s)^2 / \ln 0.01,\ 2\cdot 10^{-6})`,
    :math:`\sigma_r^2` the population variance of the window (centre included). The middle
    bound makes the most similar neighbour weigh at least 0.01 before normalisation, so no
    row is all zeros.

    Examples
    --------
    >>> weights = portable_affinities(np.array([[0.0, 0.5], [0.5, 1.0]]))
    >>> weights.shape, np.round(weights[0] + weights[1] + weights[2] + weights[3]
    ...                         + weights[4] + weights[5] + weights[6] + weights[7], 12).tolist()
    ((8, 2, 2), [[1.0, 1.0], [1.0, 1.0]])
    """
    shape = guide.shape
    padded = np.pad(guide, 1, constant_values=np.nan)
    neighbours = [_shifted(padded, dr, dc, shape) for dr, dc in OFFSETS]
    inside = [np.isfinite(n) for n in neighbours]
    count = np.ones(shape)
    total = np.zeros(shape)
    for n, i in zip(neighbours, inside):
        count = count + i
        total = total + np.where(i, n, 0.0)
    mean = (total + guide) / count
    spread = np.zeros(shape)
    for n, i in zip(neighbours, inside):
        spread = spread + np.where(i, (n - mean) ** 2, 0.0)
    variance = (spread + (guide - mean) ** 2) / count
    diff2 = [np.where(i, (n - guide) ** 2, np.inf) for n, i in zip(neighbours, inside)]
    closest = diff2[0]
    for d in diff2[1:]:
        closest = np.minimum(closest, d)
    scale = np.maximum(0.6 * variance, -closest / float(portable_log(0.01)))
    scale = np.maximum(scale, 2e-6)
    raw = [np.where(i, portable_exp(-np.where(i, d, 0.0) / scale), 0.0)
           for d, i in zip(diff2, inside)]
    norm = np.zeros(shape)
    for r in raw:
        norm = norm + r
    return np.stack([r / norm for r in raw])


def portable_colorization(
    intensity: np.ndarray,
    partial_range: np.ndarray,
    *,
    alpha: float = 1.0,
    tolerance: float = 1e-4,
    max_sweeps: int = 2000,
    progress: Callable[[int, int], None] | None = None,
    return_sweeps: bool = False,
) -> np.ndarray | tuple[np.ndarray, int]:
    r"""Fill the range by Levin et al.'s colorization, the same bits on every machine.

    The system of :func:`refsynth.evaluation.baselines.colorization_fill` (each pixel's range
    the affinity-weighted mean of its 3×3 neighbours'; measured pixels pulled towards their
    measurement with weight ``alpha``), solved by four-colour Gauss–Seidel sweeps from the
    nearest fill with elementwise IEEE arithmetic only (see the module's docstring).

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        The guide, as :func:`refsynth.synthesize` takes it; colour is reduced to grey with
        MATLAB's ``rgb2gray`` weights (BT.601) as the NYU toolbox does, integer images are
        scaled to [0, 1].
    partial_range : ndarray of shape (H, W), NaN where unknown
        The measured range; the NaN pixels are filled.
    alpha : float, default 1
        Weight of the data term on the measured pixels, > 0.
    tolerance : float, default 1e-4
        Stop after the first sweep that moves no pixel by more than ``tolerance`` times the
        span (max − min) of the measured range; >= 0 (0 runs ``max_sweeps`` sweeps).
    max_sweeps : int, default 2000
        The most sweeps, >= 1.
    progress : callable, optional
        ``progress(done, 1000)`` after a sweep: per mille of the sweeps this
        fill is estimated to need (the rate at which the largest change has
        fallen, extrapolated to the stopping rule's ``tolerance``), never
        backwards, and ``(1000, 1000)`` at the end. It reads the sweeps and
        changes nothing in them.
    return_sweeps : bool, default False
        Also return the number of sweeps run.

    Returns
    -------
    ndarray of shape (H, W), float64
        Measured pixels unchanged; a constant measured range comes back exactly.
    sweeps : int
        Only with ``return_sweeps``: the Gauss–Seidel sweeps run (at most
        ``max_sweeps``).

    Raises
    ------
    TypeError, ValueError
        Naming the argument, as :func:`refsynth.synthesize` does for the images.

    Notes
    -----
    With the weights :math:`w_{rs}` of :func:`portable_affinities`, the known mask :math:`K`
    and the measured range :math:`d`, the fill solves
    :math:`((I - W) + \alpha\,\mathrm{diag}(K))\,x = \alpha K d`. As in ``colorization_fill``
    the unknown is the correction :math:`y = x - x_0` to the nearest fill :math:`x_0`, whose
    right-hand side :math:`b_r = \sum_s w_{rs}(x_{0,s} - x_{0,r})` is exactly 0 where
    :math:`x_0` is locally constant. A sweep sets, colour by colour,

    .. math:: y_r \leftarrow \Bigl(b_r + \sum_s w_{rs}\, y_s\Bigr) / (1 + \alpha K_r),

    the terms added in the order of :data:`OFFSETS`. The result differs from the direct
    solve by what the stopping rule leaves: on the Motorcycle's x-stripes (450×375, 63 / 78
    / 85 % unknown) a mean absolute difference of about 0.002 / 0.015 / 0.046 disparity px.

    Examples
    --------
    >>> image = np.array([[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]] * 3)
    >>> partial = np.array([[2.0, np.nan, np.nan, np.nan, np.nan, 5.0]] * 3)
    >>> np.round(portable_colorization(image, partial)[1], 2).tolist()
    [2.0, 2.0, 2.0, 5.0, 5.0, 5.0]
    >>> flat = np.where(np.eye(4, dtype=bool), 7.25, np.nan)
    >>> portable_colorization(np.random.default_rng(0).random((4, 4)), flat).tolist()[0]
    [7.25, 7.25, 7.25, 7.25]
    """
    image, range_values = validate_inputs(intensity, partial_range)
    alpha = check_real("alpha", alpha, positive=True)
    tolerance = check_real("tolerance", tolerance, minimum=0.0)
    max_sweeps = check_int("max_sweeps", max_sweeps, minimum=1)
    guide = grey(image, BT601)  # MATLAB's rgb2gray, as the toolbox applies it
    shape = guide.shape
    known = np.isfinite(range_values)
    _, (rows, cols) = ndimage.distance_transform_edt(~known, return_indices=True)
    start = range_values[rows, cols]  # the nearest fill: copies, exact
    weights = portable_affinities(guide)
    padded = np.pad(start, 1, mode="edge")  # (outside the image the weight is 0)
    rhs = np.zeros(shape)
    for k, (dr, dc) in enumerate(OFFSETS):
        rhs = rhs + weights[k] * (_shifted(padded, dr, dc, shape) - start)
    diagonal = np.where(known, 1.0 + alpha, 1.0)
    span = float(np.max(range_values[known])) - float(np.min(range_values[known]))
    on_sweep = None if progress is None else _SweepEstimate(progress, tolerance * span,
                                                             max_sweeps)
    correction, sweeps = _gauss_seidel(weights, rhs, diagonal, tolerance * span, max_sweeps,
                                       on_sweep=on_sweep)
    if progress is not None:
        progress(_PER_MILLE, _PER_MILLE)
    out = start + correction
    out[known] = range_values[known]
    return (out, sweeps) if return_sweeps else out


class _SweepEstimate:
    """``on_sweep(sweeps, largest)`` → ``progress(done, 1000)``: the sweeps done over an estimate.

    The largest change of a Gauss–Seidel sweep falls about geometrically; its rate over the
    later half of the sweeps so far, extrapolated to ``stop``, estimates the sweeps left (on
    the Motorcycle at 450×375 it reads about 30 / 50 / 70 / 90 % at a tenth, a quarter, a half
    and nine tenths of the time: early, as a slowing convergence makes it).
    """

    def __init__(self, progress, stop: float, max_sweeps: int) -> None:
        self.progress, self.stop, self.max_sweeps = progress, stop, max_sweeps
        self.history: list[float] = []
        self.reported = -1

    def __call__(self, sweeps: int, largest: float) -> None:
        self.history.append(largest)
        left = self.max_sweeps - sweeps
        back = len(self.history) // 2  # the rate over the later half of the sweeps so far
        if back and self.stop > 0 and largest > self.stop:
            before = self.history[-1 - back]
            if 0 < largest < before:
                rate = float(portable_log(before / largest)) / back  # per sweep
                left = min(left, float(portable_log(largest / self.stop)) / rate)
        done = sweeps / (sweeps + max(left, 0.0))
        done = min(int(done * _PER_MILLE), _PER_MILLE - 1)
        if done > self.reported:  # never backwards
            self.reported = done
            self.progress(done, _PER_MILLE)


def _gauss_seidel(
    weights: np.ndarray, rhs: np.ndarray, diagonal: np.ndarray, stop: float, max_sweeps: int,
    *, on_sweep: Callable[[int, float], None] | None = None,
) -> tuple[np.ndarray, int]:
    """Solve ``diagonal·y − Σ_k weights[k]·y(shifted by OFFSETS[k]) = rhs`` from ``y = 0``.

    Four-colour Gauss–Seidel, at most ``max_sweeps`` sweeps; stops after a sweep whose largest
    change is ``<= stop``. Every sum is added in the order of :data:`OFFSETS`. Returns the
    solution and the number of sweeps run; ``on_sweep(sweeps, largest)``, if given, is told
    each sweep's largest change.

    The correction is held as four contiguous planes, one per colour, each with a border of
    zeros (the weight is 0 there), so that a neighbour of a colour is a shifted slice of
    another colour's plane; a colour is updated band by band of about :data:`_BAND` pixels,
    whose operands stay in the processor's cache. No two pixels of one colour are neighbours,
    so the bands of a colour read nothing that another band of it writes: the same
    operations on the same values as one update of the whole colour, bit for bit.
    """
    H, W = rhs.shape
    hh, ww = (H + 1) // 2, (W + 1) // 2
    planes = {(pr, pc): np.zeros((hh + 2, ww + 2)) for pr in (0, 1) for pc in (0, 1)}
    colours = []
    for pr in (0, 1):
        for pc in (0, 1):
            cells = (slice(pr, None, 2), slice(pc, None, 2))
            h, w = rhs[cells].shape
            reads = []
            for sr, sc in OFFSETS:  # pixel (2i + pr + sr, ...) is row i + (pr + sr) // 2 there
                qr, qc = pr + sr, pc + sc
                r0, c0 = 1 + qr // 2, 1 + qc // 2
                reads.append(planes[qr % 2, qc % 2][r0:r0 + h, c0:c0 + w])
            band = max(1, _BAND // max(w, 1))
            colours.append(([np.ascontiguousarray(wk[cells]) for wk in weights], reads,
                            np.ascontiguousarray(rhs[cells]), np.ascontiguousarray(diagonal[cells]),
                            planes[pr, pc][1:1 + h, 1:1 + w], h, band))
    largest_band = max(_BAND, ww)  # a band's pixels, at most: band · w <= max(_BAND, w)
    total_buffer = np.empty(largest_band)
    term_buffer = np.empty(largest_band)
    sweeps = 0
    while sweeps < max_sweeps:
        sweeps += 1
        largest = 0.0
        for wc, reads, bc, dc, cell, h, band in colours:
            w = cell.shape[1]
            for i0 in range(0, h, band):
                rows = slice(i0, min(i0 + band, h))
                size = (rows.stop - i0) * w
                total = total_buffer[:size].reshape(-1, w)
                term = term_buffer[:size].reshape(-1, w)
                np.copyto(total, bc[rows])
                for k in range(len(OFFSETS)):  # b + w_0 y_0 + w_1 y_1 + …, left to right
                    np.multiply(wc[k][rows], reads[k][rows], out=term)
                    np.add(total, term, out=total)
                np.divide(total, dc[rows], out=total)
                np.subtract(total, cell[rows], out=term)
                largest = max(largest, float(np.max(np.abs(term, out=term))))
                cell[rows] = total
        if on_sweep is not None:
            on_sweep(sweeps, largest)
        if largest <= stop:
            break
    y = np.empty((H, W))
    for (pr, pc), plane in planes.items():
        h, w = y[pr::2, pc::2].shape
        y[pr::2, pc::2] = plane[1:1 + h, 1:1 + w]
    return y, sweeps
