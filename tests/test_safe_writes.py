"""Every file refsynth writes is written all or nothing, and never over one of its inputs.

- A write cut short (a file-size limit, a full disk, an error while the bytes
  are produced) leaves the previous file byte for byte, no temporary file
  beside it, and raises an OSError naming the file; the command line prints
  one line and exits 2.
- Output paths are checked before any work: a folder that takes no file
  (``/proc``) fails at once; an output naming an input (directly or through
  a link) or another output is refused, and the input is untouched.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import refsynth._files
from refsynth.cli.main import main
from refsynth.cli.model import write_camera_file
from refsynth.evaluation.results_io import write_csv, write_json
from refsynth.io import write_array, write_pfm, write_png16, write_unit_png16
from refsynth.model import PinholeCamera, build_model, write_ply
from refsynth.plotting.layouts import save_figure

ROOT = Path(__file__).resolve().parents[1]
OLD = b"the previous file, which must survive\n"


def _env() -> dict:
    """The environment of a child ``python``: this worktree's ``refsynth`` first."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def _model():
    return build_model(np.full((6, 8), 3.0), PinholeCamera(50.0, 3.5, 2.5))


def _figure():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 2))
    fig.add_subplot().plot([0, 1], [1, 0])
    return fig


#: name -> (file name, write(path)): every kind of file the package writes outside a scan.
WRITERS = {
    "npy": ("a.npy", lambda p: write_array(p, np.arange(5000.0))),
    "pfm": ("a.pfm", lambda p: write_pfm(p, np.ones((40, 50)))),
    "png16": ("a.png", lambda p: write_png16(p, np.full((40, 50), 7.0))),
    "unit-png": ("c.png", lambda p: write_unit_png16(p, np.full((40, 50), 0.5))),
    "ply": ("m.ply", lambda p: write_ply(p, _model())),
    "ply-ascii": ("m.ply", lambda p: write_ply(p, _model(), ascii=True)),
    "json": ("rows.json", lambda p: write_json(p, [{"method": "np", "mar": 0.5}] * 50)),
    "csv": ("rows.csv", lambda p: write_csv(p, [{"scene": "s", "mar": 0.5}] * 50)),
    "figure": ("f.png", lambda p: save_figure(_figure(), p, dpi=50)),
    "camera": ("camera.json", lambda p: write_camera_file(p, PinholeCamera(5.0, 1.0, 1.0),
                                                          (3, 3))),
}


@pytest.mark.parametrize("kind", sorted(WRITERS))
def test_every_writer_replaces_the_file_only_when_complete(tmp_path, kind, monkeypatch):
    """fsync failing (as a full disk does) leaves the old bytes and no temporary file."""
    name, write = WRITERS[kind]
    target = tmp_path / name
    target.write_bytes(OLD)

    def failing_fsync(descriptor):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(refsynth._files.os, "fsync", failing_fsync)
    with pytest.raises(OSError, match=f"cannot write '{target}': No space left on device"):
        write(target)
    assert target.read_bytes() == OLD
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]
    monkeypatch.undo()
    write(target)  # and the same writer does replace it once the disk has room
    assert target.read_bytes() != OLD
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_an_error_while_the_bytes_are_produced_leaves_the_old_file(tmp_path, monkeypatch):
    """A figure whose rendering fails half-way: the old file stays, no temporary is left."""
    target = tmp_path / "f.png"
    target.write_bytes(OLD)
    fig = _figure()

    def half_then_fail(stream, **kwargs):
        stream.write(b"\x89PNG half a picture")
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(fig, "savefig", half_then_fail)
    with pytest.raises(OSError, match="cannot write '.*f.png'"):
        save_figure(fig, target, dpi=50)
    assert target.read_bytes() == OLD
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]


_LIMITED = textwrap.dedent("""
    import resource, signal, sys
    from pathlib import Path
    import numpy as np
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # EFBIG instead of a killed process
    limit = int(sys.argv[1])
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    from refsynth.io import write_array
    from refsynth.model import PinholeCamera, build_model, write_ply
    path, count = Path(sys.argv[2]), int(sys.argv[3])
    try:
        if path.suffix == ".ply":
            write_ply(path, build_model(np.full((1, count), 3.0), PinholeCamera(5.0, 0.0, 0.0)))
        else:
            values = np.random.default_rng(0).integers(1, 60000, count).astype(float)
            write_array(path, values[None, :])  # random: a PNG cannot compress it
    except OSError as error:
        print(error)
        sys.exit(3)
""")


@pytest.mark.skipif(not hasattr(os, "fork") or sys.platform == "darwin",
                    reason="RLIMIT_FSIZE as on Linux")
@pytest.mark.parametrize("suffix", [".npy", ".pfm", ".png", ".ply"])
@pytest.mark.parametrize("count", [700, 30_000])
def test_a_file_size_limit_leaves_the_previous_file(tmp_path, suffix, count):
    """A real short write (RLIMIT_FSIZE): small (caught only at flush) and large arrays.

    The limit is 1000 bytes: a 700-value array is a little more (1400 to 5600
    bytes) and sits in the write buffer until flushed (numpy's ``tofile``
    used to lose that error at close); a 30 000-value one fails during the
    write.
    """
    target = tmp_path / f"out{suffix}"
    target.write_bytes(OLD)
    proc = subprocess.run([sys.executable, "-c", _LIMITED, "1000", str(target), str(count)],
                          capture_output=True, text=True, env=_env(), timeout=120)
    assert proc.returncode == 3, proc.stderr
    assert f"cannot write '{target}'" in proc.stdout and "File too large" in proc.stdout
    assert target.read_bytes() == OLD
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


@pytest.fixture
def scene(tmp_path):
    """A small image and partial range on disk."""
    rng = np.random.default_rng(1)
    np.save(tmp_path / "image.npy", rng.random((16, 20)))
    partial = np.where(np.arange(20) % 3 == 0, 2.0 + rng.random((16, 20)), np.nan)
    np.save(tmp_path / "partial.npy", partial)
    return tmp_path


@pytest.mark.skipif(not hasattr(os, "fork") or sys.platform == "darwin",
                    reason="RLIMIT_FSIZE as on Linux")
def test_synth_under_a_file_size_limit_prints_one_line_and_keeps_the_old_output(scene):
    out = scene / "dense.npy"
    out.write_bytes(OLD)
    code = ("import resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
            "resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000)); "
            "from refsynth.cli.main import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", code, "synth", str(scene / "image.npy"),
                           str(scene / "partial.npy"), "--out", str(out)],
                          capture_output=True, text=True, env=_env(), timeout=300)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("refsynth synth: error:"), proc.stderr
    assert str(out) in lines[0] and "File too large" in lines[0]
    assert "wrote" not in proc.stdout
    assert out.read_bytes() == OLD
    assert sorted(p.name for p in scene.iterdir()) == ["dense.npy", "image.npy", "partial.npy"]


# ----------------------------------------------------------------------------- before the work


def _fails(argv, capsys, needle) -> str:
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], captured.err
    assert "wrote" not in captured.out
    return lines[0]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
def test_synth_into_proc_fails_at_once_naming_the_path(tmp_path, capsys):
    """Even as root (for whom permission bits allow everything), before a long fill."""
    rng = np.random.default_rng(0)
    np.save(tmp_path / "image.npy", rng.random((120, 160)))
    np.save(tmp_path / "partial.npy", np.where(np.arange(160) % 8 == 0, 2.0, np.nan)
            * np.ones((120, 1)))
    start = time.perf_counter()
    line = _fails(["synth", str(tmp_path / "image.npy"), str(tmp_path / "partial.npy"),
                   "--method", "bp", "--out", "/proc/x.npy"], capsys, "/proc/x.npy")
    assert time.perf_counter() - start < 1.0
    assert line.startswith("refsynth synth: error: --out")


def _same_bytes_after(paths, run):
    before = {p: Path(p).read_bytes() for p in paths}
    run()
    for path, data in before.items():
        assert Path(path).read_bytes() == data, path


@pytest.mark.parametrize(("option", "target"), [
    ("--out", "partial.npy"), ("--out", "image.npy"), ("--confidence", "partial.npy"),
    ("--figure", "image.npy"), ("--out", "link.npy"),
])
def test_synth_refuses_to_write_over_an_input(scene, capsys, option, target):
    (scene / "link.npy").symlink_to(scene / "partial.npy")
    argv = ["synth", str(scene / "image.npy"), str(scene / "partial.npy"), "--out",
            str(scene / "dense.npy")]
    if option == "--out":
        argv[-1] = str(scene / target)
    else:
        argv += [option, str(scene / target)]
    if option == "--figure":  # a figure's suffix names its format: an input must look like one
        np.save(scene / "image.npy", np.random.default_rng(1).random((16, 20)))
        (scene / "image.png").write_bytes((scene / "image.npy").read_bytes())
        argv[1] = argv[-1] = str(scene / "image.png")
    _same_bytes_after([scene / "image.npy", scene / "partial.npy"],
                      lambda: _fails(argv, capsys, "is one of the inputs"))


def test_synth_refuses_the_mask_as_output(scene, capsys):
    np.save(scene / "mask.npy", np.ones((16, 20), dtype=np.uint8))
    argv = ["synth", str(scene / "image.npy"), str(scene / "partial.npy"), "--mask",
            str(scene / "mask.npy"), "--out", str(scene / "mask.npy")]
    _same_bytes_after([scene / "mask.npy"], lambda: _fails(argv, capsys, "one of the inputs"))


def test_synth_refuses_two_outputs_naming_one_file(scene, capsys):
    argv = ["synth", str(scene / "image.npy"), str(scene / "partial.npy"),
            "--out", str(scene / "d.png"), "--figure", str(scene / "." / "d.png"),
            "--png-scale", "1000"]
    _fails(argv, capsys, "--out and --figure name the same file")
    assert not (scene / "d.png").exists()


@pytest.fixture
def plys(tmp_path):
    for name in ("a.ply", "b.ply"):
        write_ply(tmp_path / name, _model())
    (tmp_path / "poses.json").write_text(json.dumps([{"x": 0}, {"x": 1.0}]))
    np.save(tmp_path / "dense.npy", np.full((6, 8), 3.0))
    (tmp_path / "link.ply").symlink_to(tmp_path / "dense.npy")
    return tmp_path


@pytest.mark.parametrize("argv", [
    ["model", "{dense.npy}", "--focal", "30", "--out", "{link.ply}"],
    ["model", "{dense.npy}", "--focal", "30", "--partial", "{a.ply}", "--out", "{a.ply}"],
    ["model", "--merge", "{a.ply}", "{b.ply}", "--poses", "{poses.json}", "--out", "{a.ply}"],
    ["model", "--merge", "{a.ply}", "{b.ply}", "--poses", "{poses.json}", "--out", "{b.ply}"],
    ["model", "--merge", "{a.ply}", "{b.ply}", "--poses", "{poses.json}", "--out", "{c.ply}",
     "--poses-out", "{poses.json}"],
])
def test_model_refuses_to_write_over_an_input(plys, capsys, argv):
    argv = [str(plys / a[1:-1]) if a.startswith("{") else a for a in argv]
    inputs = [plys / n for n in ("a.ply", "b.ply", "poses.json", "dense.npy")]
    _same_bytes_after(inputs, lambda: _fails(argv, capsys, "is one of the inputs"))
    assert not (plys / "c.ply").exists()


def test_evaluate_refuses_to_write_over_an_input(tmp_path, capsys):
    rows = [{"scene": "synthetic-room-0", "method": "np"}]
    (tmp_path / "rows.json").write_text(json.dumps(rows))
    argv = ["evaluate", "--load", str(tmp_path / "rows.json"), "--json",
            str(tmp_path / "rows.json")]
    _same_bytes_after([tmp_path / "rows.json"],
                      lambda: _fails(argv, capsys, "is one of the inputs"))


def test_evaluate_refuses_the_disparity_as_output(tmp_path, capsys):
    write_png16(tmp_path / "disp.png", np.full((20, 20), 8.0))
    write_unit_png16(tmp_path / "im.png", np.full((20, 20), 0.5))
    (tmp_path / "disp.csv").write_bytes(OLD)
    (tmp_path / "disp.csv").unlink()
    (tmp_path / "link.csv").symlink_to(tmp_path / "disp.png")
    argv = ["evaluate", "--scene", f"{tmp_path / 'im.png'}:{tmp_path / 'disp.png'}",
            "--csv", str(tmp_path / "link.csv")]
    _same_bytes_after([tmp_path / "disp.png"],
                      lambda: _fails(argv, capsys, "is one of the inputs"))


@pytest.mark.parametrize("command", [["figures", "--quick"], ["demo", "--quick"], ["demo"]])
def test_folder_commands_refuse_an_output_file_that_is_a_folder(tmp_path, capsys, command):
    name = "fig07_ordering.png" if command[0] == "figures" else (
        "demo_result.png" if "--quick" in command else "room.ply")
    (tmp_path / name).mkdir()
    start = time.perf_counter()
    _fails([*command, "--out", str(tmp_path)], capsys, f"{tmp_path / name}: it is a folder")
    assert time.perf_counter() - start < 5.0


def test_a_new_file_gets_the_umask_s_permissions_and_a_replaced_one_keeps_its_own(tmp_path):
    """The temporary file is created 0600; the file it becomes is not left so."""
    previous = os.umask(0o027)
    try:
        path = write_array(tmp_path / "new.npy", np.ones(3))
        assert path.stat().st_mode & 0o777 == 0o640
        os.chmod(path, 0o604)
        write_array(path, np.zeros(3))
        assert path.stat().st_mode & 0o777 == 0o604
    finally:
        os.umask(previous)


def test_check_output_tries_a_real_file_where_permission_bits_say_yes(tmp_path, monkeypatch):
    """Root passes every os.access test: the folder is asked to take a file instead."""
    import tempfile

    from refsynth.cli.arguments import check_output

    def refuse(*args, **kwargs):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(OSError, match=f"--out: cannot write {tmp_path / 'o.npy'}: the folder "
                                      f"{tmp_path} does not take new files .Read-only file"):
        check_output(str(tmp_path / "o.npy"), "--out", (".npy",))
    monkeypatch.undo()
    assert check_output(str(tmp_path / "o.npy"), "--out", (".npy",)) == tmp_path / "o.npy"
    assert list(tmp_path.iterdir()) == []  # the trial file is gone
