r"""Portable arithmetic for the scenes: the same bits on every CPU, BLAS, SIMD width and libm (#11).

The numeric contract (``/work/contract.md``, rules C7 and C9) asks that nothing on the
path from a scene's parameters to its pixels depends on a library's choice of summation
order or on a vectorised transcendental. This module holds what the ray casters and
textures need for that:

- 3-vectors: :func:`dot3` ``(a₀b₀ + a₁b₁) + a₂b₂``, :func:`rotate3` (a 3×3 matrix applied
  to a stack of vectors, each component a :func:`dot3`), :func:`norm3` and
  :func:`hypot2` (``sqrt`` of the explicit sum, not ``hypot``): in place of ``@``,
  ``np.dot`` and ``np.linalg.norm`` (BLAS ``ddot``/``dgemm``, whose result changes with
  ``OPENBLAS_CORETYPE`` and the thread count) and of libm's ``hypot`` (not correctly
  rounded);
- trigonometry, below.

numpy's ``tan``, ``arctan`` and ``arctan2`` (float64) are dispatched to vectorised
library code (SVML on AVX-512) whose last bit differs from the scalar libm's: with
``NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL"`` they change; ``sin`` and ``cos``
come from the platform's libm, which another libm need not match. The scenes' ray
casters and textures feed the synthesis' decisions, so the numeric contract
(rule C7 of ``/work/contract.md``: no libm or SIMD transcendental in a result) asks
for these instead: argument reduction and fixed polynomials (the fdlibm kernels, by
Horner), using IEEE ``+ − × ÷``, ``rint`` and comparisons only. Each numpy
operation is one correctly rounded IEEE operation (numpy does not contract
``a * b + c`` into a fused multiply–add), so the result is the same everywhere.

Accuracy: within 2 ulp of numpy on the arguments the scenes use (angles up to a
few thousand radians; :func:`portable_sin`/:func:`portable_cos` reduce exactly
for ``|x| < 2**19 · π/2``).

Functions
---------
:func:`dot3`, :func:`rotate3`, :func:`norm3`, :func:`hypot2`; :func:`portable_sin`,
:func:`portable_cos`, :func:`portable_tan`, :func:`portable_arctan`,
:func:`portable_arctan2`.

References
----------
Sun Microsystems, fdlibm 5.3 (``k_sin.c``, ``k_cos.c``, ``s_atan.c``): the
polynomial coefficients. W. J. Cody and W. Waite, *Software Manual for the
Elementary Functions* (1980): the three-part reduction by π/2.
"""

from __future__ import annotations

import numpy as np

__all__ = ["dot3", "rotate3", "norm3", "hypot2", "portable_sin", "portable_cos", "portable_tan",
           "portable_arctan", "portable_arctan2"]

_TWO_OVER_PI = 6.36619772367581382433e-01
# π/2 in three parts, the first two with 33 significant bits: k · part is exact for |k| < 2**20
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_3 = 2.02226624879595063154e-21

_S = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
      2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_C = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
      -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)

_ATAN_HI = (4.63647609000806093515e-01, 7.85398163397448278999e-01,
            9.82793723247329054082e-01, 1.57079632679489655800e00)
_ATAN_LO = (2.26987774529616870924e-17, 3.06161699786838301793e-17,
            1.39033110312309984516e-17, 6.12323399573676603587e-17)
_AT = (3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01,
       -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02,
       6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02,
       -3.65315727442169155270e-02, 1.62858201153657823623e-02)
_PI = 3.14159265358979311600e00
_PI_LO = 1.22464679914735317720e-16


# ----------------------------------------------------------------------------- 3-vectors


def dot3(a, b) -> np.ndarray:
    """``(a₀b₀ + a₁b₁) + a₂b₂`` over the last axis (length 3), broadcast; no BLAS.

    >>> float(dot3(np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0])))
    32.0
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]) + a[..., 2] * b[..., 2]


def rotate3(matrix, vectors) -> np.ndarray:
    """``vectors @ matrix.T`` (``matrix`` 3×3, ``vectors`` (..., 3)), each output a :func:`dot3`.

    >>> rotate3(np.eye(3)[[1, 2, 0]], np.array([1.0, 2.0, 3.0]))
    array([2., 3., 1.])
    """
    matrix = np.asarray(matrix, dtype=np.float64)
    vectors = np.asarray(vectors, dtype=np.float64)
    return np.stack([dot3(vectors, matrix[i]) for i in range(3)], axis=-1)


def norm3(v) -> np.ndarray:
    """The Euclidean length over the last axis (length 3): ``sqrt(dot3(v, v))``.

    >>> float(norm3(np.array([2.0, 3.0, 6.0])))
    7.0
    """
    return np.sqrt(dot3(v, v))


def hypot2(a, b):
    """``sqrt(a·a + b·b)``, elementwise (libm's ``hypot`` is not correctly rounded).

    >>> hypot2(3.0, 4.0)
    5.0
    """
    out = np.sqrt(np.asarray(a, dtype=np.float64) * a + np.asarray(b, dtype=np.float64) * b)
    return float(out) if np.ndim(out) == 0 else out


# ----------------------------------------------------------------------------- trigonometry

_CHUNK = 1 << 14  # elements per block: the temporaries stay in the cache


def _blocks(function, *arguments):
    """``function`` on the broadcast ``arguments`` (float64), block by block; float for scalars."""
    values = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in arguments))
    shape = values[0].shape
    flat = [np.ravel(v) for v in values]
    out = np.empty(flat[0].size)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):  # NaN in, NaN out
        for start in range(0, out.size, _CHUNK):
            block = slice(start, start + _CHUNK)
            out[block] = function(*(v[block] for v in flat))
    return float(out[0]) if shape == () else out.reshape(shape)


def _reduce(x: np.ndarray):
    """``x = k π/2 + r``, ``|r| ≤ π/4`` (about): returns ``r`` and ``k mod 4`` (int)."""
    k = np.rint(x * _TWO_OVER_PI)
    r = x - k * _PIO2_1
    r -= k * _PIO2_2
    r -= k * _PIO2_3
    quadrant = np.nan_to_num(k, nan=0.0, posinf=0.0, neginf=0.0).astype(np.int64) & 3
    return r, quadrant


def _kernels(r: np.ndarray):
    """fdlibm's ``__kernel_sin`` and ``__kernel_cos`` on ``|r| ≤ π/4`` (no tail)."""
    z = r * r
    p = _S[5] * z
    p += _S[4]
    for coefficient in _S[3:0:-1]:
        p *= z
        p += coefficient
    p *= z
    p += _S[0]
    p *= z * r
    sin = r + p
    q = _C[5] * z
    for coefficient in _C[4::-1]:
        q += coefficient
        q *= z
    q *= z
    hz = 0.5 * z
    w = 1.0 - hz
    cos = w + (((1.0 - w) - hz) + q)
    return sin, cos


def _sin(x):
    r, quadrant = _reduce(x)
    s, c = _kernels(r)
    out = np.where(quadrant & 1, c, s)
    np.negative(out, out=out, where=(quadrant & 2) > 0)
    out[~np.isfinite(x)] = np.nan
    return out


def _cos(x):
    r, quadrant = _reduce(x)
    s, c = _kernels(r)
    out = np.where(quadrant & 1, s, c)
    np.negative(out, out=out, where=((quadrant + 1) & 2) > 0)
    out[~np.isfinite(x)] = np.nan
    return out


def _tan(x):
    r, quadrant = _reduce(x)
    s, c = _kernels(r)
    odd = (quadrant & 1) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(odd, -c, s) / np.where(odd, s, c)
    out[~np.isfinite(x)] = np.nan
    return out


def portable_sin(x):
    """``sin(x)``, the same bits everywhere (module docstring).

    >>> portable_sin(0.5) == 0.479425538604203
    True
    """
    return _blocks(_sin, x)


def portable_cos(x):
    """``cos(x)``, the same bits everywhere (module docstring).

    >>> portable_cos(0.0)
    1.0
    """
    return _blocks(_cos, x)


def portable_tan(x):
    """``tan(x)``: ``sin/cos`` of the reduced argument, one division (module docstring).

    >>> abs(portable_tan(np.pi / 4) - 1.0) < 1e-15
    True
    """
    return _blocks(_tan, x)


# fdlibm's intervals of |x|: t = (α |x| − β) / (γ + δ |x|), arctan x = hi + arctan t (+ lo)
_ATAN_EDGES = np.array([0.4375, 0.6875, 1.1875, 2.4375])
_ATAN_MAP = np.array([(2.0, 1.0, 2.0, 1.0), (1.0, 1.0, 1.0, 1.0), (1.0, 1.5, 1.0, 1.5),
                      (0.0, 1.0, 0.0, 1.0)])   # 7/16, 11/16, 19/16, 39/16 ≤ |x|


def _arctan(x):
    a = np.abs(x)
    index = np.searchsorted(_ATAN_EDGES, a, side="right")   # 0: |x| < 7/16, no reduction
    small = index == 0
    j = np.maximum(index - 1, 0)
    alpha, beta, gamma, delta = (_ATAN_MAP[j, i] for i in range(4))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(small, x, (alpha * a - beta) / (gamma + delta * a))
    z = t * t
    w = z * z
    s1 = _AT[10] * w
    for coefficient in _AT[8:0:-2]:
        s1 += coefficient
        s1 *= w
    s1 += _AT[0]
    s1 *= z
    s2 = _AT[9] * w
    for coefficient in _AT[7:0:-2]:
        s2 += coefficient
        s2 *= w
    s1 += s2
    s1 *= t        # t (s1 + s2)
    out = np.where(small, t - s1, np.take(_ATAN_HI, j) - ((s1 - np.take(_ATAN_LO, j)) - t))
    np.negative(out, out=out, where=~small & (x < 0))
    infinite = np.isinf(x)
    out[infinite] = np.copysign(_ATAN_HI[3], x[infinite])
    return out


def _arctan2(y, x):
    with np.errstate(divide="ignore", invalid="ignore"):
        base = _arctan(y / x)
    up = np.where(y < 0, -1.0, 1.0)
    left = up * (_PI - (-up * base - _PI_LO))      # x < 0: base ± π, with π's low part
    zero = np.where(np.signbit(x), up * _PI, 0.0 * up)   # y = x = 0
    return np.where(x > 0, base, np.where(x < 0, left, np.where(y == 0, zero, up * _ATAN_HI[3])))


def portable_arctan(x):
    """``arctan(x)`` by fdlibm's reduction to four intervals and its polynomial.

    >>> portable_arctan(1.0) == np.pi / 4
    True
    """
    return _blocks(_arctan, x)


def portable_arctan2(y, x):
    """``arctan2(y, x)``: :func:`portable_arctan` of ``y / x`` and the quadrant.

    ``x > 0``: ``arctan(y/x)``; ``x < 0``: that ``± π``; ``x = 0``: ``± π/2`` (0 when
    ``y = 0`` too, π for ``x = −0``). Infinite arguments are not handled.

    >>> portable_arctan2(1.0, -1.0) == 3 * np.pi / 4
    True
    """
    return _blocks(_arctan2, y, x)
