"""The one set of parameter checks, and the grey conversion, used across refsynth.

Every public function of refsynth validates its arguments before it starts any
work and, on bad input, raises ``TypeError`` (wrong kind of value) or
``ValueError`` (right kind, wrong value) with a message that names the
parameter, says what was expected and shows what came in::

    The parameter `radius` must be an integer >= 1, got 0

The helpers here are that contract, written once. They return the checked
value in its canonical type (``int``, ``float``, a float64 array) so a caller
writes ``radius = check_int("radius", radius, minimum=1)`` and goes on.
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np

__all__ = [
    "is_int",
    "is_real",
    "check_int",
    "check_real",
    "check_fraction",
    "check_seed",
    "check_choice",
    "check_real_array",
    "check_image",
    "check_size",
    "check_pair",
    "to_float",
    "grey",
    "BT709",
    "BT601",
]

#: Luminance weights of ITU-R BT.709 (scikit-image's ``rgb2gray``), the default.
BT709 = np.array([0.2125, 0.7154, 0.0721])
#: Luminance weights of ITU-R BT.601 (MATLAB's ``rgb2gray``, the NYU colorization toolbox).
BT601 = np.array([0.2989, 0.5870, 0.1140])


# ----------------------------------------------------------------------------- scalars


def is_int(value) -> bool:
    """True for a Python or numpy integer that is not a bool."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def is_real(value) -> bool:
    """True for a Python or numpy real number that is not a bool."""
    return isinstance(value, Real) and not isinstance(value, (bool, np.bool_))


def check_int(
    name: str, value, minimum: int | None = None, maximum: int | None = None
) -> int:
    """``value`` as an ``int`` within ``[minimum, maximum]``, or raise.

    Examples
    --------
    >>> check_int("radius", 3, minimum=1)
    3
    >>> check_int("radius", 0, minimum=1)
    Traceback (most recent call last):
    ...
    ValueError: The parameter `radius` must be an integer >= 1, got 0
    """
    if not is_int(value):
        raise TypeError(f"The parameter `{name}` must be an integer, got {value!r}")
    if minimum is not None and maximum is not None and not minimum <= value <= maximum:
        raise ValueError(
            f"The parameter `{name}` must be an integer in [{minimum}, {maximum}], got {value}"
        )
    if minimum is not None and value < minimum:
        raise ValueError(f"The parameter `{name}` must be an integer >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"The parameter `{name}` must be an integer <= {maximum}, got {value}")
    return int(value)


def check_real(
    name: str,
    value,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    positive: bool = False,
) -> float:
    """``value`` as a finite ``float`` (optionally ``> 0``, ``>= minimum``, ``<= maximum``).

    Examples
    --------
    >>> check_real("sigma", 0.8, positive=True)
    0.8
    >>> check_real("sigma", float("nan"))
    Traceback (most recent call last):
    ...
    ValueError: The parameter `sigma` must be finite, got nan
    """
    if not is_real(value):
        raise TypeError(f"The parameter `{name}` must be a real number, got {type(value).__name__}")
    try:
        value = float(value)
    except OverflowError:  # an int beyond float64, e.g. 10**400
        raise ValueError(f"The parameter `{name}` must be finite, got {value}") from None
    if not math.isfinite(value):
        raise ValueError(f"The parameter `{name}` must be finite, got {value}")
    if positive and value <= 0:
        raise ValueError(f"The parameter `{name}` must be > 0, got {value}")
    if minimum is not None and value < minimum:
        raise ValueError(f"The parameter `{name}` must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"The parameter `{name}` must be <= {maximum}, got {value}")
    return value


def check_fraction(name: str, value) -> float:
    """``value`` as a float strictly between 0 and 1."""
    if not is_real(value):
        raise TypeError(f"The parameter `{name}` must be a real number, got {value!r}")
    if not 0.0 < float(value) < 1.0:
        raise ValueError(f"The parameter `{name}` must be strictly between 0 and 1, got {value}")
    return float(value)


def check_seed(seed, name: str = "seed"):
    """``seed`` if it is None, a non-negative integer or a ``numpy.random.Generator``."""
    if seed is None or isinstance(seed, np.random.Generator) or (is_int(seed) and seed >= 0):
        return seed
    raise TypeError(
        f"The parameter `{name}` must be a non-negative integer, a numpy Generator or None, "
        f"got {seed!r}"
    )


def check_choice(name: str, value, choices) -> str:
    """``value`` if it is one of ``choices`` (strings), or raise ``ValueError``."""
    if not isinstance(value, str) or value not in choices:
        listed = ", ".join(repr(c) for c in choices)
        raise ValueError(f"The parameter `{name}` must be one of {listed}, got {value!r}")
    return value


def check_size(size, name: str = "size") -> tuple[int, int]:
    """``(width, height)`` from a positive int or a pair ``(width, height)`` of them."""
    if is_int(size) and size > 0:
        return int(size), int(size)
    if (
        isinstance(size, (tuple, list))
        and len(size) == 2
        and all(is_int(n) and n > 0 for n in size)
    ):
        return int(size[0]), int(size[1])
    raise ValueError(
        f"The parameter `{name}` must be a positive integer or a pair of positive integers "
        f"(width, height), got {size!r}"
    )


def check_pair(name: str, value) -> np.ndarray:
    """``value`` as a float64 array of two finite numbers."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = None
    real = array is not None and array.dtype != np.bool_ and (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    )
    if not real or array.shape != (2,) or not np.all(np.isfinite(array)):
        raise ValueError(f"The parameter `{name}` must be a pair of finite numbers, got {value!r}")
    return array.astype(np.float64)


# ----------------------------------------------------------------------------- arrays


def check_real_array(name: str, array, ndims: tuple[int, ...] | None = None) -> np.ndarray:
    """``array`` itself if it is a non-empty real (not bool, not complex) ndarray of ``ndims``."""
    if not isinstance(array, np.ndarray):
        raise TypeError(f"The parameter `{name}` must be a numpy array, got {type(array).__name__}")
    if (
        array.dtype == np.bool_
        or not np.issubdtype(array.dtype, np.number)
        or np.issubdtype(array.dtype, np.complexfloating)
    ):
        raise TypeError(f"The parameter `{name}` must be a real numeric array, got {array.dtype}")
    if ndims is not None and (array.ndim not in ndims or 0 in array.shape):
        expected = " or ".join(f"{n}-D" for n in ndims)
        raise ValueError(
            f"The parameter `{name}` must be a non-empty {expected} array, got shape {array.shape}"
        )
    return array


def to_float(array: np.ndarray) -> np.ndarray:
    """A float64 copy of ``array``: integers divided by their dtype's maximum, bool as 0/1.

    This is refsynth's intensity convention: an 8-bit image becomes values in
    [0, 1]; a floating image is used as given.
    """
    if np.issubdtype(array.dtype, np.integer):
        return array.astype(np.float64) / float(np.iinfo(array.dtype).max)
    return array.astype(np.float64)


def check_image(name: str, image, *, allow_nan: bool = True, colour: bool = True) -> np.ndarray:
    """``image`` as float64 (H, W) or (H, W, C) with H, W >= 2; integers scaled to [0, 1]."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"The parameter `{name}` must be a numpy array, got {type(image).__name__}")
    if image.dtype == np.bool_ or not (
        np.issubdtype(image.dtype, np.integer) or np.issubdtype(image.dtype, np.floating)
    ):
        raise TypeError(f"The parameter `{name}` must be a real numeric array, got {image.dtype}")
    if image.ndim not in ((2, 3) if colour else (2,)) or min(image.shape[:2], default=0) < 2:
        expected = "(H, W) or (H, W, C)" if colour else "(H, W)"
        raise ValueError(
            f"The parameter `{name}` must be an image of shape {expected} with H, W >= 2, "
            f"got shape {image.shape}"
        )
    values = to_float(image)
    if np.isinf(values).any() or (not allow_nan and np.isnan(values).any()):
        what = "finite" if not allow_nan else "finite or NaN (NaN = no data)"
        raise ValueError(f"The parameter `{name}` must be {what}")
    return values


# ----------------------------------------------------------------------------- grey


def grey(image: np.ndarray, weights: np.ndarray | None = BT709) -> np.ndarray:
    """The luminance of a float image: (H, W) as is, (H, W, 1) its channel, (H, W, 3) weighted.

    Parameters
    ----------
    image : ndarray of shape (H, W), (H, W, 1), (H, W, 3) or (H, W, C)
        A floating image (see :func:`to_float` for integers).
    weights : ndarray of shape (3,) or None, default :data:`BT709`
        Luminance weights for three channels; :data:`BT601` gives MATLAB's
        ``rgb2gray``; None averages the three too. Other channel counts are averaged.

    Returns
    -------
    ndarray of shape (H, W)
        The input itself when it is already 2-D, a new array otherwise.

    Notes
    -----
    The weighted sum is written out, ``(w0 R + w1 G) + w2 B`` elementwise, and the mean of
    other channel counts is a left-to-right sum: no BLAS product, whose summation order (and
    so the last bit) depends on the library and the CPU (refsynth's numeric contract,
    :mod:`refsynth.numeric`).
    """
    if image.ndim == 2:
        return image
    if image.shape[2] == 1:
        return image[:, :, 0]
    if image.shape[2] == 3 and weights is not None:
        w = np.asarray(weights, dtype=np.float64)
        return (w[0] * image[:, :, 0] + w[1] * image[:, :, 1]) + w[2] * image[:, :, 2]
    total = np.zeros(image.shape[:2])
    for channel in range(image.shape[2]):
        total = total + image[:, :, channel]
    return total / image.shape[2]


def check_bool(name: str, value) -> bool:
    """``value`` as a ``bool`` if it is a Python or numpy bool, or raise ``TypeError``.

    Examples
    --------
    >>> check_bool("use_edges", "yes")
    Traceback (most recent call last):
    ...
    TypeError: The parameter `use_edges` must be a bool, got str
    """
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"The parameter `{name}` must be a bool, got {type(value).__name__}")
    return bool(value)


__all__.append("check_bool")


def check_in_range(name: str, value, low: float, high: float) -> float:
    """``value`` as a finite ``float`` in the closed interval ``[low, high]``, or raise.

    The message names the accepted range, e.g. for a parameter whose arithmetic
    overflows or underflows outside it.

    Examples
    --------
    >>> check_in_range("sigma_i", 0.1, 1e-50, 1e50)
    0.1
    >>> check_in_range("sigma_i", 1e-300, 1e-50, 1e50)
    Traceback (most recent call last):
    ...
    ValueError: The parameter `sigma_i` must be in [1e-50, 1e+50], got 1e-300
    """
    value = check_real(name, value)
    if not low <= value <= high:
        raise ValueError(f"The parameter `{name}` must be in [{low:g}, {high:g}], got {value:g}")
    return value


def format_bytes(count: float) -> str:
    """A byte count for a message: ``80_000_000_000`` → ``"74.5 GiB"``.

    >>> format_bytes(512), format_bytes(3 * 2**30), format_bytes(2**60), format_bytes(10**400)
    ('512 B', '3.0 GiB', '1.0 EiB', '10^381 EiB')
    """
    if count >= 2**60 * 10**6:  # an absurd estimate (an int beyond float64, maybe): its order
        return f"10^{len(str(int(count) // 2**60)) - 1} EiB"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if count < 1024:
            return f"{count:.0f} {unit}" if unit == "B" else f"{count:.1f} {unit}"
        count /= 1024
    return f"{count:.1f} EiB"


def physical_memory() -> int | None:
    """This machine's physical memory in bytes, or None where the OS does not say."""
    import os  # (appended helper: the imports at the top belong to the file's first author)

    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None
    return pages * size if pages > 0 and size > 0 else None


def check_memory_need(need: float, what: str, hint: str = "", limit: float | None = None) -> None:
    """Refuse ``what`` before it starts if it would need more than ``limit`` bytes.

    ``limit`` defaults to :func:`physical_memory` ("more than this machine's
    …"; 2**50, a pebibyte, where the OS does not say).

    Examples
    --------
    >>> check_memory_need(2**40, "a fill", "lower `r`", limit=2**30)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: a fill would need about 1.0 TiB of memory, more than the 1.0 GiB available; ...
    """
    have = physical_memory() if limit is None else None
    limit = limit if limit is not None else (have or 2**50)
    if need > limit:
        where = f"this machine's {format_bytes(have)}" if have else \
            f"the {format_bytes(limit)} available"
        raise ValueError(f"{what} would need about {format_bytes(need)} of memory, more than "
                         f"{where}" + (f"; {hint}" if hint else ""))


__all__ += ["check_in_range", "format_bytes", "physical_memory", "check_memory_need"]


def check_crop(crop, shape: tuple[int, int]) -> tuple[tuple[int, int], tuple[int, int]]:
    """``crop`` as ``((r0, r1), (c0, c1))`` with ``0 <= start < stop <= size``; None: all of it.

    Raises ``TypeError`` if ``crop`` is not two pairs of integers, ``ValueError`` if it does
    not lie inside ``shape`` (rows, columns).

    >>> check_crop(((1, 3), (0, 4)), (3, 4))
    ((1, 3), (0, 4))
    """
    height, width = shape
    if crop is None:
        return (0, height), (0, width)
    try:
        (r0, r1), (c0, c1) = crop
        ok = all(is_int(v) for v in (r0, r1, c0, c1))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise TypeError(
            "The parameter `crop` must be ((row_start, row_stop), (col_start, col_stop)) "
            f"of integers, got {crop!r}"
        )
    if not (0 <= r0 < r1 <= height and 0 <= c0 < c1 <= width):
        raise ValueError(
            "The parameter `crop` must be ((row_start, row_stop), (col_start, col_stop)) "
            f"with 0 <= start < stop <= {height} rows and {width} columns, got {crop!r}"
        )
    return (int(r0), int(r1)), (int(c0), int(c1))


__all__.append("check_crop")
