"""A registered intensity image with its ground-truth range: what every scene loader returns (§3.3).

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3, doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Scene"]


@dataclass(frozen=True, eq=False)
class Scene:
    """A registered intensity image and its ground-truth range.

    Attributes
    ----------
    intensity : ndarray of shape (H, W) or (H, W, 3), float64
        Grey or colour, in [0, 1].
    range : ndarray of shape (H, W), float64
        Ground truth in ``units``; NaN where there is none.
    units : str
        ``"m"`` for the synthetic scenes, ``"disparity (px)"`` for
        Middlebury.
    name : str
        A short identifier for tables and file names.

    Notes
    -----
    The dataclass is frozen (its fields cannot be rebound) and compares by
    identity (``eq=False``: arrays have no single truth value). The arrays
    themselves are ordinary writeable arrays; refsynth never writes to
    them.

    Examples
    --------
    >>> truth = np.array([[2.0, np.nan, 2.5], [3.0, 3.0, 3.5]])
    >>> scene = Scene(intensity=np.full((2, 3), 0.5), range=truth, units="m", name="tiny")
    >>> scene.shape, int(scene.has_truth.sum())
    ((2, 3), 5)
    """

    intensity: np.ndarray
    range: np.ndarray
    units: str
    name: str

    def __post_init__(self) -> None:
        for field_name in ("intensity", "range"):
            value = getattr(self, field_name)
            if not isinstance(value, np.ndarray) or value.dtype != np.float64:
                got = value.dtype if isinstance(value, np.ndarray) else type(value).__name__
                raise TypeError(f"The field `{field_name}` must be a float64 array, got {got}")
        if self.range.ndim != 2:
            raise ValueError(f"The field `range` must be 2-D (H, W), got shape {self.range.shape}")
        if self.intensity.shape not in (self.range.shape, (*self.range.shape, 3)):
            raise ValueError(
                f"The field `intensity` must have shape {self.range.shape} or "
                f"{(*self.range.shape, 3)}, got {self.intensity.shape}"
            )
        for field_name in ("units", "name"):
            if not isinstance(getattr(self, field_name), str):
                raise TypeError(
                    f"The field `{field_name}` must be a str, "
                    f"got {type(getattr(self, field_name)).__name__}"
                )

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``."""
        return self.range.shape  # type: ignore[return-value]

    @property
    def has_truth(self) -> np.ndarray:
        """Boolean (H, W): ``True`` where the ground-truth range is finite."""
        return np.isfinite(self.range)
