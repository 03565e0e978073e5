"""Active scanning on the rig (§5): a sparse first pass, then rounds chosen by next_slices.

The scans are tiny (a 40-position slice window, rounds of 5 slices) and the rounds synthesize on
at most 12 rows of the rig's grid (``ROUND_ROWS``, patched) so that each round takes a second.
"""

import json

import numpy as np
import pytest
from rig_fakes import fake_scan

import refsynth.acquisition.active_scan as active_scan
from refsynth.acquisition import ScanSettings, load_scan
from refsynth.acquisition.manifest import check_rounds
from refsynth.acquisition.resume import read_slice_files
from refsynth.acquisition.slice_plan import active_first_pass, active_round_sizes
from refsynth.cli.scan import main

SETTINGS = ScanSettings("active", 0.04, first_fraction=0.02, per_round=0.01, count=40,
                        average=1)


@pytest.fixture(autouse=True)
def few_rows(monkeypatch):
    monkeypatch.setattr(active_scan, "ROUND_ROWS", 12)


def snapshot(folder):
    """Every slice's and picture's bytes, scan.npz, and the manifest's rounds and plan."""
    found = {"scan.npz": (folder / "scan.npz").read_bytes()}
    for sub in ("slices", "images"):
        found.update({f"{sub}/{p.name}": p.read_bytes() for p in (folder / sub).iterdir()})
    manifest = json.loads((folder / "manifest.json").read_text())
    return found, manifest["rounds"], manifest["plan"]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("active") / "scan"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(active_scan, "ROUND_ROWS", 12)
        summary, slices, pictures = fake_scan(folder, SETTINGS)
    return folder, summary, slices, pictures


def test_the_rounds_are_recorded_and_make_the_plan(uninterrupted):
    folder, summary, slices, pictures = uninterrupted
    assert summary.complete and summary.planned == 20 and slices == 20 and pictures == 10
    manifest = json.loads((folder / "manifest.json").read_text())
    rounds = manifest["rounds"]
    assert [len(r) for r in rounds] == active_round_sizes(SETTINGS) == [10, 5, 5]
    assert rounds[0] == active_first_pass(SETTINGS).tolist()
    union = [i for r in rounds for i in r]
    assert len(set(union)) == 20 and manifest["plan"] == sorted(union)
    assert sorted(int(k) for k in manifest["slices"]) == sorted(union)
    assert manifest["sessions"][0]["rounds_chosen"] == 2
    scan = load_scan(folder)
    assert scan.complete and scan.pan_index.tolist() == sorted(union)


def test_a_round_is_what_choose_round_gives_from_the_rounds_before(uninterrupted):
    """Replaying round 1 from the first pass's slice files gives the recorded round 1."""
    folder = uninterrupted[0]
    manifest = json.loads((folder / "manifest.json").read_text())
    records = {i: r for i, (r, _) in read_slice_files(folder)[0].items()}
    first = {i: records[i] for i in manifest["rounds"][0]}
    chosen = active_scan.choose_round(first, active_scan.read_pictures(folder), SETTINGS, 5)
    assert chosen == manifest["rounds"][1]
    assert not set(chosen) & set(manifest["rounds"][0])


@pytest.mark.parametrize("stop_at", [12, 15])  # inside round 1; after it, before round 2 is chosen
def test_a_scan_stopped_between_rounds_resumes_to_the_uninterrupted_scan(
        uninterrupted, tmp_path, stop_at):
    folder = tmp_path / "scan"

    def stop(done, total, index):
        if done == stop_at:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fake_scan(folder, SETTINGS, progress=stop)
    saved = json.loads((folder / "manifest.json").read_text())
    assert len(saved["slices"]) == stop_at and saved["plan"] is None
    assert len(saved["rounds"]) == 2  # round 1 recorded before it was scanned
    summary, slices, _ = fake_scan(folder, resume=True)
    assert summary.complete and summary.already == stop_at and slices == 20 - stop_at
    assert snapshot(folder) == snapshot(uninterrupted[0])
    assert not (folder / "rejected").exists()


def test_a_scan_whose_manifest_is_lost_is_rebuilt_by_replaying_its_rounds(
        uninterrupted, tmp_path):
    folder = tmp_path / "scan"

    def stop(done, total, index):
        if done == 17:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fake_scan(folder, SETTINGS, progress=stop)
    (folder / "manifest.json").unlink()
    summary, slices, _ = fake_scan(folder, SETTINGS, resume=True)
    assert summary.complete and summary.rebuilt == 17 and slices == 3
    assert snapshot(folder) == snapshot(uninterrupted[0])


@pytest.mark.parametrize(("change", "match"), [
    (lambda r: [r[0][1:], *r[1:]], "rounds\\[0\\] is not the settings' first pass"),
    (lambda r: [r[0], r[1][:4]], "rounds\\[1\\] has 4 slices where the settings give 5"),
    (lambda r: [r[0], [*r[0][:1], *r[1][1:]]], "rounds\\[1\\] scans pan 0 again"),
    (lambda r: [*r, r[2]], "4 rounds where the settings give 3"),
    (lambda r: [r[0], r[1][::-1]], "not strictly ascending"),
])
def test_the_manifest_check_refuses_rounds_that_are_not_the_settings(uninterrupted, change,
                                                                     match):
    manifest = json.loads((uninterrupted[0] / "manifest.json").read_text())
    with pytest.raises(ValueError, match=match):
        check_rounds(change(manifest["rounds"]), None, SETTINGS)
    check_rounds(manifest["rounds"], manifest["plan"], SETTINGS)
    with pytest.raises(ValueError, match="plan is not the union"):
        check_rounds(manifest["rounds"], manifest["plan"][1:], SETTINGS)
    with pytest.raises(ValueError, match="rounds is set for the strategy 'every'"):
        check_rounds([], None, ScanSettings("every", step=10))


def test_active_settings_are_checked():
    with pytest.raises(ValueError, match="`per_round`"):
        ScanSettings("active", per_round=0.001)
    with pytest.raises(ValueError, match="`first_fraction`"):
        ScanSettings("active", first_fraction=1.5)
    with pytest.raises(ValueError, match="needs the pictures"):
        ScanSettings("active", camera=False)
    assert active_round_sizes(ScanSettings("active", 0.1, first_fraction=0.3)) == [50]


def test_cli_active_scan_and_resume(tmp_path, capsys):
    pytest.importorskip("pty")
    out = tmp_path / "scan"
    arguments = ["scan", "--simulate", "--out", str(out), "--strategy", "active", "--fraction",
                 "0.03", "--first-fraction", "0.02", "--per-round", "0.01", "--average", "1",
                 "--quiet", "--timeout", "2"]
    assert main(arguments) == 0, capsys.readouterr().err
    assert "15/15 slices" in capsys.readouterr().out
    rounds = json.loads((out / "manifest.json").read_text())["rounds"]
    assert [len(r) for r in rounds] == [10, 5]
    assert main(["scan", "--simulate", "--out", str(out), "--resume", "--quiet"]) == 0
    assert "0 acquired now, 15 already on disk" in capsys.readouterr().out
    assert np.array_equal(load_scan(out).pan_index, sorted(i for r in rounds for i in r))


@pytest.mark.parametrize(("arguments", "match"), [
    (["--strategy", "stripes", "--per-round", "0.1"], "are for --strategy active"),
    (["--strategy", "active", "--no-camera"], "needs the pictures"),
    (["--strategy", "active", "--per-round", "0.001"], "`per_round`"),
])
def test_cli_active_errors_are_one_line(tmp_path, capsys, arguments, match):
    status = main(["scan", "--simulate", "--out", str(tmp_path / "x"), *arguments])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and match in err.replace("\\", ""), err


def test_the_grid_looks_each_direction_up_in_the_nearest_picture():
    """Picture k is its column index plus 1000·k: a grid column at a picture's own pan index
    sees that picture's centre column (63.5 of 128), and each column its nearest picture."""
    from refsynth.acquisition.geometry import IMAGE_HEIGHT, IMAGE_WIDTH, camera_indices

    cols = np.arange(IMAGE_WIDTH, dtype=np.float64)
    pictures = {int(c): np.tile(cols + 1000.0 * k, (IMAGE_HEIGHT, 1))
                for k, c in enumerate(camera_indices())}
    intensity, partial = active_scan.slice_grid({}, pictures, SETTINGS)
    assert intensity.shape == partial.shape == (10, 500) and np.isnan(partial).all()  # 40 / 4
    for k, c in enumerate(camera_indices()):
        assert intensity[:, c] == pytest.approx(1000.0 * k + 63.5, abs=1e-6)
    assert np.all(intensity[:, 0] // 1000 == 0) and np.all(intensity[:, 499] // 1000 == 9)
    # within one picture the columns run left to right with the pan (0.36° ≈ 1.9 px)
    assert np.all(np.diff(intensity[5, 180:220]) > 1.5)


def test_a_round_never_rescans_and_fills_up_when_the_grid_runs_out(uninterrupted):
    folder = uninterrupted[0]
    records = {i: r for i, (r, _) in read_slice_files(folder)[0].items()}
    pictures = active_scan.read_pictures(folder)
    chosen = active_scan.choose_round(records, pictures, SETTINGS, 7)
    assert len(set(chosen)) == 7 and not set(chosen) & set(records)
    # every slice but three scanned: the round gets exactly those three
    everything = dict.fromkeys(range(500), next(iter(records.values())))
    for index in (3, 250, 498):
        del everything[index]
    assert active_scan.choose_round(everything, pictures, SETTINGS, 3) == [3, 250, 498]
