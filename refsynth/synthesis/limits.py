"""What :func:`refsynth.synthesize` accepts (§3.2): its arrays, and the limits of its parameters.

:func:`refsynth.synthesize` checks everything before any work starts. The
arrays (:func:`validate_inputs`): a real intensity and a floating partial
range of the same height and width, finite or NaN, whose spans ``max − min``
do not overflow (the numeric contract brings both to their spans); a masked
range's masked entries are unknown. Beyond a type and a sign, three kinds of
limit apply to the parameters:

1. **Where the arithmetic stays finite** (:data:`PARAMETER_BOUNDS`). With
   intensity and range brought to their spans, Eq. 2's distance is at most
   about ``1 + 10⁴ λ`` (the mean-filled range term can charge ``λ (1 + ε)/ε``
   with ε = 10⁻⁴, :mod:`refsynth.synthesis.similarity`); NP's Eq. 5
   threshold multiplies it by ``1 + ε_NP``; BP adds the spatial prior, at
   most ``μ`` times the image's squared diagonal, and divides by ``2σ_i²``
   (Eq. 7) and, for Eq. 6's mean squares (at most 1), by ``2σ_s²``; the
   messages (Eq. 9) add a handful of such terms. Each parameter is bounded
   so that the worst case of every one of these stays below ``10²⁵⁰``, far
   from float64's ``1.8·10³⁰⁸``: ``λ, ε, μ ≤ 10¹⁰⁰``, ``10⁻⁵⁰ ≤ σ_i, σ_s ≤
   10⁵⁰``. Outside them the arithmetic overflowed (NaN confidence, every
   candidate at an infinite distance) or, for σ beyond 10⁵⁰, Eqs. 6–7 are
   flat to within 10⁻¹⁰⁰: no information, so it is refused as well.
2. **What the image can use.** A search radius beyond the image's diagonal
   (:func:`image_reach`) reaches no further pixel: Eq. 3's disc holds the
   whole image. BP then runs with (a power of two just above) the reach in
   its place, bit for bit the same result (:func:`search_radius`). NP runs
   with the radius given: its tie-break permutation (§3.2.4) is drawn over
   the frame padded by the radius, as the literal reference draws it, so
   another radius would change which of two equal priorities goes first; a
   radius whose padded frame does not fit in memory is refused, naming the
   reach. Canny's σ is at most the image's longer side: a Gaussian cut at 4σ
   would reach four times beyond the image and blur it to nearly one grey
   level, at a cost that grows with σ.
3. **Memory** (:func:`check_memory`): NP's estimate of its largest arrays
   (:func:`np_memory`) against the machine's physical memory, BP's
   (:func:`refsynth.synthesis.belief.memory.check_bp_memory`) against its limit
   (4 GiB by default), refused before the work with the amount it would
   need.

References
----------
Torres-Méndez & Dudek (2008), §3.2, Eqs. 2, 5, 6, 7, 9; doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from refsynth._checks import check_in_range, check_memory_need, to_float
from refsynth.synthesis.belief.memory import check_bp_memory
from refsynth.synthesis.filltable import intensity_dtype

__all__ = [
    "validate_inputs",
    "normalise_intensity",
    "PARAMETER_BOUNDS",
    "image_reach",
    "search_radius",
    "check_canny_sigma",
    "np_memory",
    "check_memory",
]

#: The accepted closed range of each real parameter of :func:`refsynth.synthesize`
#: (see the module's docstring for why). ``radius`` is ``>= 1`` and has no upper
#: bound (beyond the image it means the whole image), ``tolerance`` is ``>= 0``,
#: and ``canny_sigma`` lies in ``[0, max(H, W)]``. Read-only.
PARAMETER_BOUNDS = MappingProxyType({
    "range_weight": (0.0, 1e100),
    "epsilon": (0.0, 1e100),
    "proximity": (0.0, 1e100),
    "sigma_i": (1e-50, 1e50),
    "sigma_s": (1e-50, 1e50),
})

_FLOAT = 8  # bytes of a float64


# ----------------------------------------------------------------------------- the arrays


def normalise_intensity(intensity: np.ndarray) -> np.ndarray:
    """Return the intensity as float64 of shape (H, W, C).

    Integer images are scaled to [0, 1] by their dtype's maximum; bool maps to
    0/1; floating images are used as given. A grey image gets a trailing
    channel axis.

    Parameters
    ----------
    intensity : array_like of shape (H, W) or (H, W, C)
        A real image (bool, integer or floating).

    Returns
    -------
    ndarray of shape (H, W, C), float64
        A new array.

    Examples
    --------
    >>> out = normalise_intensity(np.array([[0, 255], [51, 102]], dtype=np.uint8))
    >>> out.shape, out[:, :, 0].tolist()
    ((2, 2, 1), [[0.0, 1.0], [0.2, 0.4]])
    """
    out = to_float(np.asarray(intensity))
    if out.ndim == 2:
        out = out[:, :, None]
    return out


def _array(name: str, value) -> np.ndarray:
    """``value`` itself if it is a numpy array (a masked array included), or raise."""
    if not isinstance(value, np.ndarray):
        raise TypeError(f"The parameter `{name}` must be a numpy array, got {type(value).__name__}")
    return value


def _span(name: str, values: np.ndarray) -> None:
    """Refuse values whose span ``max − min`` overflows float64 (the quantisation needs it)."""
    low, high = float(np.min(values)), float(np.max(values))
    if not np.isfinite(high - low):
        raise ValueError(
            f"The parameter `{name}` spans {low:g} to {high:g}: max − min overflows float64, "
            "so it cannot be brought to its span; rescale it"
        )


def validate_inputs(intensity, partial_range) -> tuple[np.ndarray, np.ndarray]:
    """Check ``intensity`` and ``partial_range`` as DESIGN.md specifies.

    Parameters
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3)
        Any real dtype (bool, integer, floating), finite everywhere. A masked
        array is accepted only with nothing masked: the intensity is needed
        at every pixel.
    partial_range : ndarray of shape (H, W), floating
        NaN where unknown; at least one value known and one unknown, H and W
        at least 2. A masked array's masked entries count as unknown.

    Returns
    -------
    image : ndarray of shape (H, W, C), float64
        The intensity as :func:`normalise_intensity` gives it.
    range : ndarray of shape (H, W), float64
        The range, NaN where unknown (or masked).

    Raises
    ------
    TypeError, ValueError
        Naming the argument: not an array, not a real dtype (complex,
        strings, datetime or timedelta), the wrong shape, inf, NaN intensity,
        values beyond float64, a span that overflows, nothing known or
        nothing to fill.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.ma.masked_array([[1.0, 2.0], [3.0, 4.0]], mask=[[0, 1], [0, 0]])
    >>> image, values = validate_inputs(np.eye(2, dtype=np.uint8), partial)
    >>> image.shape, values.tolist()
    ((2, 2, 1), [[1.0, nan], [3.0, 4.0]])
    >>> validate_inputs(np.eye(2), np.ones((2, 2)))
    Traceback (most recent call last):
    ...
    ValueError: The parameter `partial_range` has nothing to fill (no NaN)
    """
    intensity = _array("intensity", intensity)
    partial_range = _array("partial_range", partial_range)
    if intensity.dtype.kind not in "biuf":  # (numpy counts timedelta64 as an integer)
        raise TypeError(
            f"The parameter `intensity` must have a real numeric dtype, got {intensity.dtype}"
        )
    if partial_range.dtype.kind != "f":
        raise TypeError(
            "The parameter `partial_range` must have a floating dtype (NaN marks unknown range), "
            f"got {partial_range.dtype}"
        )
    if np.ma.isMaskedArray(intensity):
        if np.ma.getmaskarray(intensity).any():
            raise ValueError(
                f"The parameter `intensity` is a masked array with "
                f"{int(np.ma.getmaskarray(intensity).sum())} masked values: the intensity is "
                "needed at every pixel (fill them first)"
            )
        intensity = np.ma.getdata(intensity)
    if np.ma.isMaskedArray(partial_range):  # masked = unknown
        partial_range = np.ma.filled(partial_range.astype(np.float64), np.nan)
    if intensity.ndim not in (2, 3) or (intensity.ndim == 3 and intensity.shape[2] not in (1, 3)):
        raise ValueError(
            "The parameter `intensity` must be a 2-D grey image (H, W) or a colour image "
            f"(H, W, 3), got shape {intensity.shape}"
        )
    if partial_range.ndim != 2:
        raise ValueError(
            f"The parameter `partial_range` must be a 2-D array, got shape {partial_range.shape}"
        )
    if intensity.shape[:2] != partial_range.shape:
        raise ValueError(
            "The parameters `intensity` and `partial_range` must have the same height and "
            f"width, got {intensity.shape[:2]} and {partial_range.shape}"
        )
    if min(partial_range.shape) < 2:
        raise ValueError(
            f"The parameter `partial_range` must be at least 2x2, got shape {partial_range.shape}"
        )
    with np.errstate(over="ignore"):  # a long double beyond float64: refused just below
        image = normalise_intensity(intensity)
    if not np.all(np.isfinite(image)):
        raise ValueError("The parameter `intensity` must be finite everywhere (no NaN or inf; "
                         "no value beyond float64)")
    _span("intensity", image)
    with np.errstate(over="ignore"):  # a long double beyond float64: refused just below
        rng_values = partial_range.astype(np.float64)
    if np.any(np.isinf(rng_values)):
        beyond = "" if np.isinf(partial_range).any() else " (a value beyond float64's range)"
        raise ValueError(
            f"The parameter `partial_range` must be finite or NaN (NaN = unknown), got inf{beyond}"
        )
    known = np.isfinite(rng_values)
    if not known.any():
        raise ValueError("The parameter `partial_range` has no known range (all NaN)")
    if known.all():
        raise ValueError("The parameter `partial_range` has nothing to fill (no NaN)")
    _span("partial_range", rng_values[known])
    return image, rng_values


# ----------------------------------------------------------------------------- the parameters


def image_reach(shape: tuple[int, int]) -> int:
    """The radius from which every pixel of an (H, W) image reaches every other one.

    ``ceil(hypot(H − 1, W − 1))``: a disc of this radius (Eq. 3, integer
    offsets, inclusive) around any pixel holds the whole image.

    Parameters
    ----------
    shape : (int, int)
        The image's (H, W).

    Returns
    -------
    int
        The reach, in pixels.

    Examples
    --------
    >>> image_reach((12, 12)), image_reach((2, 2))
    (16, 2)
    """
    height, width = shape
    return math.ceil(math.hypot(height - 1, width - 1))


def search_radius(method: str, radius: float, proximity: float, shape: tuple[int, int]):
    """The ``(radius, proximity)`` to run with: for BP, a radius beyond the image is cut down.

    The result is bit for bit the one the given radius gives. BP uses the
    radius for the disc of Eq. 3 and for its spatial prior ``μ (|p − q| /
    r)²``. A radius beyond ``R``, the smallest power of two at or above the
    image's reach (:func:`image_reach`; ``R < 2 · reach``), runs as ``R``:
    its disc holds the whole image, as the given radius's does, and the prior
    keeps the caller's ``r`` through ``μ' = (μ / r²) · R²``, for which BP's
    coefficient ``μ' / (R · R)`` is exactly ``μ / (r · r)`` (a power of two
    scales a float64 exactly). NP keeps its radius: the frame of its
    tie-break permutation is padded by it (see above).

    Parameters
    ----------
    method : {"np", "bp"}
    radius : float
        The checked search radius, ``>= 1``.
    proximity : float
        BP's μ (ignored for NP).
    shape : (int, int)
        The image's (H, W).

    Returns
    -------
    (float, float)
        The radius and μ to pass to the fill.

    Examples
    --------
    >>> search_radius("np", 100.0, 1.0, (12, 12))
    (100.0, 1.0)
    >>> radius, mu = search_radius("bp", 100.0, 1.0, (12, 12))
    >>> radius, mu / (radius * radius) == 1.0 / (100.0 * 100.0)
    (16.0, True)
    """
    cut = float(2 ** math.ceil(math.log2(image_reach(shape))))
    if method == "np" or radius <= cut:
        return radius, proximity
    coefficient = proximity / (radius * radius)  # as BP computes it; 0 if it underflows
    return cut, coefficient * (cut * cut)


def check_canny_sigma(value, shape: tuple[int, int]) -> float:
    """Canny's σ as a float in ``[0, max(H, W)]``, or raise ``ValueError`` naming it.

    Parameters
    ----------
    value : real
        The ``canny_sigma`` given.
    shape : (int, int)
        The image's (H, W): σ may not exceed the longer side.

    Returns
    -------
    float

    Examples
    --------
    >>> check_canny_sigma(0.8, (12, 10))
    0.8
    >>> check_canny_sigma(1e300, (12, 10))
    Traceback (most recent call last):
    ...
    ValueError: The parameter `canny_sigma` must be in [0, 12], got 1e+300
    """
    return check_in_range("canny_sigma", value, 0.0, float(max(shape)))


def _padded_rows(shape: tuple[int, int], neighbourhood: int, radius: float) -> int:
    """Pixels of the frame NP and BP pad by ``max(ceil(r), n // 2 + 1)``."""
    pad = max(math.ceil(radius), neighbourhood // 2 + 1)
    return (shape[0] + 2 * pad) * (shape[1] + 2 * pad)


#: Bytes per pixel of the padded frame that NP's fill front keeps: twelve float64 running
#: sums (:class:`~refsynth.synthesis.priority.FillFront`), the confidence, the range, the
#: tie, the tier's key offset, the queue's keys and pixels (int64 or float64 each), and four
#: masks of one byte.
_NP_FRONT_BYTES = 12 * 8 + 6 * 8 + 4


def np_memory(shape: tuple[int, int], channels: int, neighbourhood: int, radius: float) -> int:
    """NP's peak memory in bytes, as built by :func:`~refsynth.synthesis.nonparametric.np_fill`.

    Eq. 2's table (:class:`~refsynth.synthesis.filltable.FillTable`) holds, per pixel of the
    frame padded by ``max(ceil(r), n // 2 + 1)``, an intensity row of ``n² C + 4`` entries
    (float64 up to :data:`~refsynth.synthesis.filltable.WIDE_TABLE_BYTES` in all, float32
    above: :func:`~refsynth.synthesis.filltable.intensity_dtype`), a float32 range row of
    ``2 n² + 1`` and a float64 self term. While it is built,
    at most three image-sized float64 copies of the quantised intensity and two of the
    range exist beside it, with the temporaries of one block of about 4096 rows. Then come
    the fill front (:data:`_NP_FRONT_BYTES` per pixel of the frame, and four float64 frames
    of temporaries while it is built), the copied range in the caller's unit (float64,
    padded), the order and the draws (int64 and float64 per pixel), and
    :func:`~refsynth.synthesis.api.synthesize`'s own copies of the inputs (float64 intensity
    and range, the edge map). The table goes before the outputs are made.

    Measured on the Motorcycle at 2048×2048 (colour, n = 5, r = 10, x-stripes 78 %), the
    run's peak resident memory is 3222 MiB, 3013 MiB above the
    process before the call, against this estimate's 3120 MiB (``python
    benchmarks/bench_speed.py --memory 2048x2048 --methods np``; the padding's rows of the
    table, counted here, are never touched); ``tests/test_np_memory.py`` checks the
    estimate against the traced peak.

    Parameters
    ----------
    shape : (int, int)
        The image's (H, W).
    channels : int
        Intensity channels Eq. 2 compares.
    neighbourhood : int
        The window side ``n``.
    radius : float
        The search radius ``r`` (the frame is padded by ``ceil(r)``).

    Returns
    -------
    int
        Bytes.

    Examples
    --------
    >>> from refsynth._checks import format_bytes
    >>> [format_bytes(np_memory(shape, 3, 5, 10.0)) for shape in ((12, 12), (375, 450))]
    ['1.1 MiB', '190.8 MiB']
    """
    n2 = neighbourhood * neighbourhood
    rows = _padded_rows(shape, neighbourhood, radius)
    pixels = shape[0] * shape[1]
    item = np.dtype(intensity_dtype(rows, channels, neighbourhood)).itemsize
    table = rows * (item * (n2 * channels + 4) + 4 * (2 * n2 + 1) + _FLOAT)
    inputs = pixels * (_FLOAT * (channels + 1) + 1)  # synthesize's copies
    # the quantised levels and range, image-sized; each block of the table's rows (about
    # 4096 pixels, filltable._CHUNK_PIXELS) as float64 patches and their squares, or the
    # patches beside the range's two columns and their temporaries
    block = min(pixels, 4096) * _FLOAT * (2 * n2 * channels + 3 * n2)
    build = 3 * _FLOAT * pixels * channels + 2 * _FLOAT * pixels + block
    # the front, four frames of its temporaries while it is built, the copied range; order, draws
    fill = rows * (_NP_FRONT_BYTES + 5 * _FLOAT) + pixels * (2 * _FLOAT + 1)
    return table + inputs + max(build, fill)


#: Why NP runs before BP (``check_memory``'s ``before``): how the message names it, and the way
#: out it offers.
NP_FIRST = {
    "observation": ("`observation='np'`, BP's default", "take `observation='colorization'`"),
    "proposals": ("`proposals`", "drop `proposals`"),
}


def check_memory(method: str, image: np.ndarray, range_values: np.ndarray, *,
                 neighbourhood: int, radius: float, candidates: int = 8,
                 colour: bool = True, before: str | None = None) -> None:
    """Refuse, before any work, a run that would need more memory than it may use.

    NP: :func:`np_memory` against the machine's physical memory; BP: its own
    estimate and limit (:func:`refsynth.synthesis.belief.memory.check_bp_memory`,
    which :func:`~refsynth.synthesis.belief.fill.bp_fill` checks again).

    Parameters
    ----------
    method : {"np", "bp"}
    image : ndarray of shape (H, W, C)
        The intensity as :func:`validate_inputs` returns it.
    range_values : ndarray of shape (H, W)
        The range, NaN where unknown.
    neighbourhood, radius : int, float
        As the fill gets them (BP's radius after :func:`search_radius`).
    candidates : int, default 8
        BP's ``k``.
    colour : bool, default True
        Eq. 2 on the colour channels (else one grey channel).
    before : {None, "observation", "proposals"}
        NP only: why NP runs before BP (BP's ``observation="np"``, its
        ``proposals``; :data:`NP_FIRST`), named in the message with the way out.

    Raises
    ------
    ValueError
        Naming the method, the image and the parameters that set the
        estimate, with the memory it would need.

    Examples
    --------
    >>> image, partial = np.zeros((12, 12, 3)), np.full((12, 12), np.nan)
    >>> partial[:, 0] = 1.0
    >>> check_memory("np", image, partial, neighbourhood=5, radius=1e4)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: synthesize(method='np') on a 12x12 image with ... radius=10000 would need about ...
    """
    shape = range_values.shape
    channels = image.shape[2] if colour else 1
    if method == "np":
        what = f"synthesize(method='np') on a {shape[1]}x{shape[0]} image with "
        advice = (f"lower `neighbourhood`, `radius` (radius {image_reach(shape)} already "
                  "reaches the whole image)")
        if before is not None:
            reason, way_out = NP_FIRST[before]
            what = (f"synthesize(method='bp') runs NP first ({reason}) on a "
                    f"{shape[1]}x{shape[0]} image with ")
            advice += f", or {way_out}"
        check_memory_need(np_memory(shape, channels, neighbourhood, radius),
                          f"{what}neighbourhood={neighbourhood}, radius={radius:g}", advice)
        return
    unknown = np.isnan(range_values)
    pairs = np.count_nonzero(unknown[:, :-1] & unknown[:, 1:]) + np.count_nonzero(
        unknown[:-1, :] & unknown[1:, :])
    check_bp_memory(shape, int(unknown.sum()), k=candidates, neighbourhood=neighbourhood,
                    channels=channels, n_pairs=int(pairs))
