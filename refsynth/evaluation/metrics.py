"""Error measures for synthesized range (§3.3.1, Eq. 13).

The paper reports the mean absolute residual (MAR, Eq. 13) over the pixels
whose range was unknown. For comparison with other depth-completion and
stereo work, this module adds the root-mean-square error and the bad-pixel
rates of the Middlebury evaluation on the same pixel set.

All functions take the same three arrays:

- ``estimate``: the synthesized (dense) range,
- ``truth``: the ground-truth range, ``NaN`` (or ±inf) where there is none,
- ``known``: boolean, ``True`` where the range was given to the synthesis.

and evaluate the pixels that were unknown *and* have ground truth,
``~known & isfinite(truth)``.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3.1, Eq. 13,
doi:10.1007/s11263-007-0108-2.

D. Scharstein and R. Szeliski, "A Taxonomy and Evaluation of Dense
Two-Frame Stereo Correspondence Algorithms", IJCV 47:7–42 (2002), §5.1
(bad-pixel percentage).
"""

from __future__ import annotations

import math

import numpy as np

from refsynth._checks import check_real_array, is_real

__all__ = ["BAD_THRESHOLDS", "evaluated_pixels", "mar", "rmse", "bad_pixel_rate", "evaluate"]

#: The thresholds of :func:`evaluate`'s ``bad1`` and ``bad3``, in range units.
BAD_THRESHOLDS = {"bad1": 1.0, "bad3": 3.0}


def evaluated_pixels(estimate: np.ndarray, truth: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Validate the inputs and return the mask of pixels to evaluate (Eq. 13, §3.3.1).

    Parameters
    ----------
    estimate : ndarray of shape (H, W)
        Synthesized range.
    truth : ndarray of shape (H, W)
        Ground truth; non-finite where there is none.
    known : ndarray of shape (H, W), bool
        ``True`` where the range was known (given to the synthesis).

    Returns
    -------
    ndarray of shape (H, W), bool
        ``~known & isfinite(truth)``.

    Raises
    ------
    TypeError
        If an array is not a numpy array, ``estimate`` or ``truth`` is not
        real-valued, or ``known`` is not boolean.
    ValueError
        If the shapes differ, ``estimate`` is not finite on an evaluated
        pixel, or there is no pixel to evaluate.

    Examples
    --------
    >>> truth = np.array([[1.0, 2.0], [np.inf, 4.0]])
    >>> known = np.array([[True, False], [False, False]])
    >>> evaluated_pixels(np.ones((2, 2)), truth, known).tolist()
    [[False, True], [False, True]]
    """
    estimate = check_real_array("estimate", estimate).astype(np.float64, copy=False)
    truth = check_real_array("truth", truth).astype(np.float64, copy=False)
    if not isinstance(known, np.ndarray):
        raise TypeError(f"The parameter `known` must be a numpy array, got {type(known).__name__}")
    if known.dtype != bool:
        raise TypeError(f"The parameter `known` must be a boolean array, got dtype {known.dtype}")
    if truth.shape != estimate.shape:
        raise ValueError(
            f"The parameter `truth` must have the shape of `estimate` {estimate.shape}, "
            f"got {truth.shape}"
        )
    if known.shape != estimate.shape:
        raise ValueError(
            f"The parameter `known` must have the shape of `estimate` {estimate.shape}, "
            f"got {known.shape}"
        )
    evaluated = ~known & np.isfinite(truth)
    if not evaluated.any():
        raise ValueError(
            "No pixel to evaluate: every pixel is `known` or has no finite `truth` "
            f"({np.count_nonzero(known)} known of {known.size})"
        )
    bad = np.count_nonzero(~np.isfinite(estimate[evaluated]))
    if bad:
        raise ValueError(
            "The parameter `estimate` must be finite on the evaluated pixels (unknown, with "
            f"ground truth), got {bad} non-finite of {np.count_nonzero(evaluated)}"
        )
    return evaluated


def _residuals(estimate, truth, known) -> np.ndarray:
    evaluated = evaluated_pixels(estimate, truth, known)
    return (
        np.asarray(estimate, dtype=np.float64)[evaluated]
        - np.asarray(truth, dtype=np.float64)[evaluated]
    )


def _root_mean_square(error: np.ndarray) -> float:
    """``sqrt(mean(error²))``, scaled by ``max |error|`` so that squaring neither
    underflows (errors below 1e-154) nor overflows (above 1e154)."""
    largest = float(np.max(np.abs(error)))
    if largest == 0.0:
        return 0.0
    return largest * float(np.sqrt(np.mean(np.square(error / largest))))


def mar(estimate: np.ndarray, truth: np.ndarray, known: np.ndarray) -> float:
    """Mean absolute residual over the unknown pixels with ground truth (Eq. 13).

    .. math::

        \\mathrm{MAR} = \\frac{\\sum_{i,j} |R_1(i,j) - R_2(i,j)|}
                             {\\#\\ \\text{of unknown range pixels}}

    where the sum runs over the pixels that were unknown and (for real data)
    have ground truth.

    Parameters
    ----------
    estimate, truth : ndarray of shape (H, W)
        Synthesized range ``R1`` and ground truth ``R2`` (non-finite where
        there is none), in the same unit.
    known : ndarray of shape (H, W), bool
        ``True`` where the range was known.

    Returns
    -------
    float
        In the unit of the range (the paper reports centimetres).

    References
    ----------
    Torres-Méndez & Dudek (2008), §3.3.1, Eq. 13, doi:10.1007/s11263-007-0108-2.

    Examples
    --------
    >>> truth = np.array([[1.0, 2.0], [3.0, np.nan]])
    >>> known = np.array([[True, False], [False, False]])
    >>> mar(np.array([[9.0, 2.5], [2.0, 0.0]]), truth, known)
    0.75
    """
    return float(np.mean(np.abs(_residuals(estimate, truth, known))))


def rmse(estimate: np.ndarray, truth: np.ndarray, known: np.ndarray) -> float:
    """Root-mean-square error over the pixels of Eq. 13 (not in the paper).

    Parameters
    ----------
    estimate, truth, known
        As in :func:`mar`; the same residuals, squared before the mean.

    Returns
    -------
    float
        ``sqrt(mean((estimate - truth)²))``; always >= :func:`mar`.

    Examples
    --------
    >>> known = np.array([[True, False, False]])
    >>> rmse(np.array([[9.0, 1.0, 1.0]]), np.array([[0.0, 2.0, 4.0]]), known)
    2.23606797749979
    """
    return _root_mean_square(_residuals(estimate, truth, known))


def bad_pixel_rate(
    estimate: np.ndarray, truth: np.ndarray, known: np.ndarray, threshold: float
) -> float:
    """Fraction of the pixels of Eq. 13 whose absolute error exceeds ``threshold``.

    The "bad pixels" of the Middlebury stereo evaluation (Scharstein &
    Szeliski 2002), which counts disparity errors above 1 pixel; not in the
    paper.

    Parameters
    ----------
    estimate, truth, known
        As in :func:`mar`.
    threshold : float
        In range units, >= 0. A pixel is bad when ``|error| > threshold``.

    Returns
    -------
    float
        In [0, 1].

    Examples
    --------
    >>> known = np.array([[True, False, False]])
    >>> bad_pixel_rate(np.array([[9.0, 1.0, 1.0]]), np.array([[0.0, 1.5, 4.0]]), known, 1.0)
    0.5
    """
    if not is_real(threshold):
        raise TypeError(f"The parameter `threshold` must be a real number, got {threshold!r}")
    if not (math.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"The parameter `threshold` must be a finite number >= 0, got {threshold}")
    return float(np.mean(np.abs(_residuals(estimate, truth, known)) > threshold))


def evaluate(estimate: np.ndarray, truth: np.ndarray, known: np.ndarray) -> dict:
    """All the measures at once, over the pixels of Eq. 13.

    Parameters
    ----------
    estimate, truth, known
        As in :func:`mar`; every measure is taken over the same pixels.

    Returns
    -------
    dict
        ``mar`` (Eq. 13), ``rmse``, ``bad1`` and ``bad3`` (fractions of
        pixels with absolute error above 1 and 3 range units, as in the
        Middlebury literature, where the unit is a disparity pixel) and
        ``n``, the number of evaluated pixels (an int).

    Examples
    --------
    >>> truth = np.zeros((2, 2))
    >>> known = np.array([[True, False], [False, False]])
    >>> evaluate(np.array([[0.0, 0.5], [2.0, 4.0]]), truth, known)["bad1"]
    0.6666666666666666
    """
    error = np.abs(_residuals(estimate, truth, known))
    result = {
        "mar": float(np.mean(error)),
        "rmse": _root_mean_square(error),
    }
    for key, threshold in BAD_THRESHOLDS.items():
        result[key] = float(np.mean(error > threshold))
    result["n"] = int(error.size)
    return result
