"""``register --scan`` on a scan folder: the pan angles and focal length from its manifest.json,
a registration that does not converge is an error, damaged files give one line;
``scan`` and ``register`` document every option's meaning and default."""

import argparse
import shutil
from pathlib import Path

import pytest
from rig_fakes import fake_scan

from refsynth.acquisition import ScanSettings
from refsynth.cli.main import main
from refsynth.cli.register import add_register_parser
from refsynth.cli.scan import add_scan_parser


@pytest.fixture(scope="module")
def scan_folder(tmp_path_factory):
    """The README's scan: stripes, 40 % of the slices, ten pictures."""
    folder = tmp_path_factory.mktemp("register") / "my-scan"
    fake_scan(folder, ScanSettings())
    return folder


@pytest.fixture(scope="module")
def explicit(scan_folder, tmp_path_factory):
    """The registration with every angle given by hand (the README's former command)."""
    out = tmp_path_factory.mktemp("explicit")
    images = sorted(str(p) for p in (scan_folder / "images").glob("*.png"))
    assert main(["register", *images, "--scan", str(scan_folder / "scan.npz"), "--focal", "300",
                 "--pan-step", "18", "--start", "-81", "--out", str(out)]) == 0
    return out


def outputs(folder: Path) -> tuple[bytes, bytes]:
    return (folder / "intensity.npy").read_bytes(), (folder / "partial_range.npy").read_bytes()


def run(capsys, *arguments) -> tuple[int, str, str]:
    status = main(["register", *arguments])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.mark.parametrize("scan", ["", "manifest.json", "scan.npz"])
def test_register_reads_the_angles_and_focal_length_from_the_scan(
        scan_folder, explicit, tmp_path, capsys, scan):
    status, out, err = run(capsys, "--scan", str(scan_folder / scan), "--out", str(tmp_path))
    assert status == 0, err
    assert "edge misalignment 0." in out and "nan" not in out
    assert outputs(tmp_path) == outputs(explicit)


def test_register_maps_the_given_pictures_to_their_manifest_angles(
        scan_folder, explicit, tmp_path, capsys):
    images = sorted(str(p) for p in (scan_folder / "images").glob("*.png"))
    status, _, err = run(capsys, *images, "--scan", str(scan_folder), "--out", str(tmp_path))
    assert status == 0, err
    assert outputs(tmp_path) == outputs(explicit)


def test_register_fails_when_it_does_not_converge(scan_folder, tmp_path, capsys):
    """--start 0 does not converge: an error, not "edge misalignment nan -> nan px" and exit 0."""
    status, out, err = run(capsys, "--scan", str(scan_folder), "--start", "0",
                           "--out", str(tmp_path / "out"))
    lines = err.splitlines()
    assert status == 2 and out == "" and not (tmp_path / "out").exists()
    assert lines[0].startswith("refsynth register: warning: --start 0 puts the first view at 0")
    assert lines[-1].startswith("refsynth register: error: registration did not converge")
    assert len(lines) == 2


def test_a_bare_npz_needs_the_angles_and_focal_length(scan_folder, tmp_path, capsys):
    bare = tmp_path / "scan.npz"
    shutil.copy(scan_folder / "scan.npz", bare)
    image = str(scan_folder / "images" / "pan-0025.png")
    for arguments, match in [
        ([image, "--scan", str(bare), "--focal", "300"], "give --start (and --pan-step"),
        ([image, "--scan", str(bare), "--start", "-81"], "give --focal: "),
        (["--scan", str(bare), "--focal", "300", "--start", "-81"], "give the camera views"),
        ([image, "--scan", str(scan_folder), "--focal", "nan"], "--focal must be a focal length"),
        ([str(bare), "--scan", str(scan_folder)], "is not one of the pictures of the scan"),
        ([image, "--scan", str(scan_folder), "--start", "inf"], "--start must be a finite"),
        ([image, "--scan", str(scan_folder), "--out", ""], "--out must name a folder"),
    ]:
        status, _, err = run(capsys, "--out", str(tmp_path / "out"), *arguments)
        assert status == 2 and err.count("\n") == 1 and match in err, err


def _flip(data: bytes) -> bytes:
    """One byte inside the first array changed: its CRC-32 no longer holds."""
    middle = len(data) // 3
    return data[:middle] + bytes([data[middle] ^ 0xFF]) + data[middle + 1:]


@pytest.mark.parametrize("damage", [lambda d: d[: len(d) // 2], _flip])
def test_register_on_a_damaged_scan_npz_gives_one_line(scan_folder, tmp_path, capsys, damage):
    folder = tmp_path / "scan"
    shutil.copytree(scan_folder, folder)
    npz = folder / "scan.npz"
    npz.write_bytes(damage(npz.read_bytes()))
    for scan in (folder, npz):
        status, _, err = run(capsys, "--scan", str(scan), "--out", str(tmp_path / "out"))
        assert status == 2 and err.count("\n") == 1 and "scan.npz" in err, err
        assert "Traceback" not in err and "BadZipFile" not in err
    bare = tmp_path / "bare.npz"
    shutil.copy(npz, bare)
    status, _, err = run(capsys, str(folder / "images" / "pan-0025.png"), "--scan", str(bare),
                         "--focal", "300", "--start", "-81")
    assert status == 2 and err.count("\n") == 1 and "cannot read scan file" in err, err


def test_register_on_a_folder_without_a_scan(tmp_path, capsys):
    status, _, err = run(capsys, "--scan", str(tmp_path))
    assert status == 2 and "no manifest.json" in err and err.count("\n") == 1
    status, _, err = run(capsys, "--scan", str(tmp_path / "manifest.json"))
    assert status == 2 and "scan file not found" in err


@pytest.mark.parametrize("add", [add_scan_parser, add_register_parser])
def test_every_option_says_what_it_means_and_its_default(add):
    parser = argparse.ArgumentParser()
    add(parser.add_subparsers(dest="command"))
    subparser = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    command = next(iter(subparser.choices.values()))
    for action in command._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        text = command._get_formatter()._expand_help(action)
        assert len(text) > 25, action.dest
        assert "default" in text or "required" in text, (action.dest, text)
        assert "None" not in text, (action.dest, text)
