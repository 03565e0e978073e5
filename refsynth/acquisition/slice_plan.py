"""Which slices a scan acquires: the sampling strategies on the pan axis (§3.1.1, Fig. 2).

The paper scans only part of the 500 slices of a pose, "approximately 30
to 50 % of total range" (§4), chosen by a sampling strategy; Fig. 2's rule
samples densely where the scene is far. :func:`plan_slices` gives the
strategies on the 500-slice pan axis:

- ``"all"``: every slice (the paper's complete scans, for ground truth);
- ``"every"``: every ``step``-th slice;
- ``"stripes"``: stripes of ``stripe_width`` consecutive slices with gaps
  sized for the requested fraction (:func:`refsynth.acquisition.sampling.x_stripes_for_fraction`);
- ``"distance"``: a coarse first pass (every ``coarse_step``-th slice,
  :func:`coarse_slices`), then :func:`refsynth.acquisition.sampling.distance_driven`
  on its per-slice median range, the union sized to the requested fraction;
- ``"active"`` (§5, active sensing): a sparse first pass of ``first_fraction``
  evenly spread slices (:func:`active_first_pass`), then rounds of
  ``per_round`` of the slices, each chosen from what the scan measured so far
  (:func:`refsynth.acquisition.next_slices` on the registered scan), until the
  requested fraction (:func:`active_round_sizes`).

:class:`ScanSettings` holds a strategy and the slice request (the GS
window); :func:`refsynth.acquisition.scan.run_scan` acquires the plan.

References
----------
Torres-Méndez & Dudek (2008), §3.1.1 (Fig. 2: the distance-driven heuristic) and
§4 (500 pan steps of 0.36° over 180°), doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from refsynth._checks import check_choice, check_int, check_real
from refsynth.acquisition.geometry import (
    ENCODER_POSITIONS,
    PAN_SLICES,
    SLICE_AVERAGE,
    SLICE_COUNT,
    SLICE_START,
)
from refsynth.acquisition.sampling import distance_driven, x_stripes_for_fraction

__all__ = ["STRATEGIES", "ScanSettings", "coarse_slices", "coarse_profile", "plan_slices",
           "active_first_pass", "active_round_sizes"]

#: The sampling strategies of :func:`plan_slices`.
STRATEGIES = ("all", "every", "stripes", "distance", "active")

# ----------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class ScanSettings:
    """How a scan chooses and requests its slices.

    Parameters
    ----------
    strategy : {"stripes", "every", "distance", "active", "all"}
        Which slices to scan (§3.3, Fig. 2, §5): stripes of ``stripe_width``
        slices, every ``step``-th slice, denser where a coarse pass finds
        the scene far, where the synthesis is least sure, or all 500.
    fraction : float, default 0.4
        Fraction of the 500 slices to scan, in (0, 1] (the paper: 0.3–0.5);
        ignored by ``"all"``, and by ``"every"`` when ``step`` is given.
    step : int, optional
        ``"every"``: scan every ``step``-th slice; default ``1 / fraction``
        rounded half up (0.4 → every 3rd).
    stripe_width : int, default 4
        ``"stripes"``: consecutive slices per stripe (the ``rw`` of §3.3).
    coarse_step : int, default 10
        ``"distance"``: the first pass scans every ``coarse_step``-th slice.
    first_fraction : float, default 0.2
        ``"active"``: the first pass scans this fraction of the 500 slices,
        evenly spread (at most ``fraction``).
    per_round : float, default 0.05
        ``"active"``: each later round scans this fraction of the 500 slices
        (the last one what is left to reach ``fraction``).
    seq, count, average : int
        The GS window: first encoder position, positions per slice, samples
        averaged (defaults: 379, 243 and 10, see :mod:`refsynth.acquisition.geometry`).
    camera : bool, default True
        Take the ten pictures (``C`` at pan indices 25, 75, …, 475).

    Examples
    --------
    >>> settings = ScanSettings("every", step=100, count=8)
    >>> settings.fraction, settings.average, plan_slices(settings).tolist()
    (0.4, 10, [0, 100, 200, 300, 400])
    """

    strategy: str = "stripes"
    fraction: float = 0.4
    step: int | None = None
    stripe_width: int = 4
    coarse_step: int = 10
    first_fraction: float = 0.2
    per_round: float = 0.05
    seq: int = SLICE_START
    count: int = SLICE_COUNT
    average: int = SLICE_AVERAGE
    camera: bool = True

    def __post_init__(self) -> None:
        check_choice("strategy", self.strategy, STRATEGIES)
        fraction = check_real("fraction", self.fraction, positive=True, maximum=1.0)
        if not isinstance(self.fraction, (int, float)):  # a numpy scalar: JSON needs a float
            object.__setattr__(self, "fraction", fraction)
        for name in ("first_fraction", "per_round"):
            value = check_real(name, getattr(self, name), positive=True, maximum=1.0)
            if value * PAN_SLICES < 1:
                raise ValueError(f"The parameter `{name}` must cover at least one of the "
                                 f"{PAN_SLICES} slices (>= {1 / PAN_SLICES:g}), got {value:g}")
            object.__setattr__(self, name, float(value))
        # the integers are stored as Python ints (the manifest is JSON)
        for name, low, high in (("stripe_width", 1, PAN_SLICES), ("coarse_step", 2, PAN_SLICES),
                                ("seq", 0, ENCODER_POSITIONS - 1), ("count", 1, ENCODER_POSITIONS),
                                ("average", 1, 99)):
            value = check_int(name, getattr(self, name), minimum=low, maximum=high)
            object.__setattr__(self, name, value)
        if self.step is not None:
            step = check_int("step", self.step, minimum=1, maximum=PAN_SLICES)
            object.__setattr__(self, "step", step)
        if self.seq + self.count > ENCODER_POSITIONS:
            raise ValueError(f"The parameters `seq` + `count` must be <= {ENCODER_POSITIONS}, "
                             f"got {self.seq + self.count}")
        if not isinstance(self.camera, bool):
            raise TypeError(f"The parameter `camera` must be a bool, got {self.camera!r}")
        if self.strategy == "active" and not self.camera:
            raise ValueError("The strategy `active` needs the pictures: `camera` must be True")

    def as_dict(self) -> dict:
        """The settings as a JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, values: dict) -> ScanSettings:
        """Inverse of :meth:`as_dict` (unknown keys are an error)."""
        known = {f.name for f in fields(cls)}
        unknown = set(values) - known
        if unknown:
            raise ValueError(f"unknown scan settings {sorted(unknown)}")
        return cls(**values)


def coarse_slices(settings: ScanSettings) -> np.ndarray:
    """The first pass of the ``"distance"`` strategy: every ``coarse_step``-th slice from 0."""
    return np.arange(0, PAN_SLICES, settings.coarse_step)


def coarse_profile(range_mm: dict, indices) -> np.ndarray:
    """The coarse pass as a range profile: the median range (m) of each coarse slice's returns.

    Parameters
    ----------
    range_mm : dict of int to ndarray
        Each coarse slice's ranges in mm (0 = no return), by pan index.
    indices : array_like of int
        The coarse slices (:func:`coarse_slices`).

    Returns
    -------
    ndarray of shape (500,)
        NaN where no coarse slice was taken or it saw no return: what
        :func:`plan_slices` takes as ``coarse_range``.

    Raises
    ------
    ValueError
        If no coarse slice saw a return.
    """
    profile = np.full(PAN_SLICES, np.nan)
    for index in indices:
        values = range_mm[int(index)]
        returned = values[values > 0]
        if returned.size:
            profile[index] = np.median(returned) / 1000.0
    if not np.isfinite(profile).any():
        raise ValueError("the coarse pass saw no return at all: cannot plan by distance")
    return profile


def active_first_pass(settings: ScanSettings) -> np.ndarray:
    """The first pass of the ``"active"`` strategy: ``min(first_fraction, fraction) · 500``
    slices (rounded) evenly spread from 0 to 499, ascending.

    Examples
    --------
    >>> active_first_pass(ScanSettings("active", 0.4, first_fraction=0.01)).tolist()
    [0, 125, 250, 374, 499]
    """
    count = max(1, int(round(min(settings.first_fraction, settings.fraction) * PAN_SLICES)))
    return np.unique(np.round(np.linspace(0, PAN_SLICES - 1, count)).astype(np.int64))


def active_round_sizes(settings: ScanSettings) -> list[int]:
    """The number of slices each round of the ``"active"`` strategy scans (§5).

    The first pass (:func:`active_first_pass`), then ``per_round · 500`` (rounded) per
    round until ``fraction · 500`` (rounded), the last round what is left.

    Examples
    --------
    >>> active_round_sizes(ScanSettings("active", 0.3))
    [100, 25, 25]
    >>> active_round_sizes(ScanSettings("active", 0.27, per_round=0.04))
    [100, 20, 15]
    """
    first = len(active_first_pass(settings))
    target = max(first, int(round(settings.fraction * PAN_SLICES)))
    step = max(1, int(round(settings.per_round * PAN_SLICES)))
    sizes, done = [first], first
    while done < target:
        sizes.append(min(step, target - done))
        done += sizes[-1]
    return sizes


def plan_slices(settings: ScanSettings, coarse_range: np.ndarray | None = None) -> np.ndarray:
    """The pan indices a scan acquires, ascending (§3.1.1, Fig. 2).

    Parameters
    ----------
    settings : ScanSettings
        The strategy and its parameters.
    coarse_range : ndarray of shape (500,), optional
        ``"distance"`` only (and required there): a representative range
        (metres) per slice, NaN where the first pass did not scan; in
        between it is interpolated (:func:`refsynth.acquisition.sampling.column_range_profile`).

    Returns
    -------
    ndarray of int
        Sorted, unique pan indices in ``0 … 499``. For ``"distance"`` it
        contains :func:`coarse_slices`, and its size is the one closest to
        ``fraction · 500`` that the rule reaches. For ``"active"`` it is the
        first pass (:func:`active_first_pass`): the later rounds depend on what
        the scan measures (:func:`refsynth.acquisition.scan.run_scan`).

    Examples
    --------
    >>> plan = plan_slices(ScanSettings("stripes", 0.4))
    >>> len(plan), plan[:6].tolist()
    (200, [0, 1, 2, 3, 10, 11])
    >>> plan_slices(ScanSettings("every", step=100)).tolist()
    [0, 100, 200, 300, 400]
    """
    if not isinstance(settings, ScanSettings):
        raise TypeError(f"The parameter `settings` must be a ScanSettings, got {settings!r}")
    if settings.strategy == "active":
        return active_first_pass(settings)
    if settings.strategy == "all" or (settings.strategy != "every" and settings.fraction >= 1.0):
        return np.arange(PAN_SLICES)
    if settings.strategy == "every":
        step = settings.step or max(1, int(1.0 / settings.fraction + 0.5))
        return np.arange(0, PAN_SLICES, step)
    if settings.strategy == "stripes":
        mask = x_stripes_for_fraction((1, PAN_SLICES), 1.0 - settings.fraction,
                                      rw=settings.stripe_width)
        return np.flatnonzero(mask[0])
    # distance-driven (Fig. 2), laid out around the coarse pass
    if coarse_range is None:
        raise ValueError("The `distance` strategy needs `coarse_range` from a first pass")
    profile = np.asarray(coarse_range, dtype=np.float64)
    if profile.shape != (PAN_SLICES,):
        raise ValueError(f"The parameter `coarse_range` must have shape ({PAN_SLICES},), "
                         f"got {profile.shape}")
    coarse = np.zeros(PAN_SLICES, dtype=bool)
    coarse[coarse_slices(settings)] = True
    target = settings.fraction * PAN_SLICES
    if coarse.sum() >= target:
        return np.flatnonzero(coarse)

    def union(known_fraction: float) -> np.ndarray:
        return coarse | distance_driven(profile, known_fraction, height=1)[0]

    # the union grows with the rule's own fraction: bisect for the size closest to the target
    low, high = 1.0 / PAN_SLICES, min(settings.fraction, 1.0 - 1.0 / PAN_SLICES)
    best = union(high)
    for _ in range(30):
        middle = 0.5 * (low + high)
        candidate = union(middle)
        if abs(int(candidate.sum()) - target) < abs(int(best.sum()) - target):
            best = candidate
        if candidate.sum() < target:
            low = middle
        else:
            high = middle
    return np.flatnonzero(best)
