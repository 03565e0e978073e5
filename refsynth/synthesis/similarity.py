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

Missing range (a departure from the paper)
------------------------------------------
Eq. 2 as written rewards a candidate for *lacking* range: where ``N_p`` has
range and the candidate has none, the range term is simply dropped, so a
candidate at the image border, or beside unknown range, pays nothing for the
range it cannot compare, and on stripe samplings intensity noise then picks
candidates many rows away. refsynth instead charges those offsets the *mean*
discrepancy of the offsets both neighbourhoods have (``missing_range="mean"``,
the default): the range term becomes

.. math:: \lambda \, \frac{\sum_{v \in S} G_v (R^a_v - R^b_v)^2}{\sum_{v \in S} G_v}
          \sum_{v \in A} G_v

with ``S`` the offsets both have and ``A`` those the target ``N_a`` has (in
the code the fraction carries a prior pseudo-offset of weight ε = 10⁻⁴ whose
discrepancy is the whole span, so that with ``S`` empty every offset the target
has costs ``λ`` per unit weight). It equals Eq. 2 when the candidate has range wherever the
target has. On the development rooms (seeds 100–102, 128×128) it lowered NP's
MAR on every sampling tried — grid 5/25: 0.221 → 0.144 m, x-stripes at 40 /
63 / 78 % unknown: 0.092 → 0.049, 0.327 → 0.079, 0.411 → 0.127 m. (A fixed
penalty per missing offset, tried first, helped on wide gaps but favoured
candidates with the same *pattern* of missing range — the pixel just above,
in the same gap — and so copied values down narrow gaps in long streaks.)
``missing_range="ignore"`` gives the literal Eq. 2.
:func:`neighbourhood_distance` computes either, one pair at a time; NP and BP
use :class:`refsynth.synthesis.nonparametric.PatchTable`, which computes the same for a
whole candidate set at once.

:func:`neighbourhood_distance` is the literal reading of Eq. 2, one pair at a
time. :mod:`refsynth.synthesis.nonparametric` evaluates the same sum for a whole candidate
set at once by expanding the squares into one matrix–vector product; the tests
check that the two agree.

References
----------
Torres-Méndez & Dudek (2008), §3.2.2, Eq. 2, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import numpy as np

from refsynth.synthesis.neighbourhood import gaussian_window

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
    missing_range: str = "ignore",
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
        The Gaussian window ``G``; default :func:`refsynth.synthesis.neighbourhood.gaussian_window`.
    missing_range : {"ignore", "mean"}
        ``"ignore"`` (default here): the literal Eq. 2. ``"mean"``: offsets
        where ``a`` has range and ``b`` has none cost the mean discrepancy of
        the shared ones (NP's and BP's default, see above). Not symmetric.

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
    shared = np.isfinite(dr)
    range_term = float(np.sum(g * np.where(shared, dr, 0.0) ** 2))
    if missing_range == "mean":
        target = float(np.sum(g[np.isfinite(ra)]))
        support = float(np.sum(g[shared]))
        prior = 1e-4  # as refsynth.synthesis.nonparametric._SUPPORT_PRIOR
        range_term = (range_term + prior) * target / (support + prior)
    elif missing_range != "ignore":
        raise ValueError(
            f"The parameter `missing_range` must be 'ignore' or 'mean', got {missing_range!r}"
        )
    return float(np.sum(g * intensity_term) + range_weight * range_term)
