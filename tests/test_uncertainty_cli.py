"""The uncertainty map outside synthesize(): synth's output, the figures, the model and its PLY."""

import numpy as np
import plyfile
import pytest
from hypothesis import given
from hypothesis import strategies as st

import refsynth
from refsynth.cli.main import main
from refsynth.model import PinholeCamera, Pose, build_model, merge_models, read_ply, write_ply
from refsynth.plotting.layouts import methods_figure, result_figure

NAN = np.nan


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(0)
    image = rng.random((20, 24))
    truth = np.where(np.arange(24) < 12, 2.0, 4.0)[None, :].repeat(20, 0)
    partial = np.where(np.arange(24) % 4 == 0, truth, NAN)
    np.save(tmp_path / "image.npy", image)
    np.save(tmp_path / "partial.npy", partial)
    return tmp_path


def _run(argv, capsys):
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err.strip().splitlines()


# ----------------------------------------------------------------------------- synth


@pytest.mark.parametrize("method", ["np", "bp"])
def test_synth_writes_the_uncertainty_map(files, capsys, method):
    out = files / f"u_{method}.npy"
    status, printed, _ = _run(["synth", files / "image.npy", files / "partial.npy", "--out",
                               files / "o.npy", "--method", method, "--uncertainty-out", out],
                              capsys)
    assert status == 0 and f"wrote {out}: expected absolute error" in printed
    written = np.load(out)
    partial = np.load(files / "partial.npy")
    known = np.isfinite(partial)
    assert np.all(written[known] == 0) and np.all(written[~known] > 0)
    expected = refsynth.synthesize(np.load(files / "image.npy"), partial, method=method)
    assert np.array_equal(written, expected.uncertainty)


@pytest.mark.parametrize(("value", "needle"), [
    ("u.png", "--uncertainty-out must end in .npy, .pfm"),
    ("u.txt", "--uncertainty-out must end in"),
    ("o.npy", "name the same file"),
    ("partial.npy", "--uncertainty-out"),
])
def test_synth_bad_uncertainty_paths_fail_before_the_work(files, capsys, monkeypatch, value,
                                                          needle):
    def forbidden(*args, **kwargs):
        raise AssertionError("the work started before the checks failed")

    monkeypatch.setattr("refsynth.cli.synth.synthesize", forbidden)
    monkeypatch.chdir(files)
    status, _, err = _run(["synth", "image.npy", "partial.npy", "--out", "o.npy",
                           "--uncertainty-out", value], capsys)
    assert status == 2 and len(err) == 1 and needle in err[0], err
    assert not (files / "o.npy").exists() and not (files / "u.png").exists()


def test_synth_figure_shows_the_uncertainty(files, capsys, monkeypatch):
    shown = {}

    def keep(fig, path, dpi=None):
        shown["titles"] = [ax.get_title() for ax in fig.axes]

    monkeypatch.setattr("refsynth.cli.synth.save_figure", keep)
    status, _, _ = _run(["synth", files / "image.npy", files / "partial.npy", "--out",
                         files / "o.npy", "--figure", files / "f.png"], capsys)
    assert status == 0 and any(t.startswith("uncertainty, mean") for t in shown["titles"])


# ----------------------------------------------------------------------------- figures


def test_result_figure_puts_the_uncertainty_beside_the_residual():
    truth = np.tile(np.linspace(1, 3, 10), (8, 1))
    partial = np.where(np.arange(10) % 3 == 0, truth, NAN)
    unc = np.where(np.isfinite(partial), 0.0, 0.2)
    fig = result_figure(truth / 3, np.zeros(truth.shape, bool), partial, truth + 0.1, truth,
                        units="m", uncertainty=unc)
    titles = [ax.get_title() for ax in fig.axes]
    assert titles.index("uncertainty, mean 0.2 m") == titles.index(
        "|residual|, MAR 0.1 m") + 1
    assert "uncertainty" not in " ".join(
        ax.get_title() for ax in result_figure(truth / 3, np.zeros(truth.shape, bool), partial,
                                               truth + 0.1, truth).axes)
    # without truth: the four panels and the uncertainty
    fig = result_figure(truth / 3, np.zeros(truth.shape, bool), partial, truth, uncertainty=unc)
    assert "uncertainty, mean 0.2" in [ax.get_title() for ax in fig.axes]


def test_methods_figure_adds_an_uncertainty_column():
    truth = np.tile(np.linspace(1, 3, 10), (8, 1))
    partial = np.where(np.arange(10) % 3 == 0, truth, NAN)
    conf = np.full(truth.shape, 0.5)
    fig = methods_figure(truth, partial, {"NP": (truth, conf, conf), "BP": (truth, conf)})
    titles = [ax.get_title() for ax in fig.axes]
    assert titles.count("uncertainty, mean 0.5") == 1
    assert len(methods_figure(truth, partial, {"NP": (truth, conf)}).axes) == 3 + 3


# ----------------------------------------------------------------------------- the model


def _depth():
    depth = np.full((6, 8), 3.0)
    unc = np.zeros(depth.shape)
    unc[:, 3] = 0.5  # one uncertain column
    unc[:, 5] = 0.05
    return depth, unc


def test_build_model_carries_and_thresholds_the_uncertainty():
    depth, unc = _depth()
    camera = PinholeCamera(100.0, 4.0, 3.0)
    whole = build_model(depth, camera, uncertainty=unc)
    assert np.array_equal(whole.uncertainty, unc.ravel())
    cut = build_model(depth, camera, uncertainty=unc, max_uncertainty=0.1)
    assert cut.n_vertices == whole.n_vertices - 6
    assert np.all(cut.uncertainty <= 0.1) and not np.any(cut.pixels[:, 1] == 3)
    # the triangles using column 3 go: two columns of quads (2-3, 3-4) x 5 rows x 2 triangles
    assert cut.n_faces == whole.n_faces - 2 * 5 * 2
    assert build_model(depth, camera).uncertainty is None
    assert cut.subset(np.ones(cut.n_vertices, bool)).uncertainty is not None


def test_build_model_drops_the_most_uncertain_fraction_of_the_synthesized_points():
    """drop_uncertain = 0.25 of the 16 synthesized pixels: the 4 most uncertain, the tie at
    the cut broken in raster order; measured pixels (uncertainty 0) stay."""
    depth = np.full((4, 6), 3.0)
    unc = np.zeros(depth.shape)
    unc[:, 1:5] = np.array([[0.1, 0.2, 0.3, 0.4],
                            [0.9, 0.1, 0.5, 0.2],
                            [0.5, 0.1, 0.1, 0.3],
                            [0.2, 0.5, 0.1, 0.7]])
    camera = PinholeCamera(100.0, 3.0, 2.0)
    cut = build_model(depth, camera, uncertainty=unc, drop_uncertain=0.25)
    gone = {(r, c) for r in range(4) for c in range(6)} - set(map(tuple, cut.pixels.tolist()))
    assert gone == {(1, 1), (3, 4), (1, 3), (2, 1)}    # 0.9, 0.7, then the first two 0.5s
    assert cut.n_vertices == 20
    assert build_model(depth, camera, uncertainty=unc, drop_uncertain=1.0).n_vertices == 8
    none = build_model(depth, camera, uncertainty=unc, drop_uncertain=0.0)
    assert none.n_vertices == 24 and none.n_faces == build_model(depth, camera).n_faces
    both = build_model(depth, camera, uncertainty=unc, drop_uncertain=0.25,
                       max_uncertainty=0.35)
    assert both.n_vertices == 24 - 6                   # the 4 above and 0.4, the last 0.5
    flat = build_model(np.full((12, 12), 3.0), camera, uncertainty=np.full((12, 12), 0.2),
                       drop_uncertain=0.5)
    assert flat.pixels[:, 0].min() == 6               # all tied: the first half in raster order


@given(st.integers(0, 2**32 - 1), st.floats(0.0, 1.0))
def test_drop_uncertain_keeps_no_point_more_uncertain_than_one_it_drops(seed, fraction):
    """The dropped pixels are the first round(fraction · n) of the synthesized ones in
    Python's (stable) sort by decreasing uncertainty."""
    rng = np.random.default_rng(seed)
    depth = np.full((12, 15), 2.0)
    unc = np.where(rng.random(depth.shape) < 0.3, 0.0, rng.integers(1, 5, depth.shape) / 4)
    cut = build_model(depth, PinholeCamera(50.0, 7.0, 6.0), uncertainty=unc,
                      drop_uncertain=fraction)
    kept = np.zeros(depth.shape, bool)
    kept[cut.pixels[:, 0], cut.pixels[:, 1]] = True
    synthesized = [i for i, u in enumerate(unc.ravel()) if u > 0]
    order = sorted(synthesized, key=lambda i: -unc.ravel()[i])
    assert set(np.flatnonzero(~kept.ravel())) == set(order[:round(fraction * len(order))])


@pytest.mark.parametrize(("kwargs", "error", "needle"), [
    (dict(drop_uncertain=0.1), ValueError, "needs `uncertainty`"),
    (dict(uncertainty=np.zeros((6, 8)), drop_uncertain=1.5), ValueError, "drop_uncertain"),
    (dict(uncertainty=np.zeros((6, 8)), drop_uncertain="0.1"), TypeError, "drop_uncertain"),
    (dict(max_uncertainty=0.1), ValueError, "needs `uncertainty`"),
    (dict(uncertainty=np.zeros((2, 2))), ValueError, "uncertainty"),
    (dict(uncertainty=np.full((6, 8), -1.0)), ValueError, ">= 0"),
    (dict(uncertainty=np.full((6, 8), np.inf)), ValueError, "finite"),
    (dict(uncertainty=np.zeros((6, 8)), max_uncertainty=-1.0), ValueError, "max_uncertainty"),
    (dict(uncertainty=np.zeros((6, 8)), max_uncertainty="1"), TypeError, "max_uncertainty"),
])
def test_build_model_refuses_a_bad_uncertainty(kwargs, error, needle):
    with pytest.raises(error, match=needle):
        build_model(np.full((6, 8), 3.0), PinholeCamera(100.0, 4.0, 3.0), **kwargs)


@pytest.mark.parametrize("ascii", [False, True])
def test_the_ply_carries_the_uncertainty_beside_the_confidence(tmp_path, ascii):
    depth, unc = _depth()
    model = build_model(depth, PinholeCamera(100.0, 4.0, 3.0), uncertainty=unc + 0.1)
    path = write_ply(tmp_path / "m.ply", model, ascii=ascii)
    names = [p.name for p in plyfile.PlyData.read(str(path))["vertex"].properties]
    assert names[names.index("confidence") + 1] == "uncertainty"
    back = read_ply(path)
    assert np.array_equal(back.uncertainty, model.uncertainty.astype(np.float32))
    plain = write_ply(tmp_path / "p.ply", build_model(depth, PinholeCamera(100.0, 4.0, 3.0)))
    assert "uncertainty" not in [p.name for p in plyfile.PlyData.read(str(plain))["vertex"]
                                 .properties]
    assert read_ply(plain).uncertainty is None


def test_merging_keeps_the_uncertainty_when_every_model_has_one():
    depth, unc = _depth()
    camera = PinholeCamera(100.0, 4.0, 3.0)
    a = build_model(depth, camera, uncertainty=unc)
    b = build_model(depth + 1, camera, uncertainty=unc + 1)
    merged = merge_models([a, b], [Pose(), Pose(x=10.0)])
    assert merged.uncertainty is not None and merged.uncertainty.max() == 1.5
    assert merge_models([a, build_model(depth, camera)], [Pose(), Pose(x=10.0)]).uncertainty \
        is None


def test_model_cli_reads_the_map_and_drops_above_the_threshold(tmp_path, capsys):
    depth, unc = _depth()
    np.save(tmp_path / "d.npy", depth)
    np.save(tmp_path / "u.npy", unc)
    common = ["model", tmp_path / "d.npy", "--camera", "pinhole", "--focal", "100", "--cx", "4",
              "--cy", "3"]
    assert _run([*common, "--uncertainty", tmp_path / "u.npy", "--out", tmp_path / "a.ply"],
                capsys)[0] == 0
    assert _run([*common, "--uncertainty", tmp_path / "u.npy", "--max-uncertainty", "0.1",
                 "--out", tmp_path / "b.ply"], capsys)[0] == 0
    status, out, _ = _run([*common, "--uncertainty", tmp_path / "u.npy", "--drop-uncertain",
                           "0.5", "--out", tmp_path / "c.ply"], capsys)
    assert status == 0 and "(42 synthesized; 6 dropped as too uncertain)" in out
    a, b = read_ply(tmp_path / "a.ply"), read_ply(tmp_path / "b.ply")
    assert a.n_vertices == depth.size and b.n_vertices == depth.size - 6
    assert np.allclose(np.sort(a.uncertainty), np.sort(unc.ravel()).astype(np.float32))
    c = read_ply(tmp_path / "c.ply")                    # half the 12 synthesized: column 3
    assert c.n_vertices == depth.size - 6 and c.uncertainty.max() == np.float32(0.05)


@pytest.mark.parametrize(("extra", "needle"), [
    (["--max-uncertainty", "0.1"], "--max-uncertainty needs --uncertainty"),
    (["--uncertainty", "missing.npy"], "uncertainty file not found"),
    (["--uncertainty", "small.npy"], "differs from the range's"),
    (["--uncertainty", "negative.npy"], "must be finite and >= 0"),
    (["--uncertainty", "u.npy", "--max-uncertainty", "-1"], "--max-uncertainty must be >= 0"),
    (["--drop-uncertain", "0.1"], "--drop-uncertain needs --uncertainty"),
    (["--uncertainty", "u.npy", "--drop-uncertain", "2"], "--drop-uncertain must be a fraction"),
])
def test_model_cli_bad_uncertainty_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch, extra,
                                                          needle):
    monkeypatch.chdir(tmp_path)
    np.save("d.npy", np.full((6, 8), 3.0))
    np.save("u.npy", np.zeros((6, 8)))
    np.save("small.npy", np.zeros((2, 2)))
    np.save("negative.npy", np.full((6, 8), -1.0))
    status, _, err = _run(["model", "d.npy", "--camera", "pinhole", "--focal", "100", *extra,
                           "--out", "m.ply"], capsys)
    assert status == 2 and len(err) == 1 and needle in err[0], err
    assert not (tmp_path / "m.ply").exists()
