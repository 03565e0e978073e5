r"""Eq. 2: the distance between two partial neighbourhoods (§3.2.2).

.. math::

    \|N_a - N_b\| = \sum_{v} G(\sigma, v - v_0)
        \left[ \frac{1}{C}\sum_{c=1}^{C} (I^a_{v,c} - I^b_{v,c})^2
               + \lambda \, (R^a_v - R^b_v)^2 \right]

The sum runs over the offsets ``v`` of the n×n window. Each term uses only the
data that *both* neighbourhoods have at ``v``: the range term is dropped where
either neighbourhood has no range (in particular at the centre of the
neighbourhood being synthesized).

Normalisation (our choice; the paper leaves it open)
-----------------------------------------------------
Intensity and range live in different units. refsynth divides the intensity
by its span over the whole image and the range by the span of the *known*
range, so both lie in [0, 1], and averages the intensity term over the colour
channels, so grey and colour images weigh the same. The range term then gets
the weight ``λ`` (``range_weight``, default 16): the trials noted in
``EQUATIONS.md`` found intensity-only matches pulling in depths from
similar-looking surfaces, and a range term several times heavier than the
intensity term working better. The default was chosen on synthetic rooms of
seeds 100–102 (λ ∈ {1, 4, 16, 32, 64, 256}; 16 to 256 were within a few
hundredths of a metre of each other, 1 and 4 clearly worse), a development
set disjoint from the demo's scene and from the Motorcycle. With ``λ = 0``
Eq. 2 reduces to an intensity match.

Coverage penalty (a departure from the paper, in NP only)
---------------------------------------------------------
Eq. 2 as written rewards a candidate for *lacking* range: where ``N_p`` has
range and the candidate has none, the range term is simply dropped, so a
candidate at the image border, or beside unknown range, pays nothing for the
range it cannot compare. On stripe samplings that lets intensity noise pick
candidates many rows away. NP therefore adds ``κ λ Σ_v G_v`` over the
offsets where ``N_p`` has range and the candidate does not (``κ`` =
``coverage_penalty``, default 0.003, so ``κλ ≈ 0.05``: a missing range costs
about as much as an intensity difference of a fifth of the span). ``κ = 0``
gives the literal Eq. 2. On the development rooms any κ from 0.001 to 1
roughly halved NP's MAR on grid and x-stripe samplings; κ ≥ 0.03 began to
override intensity at depth steps next to not-yet-filled edge pixels (the
two-plane test in ``tests/test_np_sampling.py``), so the default sits well
below that. :func:`neighbourhood_distance`
stays the literal Eq. 2, and the penalty is applied in
:class:`refsynth.np_sampling.PatchTable`.

:func:`neighbourhood_distance` is the literal reading of Eq. 2, one pair at a
time. :mod:`refsynth.np_sampling` evaluates the same sum for a whole candidate
set at once by expanding the squares into one matrix–vector product; the tests
check that the two agree.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth.mrf import gaussian_window

__all__ = ["neighbourhood_distance", "intensity_scale", "range_scale"]


def intensity_scale(image: np.ndarray) -> float:
    """The span of an intensity image (max − min), or 1 for a constant image."""
    span = float(np.max(image) - np.min(image))
    return span if span > 0 else 1.0


def range_scale(range_image: np.ndarray) -> tuple[float, float]:
    """Offset and span of the known range: ``(min, max − min)``, span 1 if constant."""
    known = range_image[np.isfinite(range_image)]
    low = float(known.min())
    span = float(known.max()) - low
    return low, (span if span > 0 else 1.0)


def neighbourhood_distance(
    intensity_a: np.ndarray,
    range_a: np.ndarray,
    intensity_b: np.ndarray,
    range_b: np.ndarray,
    *,
    range_weight: float = 16.0,
    window: np.ndarray | None = None,
) -> float:
    """Eq. 2 for one pair of partial neighbourhoods.

    Parameters
    ----------
    intensity_a, intensity_b : ndarray of shape (n, n) or (n, n, C)
        Normalised intensity; NaN where a voxel has no intensity (off the image).
    range_a, range_b : ndarray of shape (n, n)
        Normalised range, NaN where unknown.
    range_weight : float, default 16
        The weight λ of the range term.
    window : ndarray of shape (n, n), optional
        The Gaussian window ``G``; default :func:`refsynth.mrf.gaussian_window`.

    Returns
    -------
    float
        The weighted sum of squared differences over the shared support.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.zeros((3, 3)); r = np.full((3, 3), np.nan)
    >>> neighbourhood_distance(a, r, a, r)
    0.0
    """
    ia = np.asarray(intensity_a, dtype=np.float64)
    ib = np.asarray(intensity_b, dtype=np.float64)
    if ia.ndim == 2:
        ia, ib = ia[:, :, None], ib[:, :, None]
    ra = np.asarray(range_a, dtype=np.float64)
    rb = np.asarray(range_b, dtype=np.float64)
    if ia.shape != ib.shape or ra.shape != rb.shape or ra.shape != ia.shape[:2]:
        raise ValueError(
            "The neighbourhoods must have matching shapes, got "
            f"{ia.shape}, {ib.shape}, {ra.shape}, {rb.shape}"
        )
    n = ra.shape[0]
    g = gaussian_window(n) if window is None else np.asarray(window, dtype=np.float64)
    di = ia - ib
    intensity_term = np.where(np.isfinite(di), di, 0.0) ** 2
    intensity_term = intensity_term.sum(axis=2) / ia.shape[2]
    dr = ra - rb
    range_term = np.where(np.isfinite(dr), dr, 0.0) ** 2
    return float(np.sum(g * (intensity_term + range_weight * range_term)))
