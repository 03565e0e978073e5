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

**Cascadic multigrid** (``solver="cascadic"``, the default; Bornemann & Deuflhard
1996). Plain Gauss–Seidel needs more sweeps the larger the image (the stopping rule is met
after 641 / 388 / 968 / 1438 sweeps at 112×94 … 900×750 on the Motorcycle's x-stripes at
78 %), so its cost per unknown pixel grew from 5.3 µs at 225×188 to 17–19 µs at 900×750. The
cascade solves the same system on the image halved (2×2 block means of the guide and of the
measured range, each sum in a fixed order), recursively down to a side below ``2*COARSEST``,
takes each level's solution, repeated over its 2×2 block with the measured values put back,
as the next finer level's start, and runs at most ``sweeps`` sweeps on the finest level,
twice as many on each coarser one (``max_sweeps`` on the coarsest), each level also stopping
at the rule. Its cost is at most ``2 · sweeps`` sweeps' worth of the finest level, plus at
most ``max_sweeps`` sweeps of the coarsest (whose smaller side is under ``2*COARSEST``):
linear in the pixels. An image whose smaller side is below ``2*COARSEST`` has one level, and
its fill is plain Gauss–Seidel's, bit for bit (the oracle's cases are such images).

The sweeps are Gauss–Seidel over four colours, the pixels ``(r, c)`` grouped by
``(r mod 2, c mod 2)``: no two pixels of one colour are 3×3 neighbours, so each colour is
updated at once, vectorised. The off-diagonal weights are non-negative and sum to 1 in every
row, the measured rows are strictly dominant: where every pixel is linked through non-zero
weights to a measured one, the matrix is an irreducibly diagonally dominant M-matrix and
Gauss–Seidel converges (the bound ``max_sweeps`` holds in any case). Over-relaxation
(ω > 1) does not always converge here (it diverged on the Motorcycle at 85 % unknown with
ω = 1.6) and is not offered.

Measured with ``solver="gauss-seidel"`` (Gauss–Seidel on the image alone) on the
Motorcycle's x-stripes (phase 1, 63 / 78 / 85 % unknown, MAR in disparity px; one run
each on a shared 2-core machine, so the times are rough):

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

``python benchmarks/bench_speed.py --fill-solvers`` prints the cascade (``sweeps=200``) beside
it on the same cases at stripe phase 0: CPU µs per unknown pixel, the sweeps on the image
itself, and the fill's MAR against the ground truth beside the direct solve's.

References
----------
F. A. Bornemann and P. Deuflhard, "The cascadic multigrid method for elliptic problems",
Numerische Mathematik 75:135–152 (1996), doi:10.1007/s002110050234.
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

__all__ = ["COARSEST", "SOLVERS", "portable_affinities", "portable_colorization"]

#: The 3×3 window without its centre, (row, col) offsets in raster order.
OFFSETS = tuple((dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0))

_PER_MILLE = 1000  # the total of a progress report
#: The cascade halves the image while its smaller side is at least twice this.
COARSEST = 16
#: The solvers :func:`portable_colorization` offers.
SOLVERS = ("cascadic", "gauss-seidel")
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
    solver: str = "cascadic",
    sweeps: int = 200,
    progress: Callable[[int, int], None] | None = None,
    return_sweeps: bool = False,
) -> np.ndarray | tuple[np.ndarray, int]:
    r"""Fill the range by Levin et al.'s colorization, the same bits on every machine.

    The system of :func:`refsynth.evaluation.baselines.colorization_fill` (each pixel's range
    the affinity-weighted mean of its 3×3 neighbours'; measured pixels pulled towards their
    measurement with weight ``alpha``), solved by four-colour Gauss–Seidel sweeps with
    elementwise IEEE arithmetic only, from a coarse-to-fine start (the cascade) or from the
    nearest fill (see the module's docstring).

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
        Each level stops after the first sweep that moves no pixel by more than
        ``tolerance`` times the span (max − min) of the measured range; >= 0 (0 runs every
        level's most sweeps).
    max_sweeps : int, default 2000
        The most sweeps of the coarsest level (of the only one with
        ``solver="gauss-seidel"``) and of any level, >= 1.
    solver : {"cascadic", "gauss-seidel"}, default "cascadic"
        The cascadic multigrid (linear cost) or Gauss–Seidel on the image alone (whose
        sweeps grow with the image). Both give the same bits on an image whose smaller
        side is below ``2 * COARSEST``.
    sweeps : int, default 200
        The cascade's most sweeps on the finest level (doubled on each coarser level), >= 1.
    progress : callable, optional
        ``progress(done, 1000)`` after a sweep: per mille of the estimated work, never
        backwards, and ``(1000, 1000)`` at the end (the cascade: the sweeps run times their
        level's pixels over that plus the most the levels can still run; Gauss–Seidel: the
        rate at which the largest change has fallen, extrapolated to the stopping rule). It
        reads the sweeps and changes nothing in them.
    return_sweeps : bool, default False
        Also return the number of sweeps run on the finest level (the image itself).

    Returns
    -------
    ndarray of shape (H, W), float64
        Measured pixels unchanged; a constant measured range comes back exactly.
    sweeps : int
        Only with ``return_sweeps``: the Gauss–Seidel sweeps run on the finest level.

    Raises
    ------
    TypeError, ValueError
        Naming the argument, as :func:`refsynth.synthesize` does for the images.

    Notes
    -----
    With the weights :math:`w_{rs}` of :func:`portable_affinities`, the known mask :math:`K`
    and the measured range :math:`d`, the fill solves
    :math:`((I - W) + \alpha\,\mathrm{diag}(K))\,x = \alpha K d`. On each level the unknown
    is the correction :math:`y = x - x_0` to the level's start :math:`x_0` (the nearest fill
    on the coarsest level, the coarser level's solution elsewhere; :math:`d` where measured),
    whose right-hand side is :math:`b_r = \sum_s w_{rs}(x_{0,s} - x_{0,r})`. A sweep sets,
    colour by colour,

    .. math:: y_r \leftarrow \Bigl(b_r + \sum_s w_{rs}\, y_s\Bigr) / (1 + \alpha K_r),

    the terms added in the order of :data:`OFFSETS`. The coarser level's guide and measured
    range are the 2×2 block means (of the block's pixels inside the image, and of its
    measured pixels: NaN where it has none), each sum in raster order.

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
    sweeps = check_int("sweeps", sweeps, minimum=1)
    if solver not in SOLVERS:
        raise ValueError(f"The parameter `solver` must be one of {SOLVERS}, got {solver!r}")
    guide = grey(image, BT601)  # MATLAB's rgb2gray, as the toolbox applies it
    known = np.isfinite(range_values)
    span = float(np.max(range_values[known])) - float(np.min(range_values[known]))
    stop = tolerance * span
    # the levels, finest first: (guide, measured range, most sweeps)
    levels = [(guide, range_values, max_sweeps)]
    if solver == "cascadic":
        levels[0] = (guide, range_values, min(sweeps, max_sweeps))
        while min(levels[-1][0].shape) >= 2 * COARSEST:
            g, r, most = levels[-1]
            levels.append((_block_mean(g, np.ones(g.shape, dtype=bool)),
                           _block_mean(r, np.isfinite(r)), min(2 * most, max_sweeps)))
        levels[-1] = levels[-1][:2] + (max_sweeps,)
    on_sweep = None
    if progress is not None:
        if len(levels) == 1:
            on_sweep = _SweepEstimate(progress, stop, max_sweeps)
        else:
            on_sweep = _WorkEstimate(progress, [(g.size, most) for g, _, most in levels])
    x = None
    for g, r, most in reversed(levels):  # coarsest first
        x, run = _level(g, r, x, alpha, stop, most, on_sweep)
        if isinstance(on_sweep, _WorkEstimate):
            on_sweep.next_level()
    if progress is not None:
        progress(_PER_MILLE, _PER_MILLE)
    x[known] = range_values[known]
    return (x, run) if return_sweeps else x


def _block_mean(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """The 2×2 block means of ``values`` over ``valid`` (NaN where a block has none).

    The blocks start at (0, 0); an odd side's last block holds one row or column. The four
    pixels of a block are added in raster order, then divided by their count: elementwise
    IEEE operations only.
    """
    H, W = values.shape
    shape = ((H + 1) // 2, (W + 1) // 2)
    total, count = np.zeros(shape), np.zeros(shape)
    for dr in (0, 1):
        for dc in (0, 1):
            part, inside = values[dr::2, dc::2], valid[dr::2, dc::2]
            cells = (slice(0, part.shape[0]), slice(0, part.shape[1]))
            total[cells] = total[cells] + np.where(inside, part, 0.0)
            count[cells] = count[cells] + inside
    out = np.full(shape, np.nan)
    np.divide(total, count, out=out, where=count > 0)
    return out


def _level(guide: np.ndarray, range_values: np.ndarray, coarse: np.ndarray | None,
           alpha: float, stop: float, most: int, on_sweep) -> tuple[np.ndarray, int]:
    """One level of the fill: Gauss–Seidel from the coarser solution (or the nearest fill)."""
    shape = guide.shape
    known = np.isfinite(range_values)
    if coarse is None:
        _, (rows, cols) = ndimage.distance_transform_edt(~known, return_indices=True)
        start = range_values[rows, cols]  # the nearest fill: copies, exact
    else:  # the coarser level's solution over its 2×2 blocks, the measured values put back
        start = coarse.repeat(2, axis=0).repeat(2, axis=1)[: shape[0], : shape[1]]
        start = np.where(known, range_values, start)
    weights = portable_affinities(guide)
    padded = np.pad(start, 1, mode="edge")  # (outside the image the weight is 0)
    rhs = np.zeros(shape)
    for k, (dr, dc) in enumerate(OFFSETS):
        rhs = rhs + weights[k] * (_shifted(padded, dr, dc, shape) - start)
    diagonal = np.where(known, 1.0 + alpha, 1.0)
    correction, run = _gauss_seidel(weights, rhs, diagonal, stop, most, on_sweep=on_sweep)
    return start + correction, run


class _WorkEstimate:
    """``on_sweep(sweeps, largest)`` → ``progress(done, 1000)`` for the cascade.

    The work done is the sweeps run times their level's pixels; the estimate of the whole
    adds the most sweeps the current level and the finer ones can still run (a level that
    stops early moves the estimate forward, never back).
    """

    def __init__(self, progress, levels: list[tuple[int, int]]) -> None:
        self.progress = progress
        self.levels = levels[::-1]  # (pixels, most sweeps), coarsest first
        self.level, self.done = 0, 0
        self.reported = -1

    def next_level(self) -> None:
        self.level += 1

    def __call__(self, sweeps: int, largest: float) -> None:
        pixels, most = self.levels[self.level]
        self.done += pixels
        left = (most - sweeps) * pixels + sum(p * m for p, m in self.levels[self.level + 1:])
        done = min(int(self.done / (self.done + left) * _PER_MILLE), _PER_MILLE - 1)
        if done > self.reported:
            self.reported = done
            self.progress(done, _PER_MILLE)


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
