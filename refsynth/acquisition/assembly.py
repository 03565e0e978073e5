"""A scan as spherical samples (r, θ, φ), ready for registration (§4, App. A.2, Eq. 19).

:func:`assemble` turns the slices of a scan into arrays with one row per
scanned slice and one column per encoder position: the range ``r`` in
metres (NaN: no return), the polar angle ``θ`` from the upward axis and the
pan angle ``φ`` (:mod:`refsynth.acquisition.geometry`), as written to
``scan.npz``. :func:`load_scan` reads a scan folder back as a :class:`Scan`:
a complete scan from ``scan.npz``, an interrupted one from its slice files;
it trusts nothing unchecked — the manifest in full
(:func:`refsynth.acquisition.manifest.read_manifest`), ``scan.npz`` against
the plan and the geometry, each slice file against the CRC the manifest
recorded, each picture for being whole.

References
----------
Torres-Méndez & Dudek (2008), §4 and Appendix A.2 (Eq. 19),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from refsynth.acquisition.geometry import (
    ENCODER_POSITIONS,
    FOCAL_PX,
    PAN_SLICES,
    PAN_STEP_DEG,
    pan_angle,
    polar_angle,
)
from refsynth.acquisition.manifest import check_plan, read_manifest
from refsynth.acquisition.scan_folder import (
    SliceRecord,
    parse_slice,
    png_is_complete,
    read_npz,
    slice_bytes,
    slice_crc,
    slice_name,
)
from refsynth.acquisition.slice_plan import (
    ScanSettings,
    coarse_profile,
    coarse_slices,
    plan_slices,
)

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
    """A picture of the scan: one of the views the mosaic is built from (§4, App. A.1).

    Attributes
    ----------
    path : Path
        The PNG file (``images/pan-<i>.png``).
    pan_index : int
        The pan position it was taken at (25, 75, …, 475).
    pan_angle : float
        Radians (``φ`` of the optical axis).

    Examples
    --------
    >>> from refsynth.acquisition.geometry import pan_angle
    >>> image = CameraImage(Path("images/pan-0025.png"), 25, float(pan_angle(25)))
    >>> image.path.name, image.pan_index, round(image.pan_angle, 4)
    ('pan-0025.png', 25, -1.4137)
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

    Examples
    --------
    >>> import tempfile
    >>> from refsynth.acquisition import ScanSettings, simulate_scan
    >>> settings = ScanSettings("every", step=100, count=8, camera=False)
    >>> summary = simulate_scan(tempfile.mkdtemp(), settings)
    >>> scan = load_scan(summary.folder)
    >>> scan.r.shape, scan.pan_index.tolist(), scan.complete
    ((5, 8), [0, 100, 200, 300, 400], True)
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
    def slice_step(self) -> float:
        """The rig's pan step between two adjacent slice positions, radians (0.36°, §4).

        What :func:`refsynth.registration.register` needs (``slice_step``) to
        leave the positions no slice was taken at unmeasured.
        """
        return float(np.radians(PAN_STEP_DEG))

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


_NPZ_ARRAYS = ("r", "theta", "phi", "amplitude", "pan_index", "encoder")
#: The largest array of a scan: 500 slices of 2000 float64 samples, and a header.
_NPZ_MEMBER_BYTES = PAN_SLICES * ENCODER_POSITIONS * 8 + 4096


def _read_assembled(path: Path, plan: list[int], settings: ScanSettings) -> dict:
    """The arrays of ``scan.npz``, checked against the plan and the geometry."""
    try:
        arrays = read_npz(path, _NPZ_ARRAYS, _NPZ_MEMBER_BYTES)
    except ValueError as error:
        raise ValueError(f"{error}: resume the scan (scan --resume) to assemble it again from "
                         "its slice files") from None
    expected = assemble({}, [], settings)  # the dtypes, and the encoder axis
    shape = (len(plan), settings.count)
    problem = None
    for name, array in arrays.items():
        want = (len(plan),) if name == "pan_index" else (
            (settings.count,) if name == "encoder" else shape)
        if array.dtype != expected[name].dtype or array.shape != want:
            problem = f"{name} is {array.dtype} {array.shape}, not {expected[name].dtype} {want}"
            break
    else:
        theta, phi = np.broadcast_arrays(polar_angle(expected["encoder"])[None, :],
                                         pan_angle(np.asarray(plan, dtype=np.int64))[:, None])
        r = arrays["r"]
        if arrays["pan_index"].tolist() != plan:
            problem = "pan_index is not the plan of manifest.json"
        elif not np.array_equal(arrays["encoder"], expected["encoder"]):
            problem = "encoder is not the GS window of the settings"
        elif not (np.array_equal(arrays["theta"], theta) and np.array_equal(arrays["phi"], phi)):
            problem = "theta or phi is not the rig's geometry"
        elif not np.all(np.isnan(r) | ((r > 0) & (r < 65.536))):
            problem = "r holds values no slice can give (ranges are 0.001-65.535 m, or NaN)"
    if problem:
        raise ValueError(f"'{path}' does not hold the scan of its manifest.json: {problem} "
                         "(resume the scan to assemble it again from its slice files)")
    return arrays


def _read_slices(folder: Path, manifest: dict, settings: ScanSettings, indices) -> dict:
    """The slice files ``indices`` that are on disk, each checked (own CRC, name, GS window,
    the CRC the manifest recorded)."""
    records = {}
    for index in indices:
        path = folder / "slices" / slice_name(index)
        if path.is_symlink():
            raise ValueError(f"'{path}' is a symbolic link, not a slice of this scan (resume the "
                             "scan to set it aside and acquire it again)")
        if not path.is_file():
            continue
        data = path.read_bytes()
        record = parse_slice(data, path)
        entry = manifest["slices"].get(str(index))
        if record.pan_index != index or slice_bytes(record) != data:
            problem = f"its header says pan {record.pan_index}" if record.pan_index != index \
                else "its bytes are not those of a slice file of its data"
        elif (record.seq, record.count, record.average) != (
            settings.seq, settings.count, settings.average
        ):
            problem = "it was taken with another GS window than the settings'"
        elif entry is not None and entry["crc"] != slice_crc(data):
            problem = f"its CRC {slice_crc(data)} is not the {entry['crc']} manifest.json records"
        else:
            records[index] = record
            continue
        raise ValueError(f"'{path}' is not a slice of this scan: {problem} (resume the scan "
                         "to set it aside and acquire it again)")
    return records


def load_scan(folder: str | os.PathLike) -> Scan:
    """Load a scan folder written by :func:`run_scan` (§3.1.1, §4).

    A complete scan is read from ``scan.npz``; an incomplete one is
    assembled from the slice files of its plan that are on disk
    (``complete`` then says whether every planned slice is there). Nothing
    is trusted unchecked: the manifest in full, ``scan.npz`` against the
    plan and the geometry, each slice file against the CRC the manifest
    recorded, each picture (when its file is there) for being a whole PNG.

    Parameters
    ----------
    folder : str or Path
        The scan folder (``manifest.json``, ``slices/``, ``images/``, and
        ``scan.npz`` once complete).

    Returns
    -------
    Scan
        The samples of every slice on disk, in pan order.

    Raises
    ------
    FileNotFoundError
        If the folder holds no ``manifest.json``.
    ValueError
        If the manifest, ``scan.npz``, a slice file or a picture is invalid
        (one line naming the file).

    Examples
    --------
    >>> scan = load_scan("my-scan")            # doctest: +SKIP
    >>> scan.r.shape, scan.range_image().shape  # doctest: +SKIP
    ((200, 243), (243, 500))
    """
    folder = Path(folder)
    manifest_path = folder / "manifest.json"
    if manifest_path.is_symlink():
        raise ValueError(f"'{manifest_path}' is a symbolic link, not a scan's manifest")
    if not manifest_path.is_file():
        raise FileNotFoundError(f"No scan in '{folder}': no manifest.json")
    manifest, settings = read_manifest(manifest_path)
    plan, coarse = manifest["plan"], manifest.get("coarse")
    if plan is None and settings.strategy != "distance":
        plan = plan_slices(settings).tolist()
    if plan is not None and settings.strategy == "distance":  # the plan its coarse pass gives
        records = _read_slices(folder, manifest, settings, coarse)
        if len(records) == len(coarse):
            try:
                profile = coarse_profile({i: r.range_mm for i, r in records.items()}, coarse)
                check_plan(plan, coarse, settings, profile)
            except ValueError as error:
                raise ValueError(f"'{manifest_path}' is not a valid scan manifest: "
                                 f"{error}") from None
    npz = folder / "scan.npz"
    if manifest["complete"] and npz.is_file():
        arrays = _read_assembled(npz, plan, settings)
        complete = True
    else:
        wanted = plan if plan is not None else (coarse or coarse_slices(settings).tolist())
        records = _read_slices(folder, manifest, settings, wanted)
        arrays = assemble(records, list(records), settings)
        complete = plan is not None and len(records) == len(plan)
    images = []
    for _, entry in sorted(manifest["images"].items(), key=lambda kv: int(kv[0])):
        path = folder / entry["file"]  # images/pan-<i>.png: the manifest's check saw to it
        if path.exists() and not png_is_complete(path):
            raise ValueError(f"'{path}' is not a whole PNG picture (resume the scan to take it "
                             "again)")
        images.append(CameraImage(path, int(entry["pan_index"]),
                                  float(np.radians(entry["pan_angle_deg"]))))
    return Scan(r=arrays["r"], theta=arrays["theta"], phi=arrays["phi"],
                amplitude=arrays["amplitude"], pan_index=arrays["pan_index"],
                encoder=arrays["encoder"], images=tuple(images), settings=settings,
                complete=complete, focal=float(manifest.get("camera", {}).get("focal_px",
                                                                              FOCAL_PX)))
