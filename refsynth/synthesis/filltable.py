r"""Eq. 2 for NP's sequential fill: narrow rows per voxel, a pruned gather per step (§3.2.2).

NP (:mod:`refsynth.synthesis.nonparametric`) evaluates Eq. 2 between the
voxel ``p`` it fills and every candidate ``q`` of ``A_p`` (Eq. 3), one voxel
at a time. :class:`FillTable` holds, per voxel of the padded frame, the row

.. math:: [\, I_{v,c} \mid s_q \mid 1 \mid R_v \mid V_v \,]_{v \in N_q}

(intensity; the self term ``s_q = Σ_v G_v Σ_c I²``; the constant 1; range, stored as 0
where unknown; has-range indicator), held as two arrays: the intensity rows
``[I | s | 1]`` (fixed) and the range rows ``[R | V | 1]`` (written as the fill goes).
The integers of the numeric contract (:mod:`refsynth.numeric`) up to ``2**16`` are exact
in float32; ``s_q`` (below ``2**52``) is stored as three parts, each part exact and their
sum exactly the integer (in float64 the first part is ``s_q`` and the others 0). The
squared range ``R²`` (up to ``2**32``, which float32 cannot hold) is not stored: each step
squares the few range rows it gathers, in float64 (exact).

The range rows are float32. The intensity rows are float64 when they then take at most
:data:`WIDE_TABLE_BYTES` (1 GiB: a colour image up to about 1280×1280 with the default
window and radius), and float32 above, at half the memory
(:func:`intensity_dtype`): every step gathers some 190 intensity rows, and widening them to
float64 for the product took about 9 % of the fill's instructions. Both hold the same
integers, so the distances are the same bits either way. A float32 row is 520 bytes
(316 + 204) for a colour 5×5 window, against 1200 for
:class:`refsynth.synthesis.patch_table.PatchTable`'s float64 ``[I | V | R | R²]`` (BP's
table): the table of a 900×750 image takes about 370 MB instead of 850. (Holding ``R²`` in
the range rows too, as two float32 parts, would cost 200 bytes more a pixel, 820 MiB more at
2048×2048, for a few per cent less time.)

The gathered rows are float64, or widened to it, and the four sums of Eq. 2

.. math::

    s_i = s_p + s_q - 2 \sum_v G_v \sum_c I_p I_q, \qquad
    s_r = \sum_v G_v \left[ V_p R_q^2 - 2 R_p R_q + R_p^2 V_q \right],

    w_s = \sum_v G_v V_p V_q, \qquad w_a = \sum_v G_v V_p

come from matrix–vector products with weights built from ``p``'s row
(``s_i`` over ``[I | s_q | 1]``, the constant 1 weighted by ``s_p``; then one product of
the range rows with three weight rows: ``s_r``'s last two terms over ``[R | V]``, ``w_s``
over ``V``, and the offset copy's ``b``; one more of the squared ``R`` with ``G V_p``,
``s_r``'s first term, added to them; ``w_a`` is the sum of ``w_s``'s weights). The
weights carry the sums' units, :data:`~refsynth.numeric.EQ2_UNIT` for ``s_i`` and ``s_r``
and :data:`~refsynth.numeric.WEIGHT_UNIT` for ``w_s`` and ``w_a`` (powers of two,
so scaling is exact). Every product and partial sum is an integer below
``2**53`` times its unit, so each sum is exact whatever the order (BLAS,
threads, SIMD): the same integers as ``PatchTable.distances`` and the literal
reference, times the units ``combine_eq2`` multiplies them by first, then
combined by the rest of the IEEE operations of
:func:`refsynth.numeric.combine_eq2`, give the same distances bit for bit
(``tests/test_np_speed_table.py``).

Per step, :meth:`FillTable.shortlist` gathers the range rows only of the candidates whose
intensity term alone does not already exceed ``1 + ε`` times one candidate's whole distance
(Eq. 2's range term is never negative, so the others can be neither Eq. 4's best match nor
in Eq. 5's set): on the Motorcycle about 12 of 190 candidates, the same decisions and
distances bit for bit. The bound is the whole distance of the candidate with the smallest
intensity term; where it is the only candidate left, its distance, computed for the bound,
is returned as it is, and NP takes it without Eq. 5's draw (a set of one). The cost is a
few numpy calls and three small products (``@``) a step.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.numeric import (
    EQ2_UNIT,
    INTENSITY_BITS,
    RANGE_BITS,
    SUPPORT_PRIOR,
    WEIGHT_UNIT,
    WINDOW_BITS,
    window_weights,
)
from refsynth.synthesis.neighbourhood import intensity_patches
from refsynth.synthesis.range_copy import OFFSET_BITS, round_half_even

__all__ = ["FillTable", "WIDE_TABLE_BYTES", "intensity_dtype"]


#: The most bytes :class:`FillTable`'s intensity rows may take as float64
#: (:func:`intensity_dtype`).
WIDE_TABLE_BYTES = 2**30


def intensity_dtype(pixels: int, channels: int, n: int) -> type:
    """The dtype of :class:`FillTable`'s intensity rows: float64 up to :data:`WIDE_TABLE_BYTES`.

    Parameters
    ----------
    pixels : int
        Pixels of the padded frame (the table's rows).
    channels : int
        Intensity channels.
    n : int
        Window side.

    Returns
    -------
    type
        ``numpy.float64`` when the float64 intensity rows (``n² C + 4`` entries each) take
        at most :data:`WIDE_TABLE_BYTES`, else ``numpy.float32``: half the memory, widened
        by every product (the same integers, so the same distances).

    Examples
    --------
    >>> intensity_dtype(920 * 770, 3, 5).__name__, intensity_dtype(2068**2, 3, 5).__name__
    ('float64', 'float32')
    """
    return np.float64 if pixels * (n * n * channels + 4) * 8 <= WIDE_TABLE_BYTES else np.float32



#: Pixels of the frame built at a time, in whole rows: the float64 temporaries (about 2 MB)
#: stay in cache. (Blocks of 64 rows took 4.4-4.8 µs per unknown pixel at 450×375 and
#: 900×750, against 1.2-1.3.)
_CHUNK_PIXELS = 1 << 12

#: The offset copy's agreement on the range grid (range_copy.OFFSET_BITS), and the factor that
#: takes a weight sum back from WEIGHT_UNIT to integers (a power of two: exact).
_SLACK = 2.0 ** (RANGE_BITS - OFFSET_BITS)
_TO_WINDOW = 2.0**WINDOW_BITS


class FillTable:
    """Every voxel's neighbourhood as one row ``[I | s | R | V]``, for NP (Eq. 2).

    The same distances as :class:`refsynth.synthesis.patch_table.PatchTable`
    (bit for bit) in less memory; see the module docstring.

    Parameters
    ----------
    image : ndarray of shape (H, W, C)
        Intensity normalised to [0, 1] on the ``2**-16`` grid (``q · 2**-16``).
    range_norm : ndarray of shape (H, W)
        Range normalised to [0, 1] on the ``2**-16`` grid, NaN where unknown.
    n : int
        Odd window side.
    pad : int
        Padding of the frame (at least ``n // 2``).
    range_weight : float
        λ of Eq. 2.
    missing_range : {"mean", "ignore"}
        As in :class:`refsynth.synthesis.patch_table.PatchTable`.
    channels : {"sum", "mean"}, default "sum"
        As in :class:`refsynth.synthesis.patch_table.PatchTable`.
    dtype : {None, numpy.float32, numpy.float64}, default None
        The intensity rows' dtype; None: :func:`intensity_dtype` of the frame. Either gives
        the same distances, bit for bit.

    Examples
    --------
    >>> import numpy as np
    >>> image = np.arange(16.0).reshape(4, 4, 1) / 16
    >>> rng = np.where(np.eye(4) > 0, np.nan, 0.5)
    >>> table = FillTable(image, rng, 3, 2, 1.0)
    >>> p, q = 2 * 8 + 2, 3 * 8 + 2          # (0, 0) and (1, 0) of the image
    >>> float(table.distances(p, np.array([q]))[0]) > 0
    True
    """

    def __init__(
        self,
        image: np.ndarray,
        range_norm: np.ndarray,
        n: int,
        pad: int,
        range_weight: float,
        missing_range: str = "mean",
        channels: str = "sum",
        dtype: type | None = None,
    ) -> None:
        H, W, C = image.shape
        self.shape = (H + 2 * pad, W + 2 * pad)
        pixels = self.shape[0] * self.shape[1]
        self.channels = C
        self.divisor = C if channels == "mean" else 1  # Eq. 2's channel sum, or their mean
        nn = n * n
        base = nn * C
        self.n, self.nn, self.base = n, nn, base
        # the intensity rows: I, the self term in three parts, the constant 1
        s0, one = base, base + 3
        self.one = one
        # the range rows: R, V, the constant 1 (read by p's weights); R² is formed per step
        r0, v0 = 0, nn
        width = 2 * nn + 1
        self.r0, self.v0, self.range_width = r0, v0, width
        if dtype is None:
            dtype = intensity_dtype(pixels, C, n)
        self.intensity = np.zeros((pixels, base + 4), dtype=dtype)
        self.ranges = np.zeros((pixels, width), dtype=np.float32)
        frame_i = self.intensity.reshape(self.shape + (base + 4,))
        frame_r = self.ranges.reshape(self.shape + (width,))
        # the constant columns on the image's pixels, the only rows ever read (p and the
        # candidates): the padding's rows stay zero pages that are never touched (45 MB of
        # resident memory at 2048×2048); set_range writes the range of the rows within n // 2
        inner = (slice(pad, pad + H), slice(pad, pad + W))
        frame_i[inner + (one,)] = 1.0
        frame_r[inner + (-1,)] = 1.0
        # Σ G Σ_c I² (exact), then times EQ2_UNIT below: s_p u, the weight of the
        # candidates' constant 1 (a power-of-two scaling: exact)
        self.self_unit = np.zeros(pixels)
        self_frame = self.self_unit.reshape(self.shape)
        g = window_weights(n).ravel().astype(np.float64)
        g_int = np.repeat(g, C)  # intensity columns are (offset, channel) raveled
        levels = np.multiply(np.asarray(image, dtype=np.float64), 2.0**INTENSITY_BITS)
        np.rint(levels, out=levels)  # in place: one image-sized temporary, not two
        patches = intensity_patches(levels, n)  # a view, (H, W, n, n, C)
        h = n // 2
        rq = np.rint(np.asarray(range_norm, dtype=np.float64) * 2.0**RANGE_BITS)
        rpad = np.pad(rq, h, mode="constant", constant_values=np.nan)
        rp = sliding_window_view(rpad, (n, n))  # (H, W, n, n)
        chunk = max(1, _CHUNK_PIXELS // W)
        for top in range(0, H, chunk):
            rows = slice(top, min(H, top + chunk))
            out = frame_i[pad + rows.start : pad + rows.stop, pad : pad + W]
            ints = np.ascontiguousarray(patches[rows]).reshape(-1, W, base)
            out[:, :, :base] = ints
            s = (ints**2) @ g_int
            self_frame[pad + rows.start : pad + rows.stop, pad : pad + W] = s
            out[:, :, s0:one] = _split(s, 3, self.intensity.dtype)
            out = frame_r[pad + rows.start : pad + rows.stop, pad : pad + W]
            r = rp[rows].reshape(-1, W, nn)
            has = np.isfinite(r)
            r = np.where(has, r, 0.0)
            out[:, :, r0:v0] = r
            out[:, :, v0:-1] = has
        self.self_unit *= EQ2_UNIT
        # p's weights. Intensity, over [I | S | 1]: G I_p (-2 u) on I, u on the self term's
        # parts, s_p u on the constant 1 (written per step). Range, over [R | V] and the
        # candidates' R² (formed per step), then Eq. 2's support weights G V_p: w =
        # (row_p[perm] · row_p[square]) · coef, every factor and product an exact integer
        # times a power of two (the units of the sums, folded into coef), so every product
        # and partial sum of the mat-vec products stays exact. `square` reads R_p for the V
        # block (the weight G R_p² u) and the range row's constant 1 elsewhere.
        self.coef_i = -2.0 * g_int * EQ2_UNIT
        self.w_si = np.full(base + 4, EQ2_UNIT)
        self._w_i = self.w_si[:base]
        # the range weights as three rows over the range row, so that one product gives
        # s_r less its V_p R_q² term, w_s and the offset copy's b: row 0 is s_r's weights
        # over [R | V] (-2 G R_p u, G R_p² u; 0 on the constant), row 1 w_s's, G V_p w over V
        # (0 elsewhere), row 2 b's, -G V_p w over R and G V_p R_p w over V (b = Σ G V_p V_q
        # (R_p - R_q) w, as R_q = 0 where V_q = 0); then a fourth block, G V_p u, the weights
        # of the candidates' R_q² (s_r's V_p R_q² term). An unused entry reads the constant
        # 1 twice and has the coefficient 0.
        last, zeros = np.full(nn, width - 1), np.zeros(nn)
        r_cols, v_cols = np.arange(r0, v0), np.arange(v0, width - 1)
        self.perm = np.concatenate([r_cols, r_cols, [width - 1],
                                    last, v_cols, [width - 1],
                                    v_cols, v_cols, [width - 1],
                                    v_cols])
        self.square = np.concatenate([last, r_cols, [width - 1],
                                      last, last, [width - 1],
                                      last, r_cols, [width - 1],
                                      last])
        self.coef = np.concatenate([-2.0 * g * EQ2_UNIT, g * EQ2_UNIT, [0.0],
                                    zeros, g * WEIGHT_UNIT, [0.0],
                                    -g * WEIGHT_UNIT, g * WEIGHT_UNIT, [0.0],
                                    g * EQ2_UNIT])
        self.weights = np.zeros(3 * width + nn)
        self.range_weights = self.weights[: 3 * width].reshape(3, width)
        self.square_weights = self.weights[3 * width :]  # G V_p u, on R_q²
        self.product = np.zeros(3 * width + nn)
        # row_p[perm] and row_p[square] by one take into a buffer (mode "clip": the indices
        # are valid, and "raise" with out= would take into a temporary first)
        self._both = np.concatenate([self.perm, self.square])
        self._taken = np.empty(2 * self.perm.size, dtype=np.float32)
        self._by_perm, self._by_square = self._taken[: self.perm.size], self._taken[
            self.perm.size :]
        # views of the weights, made once: support
        self.g_v = self.range_weights[1, v0 : v0 + nn]  # G V_p w
        # offset_shift's operands: p's R and V (from the product above, float64, exact), the
        # last gathered range rows and their [a w; b w] (rows 1 and 2 of the products), and
        # buffers for the window's terms
        self._rp, self._vp = self.product[r0:v0], self.product[3 * width :]
        self._ab_single = np.zeros((2, 1))  # the bound's candidate's [a w; b w]
        self._ab_single_mv = memoryview(self._ab_single.reshape(-1))
        # the rows the last step gathered and their [a w; b w], in a list that the step's
        # closure shares with offset_shift: the closure holds no reference to the table,
        # whose cycle through it would keep the table (most of NP's memory) alive after NP
        # until the garbage collector ran
        self._last = [np.zeros((0, width)), self._ab_single]
        self._delta, self._support = np.empty(nn), np.empty(nn)
        self._square = np.empty(nn)  # the bound's G V_p u R_q
        self.lam = float(range_weight)
        self.missing_range = missing_range
        # _combine's scalar operands as 0-d arrays, made once: a ufunc takes a Python scalar
        # by a slower path (about 0.3 µs a call); the same float64 values, the same bits
        self._scalars = (np.array(float(self.divisor)), np.array(self.lam),
                         np.array(self.lam * SUPPORT_PRIOR), np.array(SUPPORT_PRIOR))
        self._single = np.zeros(1)  # the shortlist's distances when it keeps one candidate
        self._single_mv = memoryview(self._single)
        self._bound = np.zeros(())  # the shortlist's bound, written per step
        self._wa = np.zeros(())  # w_a w_unit, written per step
        # set_range writes p's range into the rows p - o (o the window's offset of raster
        # index k = a n + b: o = (a - h) Wp + (b - h)) at the columns R + k and V + k: the
        # entries p width + e of the flat range rows, e = -o width + (R or V) + k
        k = np.arange(nn)
        a, b = np.divmod(k, n)
        rows = -((a - h) * self.shape[1] + (b - h)) * width
        self._window_entries = np.concatenate([rows + r0 + k, rows + v0 + k])
        self._window_values = np.ones(2 * nn, dtype=np.float32)  # [R ... | 1 ...]
        self._flat_ranges = self.ranges.reshape(-1)  # a view
        # single values through memoryviews (cheaper than numpy's scalar indexing)
        self._w_si_mv, self._self_mv = memoryview(self.w_si), memoryview(self.self_unit)
        #: :meth:`shortlist` as ``shortlist_step(p, candidates, scale)``, which NP's loop calls
        self.shortlist_step = self._shortlister()

    @property
    def table(self) -> np.ndarray:
        """Every voxel's whole row ``[I | s | 1 | R | V | 1]`` (a copy, for inspection).

        The constant columns are 1 on the image's pixels, the only rows that are read, and 0
        on the padding."""
        return np.concatenate([self.intensity, self.ranges], axis=1)

    def distances(self, p: int, candidates: np.ndarray) -> np.ndarray:
        """Eq. 2 between ``N_p`` and each candidate, as ``PatchTable.distances``.

        Parameters
        ----------
        p : int
            Padded flat index of the target.
        candidates : ndarray of int, shape (M,)
            Padded flat indices of the candidates: pixels of the image (Eq. 3's candidates
            are; a row of the padding holds no constant columns, and its distance is not
            ``PatchTable``'s).

        Returns
        -------
        ndarray of shape (M,), float64

        Examples
        --------
        >>> import numpy as np
        >>> from refsynth.synthesis.patch_table import PatchTable
        >>> rng = np.random.default_rng(0)
        >>> image = rng.integers(0, 2**16, (6, 6, 3)) / 2**16
        >>> levels = rng.integers(0, 2**16, (6, 6)) / 2**16
        >>> known = np.where(rng.random((6, 6)) < 0.5, levels, np.nan)
        >>> fast, wide = FillTable(image, known, 3, 2, 1.0), PatchTable(image, known, 3, 2, 1.0)
        >>> q = np.r_[22:28, 32:38]      # the image's first two rows (padded frame 10 wide)
        >>> bool(np.array_equal(fast.distances(33, q), wide.distances(33, q)))
        True
        """
        return self.shortlist_step(p, candidates, 1.0, True)[1]

    def shortlist(self, p: int, candidates: np.ndarray, scale: float
                  ) -> tuple[np.ndarray, np.ndarray]:
        """The candidates that can be Eq. 4's best match or in Eq. 5's set, and their Eq. 2.

        Eq. 2 is the intensity term plus a range term ``>= 0``, so a candidate whose
        intensity term alone exceeds ``scale`` times some candidate's distance is neither
        the best match nor within ``scale`` of it. The range term is evaluated for the rest
        only (on the Motorcycle about one candidate in sixteen). The candidate with the
        smallest intensity term gives the bound.

        Parameters
        ----------
        p : int
            Padded flat index of the target.
        candidates : ndarray of int, shape (M,), M >= 1
            Padded flat indices of the candidates, in Eq. 4's tie order.
        scale : float
            ``1 + ε`` of Eq. 5 (>= 1).

        Returns
        -------
        kept : ndarray of int
            The candidates that may be within ``scale`` of the best, in their order; the
            best match and every member of Eq. 5's set among them.
        distances : ndarray of shape (len(kept),), float64
            Their Eq. 2 distances, bit for bit those of :meth:`distances`. With one
            candidate kept, a buffer of the table that the next call overwrites.

        Notes
        -----
        Every step is exact or monotone: the intensity term ``t_q`` (the same float as in
        :meth:`distances`) and ``D_q = fl(t_q + r_q)`` with ``r_q >= 0`` give ``D_q >= t_q``;
        with ``k`` any candidate (the bound's) and ``D_min <= D_k``, every ``q``
        with ``D_q <= fl(scale D_min)`` has ``t_q <= fl(scale D_k)`` and is kept. The
        kept candidates keep their order, so the first minimum among them is the first
        overall. :meth:`offset_shift` then reads the kept candidates' rows.

        Examples
        --------
        >>> import numpy as np
        >>> rng = np.random.default_rng(0)
        >>> image = rng.integers(0, 2**16, (6, 6, 3)) / 2**16
        >>> known = np.where(rng.random((6, 6)) < 0.5, rng.random((6, 6)), np.nan)
        >>> table = FillTable(image, known, 3, 2, 1.0)
        >>> q = np.r_[22:28, 32:38]      # the image's first two rows
        >>> every = table.distances(33, q)
        >>> kept, d = table.shortlist(33, q, 1.1)
        >>> bool(np.array_equal(d, every[np.isin(q, kept)]))
        True
        >>> bool(set(q[every <= 1.1 * every.min()]) <= set(kept))
        True
        """
        return self.shortlist_step(p, candidates, scale)

    def _shortlister(self) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
        """:meth:`shortlist` (and, with ``every``, :meth:`distances`) as a closure.

        ``shortlist_step(p, candidates, scale, every=False)``. A step is some twenty numpy
        calls on small arrays, so the closure reads its operands from local names (methods
        would look each one up on ``self``). It writes ``p``'s weights, picks the bound's
        candidate (the smallest intensity term), forms its whole distance,
        then that of the candidates the bound keeps; it leaves the rows :meth:`offset_shift`
        reads in ``self._last``. It refers to the table's arrays, never to the table."""
        intensity, ranges = self.intensity, self.ranges
        own_intensity = intensity[:, : self.base]  # p's I, by one integer index
        coef_i, w_i, w_si = self.coef_i, self._w_i, self.w_si
        w_si_mv, self_mv, one = self._w_si_mv, self._self_mv, self.one
        both, taken, by_perm, by_square = self._both, self._taken, self._by_perm, self._by_square
        product, coef, weights = self.product, self.coef, self.weights
        g_v, wa = self.g_v, self._wa
        range_weights, square_weights, square = (self.range_weights, self.square_weights,
                                                 self._square)
        nn, bound, last, scalars = self.nn, self._bound, self._last, self._scalars
        missing = self.missing_range
        ab_single, ab_single_mv = self._ab_single, self._ab_single_mv
        divisor = None if self.divisor == 1 else self._scalars[0]  # x / 1 is x: skipped
        single, single_mv = self._single, self._single_mv
        lam, mean = self.lam, self.missing_range == "mean"
        wa_mv = memoryview(wa.reshape(1))  # w_a w_unit, written as a Python float
        multiply, less_equal, divide, float64 = np.multiply, np.less_equal, np.divide, np.float64

        def finish(si: np.ndarray, rows: np.ndarray) -> np.ndarray:
            # Eq. 2 from the intensity terms si and the gathered range rows (in place)
            sums = range_weights @ rows.T  # [s_r u; w_s w; b w], exact
            r = rows[:, :nn]
            sr, ws, _ = sums
            np.add(sr, np.multiply(r, r) @ square_weights, sr)  # + Σ G V_p R_q² u
            last[0], last[1] = rows, sums[1:]  # the offset copy's rows, a and b (w_s is a)
            if not mean:
                return _combine(si, sr, None, None, 1, lam, missing, scalars)
            return _combine(si, sr, ws, wa, 1, lam, missing, scalars, keep_ws=True)

        def shortlist(p: int, candidates: np.ndarray, scale: float, every: bool = False):
            # p's weights. Intensity: -2 G I_p u on I, s_p u on the constant 1. Range: R_p,
            # R_p², V_p (exact products) times the coefficients; w_a w_unit (exact)
            multiply(own_intensity[p], coef_i, w_i)
            w_si_mv[one] = self_mv[p]
            ranges[p].take(both, out=taken, mode="clip")
            multiply(multiply(by_perm, by_square, product, dtype=float64), coef, weights)
            # w_a w_unit: integers times a power of two, so the sum is exact in any order
            wa_mv[0] = support = sum(g_v.tolist())
            # Eq. 2's intensity term of each candidate, exact: every product and partial
            # sum is an integer below 2**53 times the power of two its weights carry (the
            # positive terms, s_q's parts and s_p, add up to at most s_p + s_q <= 2 C ΣG
            # 2**32, the negative ones, -2 G I_p I_q, to at least -2 sqrt(s_p s_q) >= -2 C
            # ΣG 2**32 by Cauchy–Schwarz: every partial sum, in any order, lies within
            # ±2 C ΣG 2**32 < 1.6 2**52, as C <= 3 and ΣG <= 262151 < 1.01 2**18); float32
            # rows are widened by the product
            si = intensity.take(candidates, axis=0) @ w_si
            if divisor is not None:
                divide(si, divisor, si)
            if every:  # distances(): every candidate's range term
                return candidates, finish(si, ranges.take(candidates, axis=0).astype(float64))
            k = int(si.argmin())  # the bound's candidate: the smallest intensity term
            q, t = int(candidates[k]), float(si[k])
            # the bound: the whole Eq. 2 of the candidate q, _combine's operations on Python
            # floats (the same IEEE operations, so the same bits); its range row (float32)
            # stays for offset_shift
            row = ranges[q : q + 1]
            sr, ws, b = range_weights.dot(row[0]).tolist()  # widened by dot: exact
            r = row[0, :nn]
            sr = sr + float(multiply(square_weights, r, square).dot(r))
            ab_single_mv[0], ab_single_mv[1] = ws, b  # offset_shift's a w, b w
            if lam != 1.0:
                sr = sr * lam
            if mean:
                ws = ws + SUPPORT_PRIOR
                best = t + (sr + lam * SUPPORT_PRIOR) * (support / ws)
            else:
                best = t + sr
            bound[()] = scale * best
            if candidates.size > 1:
                keep = less_equal(si, bound)
                candidates = candidates.compress(keep)
            if candidates.size == 1:  # q alone (D_q <= scale D_q keeps it): its D is known
                last[0], last[1] = row, ab_single  # q's row (float32), for offset_shift
                single_mv[0] = best
                return candidates, single
            return candidates, finish(si.compress(keep),
                                      ranges.take(candidates, axis=0).astype(float64))

        return shortlist

    def offset_shift(self, j: int) -> int:
        """The offset copy's ``Δ`` between ``N_p`` and the last :meth:`distances`' candidate ``j``.

        :func:`refsynth.synthesis.range_copy.offset_shift` (the same integer) on the rows
        :meth:`distances` (or :meth:`shortlist`) has just gathered: ``a`` and ``b`` are two
        of the sums Eq. 2's product has just formed, ``p``'s ``R`` and ``V`` are in its
        weights and the candidate's in its row, so the shift costs a few operations on the
        window and no gather.

        Parameters
        ----------
        j : int
            Index of the drawn candidate in the ``candidates`` of the last :meth:`distances`
            call (whose ``p`` is the target).

        Returns
        -------
        int
            ``Δ`` on the range's integer grid, 0 where the shift is not taken.

        Notes
        -----
        With ``G`` the integer window and ``u`` :data:`~refsynth.numeric.WEIGHT_UNIT` (a
        power of two): ``a u = Σ G V_p V_q u`` (Eq. 2's ``w_s``) and ``b u = Σ G V_p V_q δ u``
        with ``δ = R_p − R_q``, formed as ``Σ (G V_p R_p u) V_q − (G V_p u) R_q`` (``R_q = 0``
        where ``V_q = 0``) by the third row of the range weights, and the agreement test
        ``|δ (a u) − b u| ≤ 2^{16−7} (a u)`` on the shared support (``V_p V_q = 1``),
        decided at its largest and smallest ``δ`` (``a > 0``, so ``δ (a u) − b u`` grows with
        ``δ``). Every product and sum is an integer below ``2**53`` times ``u``: exact in any
        order, the integers and the decision of ``range_copy.offset_shift``.

        Examples
        --------
        >>> import numpy as np
        >>> image = np.zeros((4, 6, 1))
        >>> ramp = np.tile(np.arange(6.0), (4, 1)) / 8
        >>> known = np.where(np.arange(6) != 3, ramp, np.nan)
        >>> table = FillTable(image, known, 3, 2, 1.0)
        >>> p, q = 3 * 10 + 5, 3 * 10 + 3     # (1, 3), unknown, and (1, 1): two columns left
        >>> _ = table.distances(p, np.array([q]))
        >>> table.offset_shift(0) == 2 * 2**16 // 8   # R_p - R_q: two steps of the ramp
        True
        """
        rows, ab_rows = self._last
        a, b = ab_rows[:, j].tolist()  # a u and b u, from Eq. 2's products
        if a == 0.0:  # no shared support
            return 0
        row = rows[j]
        # δ = R_p − R_q on the shared support (V_p V_q = 1; a > 0, so it is not empty)
        delta = np.subtract(self._rp, row[self.r0 : self.v0], self._delta).compress(
            np.multiply(self._vp, row[self.v0 : -1], self._support)).tolist()
        # max |δ a − b| over it is at its largest or smallest δ (a > 0; each product and
        # difference exact): the same test as on every δ
        slack = _SLACK * a
        if a * max(delta) - b > slack or b - a * min(delta) > slack:
            return 0
        return round_half_even(int(b * _TO_WINDOW), int(a * _TO_WINDOW))

    def set_range(self, p: int, value: float) -> None:
        """Record normalised range ``value`` (a multiple of ``2**-16``) at padded index ``p``.

        Parameters
        ----------
        p : int
            Padded flat index.
        value : float
            The normalised range now known at ``p``.

        Examples
        --------
        >>> import numpy as np
        >>> table = FillTable(np.zeros((3, 3, 1)), np.full((3, 3), np.nan), 3, 1, 1.0)
        >>> table.set_range(12, 0.5)
        >>> float(table.ranges[12, table.r0 + 4]) == 2.0**15   # the centre's R column
        True
        """
        # np.rint's value (both round half to even), exact in float32 (at most 2**16)
        self._window_values[: self.nn] = float(round(value * 2.0**RANGE_BITS))
        self._flat_ranges.put(self._window_entries + p * self.range_width, self._window_values)


def _split(x: np.ndarray, parts: int, dtype=np.float32) -> np.ndarray:
    """Integers ``x`` (float64, below ``2**53``) as ``parts`` of ``dtype`` that sum to ``x``.

    Each part is the remainder so far rounded to ``dtype`` (float32: 24 significant bits),
    so three float32 parts hold any Eq. 2 self term (below ``2**52``; in float64 the first
    part is ``x`` and the rest 0); the build checks that the parts sum back. Returns
    ``x.shape + (parts,)``.
    """
    out = np.empty(x.shape + (parts,), dtype=dtype)
    rest = x
    for k in range(parts - 1):
        out[..., k] = rest
        rest = rest - out[..., k]
    out[..., -1] = rest
    if not np.array_equal(out.astype(np.float64).sum(axis=-1), x):
        raise ValueError(f"The integers do not fit {parts} {np.dtype(dtype).name} parts")
    return out


def _combine(si, sr, ws, wa, channels: int, range_weight: float, missing_range: str,
             scalars: tuple, keep_ws: bool = False):
    """:func:`refsynth.numeric.combine_eq2` in place on ``si``, ``sr`` and ``ws``.

    ``si`` and ``sr`` arrive already multiplied by :data:`~refsynth.numeric.EQ2_UNIT`,
    ``ws`` and the scalar ``wa`` by :data:`~refsynth.numeric.WEIGHT_UNIT` (powers of
    two: exact, the same values ``combine_eq2`` forms first). The rest are the same
    IEEE operations in the same order (so the same bits), without allocating, and
    without the multiplications and divisions by 1 (exact identities): ``si``
    returns the distances. ``scalars`` holds the operands ``C``, ``λ``, ``λ ε`` and
    ``ε`` as 0-d float64 arrays (the same values; see ``FillTable``). With ``keep_ws``
    the prior is added to ``ws`` into a new array, so that ``ws`` stays the offset
    copy's ``a`` (:meth:`FillTable.offset_shift`). (Two one-row additions: one call on
    the two rows and a column of priors, broadcast, costs twice as much.)
    """
    divisor, lam, lam_prior, prior = scalars[:4]
    if channels != 1:  # x / 1 and x * 1 are x exactly: skipped
        np.divide(si, divisor, si)
    if range_weight != 1.0:
        np.multiply(sr, lam, sr)
    if missing_range == "mean":
        np.add(sr, lam_prior, sr)
        ws = np.add(ws, prior) if keep_ws else np.add(ws, prior, ws)
        np.divide(wa, ws, ws)
        np.multiply(sr, ws, sr)
    return np.add(si, sr, si)
