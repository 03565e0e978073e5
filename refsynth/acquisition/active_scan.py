"""One round of active scanning on the rig: where the scan should look next (§5, §4).

The ``"active"`` strategy of :func:`refsynth.acquisition.run_scan` scans a
sparse first pass, then rounds: the slices measured so far and the pictures
are put on one grid, the range is synthesized there, and
:func:`refsynth.acquisition.next_slices` chooses the slices of the next round.

The grid is the rig's own: one column per pan position (500, ``φ``), one row
per encoder position of the slice window (``θ``), every ``k``-th so that at
most :data:`ROUND_ROWS` rows are used. The range is the slices' (metres, NaN
where no slice was taken or there was no return); the intensity is each
direction ``(θ, φ)`` looked up in the picture whose axis is nearest in pan, by
the camera model the manifest records (a pinhole at the laser's centre,
:func:`refsynth.acquisition.geometry.camera_rays`). This is the registration
the rig's nominal geometry gives — the start of Appendix A's registration,
without its refinement: enough to say where to look, and the same for every
round, so that a round depends only on the slices it is given.

References
----------
Torres-Méndez & Dudek (2008), §5 (active sensing), §4 (the rig: 500 slices
over 180°, a picture every 18°) and App. A (registration),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from refsynth._checks import grey
from refsynth.acquisition.active import next_slices
from refsynth.acquisition.geometry import (
    CAMERA_EVERY,
    CAMERA_FIRST,
    FOCAL_PX,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    PAN_SLICES,
    camera_indices,
    directions,
    image_name,
    pan_angle,
    polar_angle,
)
from refsynth.acquisition.scan_folder import SliceRecord
from refsynth.acquisition.slice_plan import ScanSettings
from refsynth.io import read_array
from refsynth.scenes.portable import portable_cos, portable_sin

__all__ = ["ROUND_ROWS", "ROUND_METHOD", "slice_grid", "choose_round"]

#: The most rows of the grid a round synthesizes on (every k-th encoder position).
ROUND_ROWS = 60
#: The synthesis (its range and uncertainty map) that chooses a round (with seed 0).
ROUND_METHOD = "bp"


def _bilinear(image: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``image`` (H, W) at fractional ``(rows, cols)``, clamped to the picture."""
    rows = np.clip(rows, 0.0, image.shape[0] - 1.0)
    cols = np.clip(cols, 0.0, image.shape[1] - 1.0)
    r0 = np.minimum(np.floor(rows).astype(np.int64), image.shape[0] - 2)
    c0 = np.minimum(np.floor(cols).astype(np.int64), image.shape[1] - 2)
    fr, fc = rows - r0, cols - c0
    top = image[r0, c0] * (1 - fc) + image[r0, c0 + 1] * fc
    bottom = image[r0 + 1, c0] * (1 - fc) + image[r0 + 1, c0 + 1] * fc
    return top * (1 - fr) + bottom * fr


def slice_grid(records: dict[int, SliceRecord], pictures: dict[int, np.ndarray],
               settings: ScanSettings) -> tuple[np.ndarray, np.ndarray]:
    """The scan so far and its pictures on the rig's grid: ``(intensity, partial_range)``.

    Parameters
    ----------
    records : dict of int to SliceRecord
        The slices measured, by pan index.
    pictures : dict of int to ndarray
        The ten pictures by pan index (25, 75, …, 475), (H, W) or (H, W, 3).
    settings : ScanSettings
        The scan's slice window (``seq``, ``count``).

    Returns
    -------
    intensity : ndarray of shape (R, 500), float64
        The grey level seen along each grid direction (nearest picture in pan).
    partial_range : ndarray of shape (R, 500), float64
        Metres; NaN where no slice was taken, or it saw no return.
    """
    step = max(1, -(-settings.count // ROUND_ROWS))  # ceil: at most ROUND_ROWS rows
    encoder = np.arange(settings.seq, settings.seq + settings.count, step)
    theta = polar_angle(encoder)
    phi = pan_angle(np.arange(PAN_SLICES))
    rays = directions(theta[:, None], phi[None, :])  # (R, 500, 3)
    nearest = np.clip(np.round((np.arange(PAN_SLICES) - CAMERA_FIRST) / CAMERA_EVERY), 0,
                      len(camera_indices()) - 1).astype(np.int64)
    intensity = np.zeros((encoder.size, PAN_SLICES))
    for number, index in enumerate(camera_indices()):
        columns = np.flatnonzero(nearest == number)
        picture = np.asarray(pictures[int(index)], dtype=np.float64)
        if picture.ndim == 3:
            picture = grey(picture)
        cos, sin = portable_cos(pan_angle(index)), portable_sin(pan_angle(index))
        ray = rays[:, columns]
        x = cos * ray[..., 0] - sin * ray[..., 2]  # the ray in the picture's camera frame
        z = sin * ray[..., 0] + cos * ray[..., 2]
        col = FOCAL_PX * x / z + IMAGE_WIDTH / 2 - 0.5
        row = IMAGE_HEIGHT / 2 - 0.5 - FOCAL_PX * ray[..., 1] / z
        intensity[:, columns] = _bilinear(picture, row, col)
    partial = np.full((encoder.size, PAN_SLICES), np.nan)
    for index, record in records.items():
        values = record.range_mm[::step].astype(np.float64)
        partial[:, int(index)] = np.where(values > 0, values / 1000.0, np.nan)
    return intensity, partial


def read_pictures(folder: str | os.PathLike) -> dict[int, np.ndarray]:
    """The ten pictures of the scan in ``folder`` (``images/pan-<i>.png``), by pan index."""
    folder = Path(folder)
    return {int(i): read_array(str(folder / "images" / image_name(int(i))))
            for i in camera_indices()}


def choose_round(records: dict[int, SliceRecord], pictures: dict[int, np.ndarray],
                 settings: ScanSettings, n: int) -> list[int]:
    """The ``n`` slices a round of the ``"active"`` strategy scans, ascending (§5).

    :func:`slice_grid`, then :func:`refsynth.acquisition.next_slices` with
    :data:`ROUND_METHOD` and seed 0. A slice measured but without any return on
    the grid's rows looks unmeasured there: it is never chosen again. If the
    grid has fewer than ``n`` columns left, the rest are the unscanned slices
    farthest from any scanned one.

    Parameters
    ----------
    records : dict of int to SliceRecord
        Exactly the slices of the rounds so far (the round depends on nothing else).
    pictures : dict of int to ndarray
        See :func:`slice_grid`.
    settings : ScanSettings
    n : int
        Slices to choose, at least 1.

    Returns
    -------
    list of int
        ``n`` distinct unscanned pan indices, ascending.
    """
    intensity, partial = slice_grid(records, pictures, settings)
    scanned = np.zeros(PAN_SLICES, dtype=bool)
    scanned[[int(i) for i in records]] = True
    open_columns = int(np.count_nonzero(~np.isfinite(partial).any(axis=0)))
    silent = open_columns - int(np.count_nonzero(~scanned))  # scanned, but no return here
    picks: list[int] = []
    if open_columns and np.isfinite(partial).any():
        asked = min(n + silent, open_columns)
        found = next_slices(intensity, partial, asked, method=ROUND_METHOD, seed=0)
        picks = [int(i) for i in found if not scanned[i]][:n]
    while len(picks) < n:  # too few columns left on the grid: the farthest from a scan
        taken = scanned.copy()
        taken[picks] = True
        where = np.flatnonzero(taken)
        distance = np.min(np.abs(np.arange(PAN_SLICES)[:, None] - where[None, :]), axis=1)
        distance[taken] = -1
        picks.append(int(np.argmax(distance)))
    return sorted(picks)
