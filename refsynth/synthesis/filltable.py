r"""Eq. 2 for NP's sequential fill: one narrow row per voxel, one gather per step (§3.2.2).

NP (:mod:`refsynth.synthesis.nonparametric`) evaluates Eq. 2 between the
voxel ``p`` it fills and every candidate ``q`` of ``A_p`` (Eq. 3), one voxel
at a time. :class:`FillTable` holds, per voxel of the padded frame, the row

.. math:: [\, I_{v,c} \mid s_q \mid R_v \mid V_v \mid R_v^2 \,]_{v \in N_q}

(intensity; the self term ``s_q = Σ_v G_v Σ_c I²``; range, stored as 0 where
unknown; has-range indicator; squared range) in float32. The integers of the
numeric contract (:mod:`refsynth.numeric`) up to ``2**16`` are exact in
float32; ``s_q`` (below ``2**52``) is stored as three float32 parts and
``R²`` (up to ``2**32``) as two, each part exact and their sum exactly the
integer. A row is 712 bytes for a colour 5×5 window, against 1200 for
:class:`refsynth.synthesis.similarity.PatchTable`'s float64 ``[I | V | R | R²]``
(BP's table): the table of a 900×750 image takes about 500 MB instead of 850,
and each step gathers 40 % fewer bytes.

The gathered rows are widened to float64 and the four sums of Eq. 2

.. math::

    s_i = s_p + s_q - 2 \sum_v G_v \sum_c I_p I_q, \qquad
    s_r = \sum_v G_v \left[ V_p R_q^2 - 2 R_p R_q + R_p^2 V_q \right],

    w_s = \sum_v G_v V_p V_q, \qquad w_a = \sum_v G_v V_p

come from three matrix–vector products with weights built from ``p``'s row
(``s_i`` over ``[I | s_q]``, ``s_r`` over ``[R | V | R²]``, ``w_s`` over
``V``; ``w_a`` is the sum of ``w_s``'s weights). The weights carry the sums'
units, :data:`~refsynth.numeric.EQ2_UNIT` for ``s_i`` and ``s_r`` and
:data:`~refsynth.numeric.WEIGHT_UNIT` for ``w_s`` and ``w_a`` (powers of two,
so scaling is exact). Every product and partial sum is an integer below
``2**53`` times its unit, so each sum is exact whatever the order (BLAS,
threads, SIMD): the same integers as ``PatchTable.distances`` and the literal
reference, times the units ``combine_eq2`` multiplies them by first, then
combined by the rest of the IEEE operations of
:func:`refsynth.numeric.combine_eq2`, give the same distances bit for bit
(``tests/test_np_speed_table.py``).

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from refsynth.numeric import (
    EQ2_UNIT,
    INTENSITY_BITS,
    RANGE_BITS,
    SUPPORT_PRIOR,
    WEIGHT_UNIT,
    window_weights,
)
from refsynth.synthesis.neighbourhood import intensity_patches, window_offsets

__all__ = ["FillTable"]

#: Rows of the frame built at a time (bounds the float64 temporaries).
_CHUNK_ROWS = 64


class FillTable:
    """Every voxel's neighbourhood as one float32 row ``[I | s | R | V | R²]``, for NP (Eq. 2).

    The same distances as :class:`refsynth.synthesis.similarity.PatchTable`
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
        As in :class:`refsynth.synthesis.similarity.PatchTable`.
    channels : {"sum", "mean"}, default "sum"
        As in :class:`refsynth.synthesis.similarity.PatchTable`.

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
    ) -> None:
        H, W, C = image.shape
        self.shape = (H + 2 * pad, W + 2 * pad)
        self.channels = C
        self.divisor = C if channels == "mean" else 1  # Eq. 2's channel sum, or their mean
        nn = n * n
        base = nn * C
        self.nn, self.base = nn, base
        # column blocks: I, the self term in three parts, R, V, R² high and low parts
        s0 = base
        r0 = s0 + 3
        v0, h0, l0 = r0 + nn, r0 + 2 * nn, r0 + 3 * nn
        width = l0 + nn
        self.r0, self.v0, self.h0, self.l0, self.width = r0, v0, h0, l0, width
        table = np.zeros((self.shape[0] * self.shape[1], width), dtype=np.float32)
        frame = table.reshape(self.shape + (width,))
        self.self_term = np.zeros(self.shape[0] * self.shape[1])  # Σ G Σ_c I², exact
        self_frame = self.self_term.reshape(self.shape)
        g = window_weights(n).ravel().astype(np.float64)
        g_int = np.repeat(g, C)  # intensity columns are (offset, channel) raveled
        levels = np.rint(np.asarray(image, dtype=np.float64) * 2.0**INTENSITY_BITS)
        patches = intensity_patches(levels, n)  # a view, (H, W, n, n, C)
        h = n // 2
        rq = np.rint(np.asarray(range_norm, dtype=np.float64) * 2.0**RANGE_BITS)
        rpad = np.pad(rq, h, mode="constant", constant_values=np.nan)
        rp = sliding_window_view(rpad, (n, n))  # (H, W, n, n)
        for top in range(0, H, _CHUNK_ROWS):
            rows = slice(top, min(H, top + _CHUNK_ROWS))
            out = frame[pad + rows.start : pad + rows.stop, pad : pad + W]
            ints = np.ascontiguousarray(patches[rows]).reshape(-1, W, base)
            out[:, :, :base] = ints
            s = (ints**2) @ g_int
            self_frame[pad + rows.start : pad + rows.stop, pad : pad + W] = s
            out[:, :, s0:r0] = _split(s, 3)
            r = rp[rows].reshape(-1, W, nn)
            has = np.isfinite(r)
            r = np.where(has, r, 0.0)
            out[:, :, r0:v0] = r
            out[:, :, v0:h0] = has
            out[:, :, h0:] = np.concatenate(np.moveaxis(_split(r * r, 2), -1, 0), axis=-1)
        self.table = table
        # p's weights w = row_p[perm] * coef (then the V block times R_p again), over
        # the columns [I | S | R | V | R²_hi | R²_lo], then Eq. 2's support weights
        # G V_p; the units of the sums (powers of two) are folded into coef, which
        # keeps every product and partial sum exact. perm's index `width` reads the
        # 1 kept after p's row (the weight of the candidate's self term).
        perm = np.concatenate([np.arange(base), np.full(3, width), np.arange(r0, v0),
                               np.arange(r0, v0), np.arange(v0, h0), np.arange(v0, h0),
                               np.arange(v0, h0)])
        self.perm = perm
        self.coef = np.concatenate([-2.0 * g_int, np.ones(3), -2.0 * g, g, g, g]) * EQ2_UNIT
        self.coef = np.concatenate([self.coef, g * WEIGHT_UNIT])
        self.row = np.ones(width + 1)  # p's row in float64, then the constant 1
        self.weights = np.zeros(width + nn)
        self.channels = C
        self.lam = float(range_weight)
        self.missing_range = missing_range
        dr, dc = window_offsets(n)
        offsets = dr * self.shape[1] + dc
        # p's range sits in the rows p - offset, at that offset's R, V, R² columns
        self.update_flat = np.tile(-offsets * width, 4) + r0 + np.arange(4 * nn)
        self.update_values = np.ones(4 * nn, dtype=np.float32)
        self.flat = table.reshape(-1)

    def distances(self, p: int, candidates: np.ndarray) -> np.ndarray:
        """Eq. 2 between ``N_p`` and each candidate, as ``PatchTable.distances``.

        Parameters
        ----------
        p : int
            Padded flat index of the target.
        candidates : ndarray of int, shape (M,)
            Padded flat indices of the candidates.

        Returns
        -------
        ndarray of shape (M,), float64

        Examples
        --------
        >>> import numpy as np
        >>> from refsynth.synthesis.similarity import PatchTable
        >>> rng = np.random.default_rng(0)
        >>> image = rng.integers(0, 2**16, (6, 6, 3)) / 2**16
        >>> levels = rng.integers(0, 2**16, (6, 6)) / 2**16
        >>> known = np.where(rng.random((6, 6)) < 0.5, levels, np.nan)
        >>> fast, wide = FillTable(image, known, 3, 2, 1.0), PatchTable(image, known, 3, 2, 1.0)
        >>> q = np.arange(2 * 10 + 2, 3 * 10 + 8)      # the first row of the image, and more
        >>> bool(np.array_equal(fast.distances(33, q), wide.distances(33, q)))
        True
        """
        r0, v0, h0, width = self.r0, self.v0, self.h0, self.width
        row = self.row
        np.copyto(row[:width], self.table[p])
        w = np.multiply(row.take(self.perm), self.coef, out=self.weights)
        w[v0:h0] *= row[r0:v0]  # G R_p R_p u, exact
        rows = self.table.take(candidates, axis=0).astype(np.float64)
        # exact: every product and partial sum is an integer below 2**53 times the
        # power of two its weights carry, so these are the integer sums times their units
        si = rows[:, :r0] @ w[:r0]  # (s_q - 2 Σ G Σ_c I_p I_q) u
        si += self.self_term[p] * EQ2_UNIT
        sr = rows[:, r0:] @ w[r0:width]  # s_r u
        if self.missing_range != "mean":
            return _combine(si, sr, None, None, self.divisor, self.lam, self.missing_range)
        g_v = w[width:]  # G V_p w_unit
        ws = rows[:, v0:h0] @ g_v  # w_s w_unit
        return _combine(si, sr, ws, g_v.sum(), self.divisor, self.lam, self.missing_range)

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
        >>> float(table.table[12, table.r0 + 4]) == 2.0**15   # the centre's R column
        True
        """
        values = self.update_values
        nn = self.nn
        q = float(round(value * 2.0**RANGE_BITS))  # np.rint's value: both round half to even
        values[:nn] = q
        hi = float(np.float32(q * q))  # R² as in the table: float32 high and low parts
        values[2 * nn : 3 * nn] = hi
        values[3 * nn :] = q * q - hi
        self.flat[self.update_flat + p * self.width] = values


def _split(x: np.ndarray, parts: int) -> np.ndarray:
    """Integers ``x`` (float64, below ``2**53``) as ``parts`` float32 that sum to ``x`` exactly.

    Each part is the remainder so far rounded to float32 (24 significant bits),
    so two parts hold ``R² ≤ 2**32`` and three any Eq. 2 self term (below
    ``2**52``); the build checks that the parts sum back. Returns
    ``x.shape + (parts,)``.
    """
    out = np.empty(x.shape + (parts,), dtype=np.float32)
    rest = x
    for k in range(parts - 1):
        out[..., k] = rest
        rest = rest - out[..., k]
    out[..., -1] = rest
    if not np.array_equal(out.astype(np.float64).sum(axis=-1), x):
        raise ValueError("The integers do not fit the float32 parts")
    return out


def _combine(si, sr, ws, wa, channels: int, range_weight: float, missing_range: str):
    """:func:`refsynth.numeric.combine_eq2` in place on ``si``, ``sr`` and ``ws``.

    ``si`` and ``sr`` arrive already multiplied by :data:`~refsynth.numeric.EQ2_UNIT`,
    ``ws`` and the scalar ``wa`` by :data:`~refsynth.numeric.WEIGHT_UNIT` (powers of
    two: exact, the same values ``combine_eq2`` forms first). The rest are the same
    IEEE operations in the same order (so the same bits), without allocating, and
    without the multiplications and divisions by 1 (exact identities): ``si``
    returns the distances.
    """
    if channels != 1:  # x / 1 and x * 1 are x exactly: skipped
        np.divide(si, channels, out=si)
    if range_weight != 1.0:
        np.multiply(sr, range_weight, out=sr)
    if missing_range == "mean":
        np.add(sr, range_weight * SUPPORT_PRIOR, out=sr)
        np.add(ws, SUPPORT_PRIOR, out=ws)
        np.divide(wa, ws, out=ws)
        np.multiply(sr, ws, out=sr)
    return np.add(si, sr, out=si)
