"""Tampered case folders and foreign export targets: one line naming the file, exit 2.

Checksums are verified before any case runs, so a case file changed in place, truncated or
with a flipped byte is reported as such (the reference itself, which passes every case, is
never blamed); a malformed manifest or case, with consistent checksums, is one line naming
the file; case names stay inside the folder. ``oracle export`` writes only into a new or
empty folder or over an earlier export, every file through ``write_atomic``.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import refsynth.cli.main as cli_main
import refsynth.oracle.export as export_module
from refsynth.oracle import build_cases, check_function, export_cases, refsynth_reference
from refsynth.oracle.cases import select_cases
from refsynth.oracle.files import load_cases

CASES = ["eq7", "np-8x8-noise"]


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("folders") / "cases"
    export_cases(root, select_cases(build_cases(), CASES))
    return root


@pytest.fixture
def folder(pristine, tmp_path) -> Path:
    copy = tmp_path / "copy"
    shutil.copytree(pristine, copy)
    return copy


def check_cli(folder, capsys, *extra) -> tuple[int, list[str], list[str]]:
    code = cli_main.main(["oracle", "check", "refsynth.oracle:refsynth_reference", "--dir",
                          str(folder), *extra])
    captured = capsys.readouterr()
    return code, captured.out.strip().splitlines(), captured.err.strip().splitlines()


def one_line(capsys_result, *words) -> None:
    code, out, err = capsys_result
    assert code == 2 and not out, (code, out, err)
    assert len(err) == 1 and err[0].startswith("refsynth oracle: error:"), err
    for word in words:
        assert word in err[0], err


def _manifest(folder) -> dict:
    return json.loads((folder / "manifest.json").read_text())


def _rewrite(folder, manifest) -> None:
    (folder / "manifest.json").write_text(json.dumps(manifest))


def _rehash(folder, name) -> None:
    """Make the manifest agree with the case's files again (a consistent tampering)."""
    manifest = _manifest(folder)
    for entry in manifest["cases"]:
        if entry["name"] == name:
            entry["sha256"] = hashlib.sha256((folder / entry["npz"]).read_bytes()).hexdigest()
            entry["json_sha256"] = hashlib.sha256(
                (folder / entry["json"]).read_bytes()).hexdigest()
    _rewrite(folder, manifest)


def test_the_pristine_folder_passes(pristine, capsys):
    code, out, _ = check_cli(pristine, capsys)
    assert code == 0 and out == ["PASS 2 cases at tolerance exact: 2 passed, 0 failed"]


@pytest.mark.parametrize("damage", ["flip", "truncate", "in-place", "json-options"])
def test_a_changed_case_file_is_named_before_any_case_runs(folder, capsys, damage):
    npz = folder / "cases" / "np-8x8-noise.npz"
    data = npz.read_bytes()
    target = npz
    if damage == "flip":
        npz.write_bytes(data[:200] + bytes([data[200] ^ 1]) + data[201:])
    elif damage == "truncate":
        npz.write_bytes(data[: len(data) // 2])
    elif damage == "in-place":   # a valid archive, one expected value changed
        with np.load(npz) as archive:
            arrays = {key: archive[key] for key in archive.files}
        arrays["range"] = arrays["range"] + 1.0
        export_module.write_npz(npz, arrays)
    else:
        target = folder / "cases" / "np-8x8-noise.json"
        meta = json.loads(target.read_text())
        meta["options"]["epsilon"] = 0.5
        target.write_text(json.dumps(meta))
    one_line(check_cli(folder, capsys), str(target), "SHA-256", "changed, truncated or corrupted")
    # the reference is never blamed: the API raises too, nothing is reported as a mismatch
    with pytest.raises(ValueError, match="SHA-256"):
        check_function(refsynth_reference, folder)


def test_a_missing_case_file_is_named(folder, capsys):
    (folder / "cases" / "eq7.npz").unlink()
    one_line(check_cli(folder, capsys), "eq7.npz", "is missing")


@pytest.mark.parametrize("change, words", [
    (lambda m: m.pop("cases"), ["lists no cases"]),
    (lambda m: m.update(cases=[]), ["lists no cases"]),
    (lambda m: m.update(cases=[1]), ["cases[0] is 1, not an object"]),
    (lambda m: m.update(cases="eq7"), ["lists no cases"]),
    (lambda m: m["cases"][0].update(name="../../x", json="cases/../../x.json",
                                    npz="cases/../../x.npz"),
     ["the name '../../x' is not a case name"]),
    (lambda m: m["cases"][0].update(json="../../etc/passwd"), ["json must be 'cases/"]),
    (lambda m: m["cases"][0].update(kind="eq99"), ["unknown kind 'eq99'"]),
    (lambda m: m["cases"][0].pop("json_sha256"), ["lacks json_sha256"]),
    (lambda m: m["cases"][0].update(sha256="00"), ["sha256 is not a SHA-256"]),
    (lambda m: m["cases"].append(dict(m["cases"][0])), ["is listed twice"]),
    (lambda m: m.update(version=1), ["format version 1", "export the cases again"]),
    (lambda m: m.update(format="refsynth-scan"), ["is not a refsynth oracle manifest"]),
])
def test_a_malformed_manifest_is_one_line_naming_it(folder, capsys, change, words):
    manifest = _manifest(folder)
    change(manifest)
    _rewrite(folder, manifest)
    one_line(check_cli(folder, capsys), str(folder / "manifest.json"), *words)


@pytest.mark.parametrize("text", ["{\"format\": ", "[" * 100_000, "\xff\xfe", ""])
def test_a_manifest_that_is_not_json_is_one_line(folder, capsys, text):
    (folder / "manifest.json").write_bytes(text.encode("latin-1"))
    one_line(check_cli(folder, capsys), "manifest.json", "is not valid JSON")


@pytest.mark.parametrize("damage, words", [
    ("truncated-json", ["eq7.json", "is not valid JSON"]),
    ("no-arrays", ["eq7.json", "has no 'arrays'"]),
    ("not-an-object", ["eq7.json", "is not a case"]),
    ("bad-role", ["eq7.json", "array 'log_phi' must be an identifier with a role"]),
    ("other-name", ["eq7.json", "is the case 'np-8x8-noise'"]),
    ("seed-string", ["eq7.json", "'seed' must be an integer or null"]),
    ("bad-zip", ["eq7.npz", "is not a readable NPZ archive: BadZipFile"]),
    ("bare-npy", ["eq7.npz", "is not a readable NPZ archive"]),
    ("pickle", ["eq7.npz", "is not a readable NPZ archive"]),
    ("dtype", ["eq7.npz", "array 'log_phi' is float32"]),
    ("extra-array", ["eq7.npz", "list different arrays (extra)"]),
    ("np-without-order", ["np-8x8-noise.json", "lacks the arrays order"]),
])
def test_a_malformed_case_with_consistent_checksums_is_one_line_naming_it(folder, capsys, damage,
                                                                         words):
    name = "np-8x8-noise" if damage == "np-without-order" else "eq7"
    json_path, npz_path = folder / "cases" / f"{name}.json", folder / "cases" / f"{name}.npz"
    meta = json.loads(json_path.read_text())
    with np.load(npz_path) as archive:
        arrays = {key: archive[key] for key in archive.files}
    if damage == "truncated-json":
        json_path.write_text(json_path.read_text()[:50])
    elif damage == "no-arrays":
        json_path.write_text(json.dumps({k: v for k, v in meta.items() if k != "arrays"}))
    elif damage == "not-an-object":
        json_path.write_text("[1, 2]")
    elif damage == "bad-role":
        meta["arrays"]["log_phi"]["role"] = "golden"
        json_path.write_text(json.dumps(meta))
    elif damage == "other-name":
        meta["name"] = "np-8x8-noise"
        json_path.write_text(json.dumps(meta))
    elif damage == "seed-string":
        meta["seed"] = "0"
        json_path.write_text(json.dumps(meta))
    elif damage == "bad-zip":
        npz_path.write_bytes(b"PK\x03\x04" + b"\x00" * 60)
    elif damage == "bare-npy":
        with open(npz_path, "wb") as stream:
            np.save(stream, arrays["log_phi"])
    elif damage == "pickle":
        with open(npz_path, "wb") as stream:
            np.save(stream, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    elif damage == "dtype":
        arrays["log_phi"] = arrays["log_phi"].astype(np.float32)
        export_module.write_npz(npz_path, arrays)
    elif damage == "extra-array":
        arrays["extra"] = np.zeros(2)
        export_module.write_npz(npz_path, arrays)
    else:
        del meta["arrays"]["order"], arrays["order"]
        json_path.write_text(json.dumps(meta))
        export_module.write_npz(npz_path, arrays)
    _rehash(folder, name)
    one_line(check_cli(folder, capsys), *words)


def test_case_names_stay_inside_the_folder(folder, tmp_path):
    outside = tmp_path / "x.json"
    outside.write_text("{}")
    manifest = _manifest(folder)
    manifest["cases"][0].update(name="../../x", json="cases/../../x.json",
                                npz="cases/../../x.npz")
    _rewrite(folder, manifest)
    with pytest.raises(ValueError, match="not a case name"):
        load_cases(folder)


def test_a_case_file_that_is_a_symlink_is_refused(folder, tmp_path):
    target = tmp_path / "elsewhere.npz"
    shutil.copy(folder / "cases" / "eq7.npz", target)
    (folder / "cases" / "eq7.npz").unlink()
    (folder / "cases" / "eq7.npz").symlink_to(target)
    with pytest.raises(ValueError, match="not a regular file"):
        load_cases(folder)


# ----------------------------------------------------------------------------- export


def export_cli(folder, capsys) -> tuple[int, list[str], list[str]]:
    code = cli_main.main(["oracle", "export", str(folder), "--cases", "eq7"])
    captured = capsys.readouterr()
    return code, captured.out.strip().splitlines(), captured.err.strip().splitlines()


def test_export_refuses_a_scan_folder_and_leaves_it_alone(tmp_path, capsys):
    scan = tmp_path / "scan"
    (scan / "slices").mkdir(parents=True)
    manifest = b'{"format": "refsynth-scan", "version": 3}\n'
    (scan / "manifest.json").write_bytes(manifest)
    one_line(export_cli(scan, capsys), "refusing to export into", "not an oracle export's")
    assert (scan / "manifest.json").read_bytes() == manifest
    assert sorted(p.name for p in scan.iterdir()) == ["manifest.json", "slices"]


@pytest.mark.parametrize("planted", ["notes.txt", "images/", "cases/readme.md", "cases/x/",
                                     "link"])
def test_export_refuses_a_folder_holding_anything_else(pristine, tmp_path, capsys, planted):
    target = tmp_path / "earlier"
    shutil.copytree(pristine, target)
    path = target / planted.rstrip("/")
    if planted == "link":
        (target / "cases").rename(target / "real-cases")
        (target / "cases").symlink_to(target / "real-cases")
        planted = "cases"
    elif planted.endswith("/"):
        path.mkdir()
    else:
        path.write_text("mine")
    one_line(export_cli(target, capsys), "refusing to export into", planted.rstrip("/"))


def test_export_over_an_earlier_export_and_into_an_empty_folder(pristine, tmp_path, capsys):
    earlier = tmp_path / "earlier"
    shutil.copytree(pristine, earlier)
    empty = tmp_path / "empty"
    empty.mkdir()
    for target in (earlier, empty):
        code, out, err = export_cli(target, capsys)
        assert code == 0 and not err and out[0].startswith("wrote 1 cases")
        assert [c["name"] for c in _manifest(target)["cases"]] == ["eq7"]
        assert check_function(refsynth_reference, target).passed


def test_export_writes_every_file_through_write_atomic(tmp_path, monkeypatch):
    written = []
    original = export_module.write_atomic

    def recording(path, data):
        written.append(Path(path).relative_to(tmp_path).as_posix())
        return original(path, data)

    monkeypatch.setattr(export_module, "write_atomic", recording)
    export_cases(tmp_path, select_cases(build_cases(), ["eq7", "eq5-ties"]))
    on_disk = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")
                     if p.is_file())
    assert sorted(written) == on_disk and len(on_disk) == 6
