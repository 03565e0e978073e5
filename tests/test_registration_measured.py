"""Nothing made up: after ``register`` only the columns of scanned slices are measured.

The scan goes onto the cylinder at the rig's pan step (``slice_step``; a scan folder's own), so
a pan position no slice was taken at stays NaN, whatever the strategy: ``stripes``, ``every``
n-th, ``distance``-driven. Stretching each slice across its gap (the smallest gap taken as the
step) marked nearly every column of an ``every --step 5`` scan measured though 20 % was
scanned.
"""

import re

import numpy as np
import pytest
from rig_fakes import fake_scan

from refsynth.acquisition import ScanSettings, load_scan
from refsynth.acquisition.geometry import PAN_CENTRE, PAN_SLICES, PAN_STEP_DEG
from refsynth.cli.main import main
from refsynth.io import read_array
from refsynth.registration import register, scan_to_cylinder

STRATEGIES = {"stripes": ScanSettings("stripes", 0.4), "every": ScanSettings("every", step=5),
              "distance": ScanSettings("distance", 0.3)}
#: Three of the ten views (pan 175, 225, 275): a registered range of about 40°, quick to build.
VIEWS = slice(3, 6)


@pytest.fixture(scope="module")
def scans(tmp_path_factory):
    base = tmp_path_factory.mktemp("measured")
    for name, settings in STRATEGIES.items():
        fake_scan(base / name, settings)
    return base


def scanned_columns(result, scan) -> np.ndarray:
    """Per column of the registered range: whether the pan position it looks at was scanned
    (the global warp's inverse at the crop's middle row, to the nearest pan position)."""
    row0, row1, col0, col1 = result.crop
    cols = np.arange(col0, col1, dtype=np.float64)
    phi, _ = result.warp.invert(cols, np.full_like(cols, (row0 + row1) / 2))
    index = np.round(np.degrees(phi) / PAN_STEP_DEG + PAN_CENTRE).astype(int)
    assert index.min() >= 0 and index.max() < PAN_SLICES
    return scan.known_slices[index]


@pytest.mark.parametrize("strategy", STRATEGIES)
def test_only_scanned_columns_are_measured(scans, strategy):
    scan = load_scan(scans / strategy)
    views = scan.images[VIEWS]
    images = [read_array(str(view.path)) for view in views]
    result = register(images, [view.pan_angle for view in views], scan.focal,
                      (scan.r, scan.theta, scan.phi), refine=False, slice_step=scan.slice_step)
    measured = np.isfinite(result.partial_range).any(axis=0)
    scanned = scanned_columns(result, scan)
    assert 0.15 < scanned.mean() < 0.45
    # the same columns, up to the rounding of a pan step (1.9 mosaic columns) onto the mosaic
    assert np.mean(measured == scanned) >= 0.97, (measured.mean(), scanned.mean())
    assert abs(measured.mean() - scanned.mean()) <= 0.02
    span = scan.pan_index[-1] - scan.pan_index[0]  # one column per pan position
    assert result.measured.range.shape[1] == span + 1


def test_without_the_rig_s_step_an_every_n_th_scan_is_stretched(scans):
    """What ``slice_step`` prevents: the smallest gap (5 pan steps) taken as the step."""
    scan = load_scan(scans / "every")
    views = scan.images[VIEWS]
    images = [read_array(str(view.path)) for view in views]
    result = register(images, [view.pan_angle for view in views], scan.focal,
                      (scan.r, scan.theta, scan.phi), refine=False)
    assert np.isfinite(result.partial_range).any(axis=0).mean() > 0.9
    assert result.measured is result.cylinder


def test_the_cli_reports_the_measured_columns_and_the_step(scans, tmp_path, capsys):
    folder = scans / "every"
    images = [str(view.path) for view in load_scan(folder).images[VIEWS]]
    status = main(["register", *images, "--scan", str(folder), "--no-refine",
                   "--out", str(tmp_path)])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    match = re.search(r"(\d+)% of the columns measured \(slice step 0\.36 degrees, from the "
                      r"scan's manifest\.json\)", captured.out)
    assert match, captured.out
    assert 17 <= int(match.group(1)) <= 23
    partial = np.load(tmp_path / "partial_range.npy")
    assert 0.17 <= np.isfinite(partial).any(axis=0).mean() <= 0.23
    # a bare NPZ: the smallest gap, said so
    scan = load_scan(folder)
    np.savez(tmp_path / "bare.npz", r=scan.r, theta=scan.theta, phi=scan.phi)
    bare = [*images, "--scan", str(tmp_path / "bare.npz"), "--focal", "300", "--start",
            f"{np.degrees(scan.images[VIEWS][0].pan_angle):.6f}", "--no-refine"]
    status = main(["register", *bare, "--out", str(tmp_path / "bare")])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "(slice step 1.8 degrees, from the smallest gap between the scan's slices" in (
        captured.out)
    status = main(["register", *bare, "--slice-step", "0", "--out", str(tmp_path / "bare")])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "--slice-step must be an angle" in err


def test_scan_to_cylinder_at_the_rig_s_step_leaves_unscanned_positions_empty():
    theta = np.arctan2(300.0, [10.0, 0.0, -10.0])
    r = np.array([[2.0, 2.0, 2.0], [3.0, 3.0, 3.0], [4.0, np.nan, 4.0]])
    step = np.radians(0.36)
    phi = np.array([0.0, 5 * step, 7 * step])  # pan 0, 5 and 7 of 8 positions
    image = scan_to_cylinder(r, theta, phi, 300.0, h_step=10.0, phi_step=step)
    assert image.range.shape == (3, 8)
    assert np.isfinite(image.range).any(axis=0).tolist() == [True, False, False, False, False,
                                                              True, False, True]
    np.testing.assert_array_equal(image.range[:, 5], [3.0, 3.0, 3.0])
    stretched = scan_to_cylinder(r, theta, phi, 300.0, h_step=10.0)  # the gap 2 steps
    assert stretched.range.shape == (3, 4)
    with pytest.raises(ValueError, match="`phi_step` must be at most the smallest gap"):
        scan_to_cylinder(r, theta, phi, 300.0, phi_step=3 * step)
    with pytest.raises(ValueError, match="`phi_step` must leave at most"):
        scan_to_cylinder(r, theta, phi, 300.0, phi_step=1e-12)
    with pytest.raises(ValueError, match="`slice_step`"):
        register([np.zeros((20, 20))], [0.0], 300.0, (r, theta, phi), slice_step=-1.0)
