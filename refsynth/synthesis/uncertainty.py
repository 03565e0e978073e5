r"""The uncertainty map: each synthesized pixel's expected absolute error, in the range's unit.

NP's confidence (Eq. 11) is a fill-order quantity in [0, 1], and BP's (the pooled belief of
Eq. 8's label) saturates at 1 on most pixels: neither is an error a user can threshold in
metres. :func:`uncertainty_map` gives one: an (H, W) float64 map, 0 on measured pixels, > 0
and finite on every synthesized one, in the unit of the range, calibrated so that its mean is
close to the mean absolute error (Eq. 13's MAR) and its ranking close to that of the true
errors (a small area under the sparsification error, AUSE).

Every signal is a spread, in the range's unit, of the values the synthesis could have given
a pixel:

``spread``
    The spread ``max − min`` of the candidate estimates of the pixel: the final estimate, the
    method's own fill (``raw``; the same array unless the estimate was post-processed, e.g.
    by :func:`~refsynth.synthesis.gap_readings.gap_gate` and
    :func:`~refsynth.synthesis.median_pass.median_pass`) and the row interpolation between
    the measured columns bounding the pixel's gap
    (:func:`~refsynth.synthesis.gap_readings.row_interpolation`). Where the copy of Eq. 5 (or
    BP's label of Eq. 8) agrees with the straight line across the gap, the surface is smooth
    and both are close to the truth; where they disagree, one of them is wrong.
``labels`` (BP)
    The mean absolute deviation of BP's ``k`` candidate labels' centre ranges (the training
    patches of Fig. 6, step 2) around the estimate: the spread of what the training set
    proposes for the pixel. Weighting the labels by their normalised belief (Eq. 8) ranks
    worse (the belief saturates); the labels count equally.
``variation``
    The local variation of the estimate, ``max − min`` over the 9 × 9 window around the
    pixel, times ``1/4 + t``, ``t`` the pixel's distance to the nearer bounding column over
    the gap's span (:func:`~refsynth.synthesis.gap_readings.row_gaps`; 1/2 for a gap open at
    the border): a depth edge near the pixel can lie a few columns either way.
``floor``
    The range's noise level — the median absolute difference of vertically adjacent
    measured pixels (a column scan's own variation) — times the distance, in pixels, to the
    nearest measured pixel: it keeps the map above 0 on every synthesized pixel.

The map is ``scale · (w_s · spread + w_l · labels + w_v · variation + w_f · floor)``, with
the weights and the scale of :data:`CALIBRATION` per method. Every term is a difference of
range values (or a distance times one), so a positive scale of the range scales the map by
the same factor; it is a function of the partial range, the final dense range and the
method's per-pixel information only, so it stays right when the range is post-processed
(give the method's own fill as ``raw``).

Calibration: on the choosing scenes — the Motorcycle and the five scenes of
``../shared/data`` — at x-stripes 78 %, 450 × 375, seed 0, NP's and BP's results as they are
and after the default post-passes (:func:`~refsynth.synthesis.gap_readings.gap_gate`, then
:func:`~refsynth.synthesis.median_pass.median_pass`), a grid of the
weights keeps those whose mean AUSE (a fraction of the MAR) is at most 0.15, and of these
takes the one whose ``mean(map) / MAR`` varies least across the cases
(``python benchmarks/bench_uncertainty.py ../shared/data --motorcycle --default --fit`` prints
them). The scale is then set on :func:`refsynth.synthesize`'s default output: it centres
that ratio's range over the default output's cases on 1 (the fit's scale divided by the
geometric mean of those cases' lowest and highest ratio). Without ``--fit`` the command
prints the figures of ``docs/uncertainty.md``.

The numeric contract (:mod:`refsynth.numeric`): the map is made of differences, maxima and
minima, products by constants, a median and a sum over the labels from left to right, so
the same inputs give the same bits on any machine.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2 (Eq. 5), §3.2.3 (Fig. 6, Eq. 8), §3.3.1 (Eq. 13),
§5, doi:10.1007/s11263-007-0108-2.
E. Ilg et al., "Uncertainty estimates and multi-hypotheses networks for optical flow",
ECCV 2018 (sparsification curves and AUSE).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from refsynth._checks import check_choice, check_real_array
from refsynth.numeric import left_to_right_sum
from refsynth.synthesis.gap_readings import row_gaps, row_interpolation

__all__ = ["CALIBRATION", "UNCERTAINTY_METHODS", "WINDOW", "uncertainty_features",
           "uncertainty_map"]

#: The methods :func:`uncertainty_map` is calibrated for.
UNCERTAINTY_METHODS = ("np", "bp")
#: The side of the window of the ``variation`` term, in pixels.
WINDOW = 9
#: Per method, the weights of the terms and the scale (see the module's docstring; re-fitted
#: by ``python benchmarks/bench_uncertainty.py ../shared/data --motorcycle --default --fit``).
CALIBRATION = {
    "np": {"spread": 1.0, "labels": 0.0, "variation": 0.25, "floor": 4.0, "scale": 0.251},
    "bp": {"spread": 0.5, "labels": 0.25, "variation": 0.1, "floor": 2.0, "scale": 0.482},
}


def _check_dense(name: str, array, shape: tuple[int, int], unknown: np.ndarray) -> np.ndarray:
    """``array`` as float64 of ``shape``, finite on the unknown pixels, or raise naming it."""
    array = check_real_array(name, array, ndims=(2,))
    if array.shape != shape:
        raise ValueError(f"The parameter `{name}` must have the partial range's shape {shape}, "
                         f"got {array.shape}")
    array = np.asarray(array, dtype=np.float64)
    if not np.isfinite(array[unknown]).all():
        raise ValueError(f"The parameter `{name}` must be finite on every unknown pixel")
    return array


def _check_inputs(partial_range, estimate, raw, candidate_values, method):
    """The checked arrays (float64), the measured mask; raise naming the bad argument."""
    method = check_choice("method", method, UNCERTAINTY_METHODS)
    partial = np.asarray(check_real_array("partial_range", partial_range, ndims=(2,)),
                         dtype=np.float64)
    if np.isinf(partial).any():
        raise ValueError("The parameter `partial_range` must be finite or NaN (NaN = unknown)")
    known = np.isfinite(partial)
    if not known.any():
        raise ValueError("The parameter `partial_range` must have at least one measured pixel")
    unknown = ~known
    estimate = _check_dense("estimate", estimate, partial.shape, unknown)
    raw = estimate if raw is None else _check_dense("raw", raw, partial.shape, unknown)
    if method == "bp":
        if candidate_values is None:
            raise ValueError("The parameter `candidate_values` is needed with method='bp' "
                             "(BP's labels' centre ranges, SynthesisResult.candidate_values)")
        candidate_values = np.asarray(check_real_array("candidate_values", candidate_values),
                                      np.float64)
        count = int(unknown.sum())
        if candidate_values.ndim != 2 or candidate_values.shape[0] != count or (
                count and not candidate_values.shape[1]):
            raise ValueError(f"The parameter `candidate_values` must have one row per unknown "
                             f"pixel ({count}), got shape {candidate_values.shape}")
        if not np.isfinite(candidate_values).all():
            raise ValueError("The parameter `candidate_values` must be finite")
    elif candidate_values is not None:
        raise ValueError("The parameter `candidate_values` applies to method='bp' only")
    return partial, known, estimate, raw, candidate_values, method


def _noise(partial: np.ndarray, known: np.ndarray) -> float:
    """The range's noise level: the median |difference| of vertically adjacent measured pixels.

    Falls back to ``2**-16`` of the measured span, then of the largest |value|, then to the
    smallest normal float (a partial range of zeros), so that it is always > 0.
    """
    pairs = known[1:] & known[:-1]
    if pairs.any():
        noise = float(np.median(np.abs(partial[1:][pairs] - partial[:-1][pairs])))
        if noise > 0.0:
            return noise
    values = partial[known]
    for fallback in (float(values.max() - values.min()), float(np.abs(values).max())):
        if fallback > 0.0:
            return fallback * 2.0**-16
    return float(np.finfo(np.float64).tiny)


def _row_line(partial: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The row interpolation and each pixel's position in its gap (a 0–1/2 fraction).

    The interpolation is :func:`~refsynth.synthesis.gap_readings.row_interpolation`; the
    position is the distance to the nearer bounding column over ``right − left``, 1/2 in a
    gap open at the border or in a row without a measured pixel.
    """
    line = row_interpolation(partial)
    left, right, width = row_gaps(partial)
    cols = np.arange(partial.shape[1])[None, :]
    position = np.where(width > 0, np.minimum(cols - left, right - cols)
                        / np.maximum(right - left, 1), 0.5)
    return line, position


def uncertainty_features(partial_range: np.ndarray, estimate: np.ndarray, *,
                         raw: np.ndarray | None = None,
                         candidate_values: np.ndarray | None = None,
                         method: str = "np") -> dict[str, np.ndarray]:
    """The terms of :func:`uncertainty_map`, each an (H, W) map in the range's unit.

    Parameters are those of :func:`uncertainty_map`.

    Returns
    -------
    dict of str to ndarray of shape (H, W), float64
        ``spread``, ``labels`` (zeros for NP), ``variation`` and ``floor``, as the module's
        docstring defines them; every one 0 on measured pixels, ``floor`` > 0 on every
        unknown one.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, 3.0]])
    >>> terms = uncertainty_features(partial, np.array([[1.0, 2.5, 3.0]]))
    >>> float(terms["spread"][0, 1]), float(terms["spread"][0, 0])
    (0.5, 0.0)
    """
    partial, known, estimate, raw, values, method = _check_inputs(
        partial_range, estimate, raw, candidate_values, method)
    unknown = ~known
    line, position = _row_line(partial, known)
    spread = (np.maximum(np.maximum(estimate, raw), line)
              - np.minimum(np.minimum(estimate, raw), line))
    labels = np.zeros(partial.shape)
    if method == "bp":
        deviation = np.abs(values - estimate[unknown][:, None])
        labels[unknown] = left_to_right_sum(deviation, axis=1) / values.shape[1]
    dense = np.where(known, partial, estimate)
    variation = (ndimage.maximum_filter(dense, WINDOW, mode="nearest")
                 - ndimage.minimum_filter(dense, WINDOW, mode="nearest"))
    distance = ndimage.distance_transform_edt(unknown)
    floor = _noise(partial, known) * distance
    terms = dict(spread=spread, labels=labels, variation=variation * (0.25 + position),
                 floor=floor)
    return {name: np.where(unknown, term, 0.0) for name, term in terms.items()}


def uncertainty_map(partial_range: np.ndarray, estimate: np.ndarray, *, method: str = "np",
                    raw: np.ndarray | None = None,
                    candidate_values: np.ndarray | None = None) -> np.ndarray:
    """Each pixel's expected absolute error, in the range's unit (0 where measured).

    A public function of any dense estimate made from ``partial_range``: NP's or BP's range
    (:attr:`refsynth.SynthesisResult.uncertainty` is this map of the result's range), the
    same after a post-pass (give the method's own fill as ``raw``), or another fill with the
    calibration of ``method``.

    Parameters
    ----------
    partial_range : ndarray of shape (H, W), real
        The measured range, NaN where unknown; at least one pixel measured.
    estimate : ndarray of shape (H, W), real
        The final dense range, finite on every unknown pixel.
    method : {"np", "bp"}, default "np"
        Whose calibration (:data:`CALIBRATION`) to use; ``"bp"`` needs ``candidate_values``.
    raw : ndarray of shape (H, W), optional
        The method's own fill when ``estimate`` is a post-processed version of it (default:
        ``estimate`` itself).
    candidate_values : ndarray of shape (N, k), BP only
        BP's labels' centre ranges, one row per unknown pixel in raster order
        (:attr:`refsynth.SynthesisResult.candidate_values`).

    Returns
    -------
    ndarray of shape (H, W), float64
        0 on measured pixels, finite and > 0 on every unknown one.

    Raises
    ------
    TypeError, ValueError
        Naming the argument: a non-array or non-real array, a shape that differs from
        ``partial_range``'s, an estimate that is not finite on an unknown pixel, no measured
        pixel, an unknown ``method``, ``candidate_values`` missing for BP, given for NP or of
        the wrong number of rows.

    Examples
    --------
    >>> import numpy as np
    >>> partial = np.array([[1.0, np.nan, np.nan, 1.0], [1.0, np.nan, np.nan, 1.0]])
    >>> smooth = uncertainty_map(partial, np.ones((2, 4)))
    >>> doubtful = uncertainty_map(partial, np.array([[1.0, 5.0, 1.0, 1.0]] * 2))
    >>> float(smooth[0, 0]), bool((smooth[:, 1:3] > 0).all())
    (0.0, True)
    >>> bool(doubtful[0, 1] > smooth[0, 1])
    True
    """
    terms = uncertainty_features(partial_range, estimate, raw=raw,
                                 candidate_values=candidate_values, method=method)
    weights = CALIBRATION[method]
    total = np.zeros(terms["floor"].shape)
    for name in ("spread", "labels", "variation", "floor"):
        total = total + weights[name] * terms[name]
    return weights["scale"] * total
