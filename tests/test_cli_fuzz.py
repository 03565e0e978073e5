"""A fuzz of the command line: random argv never gives a traceback.

Random argv are drawn from each subcommand's own option names, real and junk
values (tiny files, damaged files, missing files, bad numbers, odd paths) and
run through :func:`refsynth.cli.main.main` in-process. Every run must exit 0
or 2, print no traceback, and print at most one line on stderr when it exits
2. To stay fast, the work that would start after the checks — the demo, the
figures, the evaluation grid, and the subcommands owned elsewhere (scan,
register, model, notebooks: their argparse layer is fuzzed) — is replaced by
a stub that raises :class:`WorkStarted`; ``synth`` runs for real on 8×9
images.
"""

import argparse
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

import refsynth.cli.main as cli_main
from refsynth.io import write_pfm

#: Subcommands whose handler is replaced by a stub (their parsers are still fuzzed).
STUBBED_COMMANDS = ("scan", "register", "model", "notebooks")
#: Library calls behind the checks of the subcommands, replaced by a stub.
STUBBED_WORK = ("refsynth.cli.demo.run_demo", "refsynth.cli.demo.run_pipeline_demo",
                "refsynth.cli.figures.make_figures", "refsynth.cli.evaluate.run_cases")


class WorkStarted(BaseException):  # noqa: N818 - not an error: the checks passed
    """Raised by a stub where the real work would start."""


def _work_started(*args, **kwargs):
    raise WorkStarted


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Tiny inputs, damaged inputs, saved rows; every path the fuzz names is inside."""
    root = tmp_path_factory.mktemp("cli-fuzz")
    rng = np.random.default_rng(0)
    image = rng.random((8, 9))
    partial = np.where(np.arange(9) % 3 == 0, 2.0 + image, np.nan)
    np.save(root / "image.npy", image)
    Image.fromarray((image * 255).astype(np.uint8)).save(root / "image.png")
    np.save(root / "partial.npy", partial)
    write_pfm(root / "partial.pfm", np.where(np.isnan(partial), np.inf, partial))
    stored = np.where(np.isnan(partial), 0, np.rint(partial * 1000)).astype(np.uint16)
    Image.fromarray(stored).save(root / "range.png")
    np.save(root / "mask.npy", np.isfinite(partial).astype(np.uint8))
    np.save(root / "complex.npy", partial + 0j)
    np.save(root / "full.npy", 2.0 + image)
    (root / "junk.npy").write_bytes(b"\x93NUMPY\x01\x00{'descr'")
    (root / "junk.pfm").write_bytes(b"Pf\r\n1_0 2\n-1\n\x00\x00")
    (root / "junk.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    (root / "note.txt").write_text("hello")
    (root / "deep.json").write_text("[" * 50_000 + "]" * 50_000)
    (root / "wrong.json").write_text(json.dumps([1, 2, {"scene": None}]))
    row = dict(scene="synthetic-room-0", scene_spec="synthetic-0", size="16x16", units="m",
               sampling="x78", unknown_percent=75.0, known=64, evaluated=192,
               method="nearest", seeds=[0], mar=0.5, mar_sd=None, mar_min=0.5, mar_max=0.5,
               mar_per_seed=[0.5], rmse=0.7, bad1=0.1, bad3=0.0, seconds=0.01)
    (root / "rows.json").write_text(json.dumps([row]))
    (root / "a-folder").mkdir()
    return root


FILES = ["image.npy", "image.png", "partial.npy", "partial.pfm", "range.png", "mask.npy",
         "complex.npy", "full.npy", "junk.npy", "junk.pfm", "junk.png", "note.txt",
         "missing.npy", "deep.json", "wrong.json", "rows.json", "a-folder", "note.txt/x.npy"]
OUTPUTS = ["out.npy", "out.pfm", "out.png", "out.tif", "out", "", "a-folder", "a-folder/",
           "new/sub/out.npy", "note.txt/out.npy", "out.json", "out.csv", "fig.png", "fig.txt"]
NUMBERS = ["0", "1", "2", "3", "5", "-1", "0.5", "2.5", "1e-3", "1e30", "nan", "inf", "-inf",
           "abc", "", "٣", "1_0", "0x10", "99999999999999999999", "12345678901234567890123"]
WORDS = ["np", "bp", "onion", "priority", "default", "quick", "synthetic", "synthetic-1",
         "synthetic-٣", "motorcycle", "kitchen", "x78", "g5_25", "g1_99999999999999999999999",
         "distance40", "nearest", "np,bp", "np,magic", "16", "32", "16x16", "100000",
         "native", ",", "image.npy:partial.npy", "a:b", "tcp://127.0.0.1:1", "-", "--",
         "corrupt=0.1,corrupt=0.2"]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


COMMANDS = _subparsers(cli_main.build_parser())
OPTIONS = {name: sorted({s for a in sub._actions for s in a.option_strings})
           for name, sub in COMMANDS.items()}
#: The options that take no value (flags), per subcommand.
FLAGS = {name: {s for a in sub._actions if a.nargs == 0 for s in a.option_strings}
         for name, sub in COMMANDS.items()}


#: A valid start for each subcommand that runs its checks to the end (or to the stub).
BASES = {
    "synth": [["image.npy", "partial.npy", "--out", "out.npy"],
              ["image.png", "range.png", "--out", "out.png", "--method", "bp"]],
    "evaluate": [["--scene", "synthetic", "--size", "16", "--sampling", "x78",
                  "--methods", "nearest", "--quiet"], ["--load", "rows.json"]],
    "demo": [["--size", "16", "--out", "demo-out"]],
    "figures": [["--quick", "--out", "figures-out"]],
}


@st.composite
def argv(draw):
    """A subcommand, then a shuffled mix of its options (with values) and positionals.

    Half the time the mix is added to a valid start (:data:`BASES`), so that
    the checks after parsing are reached too.
    """
    command = draw(st.sampled_from(sorted(COMMANDS)))
    value = st.one_of(st.sampled_from(FILES), st.sampled_from(OUTPUTS),
                      st.sampled_from(NUMBERS), st.sampled_from(WORDS))
    options = [o for o in OPTIONS[command] if o not in ("-h", "--help")]
    base = draw(st.sampled_from(BASES[command])) if command in BASES and draw(
        st.booleans()) else None
    items = []
    chosen = draw(st.lists(st.sampled_from(options), max_size=2 if base else 6)) if options else []
    for option in chosen:
        takes_value = option not in FLAGS[command] if base else draw(st.integers(0, 4))
        items.append([option] + ([draw(value)] if takes_value else []))
    if base is None:
        items += [[draw(st.sampled_from(FILES + WORDS))]
                  for _ in range(draw(st.integers(0, 3)))]
    order = draw(st.permutations(range(len(items))))
    return [command, *(base or []), *[word for i in order for word in items[i]]]


def _stubbed_parser(real_build):
    def build():
        parser = real_build()
        for name in STUBBED_COMMANDS:
            if name in _subparsers(parser):
                _subparsers(parser)[name].set_defaults(func=_work_started)
        return parser

    return build


@pytest.fixture
def stubbed(folder, monkeypatch):
    """In ``folder``, with the long work and the subcommands owned elsewhere stubbed."""
    monkeypatch.chdir(folder)
    monkeypatch.setattr(cli_main, "build_parser", _stubbed_parser(cli_main.build_parser))
    for target in STUBBED_WORK:
        monkeypatch.setattr(target, _work_started)
    return folder


@settings(deadline=None, max_examples=150,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(words=argv())
def test_random_argv_exit_0_or_2_with_at_most_one_line(stubbed, capsys, words):
    try:
        status = cli_main.main(words)
    except WorkStarted:
        status = None
    err = capsys.readouterr().err
    assert "Traceback" not in err, (words, err)
    if status is not None:
        assert status in (0, 2), (words, status, err)
    if status == 2:
        assert len(err.strip().splitlines()) == 1, (words, err)
