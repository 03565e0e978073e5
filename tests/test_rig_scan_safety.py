"""Scan folders written safely: the lock, stale temporary files, planted symbolic links.

A session locks its folder (a second scan into it is refused in one line); every write goes
through an exclusive temporary file with an unpredictable name, so a symbolic link planted
under a temporary-looking name, in place of a slice or a picture, redirects nothing; what a
kill left behind (a temporary file, a slice on disk the manifest does not list yet) is
finished, removed or set aside, never lost and never written through.
"""

import errno
import fcntl
import json
import os
import shutil
from pathlib import Path

import pytest
from rig_fakes import fake_scan

from refsynth.acquisition import ScanSettings, load_scan, read_slice
from refsynth.acquisition.scan_folder import LOCK_NAME, SliceRecord, lock_folder, slice_bytes
from refsynth.cli.scan import main as scan_main

EVERY_25 = ScanSettings("every", step=25)


@pytest.fixture(scope="module")
def pristine(tmp_path_factory):
    """A complete scan (every 25th slice, 10 pictures) and the same scan cut short: the first
    10 slices on disk and in the manifest."""
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
    return base


def copy(pristine: Path, name: str, tmp_path: Path) -> Path:
    target = tmp_path / name
    shutil.copytree(pristine / name, target, symlinks=True)
    return target


def files(folder: Path, sub: str) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((folder / sub).iterdir())
            if p.is_file() and not p.is_symlink()}


def victim(tmp_path: Path, name: str = "victim.txt") -> Path:
    """A file outside the scan folder that no write may reach."""
    path = tmp_path / "outside" / name
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(b"not yours")
    return path


# ----------------------------------------------------------------------------- the lock


def test_a_second_scan_into_a_locked_folder_is_refused_and_touches_nothing(tmp_path):
    folder = tmp_path / "scan"
    folder.mkdir()
    with lock_folder(folder):
        with pytest.raises(ValueError, match="is in use by another scan"):
            fake_scan(folder, EVERY_25)
        assert list(folder.iterdir()) == []
    summary, _, _ = fake_scan(folder, EVERY_25)  # the lock goes with its holder
    assert summary.complete


def test_the_cli_refuses_a_locked_folder_in_one_line(tmp_path, capsys):
    out = tmp_path / "scan"
    out.mkdir()
    with lock_folder(out):
        status = scan_main(["scan", "--simulate", "--out", str(out), "--strategy", "every",
                            "--step", "100", "--no-camera", "--quiet"])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1, err
    assert err.startswith(f"refsynth scan: error: '{out}' is in use by another scan")
    assert list(out.iterdir()) == []


def test_a_folder_that_cannot_be_locked_is_locked_through_a_lock_file(tmp_path, monkeypatch):
    real = fcntl.flock

    def no_folder_locks(descriptor, operation):
        if os.path.isdir(f"/proc/self/fd/{descriptor}"):
            raise OSError(errno.ENOLCK, "No locks available")
        return real(descriptor, operation)

    monkeypatch.setattr(fcntl, "flock", no_folder_locks)
    folder = tmp_path / "scan"
    folder.mkdir()
    with lock_folder(folder):
        assert (folder / LOCK_NAME).is_file()
        with pytest.raises(ValueError, match="is in use by another scan"):
            fake_scan(folder, EVERY_25)
    assert fake_scan(folder, EVERY_25)[0].complete
    # a link planted under the lock file's name is neither followed nor created through
    other = tmp_path / "other"
    other.mkdir()
    target = victim(tmp_path, "lock-victim")
    (other / LOCK_NAME).symlink_to(target)
    with pytest.raises(ValueError, match=f"cannot lock the scan folder '{other}'"):
        fake_scan(other, EVERY_25)
    assert target.read_bytes() == b"not yours"


# ----------------------------------------------------------------------------- temporary files


TEMPORARY_NAMES = [".manifest.json.tmp", ".scan.npz.tmp", "images/.pan-0025.png.tmp",
                   "images/.pan-0325.png.tmp", "slices/.pan-0250.slice.tmp",
                   ".manifest.json.abc12_yz.tmp", ".scan.npz.qwertyui.tmp",
                   "images/.pan-0475.png.zz99zz99.tmp", "slices/.pan-0300.slice.a1b2c3d4.tmp"]


@pytest.mark.parametrize("resume", [True, False])
def test_links_planted_under_temporary_names_redirect_no_write(pristine, tmp_path, resume):
    folder = copy(pristine, "interrupted", tmp_path) if resume else tmp_path / "new"
    targets = []
    for number, name in enumerate(TEMPORARY_NAMES):
        target = victim(tmp_path, f"victim-{number}")
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).symlink_to(target)
        targets.append(target)
    summary, _, _ = fake_scan(folder, EVERY_25, resume=resume)
    assert summary.complete
    assert all(target.read_bytes() == b"not yours" for target in targets)
    # the links themselves are set aside (moved, not followed) and named in the summary
    rejected = sorted(p.name for p in (folder / "rejected").iterdir())
    assert rejected == sorted(Path(name).name for name in TEMPORARY_NAMES)
    assert all((folder / "rejected" / name).is_symlink() for name in rejected)
    assert f"{len(TEMPORARY_NAMES)} files not trusted, set aside" in str(summary)
    assert files(folder, "slices") == files(pristine / "complete", "slices")
    load_scan(folder)


def test_stale_temporary_files_of_a_killed_run_are_finished_or_removed(pristine, tmp_path):
    folder = copy(pristine, "interrupted", tmp_path)
    reference = files(pristine / "complete", "slices")
    slices = folder / "slices"
    # killed between a slice's temporary file and its link into place: finished
    (slices / ".pan-0250.slice.k3j9x_ab.tmp").write_bytes(reference["pan-0250.slice"])
    # killed after the link, before the temporary file's removal: the same bytes, removed
    (slices / ".pan-0000.slice.zzzzzzzz.tmp").write_bytes(reference["pan-0000.slice"])
    # killed during the write: never a complete file, removed
    (slices / ".pan-0275.slice.abcdefgh.tmp").write_bytes(reference["pan-0275.slice"][:99])
    (folder / ".manifest.json.q1w2e3r4.tmp").write_bytes(b'{"format": "refsyn')
    (folder / "images" / ".pan-0025.png.mnbvcxz_.tmp").write_bytes(b"\x89PNG")
    # whole slices that are not the one in place: kept, set aside
    record = read_slice(slices / "pan-0100.slice")
    other = slice_bytes(SliceRecord(100, record.seq, record.count, record.average,
                                    record.range_mm + 1, record.amplitude))
    (slices / ".pan-0100.slice.00000000.tmp").write_bytes(other)
    (slices / ".pan-0125.slice.11111111.tmp").write_bytes(reference["pan-0275.slice"])
    # a user's own hidden file is not refsynth's: left alone
    (folder / ".notes.tmp").write_bytes(b"mine")
    summary, acquired, _ = fake_scan(folder, EVERY_25, resume=True)
    assert summary.complete and summary.already == 11 and acquired == 9
    assert files(folder, "slices") == reference
    assert sorted(p.name for p in slices.iterdir()) == sorted(reference)
    assert not [p for p in (folder / "images").iterdir() if p.name.endswith(".tmp")]
    assert (folder / ".notes.tmp").read_bytes() == b"mine"
    assert not list(folder.glob(".manifest.json*"))
    rejected = folder / "rejected"
    assert sorted(p.name for p in rejected.iterdir()) == [".pan-0100.slice.00000000.tmp",
                                                          ".pan-0125.slice.11111111.tmp"]
    assert (rejected / ".pan-0100.slice.00000000.tmp").read_bytes() == other
    assert (rejected / ".pan-0125.slice.11111111.tmp").read_bytes() == reference["pan-0275.slice"]


def test_a_slice_on_disk_that_the_manifest_does_not_list_yet_is_adopted(pristine, tmp_path):
    """Killed between a slice's write and the manifest's update: the slice is checked and kept,
    not acquired again, not replaced."""
    folder = copy(pristine, "interrupted", tmp_path)
    reference = files(pristine / "complete", "slices")
    for name in ("pan-0250.slice", "pan-0275.slice"):
        (folder / "slices" / name).write_bytes(reference[name])
    stamp = (folder / "slices" / "pan-0250.slice").stat().st_ino
    summary, acquired, _ = fake_scan(folder, EVERY_25, resume=True)
    assert summary.complete and summary.already == 12 and acquired == 8
    assert (folder / "slices" / "pan-0250.slice").stat().st_ino == stamp
    assert files(folder, "slices") == reference and not (folder / "rejected").exists()
    manifest = json.loads((folder / "manifest.json").read_text())
    assert {"250", "275"} <= set(manifest["slices"])


# ----------------------------------------------------------------------------- links in place


def test_a_link_in_place_of_a_slice_is_set_aside_and_the_slice_taken_again(pristine, tmp_path):
    folder = copy(pristine, "interrupted", tmp_path)
    reference = files(pristine / "complete", "slices")
    target = victim(tmp_path)
    target.write_bytes(reference["pan-0100.slice"])  # even a valid slice is not read through
    (folder / "slices" / "pan-0100.slice").unlink()
    (folder / "slices" / "pan-0100.slice").symlink_to(target)
    (folder / "slices" / "pan-0300.slice").symlink_to(victim(tmp_path, "second"))
    summary, acquired, _ = fake_scan(folder, EVERY_25, resume=True)
    assert summary.complete and acquired == 11
    assert target.read_bytes() == reference["pan-0100.slice"]
    assert (tmp_path / "outside" / "second").read_bytes() == b"not yours"
    assert sorted(p.name for p in (folder / "rejected").iterdir()) == ["pan-0100.slice",
                                                                       "pan-0300.slice"]
    assert files(folder, "slices") == reference


def test_a_linked_manifest_is_refused_in_one_line(pristine, tmp_path, capsys):
    folder = copy(pristine, "interrupted", tmp_path)
    elsewhere = tmp_path / "outside-manifest.json"
    shutil.move(folder / "manifest.json", elsewhere)
    (folder / "manifest.json").symlink_to(elsewhere)
    before = elsewhere.read_bytes()
    with pytest.raises(ValueError, match="manifest.json' is a symbolic link"):
        fake_scan(folder, resume=True)
    status = scan_main(["scan", "--simulate", "--out", str(folder), "--resume", "--quiet"])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "is a symbolic link" in err, err
    assert elsewhere.read_bytes() == before
    with pytest.raises(ValueError, match="manifest.json' is a symbolic link"):
        load_scan(folder)


def test_load_scan_refuses_a_link_in_place_of_a_slice(pristine, tmp_path):
    folder = copy(pristine, "interrupted", tmp_path)
    target = victim(tmp_path)
    shutil.move(folder / "slices" / "pan-0100.slice", target)
    (folder / "slices" / "pan-0100.slice").symlink_to(target)
    with pytest.raises(ValueError, match="pan-0100.slice' is a symbolic link, not a slice"):
        load_scan(folder)


@pytest.mark.parametrize("name", ["slices", "images", "rejected"])
def test_a_linked_subfolder_is_refused_and_nothing_is_written_through_it(pristine, tmp_path,
                                                                         name):
    folder = copy(pristine, "interrupted", tmp_path)
    outside = tmp_path / "outside-folder"
    if (folder / name).exists():
        shutil.move(folder / name, outside)
    else:
        outside.mkdir()
    (folder / name).symlink_to(outside, target_is_directory=True)
    before = sorted(p.name for p in outside.iterdir())
    with pytest.raises(ValueError, match=f"'{folder / name}' is a symbolic link"):
        fake_scan(folder, resume=True)
    assert sorted(p.name for p in outside.iterdir()) == before


def test_a_link_in_place_of_scan_npz_is_replaced_not_written_through(pristine, tmp_path):
    folder = copy(pristine, "interrupted", tmp_path)
    target = victim(tmp_path)
    (folder / "scan.npz").symlink_to(target)
    summary, _, _ = fake_scan(folder, resume=True)
    assert summary.complete and target.read_bytes() == b"not yours"
    assert not (folder / "scan.npz").is_symlink()
    assert (folder / "scan.npz").read_bytes() == (pristine / "complete" / "scan.npz").read_bytes()


def test_an_out_that_cannot_be_a_scan_folder_gives_one_line(tmp_path, capsys):
    afile = tmp_path / "a-file"
    afile.write_bytes(b"mine")
    for out, message in [(afile, f"'{afile}' is not a folder"),
                         (afile / "scan", f"cannot create the scan folder '{afile / 'scan'}'")]:
        status = scan_main(["scan", "--simulate", "--out", str(out), "--quiet", "--no-camera"])
        err = capsys.readouterr().err
        assert status == 2 and err.count("\n") == 1 and message in err, err
    assert afile.read_bytes() == b"mine"
