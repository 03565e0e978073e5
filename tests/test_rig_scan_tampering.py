"""Scans that never lose a slice: resume and load_scan against damaged and tampered folders.

A folder whose manifest.json is gone, manifests of the wrong
shape or contradicting their settings, slice files copied over one another,
truncated pictures, paths out of the folder, a damaged scan.npz. Every test
snapshots the slice files, tampers, resumes or loads, and checks that every
acquired slice file is still there byte for byte (in slices/, or set aside in
rejected/ when it was the file tampered with).
"""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rig_fakes import RIG as _RIG
from rig_fakes import fake_scan

from refsynth.acquisition import ScanSettings, load_scan, plan_slices, read_slice
from refsynth.acquisition.manifest import check_manifest, read_manifest
from refsynth.acquisition.scan_folder import SliceRecord, slice_bytes, slice_crc, write_new
from refsynth.cli.scan import main as scan_main

# ----------------------------------------------------------------------------- folders

EVERY_25 = ScanSettings("every", step=25)
DISTANCE = ScanSettings("distance", 0.3, camera=False)


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """A complete scan (every 25th slice, 10 pictures) and an interrupted one."""
    base = tmp_path_factory.mktemp("pristine")
    fake_scan(base / "complete", EVERY_25)
    interrupted = base / "interrupted"
    shutil.copytree(base / "complete", interrupted)
    for path in sorted((interrupted / "slices").iterdir())[10:]:
        path.unlink()
    (interrupted / "scan.npz").unlink()
    manifest = json.loads((interrupted / "manifest.json").read_text())
    manifest["slices"] = {k: v for k, v in manifest["slices"].items() if int(k) < 250}
    manifest["complete"] = False
    (interrupted / "manifest.json").write_text(json.dumps(manifest))
    fake_scan(base / "distance", DISTANCE)
    return base


def copy(pristine: Path, name: str, tmp_path: Path) -> Path:
    target = tmp_path / name
    shutil.copytree(pristine / name, target)
    return target


def slice_snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((folder / "slices").iterdir())
            if p.is_file() and not p.name.startswith(".")}


def every_file(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def assert_no_slice_lost(folder: Path, before: dict[str, bytes], tampered=()) -> None:
    """Every slice file of ``before`` is in slices/ byte for byte; a tampered one may instead be
    in rejected/ byte for byte (set aside, not lost)."""
    rejected = {p.name.split(".slice")[0] + ".slice": p.read_bytes()
                for p in (folder / "rejected").iterdir()} if (folder / "rejected").is_dir() else {}
    for name, data in before.items():
        path = folder / "slices" / name
        if name in tampered:
            kept = path.is_file() and path.read_bytes() == data
            assert kept or rejected.get(name) == data, name
        else:
            assert path.is_file() and path.read_bytes() == data, name


def edit_manifest(folder: Path, change) -> None:
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text())
    change(manifest)
    path.write_text(json.dumps(manifest))


# ----------------------------------------------------------------------------- item 1: no manifest


def test_resume_without_a_manifest_and_without_settings_refuses_and_touches_nothing(
        pristine, tmp_path):
    folder = copy(pristine, "complete", tmp_path)
    (folder / "manifest.json").unlink()
    (folder / "scan.npz").unlink()
    before = every_file(folder)
    with pytest.raises(ValueError, match="has no manifest.json, and its 20 valid slice files "
                       r"\(pan 0-475; seq 379, count 243, average 10\) do not record"):
        fake_scan(folder, resume=True)
    assert every_file(folder) == before
    with pytest.raises(ValueError, match="holds slice files but no manifest.json"):
        fake_scan(folder, EVERY_25)  # a new scan there: refused too
    assert every_file(folder) == before


def test_resume_without_a_manifest_rebuilds_it_from_the_slice_files(pristine, tmp_path):
    folder = copy(pristine, "interrupted", tmp_path)
    before = slice_snapshot(folder)
    (folder / "manifest.json").unlink()
    summary, slices, pictures = fake_scan(folder, EVERY_25, resume=True)
    assert summary.complete and summary.rebuilt == 10 and summary.already == 10
    assert summary.acquired == 10 and slices == 10 and pictures == 0  # the pictures are there
    assert "manifest.json rebuilt from 10 slice files" in str(summary)
    assert_no_slice_lost(folder, before)
    assert slice_snapshot(folder) == slice_snapshot(pristine / "complete")
    assert (folder / "scan.npz").read_bytes() == (pristine / "complete" / "scan.npz").read_bytes()
    manifest, _ = read_manifest(folder / "manifest.json")
    assert manifest["sessions"][0]["rebuilt_from"] == 10 and len(manifest["images"]) == 10
    scan, reference = load_scan(folder), load_scan(pristine / "complete")
    assert [im.pan_angle for im in scan.images] == [im.pan_angle for im in reference.images]


@pytest.mark.parametrize(
    ("settings", "match"),
    [(ScanSettings("every", step=25, average=5), "were not taken with seq 379, count 243, "
      "average 5"),
     (ScanSettings("every", step=50), r"10 of its 20 valid slice files .* are not in their plan "
      r"\(pan 25, 75, 125, 175, 225, \.\.\.\)"),
     (ScanSettings("stripes", 0.4), "are not in their plan")],
)
def test_resume_without_a_manifest_refuses_settings_the_slices_do_not_belong_to(
        pristine, tmp_path, settings, match):
    folder = copy(pristine, "complete", tmp_path)
    (folder / "manifest.json").unlink()
    before = every_file(folder)
    with pytest.raises(ValueError, match=match):
        fake_scan(folder, settings, resume=True)
    assert every_file(folder) == before


def test_distance_resume_without_a_manifest_checks_the_plan_it_makes(pristine, tmp_path):
    folder = copy(pristine, "distance", tmp_path)
    (folder / "manifest.json").unlink()
    before = every_file(folder)
    with pytest.raises(ValueError, match="are not in their plan"):
        fake_scan(folder, ScanSettings("distance", 0.2, camera=False), resume=True)
    assert every_file(folder) == before  # the manifest it began is gone again
    summary, slices, _ = fake_scan(folder, DISTANCE, resume=True)
    assert summary.complete and slices == 0 and summary.already == summary.planned == 150
    assert every_file(folder).keys() == every_file(pristine / "distance").keys()


def test_cli_resume_without_a_manifest(ptys, tmp_path, capsys):
    """--average 5 --strategy every --step 50, manifest and scan.npz gone."""
    out = tmp_path / "D"
    arguments = ["scan", "--simulate", "--out", str(out), "--quiet", "--timeout", "2"]
    assert scan_main([*arguments, "--average", "5", "--strategy", "every", "--step", "50"]) == 0
    before = slice_snapshot(out)
    (out / "manifest.json").unlink()
    (out / "scan.npz").unlink()
    capsys.readouterr()
    assert scan_main([*arguments, "--resume", "--seed", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has no manifest.json" in err
    assert slice_snapshot(out) == before
    # with the strategy given, --average defaults to the slice files' own
    assert scan_main([*arguments, "--resume", "--strategy", "every", "--step", "50"]) == 0
    assert "10/10 slices" in capsys.readouterr().out
    assert slice_snapshot(out) == before and load_scan(out).complete


@pytest.fixture
def ptys():
    pytest.importorskip("pty")
    pytest.importorskip("termios")


# ----------------------------------------------------------------------------- items 2-3: manifests

BAD_MANIFESTS = {
    "slices a list": lambda m: m.update(slices=[]),
    "image without file": lambda m: m["images"]["25"].pop("file"),
    "image out of the folder": lambda m: m["images"]["25"].update(file="../../../../etc/hostname"),
    "slice out of the folder": lambda m: m["slices"]["0"].update(file="/etc/passwd"),
    "plan 10**30": lambda m: m.update(plan=[10**30]),
    "plan of floats": lambda m: m.update(plan=[0.5, 1.7]),
    "plan empty": lambda m: m.update(plan=[]),
    "plan with duplicates": lambda m: m.update(plan=sorted(m["plan"] + [25])),
    "plan shortened": lambda m: m.update(plan=m["plan"][:5]),
    "plan of bools": lambda m: m.update(plan=[True]),
    "plan a string": lambda m: m.update(plan="0,25"),
    "plan descending": lambda m: m.update(plan=m["plan"][::-1]),
    "plan of another step": lambda m: m.update(plan=list(range(0, 500, 50))),
    "slice key not an index": lambda m: m["slices"].update({"0x1": m["slices"]["0"]}),
    "slice key out of range": lambda m: m["slices"].update({"500": m["slices"]["0"]}),
    "slice crc lower case": lambda m: m["slices"]["0"].update(crc="abcd"),
    "slice entry null": lambda m: m["slices"].update({"0": None}),
    "image at no camera index": lambda m: m["images"].update({"26": m["images"]["25"]}),
    "image angle nan": lambda m: m["images"]["25"].update(pan_angle_deg=float("nan")),
    "image angle wrong": lambda m: m["images"]["25"].update(pan_angle_deg=0.0),
    "image angle huge": lambda m: m["images"]["25"].update(pan_angle_deg=10**400),
    "image pan_index a string": lambda m: m["images"]["25"].update(pan_index="25"),
    "settings null": lambda m: m.update(settings=None),
    "settings unknown key": lambda m: m["settings"].update(speed=3),
    "settings fraction huge": lambda m: m["settings"].update(fraction=10**400),
    "settings average 0": lambda m: m["settings"].update(average=0),
    "settings step a float": lambda m: m["settings"].update(step=25.0),
    "format": lambda m: m.update(format="refsynth-scan/2"),
    "no plan key": lambda m: m.pop("plan"),
    "complete a string": lambda m: m.update(complete="yes"),
    "coarse for every": lambda m: m.update(coarse=[0, 10]),
    "sessions an object": lambda m: m.update(sessions={}),
    "source seed negative": lambda m: m["source"].update(seed=-1),
    "focal zero": lambda m: m["camera"].update(focal_px=0),
    "geometry of another rig": lambda m: m["geometry"].update(pan_slices=1000),
}
RAW_MANIFESTS = {
    "a list": b"[1, 2]",
    "null": b"null",
    "a string": b'"scan"',
    "empty file": b"",
    "not JSON": b"{'format': 1",
    "binary": bytes(range(256)),
    "deeply nested": b"[" * 100000 + b"]" * 100000,
    "NaN": b"NaN",
}


def _tamper(folder: Path, case: str) -> None:
    if case in RAW_MANIFESTS:
        (folder / "manifest.json").write_bytes(RAW_MANIFESTS[case])
    else:
        edit_manifest(folder, BAD_MANIFESTS[case])


@pytest.mark.parametrize("name", ["complete", "interrupted"])
@pytest.mark.parametrize("case", [*BAD_MANIFESTS, *RAW_MANIFESTS])
def test_bad_manifests_give_one_line_naming_the_file_and_lose_nothing(
        pristine, tmp_path, name, case):
    folder = copy(pristine, name, tmp_path)
    _tamper(folder, case)
    before = every_file(folder)
    path = str(folder / "manifest.json")
    with pytest.raises(ValueError) as loaded:
        load_scan(folder)
    message = str(loaded.value)
    assert message.startswith(f"'{path}' is not a valid scan manifest: ") and "\n" not in message
    with pytest.raises(ValueError) as resumed:
        fake_scan(folder, resume=True)
    message = str(resumed.value)
    assert message.startswith(f"cannot resume: '{path}' is not a valid scan manifest: ")
    assert "\n" not in message and "rebuild it from the slice files" in message
    assert every_file(folder) == before


def test_a_shortened_distance_plan_is_not_the_one_its_coarse_pass_gives(pristine, tmp_path):
    folder = copy(pristine, "distance", tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    coarse = manifest["coarse"]
    edit_manifest(folder, lambda m: m.update(plan=sorted(set(coarse) | set(m["plan"][:60]))))
    before = every_file(folder)
    with pytest.raises(ValueError, match="plan is not the plan of the settings"):
        load_scan(folder)
    with pytest.raises(ValueError, match="plan is not the plan of the settings"):
        fake_scan(folder, resume=True)
    assert every_file(folder) == before


def test_valid_manifests_pass_the_check(pristine):
    for name in ("complete", "interrupted", "distance"):
        manifest = json.loads((pristine / name / "manifest.json").read_text())
        assert isinstance(check_manifest(manifest), ScanSettings)


# ----------------------------------------------------------------------------- slice files


def _copy_over(folder: Path, source: int, target: int) -> None:
    """Copy slice ``source`` over ``target`` with its header edited to say ``target``."""
    data = (folder / "slices" / f"pan-{source:04d}.slice").read_bytes()
    edited = data.replace(f"pan {source}\n".encode(), f"pan {target}\n".encode(), 1)
    (folder / "slices" / f"pan-{target:04d}.slice").write_bytes(edited)
    assert read_slice(folder / "slices" / f"pan-{target:04d}.slice").pan_index == target


def _truncate(folder: Path, index: int) -> None:
    path = folder / "slices" / f"pan-{index:04d}.slice"
    path.write_bytes(path.read_bytes()[:200])


def _flip(folder: Path, index: int) -> None:
    path = folder / "slices" / f"pan-{index:04d}.slice"
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))


def _other_window(folder: Path, index: int) -> None:
    range_mm, amplitude = _RIG.measure(index, 379, 243, 5)
    record = SliceRecord(index, 379, 243, 5, range_mm, amplitude)
    (folder / "slices" / f"pan-{index:04d}.slice").write_bytes(slice_bytes(record))


SLICE_TAMPERING = {
    "copied over another, header edited": lambda f: _copy_over(f, 50, 100),
    "truncated": lambda f: _truncate(f, 100),
    "a flipped bit": lambda f: _flip(f, 100),
    "another GS window": lambda f: _other_window(f, 100),
}


@pytest.mark.parametrize("case", SLICE_TAMPERING)
def test_a_tampered_slice_is_set_aside_and_acquired_again(pristine, tmp_path, case):
    folder = copy(pristine, "complete", tmp_path)
    before = slice_snapshot(folder)
    SLICE_TAMPERING[case](folder)
    tampered = (folder / "slices" / "pan-0100.slice").read_bytes()
    summary, slices, pictures = fake_scan(folder, resume=True)
    assert summary.complete and slices == 1 and pictures == 0
    assert summary.already == 19 and summary.acquired == 1
    assert summary.rejected == [folder / "rejected" / "pan-0100.slice"]
    assert str(summary).startswith("20/20 slices")
    assert str(summary).endswith(f"; 1 file not trusted, set aside in {folder / 'rejected'}")
    assert (folder / "rejected" / "pan-0100.slice").read_bytes() == tampered  # kept, not deleted
    assert slice_snapshot(folder) == before  # acquired again: the same bytes
    assert_no_slice_lost(folder, before)
    manifest, _ = read_manifest(folder / "manifest.json")
    assert manifest["sessions"][-1]["rejected"] == ["rejected/pan-0100.slice"]
    assert (folder / "scan.npz").read_bytes() == (pristine / "complete" / "scan.npz").read_bytes()


@pytest.mark.parametrize("case", SLICE_TAMPERING)
def test_load_scan_checks_each_slice_of_an_interrupted_scan(pristine, tmp_path, case):
    folder = copy(pristine, "interrupted", tmp_path)
    SLICE_TAMPERING[case](folder)
    with pytest.raises(ValueError, match="pan-0100.slice"):
        load_scan(folder)


def test_a_slice_the_manifest_vouches_for_but_the_settings_contradict_refuses(pristine, tmp_path):
    folder = copy(pristine, "complete", tmp_path)
    _other_window(folder, 100)
    data = (folder / "slices" / "pan-0100.slice").read_bytes()
    edit_manifest(folder, lambda m: m["slices"]["100"].update(crc=slice_crc(data)))
    before = every_file(folder)
    with pytest.raises(ValueError, match="records slices/pan-0100.slice .* but its settings say"):
        fake_scan(folder, resume=True)
    assert every_file(folder) == before


def test_stray_and_extra_slice_files_are_left_alone_and_not_counted(pristine, tmp_path):
    """A valid slice outside the plan (the '201/200 slices' summary) and stray files."""
    folder = copy(pristine, "complete", tmp_path)
    _other_window(folder, 7)
    record = SliceRecord(1, 379, 243, 10, *_RIG.measure(1, 379, 243, 10))
    (folder / "slices" / "pan-0001.slice").write_bytes(slice_bytes(record))
    (folder / "slices" / "notes.txt").write_text("mine")
    (folder / "slices" / "pan-9999.slice").write_text("not a pan index")
    before = slice_snapshot(folder)
    summary, slices, _ = fake_scan(folder, resume=True)
    assert str(summary).startswith("20/20 slices") and summary.already == 20 and slices == 0
    # the off-plan slice with another window is set aside; everything else is left alone
    assert summary.rejected == [folder / "rejected" / "pan-0007.slice"]
    assert_no_slice_lost(folder, before, tampered={"pan-0007.slice"})


def test_a_truncated_picture_is_taken_again(pristine, tmp_path):
    folder = copy(pristine, "complete", tmp_path)
    picture = folder / "images" / "pan-0125.png"
    whole = picture.read_bytes()
    picture.write_bytes(whole[: len(whole) // 2])
    with pytest.raises(ValueError, match="pan-0125.png' is not a whole PNG picture"):
        load_scan(folder)
    before = slice_snapshot(folder)
    summary, slices, pictures = fake_scan(folder, resume=True)
    assert pictures == 1 and slices == 0 and summary.images == 1
    assert picture.read_bytes() == whole
    assert (folder / "rejected" / "pan-0125.png").read_bytes() == whole[: len(whole) // 2]
    assert_no_slice_lost(folder, before)
    load_scan(folder)


def test_a_slice_write_cut_short_is_finished_or_dropped(pristine, tmp_path):
    """A kill between the write of a slice's temporary file and its rename."""
    folder = copy(pristine, "interrupted", tmp_path)
    reference = slice_snapshot(pristine / "complete")
    slices = folder / "slices"
    (slices / ".pan-0250.slice.tmp").write_bytes(reference["pan-0250.slice"])  # whole
    (slices / ".pan-0275.slice.tmp").write_bytes(reference["pan-0275.slice"][:100])  # cut short
    before = slice_snapshot(folder)
    summary, acquired, _ = fake_scan(folder, resume=True)
    assert summary.complete and summary.already == 11 and acquired == 9
    assert slice_snapshot(folder) == reference and not list(slices.glob(".*"))
    assert_no_slice_lost(folder, before)


def test_new_slices_never_replace_a_file(tmp_path):
    path = tmp_path / "pan-0001.slice"
    path.write_bytes(b"mine")
    with pytest.raises(FileExistsError, match="refusing to replace"):
        write_new(path, b"theirs")
    assert path.read_bytes() == b"mine"


# ----------------------------------------------------------------------------- scan.npz

NPZ_DAMAGE = {
    "truncated": lambda data: data[: len(data) // 2],
    "garbage": lambda data: b"PK\x03\x04" + bytes(100),
    "a flipped byte": lambda data: data[:5000] + bytes([data[5000] ^ 0xFF]) + data[5001:],
    "empty": lambda data: b"",
}


@pytest.mark.parametrize("case", NPZ_DAMAGE)
def test_a_damaged_scan_npz_gives_valueerror_and_resume_rebuilds_it(pristine, tmp_path, case):
    folder = copy(pristine, "complete", tmp_path)
    npz = folder / "scan.npz"
    good = npz.read_bytes()
    npz.write_bytes(NPZ_DAMAGE[case](good))
    with pytest.raises(ValueError, match="scan.npz") as error:
        load_scan(folder)
    assert "\n" not in str(error.value)
    before = slice_snapshot(folder)
    summary, slices, _ = fake_scan(folder, resume=True)
    assert summary.complete and slices == 0 and npz.read_bytes() == good
    assert_no_slice_lost(folder, before)


def test_a_scan_npz_that_is_not_its_manifest_s_scan_is_refused(pristine, tmp_path):
    folder = copy(pristine, "complete", tmp_path)
    with np.load(folder / "scan.npz") as data:
        arrays = {k: data[k] for k in data.files}
    for name, change in [("pan_index", lambda a: a[::-1].copy()),
                         ("r", lambda a: np.full_like(a, -1.0)),
                         ("theta", lambda a: a + 1e-9),
                         ("amplitude", lambda a: a.astype(np.int64))]:
        np.savez(folder / "scan.npz", **{**arrays, name: change(arrays[name])})
        with pytest.raises(ValueError, match="does not hold the scan of its manifest.json"):
            load_scan(folder)


def test_scans_written_before_still_load(pristine):
    """The folders of the current format load as they always did."""
    scan = load_scan(pristine / "complete")
    assert scan.complete and scan.pan_index.tolist() == list(range(0, 500, 25))
    assert scan.focal == 300.0 and len(scan.images) == 10
    partial = load_scan(pristine / "interrupted")
    assert not partial.complete and partial.pan_index.tolist() == list(range(0, 250, 25))
    np.testing.assert_array_equal(partial.r, scan.r[:10])


# ----------------------------------------------------------------------------- fuzz

JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**40), 10**40)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner,
                                                                max_size=4),
    max_leaves=8,
)


def _paths(value, prefix=()):
    yield prefix
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, (*prefix, key))
    elif isinstance(value, list):
        for index, item in enumerate(value[:3]):
            yield from _paths(item, (*prefix, index))


def _replace(value, path, new):
    if not path:
        return new
    value[path[0]] = _replace(value[path[0]], path[1:], new)
    return value


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzzed_manifests_give_valueerror_or_load_and_never_lose_a_slice(pristine, tmp_path_factory,
                                                                         data):
    name = data.draw(st.sampled_from(["complete", "interrupted"]))
    manifest = json.loads((pristine / name / "manifest.json").read_text())
    paths = list(_paths(manifest))
    path = data.draw(st.sampled_from(paths))
    new = data.draw(JSON_VALUES)
    tampered = _replace(manifest, path, new)
    try:
        check_manifest(tampered)
    except ValueError as error:
        assert "\n" not in str(error)
    folder = tmp_path_factory.mktemp("fuzz") / name
    shutil.copytree(pristine / name, folder)
    (folder / "manifest.json").write_text(json.dumps(tampered))
    before = slice_snapshot(folder)
    for action in (lambda: load_scan(folder), lambda: fake_scan(folder, resume=True)):
        try:
            action()
        except ValueError as error:
            assert "\n" not in str(error)
        assert_no_slice_lost(folder, before)
    shutil.rmtree(folder)


# ----------------------------------------------------------------------------- item 10: the CLI


@pytest.mark.parametrize(
    ("arguments", "match"),
    [(["--timeout", "inf"], "--timeout must be a finite number of seconds <= 3600, got inf"),
     (["--timeout", "1e300"], "--timeout must be a finite"),
     (["--sweep-time", "nan"], "--sweep-time must be >= 0"),
     (["--sweep-time", "1e300"], "--sweep-time must be >= 0 and <= 60"),
     (["--retries", "100000000000000000000"], "--retries must be >= 0 and <= 1000"),
     (["--pan-baud", "100000000000000000000"], "--pan-baud must be <= 100000000"),
     (["--faults", "corrupt=0.1,corrupt=0.2"], "the fault 'corrupt' is given twice"),
     (["--faults", "delay=inf"], "`delay` must be finite"),
     (["--out", " "], "--out must name a folder")],
)
def test_cli_scan_refuses_bad_options_in_one_line(tmp_path, capsys, arguments, match):
    status = scan_main(["scan", "--simulate", "--out", str(tmp_path / "x"), *arguments])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("refsynth scan: error: ") and err.count("\n") == 1
    assert match in err, err
    assert not (tmp_path / "x").exists()


def test_the_plans_of_the_fixtures():
    assert plan_slices(EVERY_25).tolist() == list(range(0, 500, 25))


class _Reached(Exception):
    """The command got past its checks to the simulator."""


OPTION_TEXT = st.one_of(
    st.sampled_from(["inf", "-inf", "nan", "1e300", "-1", "0", "1e-300", "3600", "3601", "60",
                     "61", "10" * 12, "0x10", "1_0", " 2", "", "1e309"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**30), 10**30).map(str),
    st.text(max_size=8),
)
FAULT_TEXT = st.lists(
    st.tuples(st.sampled_from(["corrupt", "drop", "error", "delay", "disconnect",
                               "disconnect_after", "oops", ""]), OPTION_TEXT),
    max_size=4,
).map(lambda items: ",".join(f"{k}={v}" for k, v in items))


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(option=st.sampled_from(["--timeout", "--sweep-time", "--retries", "--pan-baud",
                               "--laser-baud", "--seed", "--faults"]),
       text=OPTION_TEXT, faults=FAULT_TEXT)
def test_fuzzed_scan_options_fail_in_one_line_or_reach_the_rig_with_sane_values(
        tmp_path, monkeypatch, capsys, option, text, faults):
    import refsynth.cli.scan as command

    seen = {}

    def simulator(seed, faults, camera_dir):
        seen.update(seed=seed, faults=faults)
        raise _Reached

    monkeypatch.setattr(command, "RigSimulator", simulator)
    value = faults if option == "--faults" else text
    try:
        status = scan_main(["scan", "--simulate", "--out", str(tmp_path / "x"),
                            f"{option}={value}"])
    except SystemExit as exit_:  # an argparse usage error
        assert exit_.code == 2
        return
    except _Reached:
        assert isinstance(seen["seed"], int) and seen["seed"] >= 0
        return
    finally:
        err = capsys.readouterr().err
    assert status == 2 and err.startswith("refsynth scan: error: ") and err.count("\n") == 1, err
