"""A scan as spherical samples (r, θ, φ), ready for registration (§4, App. A.2, Eq. 19).

:func:`assemble` turns the slices of a scan into arrays with one row per
scanned slice and one column per encoder position: the range ``r`` in
metres (NaN: no return), the polar angle ``θ`` from the upward axis and the
pan angle ``φ`` (:mod:`refsynth.acquisition.geometry`), as written to
``scan.npz``. :func:`load_scan` reads a scan folder back as a :class:`Scan`:
a complete scan from ``scan.npz``, an interrupted one from its slice files.

References
----------
Torres-Méndez & Dudek (2008), §4 and Appendix A.2 (Eq. 19),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from refsynth.acquisition.geometry import FOCAL_PX, PAN_SLICES, pan_angle, polar_angle
from refsynth.acquisition.scan_folder import SliceRecord, read_slice
from refsynth.acquisition.slice_plan import ScanSettings

__all__ = ["assemble", "CameraImage", "Scan", "load_scan"]


def assemble(records: dict[int, SliceRecord], indices, settings: ScanSettings) -> dict:
    """The slices ``indices`` of ``records`` as the arrays of ``scan.npz``.

    Returns
    -------
    dict
        ``r`` (S, N) float64 metres, NaN where there was no return;
        ``theta``, ``phi`` (S, N) float64 radians; ``amplitude`` (S, N)
        uint8; ``pan_index`` (S,) int64, ascending; ``encoder`` (N,) int64
        (the GS window of ``settings``).
    """
    indices = np.asarray(sorted(int(i) for i in indices), dtype=np.int64)
    encoder = np.arange(settings.seq, settings.seq + settings.count, dtype=np.int64)
    if indices.size:
        range_mm = np.stack([records[int(i)].range_mm for i in indices])
        amplitude = np.stack([records[int(i)].amplitude for i in indices])
    else:
        range_mm = np.zeros((0, encoder.size), dtype=np.uint16)
        amplitude = np.zeros((0, encoder.size), dtype=np.uint8)
    r = np.where(range_mm > 0, range_mm / 1000.0, np.nan)
    theta, phi = np.broadcast_arrays(polar_angle(encoder)[None, :], pan_angle(indices)[:, None])
    return {"r": r, "theta": np.array(theta), "phi": np.array(phi),
            "amplitude": amplitude.astype(np.uint8), "pan_index": indices, "encoder": encoder}


@dataclass(frozen=True)
class CameraImage:
    """A picture of the scan.

    Attributes
    ----------
    path : Path
    pan_index : int
    pan_angle : float
        Radians (``φ`` of the optical axis).
    """

    path: Path
    pan_index: int
    pan_angle: float


@dataclass(frozen=True, eq=False)
class Scan:
    """A scan as spherical samples, ready for registration (App. A.2, Eq. 19).

    Attributes
    ----------
    r : ndarray of shape (S, N), float64
        Range in metres; NaN where there was no return. One row per scanned
        slice, one column per encoder position.
    theta : ndarray of shape (S, N), float64
        Polar angle from the upward axis, radians (Eq. 19's θ; π/2 is
        horizontal).
    phi : ndarray of shape (S, N), float64
        Pan (azimuth) angle, radians, positive to the right.
    amplitude : ndarray of shape (S, N), uint8
        0 where there was no return.
    pan_index : ndarray of shape (S,), int64
    encoder : ndarray of shape (N,), int64
    images : tuple of CameraImage
    settings : ScanSettings
    complete : bool
        Whether every planned slice is there.
    focal : float
        The camera's focal length in pixels (300).
    """

    r: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    amplitude: np.ndarray
    pan_index: np.ndarray
    encoder: np.ndarray
    images: tuple[CameraImage, ...]
    settings: ScanSettings
    complete: bool
    focal: float = FOCAL_PX

    @property
    def theta_axis(self) -> np.ndarray:
        """(N,) polar angles of the encoder positions (the columns of ``r``)."""
        return polar_angle(self.encoder)

    @property
    def phi_axis(self) -> np.ndarray:
        """(S,) pan angles of the scanned slices (the rows of ``r``)."""
        return pan_angle(self.pan_index)

    @property
    def known_slices(self) -> np.ndarray:
        """Boolean (500,): ``True`` for the scanned pan indices."""
        known = np.zeros(PAN_SLICES, dtype=bool)
        known[self.pan_index] = True
        return known

    def range_image(self) -> np.ndarray:
        """The partial range as an (N, 500) image: rows are encoder positions (top = up),
        columns pan indices; NaN where not scanned or no return."""
        image = np.full((self.encoder.size, PAN_SLICES), np.nan)
        image[:, self.pan_index] = self.r.T
        return image

    def points(self) -> np.ndarray:
        """The returns as (M, 3) points in metres (x right, y up, z forward)."""
        valid = np.isfinite(self.r)
        r, theta, phi = self.r[valid], self.theta[valid], self.phi[valid]
        return np.stack([r * np.sin(theta) * np.sin(phi), r * np.cos(theta),
                         r * np.sin(theta) * np.cos(phi)], axis=-1)


def load_scan(folder: str | os.PathLike) -> Scan:
    """Load a scan folder written by :func:`run_scan`.

    A complete scan is read from ``scan.npz``; an incomplete one is
    assembled from its slice files (``complete=False``).

    Raises
    ------
    FileNotFoundError
        If the folder holds no ``manifest.json``.
    ValueError
        If the manifest or a file is invalid.

    Examples
    --------
    >>> scan = load_scan("my-scan")            # doctest: +SKIP
    >>> scan.r.shape, scan.range_image().shape  # doctest: +SKIP
    ((200, 243), (243, 500))
    """
    folder = Path(folder)
    manifest_path = folder / "manifest.json"
    if not manifest_path.is_file():
        raise FileNotFoundError(f"No scan in '{folder}': no manifest.json")
    try:
        manifest = json.loads(manifest_path.read_text(encoding="utf-8"))
        settings = ScanSettings.from_dict(manifest["settings"])
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(f"'{manifest_path}' is not a valid scan manifest: {error}") from None
    npz = folder / "scan.npz"
    if manifest.get("complete") and npz.is_file():
        with np.load(npz, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
        complete = True
    else:
        records = {}
        for path in sorted((folder / "slices").glob("pan-*.slice")):
            record = read_slice(path)
            records[record.pan_index] = record
        arrays = assemble(records, list(records), settings)
        complete = False
    images = tuple(
        CameraImage(folder / entry["file"], int(entry["pan_index"]),
                    float(np.radians(entry["pan_angle_deg"])))
        for _, entry in sorted(manifest.get("images", {}).items(), key=lambda kv: int(kv[0]))
    )
    return Scan(r=arrays["r"], theta=arrays["theta"], phi=arrays["phi"],
                amplitude=arrays["amplitude"], pan_index=arrays["pan_index"],
                encoder=arrays["encoder"], images=images, settings=settings, complete=complete)
