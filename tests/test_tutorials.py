"""The tutorials: they run, write their figures, and their text's claims hold; the solutions run.

Each tutorial runs once per session (``tutorial_runs.py``): as a notebook
when the ``course`` extra is installed (``test_notebooks.py`` checks the
inline figures of the same run), else as plain Python. The claims below are
the ones the tutorials' text makes about the numbers they print (the
tutorials print them; the text explains them): if a change in refsynth
breaks one, the text must change with it. One tutorial also runs as plain
Python in every case, so the plain-Python path (Agg, files only) stays
checked. The solutions of the exercises assert their own answers. The runs the selected
tests need start ahead, two at a time (``tutorial_runs.prefetch``).
"""

import re

import pytest
from tutorial_runs import (
    PLAIN,
    SOLUTIONS,
    TUTORIALS,
    TUTORIALS_DIR,
    run,
    run_as_python,
    run_solution,
)

#: The tutorials execute (``-m "not slow"`` leaves them out).
pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("tutorial_runs_started")]

NUMBER = r"(-?[\d.]+)"


def numbers(pattern: str, text: str) -> list[float]:
    """The numbers captured by ``pattern`` (``{n}`` stands for a number) in ``text``."""
    found = re.search(pattern.replace("{n}", NUMBER), text)
    assert found, f"no match for {pattern!r} in the tutorial's output"
    return [float(value) for value in found.groups()]


def text_source(number: str) -> str:
    """The source (prose and code) of the tutorial whose file name starts with ``number``."""
    (path,) = TUTORIALS_DIR.glob(f"{number}_*.py")
    return " ".join(path.read_text(encoding="utf-8").replace("# ", " ").split())


def tie_or(mean_a, sd_a, mean_b, sd_b) -> str:
    if abs(mean_a - mean_b) <= sd_a + sd_b:
        return "a tie"
    return "better" if mean_a < mean_b else "worse"


def claims_00(text: str) -> None:
    by_hand, library = numbers(r"Eq. 13 by hand {n} m, refsynth.evaluation.mar {n} m", text)
    assert by_hand == library
    assert "a perfect fill scores 0.0" in text
    rows = {name.strip(): tuple(map(float, values)) for name, *values in re.findall(
        r"^\s*(.+?): +([\d.]+) % unknown, mean distance +([\d.]+) px, nearest MAR ([\d.]+) m, "
        r"linear MAR ([\d.]+) m$", text, flags=re.M)}
    assert len(rows) == 6
    # the text: ranked by the mean distance and by nearest's MAR, the samplings agree
    assert "ranked by mean distance and by nearest's MAR: the same order" in text
    # the layout matters as much as the fraction: 24/80 and 10/20, same fraction, far apart
    assert rows["grid 24/80"][0] == rows["grid 10/20"][0]
    assert rows["grid 24/80"][1] > 3 * rows["grid 10/20"][1]  # "several times further"
    assert rows["grid 24/80"][2] > 3 * rows["grid 10/20"][2]
    # vertical stripes and distance-driven columns are easy: narrow gaps, low errors,
    # and the linear fill does better still on the room's planes
    grids = [values for name, values in rows.items() if name.startswith("grid")]
    for easy in ("x-stripes 60 %", "distance-driven, 40 % known"):
        assert rows[easy][1] < 2.0
        assert rows[easy][2] < min(grid[2] for grid in grids)
        assert rows[easy][3] < rows[easy][2]


def claims_01(text: str) -> None:
    assert "identical 0.0000" in text
    a_b = re.search(r"a-b ([\d.]+), b-a ([\d.]+)", text)
    assert a_b and a_b.group(1) == a_b.group(2)
    assert "intensity term alone 0.0025" in text
    c_lo, c_hi, d_lo, d_hi, d_share = numbers(
        r"C in \[{n}, {n}\], D in \[{n}, {n}\] \(above 0.95 on {n} % of it\)", text)
    assert 0 <= c_lo <= c_hi <= 1 and 0 <= d_lo <= d_hi <= 1
    assert d_share > 75  # "D is close to 1 on most of the front"
    mar_np, mar_nn, mar_linear = numbers(
        r"NP: MAR {n} over \d+ synthesized pixels; nearest-neighbour fill: MAR {n}; "
        r"linear fill: MAR {n}", text)
    assert mar_np < mar_nn and mar_np < mar_linear
    ratios = [float(r) for r in re.findall(r"px from the known range: .* ratio ([\d.]+)", text)]
    assert len(ratios) == 3 and max(ratios) < 1  # "ahead at every distance"
    near, away = numbers(r"within 2 px of an intensity edge {n}, elsewhere {n}", text)
    assert near > 2 * away  # "concentrated at the intensity edges"
    late, early = numbers(r"mean fill time .*: within 2 px of an edge {n}, elsewhere {n}", text)
    assert late > early  # "its outline waits"
    scores = {label: tuple(map(float, values)) for label, *values in re.findall(
        r"^\s*(priority order|onion order|no edges|no isophotes): MAR ([\d.]+) ± ([\d.]+)",
        text, flags=re.M)}
    assert len(scores) == 4
    for other in ("onion order", "no edges", "no isophotes"):
        verdict = tie_or(*scores["priority order"], *scores[other])
        assert re.search(rf"against {other} \([^)]*\): {verdict}$", text, flags=re.M)
        # the text, under refsynth's readings of the fill: the edge term wins beyond the
        # spread, the onion order and the isophotes tie
        assert verdict == ("better" if other == "no edges" else "a tie"), other
    assert ("Under refsynth's readings of the fill the edge term wins beyond the spread and "
            "the onion order and the isophotes tie") in text_source("01")
    assert scores["no edges"][0] > scores["priority order"][0]
    small = {grid: (np_mar, nn) for grid, np_mar, nn in re.findall(
        r"64x64, grid (\d+/\d+) .*: NP MAR ([\d.]+) m \(3 seeds\), nearest ([\d.]+) m", text)}
    assert float(small["5/25"][0]) > float(small["5/25"][1])  # NP loses at 64x64, 5/25
    assert float(small["3/13"][0]) < float(small["3/13"][1])  # ... not with the grid scaled
    rings = [float(v) for v in re.findall(r"\d: ([\d.]+)", text.split("by ring into the holes:")[1]
                                          .splitlines()[0])]
    assert len(rings) == 5
    median, = numbers(r"confidence of synthesized pixels: median {n}", text)
    if median < 0.05:  # the text: "it falls ring by ring"
        assert "the confidence has all but vanished" in text
        assert all(a >= b for a, b in zip(rings, rings[1:]))
    else:
        assert "stays well above 0" in text


def claims_02(text: str) -> None:
    assert "agreeing candidate 0.0000" in text
    sweeps = re.findall(r"after \d sweep\(s\): P\(2 m\) per pixel = \[([\d., ]+)\]", text)
    assert len(sweeps) == 3
    sweeps = [[float(p) for p in probs.split(",")] for probs in sweeps]
    assert all(0.0 <= p <= 1.0 for probs in sweeps for p in probs)
    assert sweeps[1] == sweeps[2]  # settled after two sweeps
    assert sweeps[2][1] > 0.5 and sweeps[2][2] > 0.5  # the right pixel is pulled over to 2 m
    edge = [float(p) for p in re.search(r"on an edge: P\(2 m\) = \[([\d., ]+)\]", text)
            .group(1).split(",")]
    assert edge[0] == sweeps[0][0] and edge[2] < 0.5 < edge[1]  # the ends keep their evidence
    # section 4: per case NP, the nearest and colorization fills, then Fig. 6's BP, refsynth's
    # default BP over 3 seeds, and its seed 0 (MAR, sweeps, ceiling, error on the confident
    # half and the rest)
    cases, bps, current = {}, {}, None
    for line in text.splitlines():
        if re.match(r"^\S+, [\d.]+ % unknown: ", line):
            current = line.split(",")[0]
            cases[current] = dict(zip(("np", "np_sd", "nearest", "colorization"), numbers(
                r"NP: MAR {n} ± {n} \(3 seeds\); nearest: MAR {n}; colorization: MAR {n}$",
                line)))
        elif line.startswith("    BP, refsynth's defaults: "):
            cases[current]["bp"], cases[current]["bp_sd"] = numbers(
                r"MAR {n} ± {n} \(3 seeds; seed 0's details below\)$", line)
        elif line.startswith("    BP, "):
            label = "fig6" if line.startswith("    BP, Fig. 6 as printed: ") else "default"
            assert label == "fig6" or line.startswith("    BP, refsynth's defaults (seed 0): ")
            bps[current, label] = dict(zip(("mar", "sweeps", "ceiling", "top", "rest"), numbers(
                r"MAR {n} after {n} sweeps; candidate ceiling {n}; error on its 50 % most "
                r"confident pixels {n}, on the rest {n}$", line)))
    bike, room = "motorcycle-128x128", "synthetic-room-3"
    assert set(cases) == {bike, room} and len(bps) == 4
    for bp in bps.values():
        assert bp["top"] < bp["rest"]  # the confidence is the right way round, all four
    # Fig. 6's BP goes to the cap on both cases, refsynth's on the Motorcycle; it settles on
    # the room
    assert bps[bike, "fig6"]["sweeps"] == bps[room, "fig6"]["sweeps"] == 50
    assert bps[bike, "default"]["sweeps"] == 50 and bps[room, "default"]["sweeps"] < 50
    b, b6, bd = cases[bike], bps[bike, "fig6"], bps[bike, "default"]
    # the Motorcycle: refsynth's BP beats NP beyond the two spreads and beats the nearest and
    # colorization fills; Fig. 6's BP loses to NP beyond its spread and beats the nearest
    # fill narrowly; both ceilings well below every method's error, refsynth's not the lower
    # one (what improved is the pick, not the candidates)
    assert b["np"] - b["bp"] > b["np_sd"] + b["bp_sd"]
    assert b["bp"] < b["nearest"] and b["bp"] < b["colorization"]
    assert b6["mar"] - b["np"] > 2 * b["np_sd"]
    assert b6["mar"] < b["nearest"] < b6["mar"] + 0.02
    errors = (b6["mar"], bd["mar"], b["bp"], b["np"], b["nearest"], b["colorization"])
    assert max(b6["ceiling"], bd["ceiling"]) < 0.6 * min(errors)
    assert bd["ceiling"] >= b6["ceiling"]
    r, r6, rd = cases[room], bps[room, "fig6"], bps[room, "default"]
    # the room: refsynth's BP ties with NP and beats the nearest and colorization fills;
    # Fig. 6's BP loses to NP and to the nearest fill; refsynth's ceiling below NP's MAR,
    # Fig. 6's far above; refsynth's labels above its ceiling; its confident half better by
    # a wider margin than Fig. 6's
    assert abs(r["bp"] - r["np"]) <= r["np_sd"] + r["bp_sd"]
    assert r["bp"] < 0.5 * min(r["nearest"], r["colorization"])
    assert r6["mar"] > r["np"] and r6["mar"] > r["nearest"]
    assert rd["ceiling"] < r["np"] < r6["ceiling"]
    assert rd["mar"] - rd["ceiling"] > 0.005
    assert rd["rest"] - rd["top"] > r6["rest"] - r6["top"]
    # section 5: the gate and then the median lower NP's and BP's MAR on the Motorcycle's
    # x-stripes, the 3 x 3 window ties; on the room's grid the gate changes nothing and the
    # median acts alone
    post = {label: numbers(r"NP MAR {n} ± {n}, BP {n} ± {n}", rest) for label, rest in
            re.findall(r"^Motorcycle, x-stripes 63 %, (.*?): (NP MAR .*)$", text, flags=re.M)}
    assert list(post) == ["as filled", "gated", "gated, then the median",
                          "the same with the 3 x 3 window (the default)"]
    steps = list(post.values())
    for before, after in zip(steps[:3], steps[1:3]):
        assert after[0] < before[0] and after[2] < before[2]
    # the 3 x 3 window ties with the 5 x 5 here, NP and BP, within the seeds' spreads
    (np5, np5_sd, bp5, bp5_sd), (np3, np3_sd, bp3, bp3_sd) = steps[2], steps[3]
    assert abs(np3 - np5) <= np5_sd + np3_sd and abs(bp3 - bp5) <= bp5_sd + bp3_sd
    assert "the room's grid 5/25: the gate changes nothing (True)" in text
    filled, median = numbers(r"the room's grid 5/25, NP: MAR {n} m as filled, {n} m after", text)
    assert median < filled
    source = text_source("02")
    for phrase in ("On the Motorcycle's vertical stripes refsynth's BP beats NP",
                   "Fig. 6's BP loses to NP",
                   "On the room's grid refsynth's BP ties with NP",
                   "Fig. 6's BP loses to NP and to the nearest fill too",
                   "refsynth's is *below* NP's MAR",
                   "refsynth's ceiling is not the lower one",
                   "Fig. 6's BP goes to the cap of 50 sweeps on both cases",
                   "On the room refsynth's BP settles in a few sweeps"):
        assert phrase in source, phrase


def claims_03(text: str) -> None:
    trace = [float(d) for d in text.split("distance to the truth (px): ")[1].splitlines()[0]
             .split(", ")]
    assert abs(trace[-1] - trace[-2]) < 1e-3 and 0.01 < trace[-1] < 0.5  # converged, not to 0
    assert trace[3] < 0.2 * trace[0]  # "three or four iterations"
    plain, = numbers(r"photometric=False: RMS error {n} px", text)
    photometric, = numbers(r"photometric=True: RMS error {n} px", text)
    assert photometric < plain
    shift = numbers(r"chamfer shift \({n}, {n}\)", text)
    assert all(abs(s) <= 10 for s in shift)  # "a few pixels"
    nominal, = numbers(r"edge misalignment, nominal: mean {n} px", text)
    global_, = numbers(r"edge misalignment, +global: mean {n} px", text)
    local, = numbers(r"edge misalignment, +local: mean {n} px", text)
    assert nominal > 3 and global_ < 1 and nominal - global_ > 5 * abs(global_ - local)
    controls = re.search(r"control points per pass: \[([\d, ]*)\]", text).group(1)
    if all(int(c) == 0 for c in controls.split(",")):
        assert local == global_  # no control point: the stretch leaves the range alone


def claims_04(text: str) -> None:
    assert text.count(": rejected (") == 3
    assert "accepted?!" not in text
    assert "identical slices: True" in text
    assert "identical to the uninterrupted scan: True" in text
    errors = [float(e) for e in re.findall(r"median error ([\d.]+) mm", text)]
    assert len(errors) == 2 and all(e < 10 for e in errors)


def claims_05(text: str) -> None:
    # section 3, on BP's dense range: with the rule no triangle of measured points crosses a
    # true jump (without it some do), those that still cross one have a synthesized vertex,
    # and the longest edge is a fraction of a metre instead of metres
    rows = {label: numbers(r"{n} triangles; across a true depth jump: {n} measured, {n} with "
                           r"a synthesized vertex; longest edge {n} m", line)
            for label, line in re.findall(r"^(no rule \(the curtain\)|max_jump = 0.05): (.*)$",
                                          text, flags=re.M)}
    assert len(rows) == 2
    (_, curtain_measured, _, curtain_longest) = rows["no rule (the curtain)"]
    (_, measured, synthesized, longest) = rows["max_jump = 0.05"]
    assert curtain_measured > 0 and measured == 0 and synthesized > 0
    assert longest < 1 < 2 < curtain_longest
    assert "read back exactly: True" in text


CLAIMS = {"00": claims_00, "01": claims_01, "02": claims_02, "03": claims_03, "04": claims_04,
          "05": claims_05}


@pytest.mark.parametrize("path", TUTORIALS, ids=lambda p: p.stem)
def test_tutorial_writes_its_figures(path):
    assert run(path.name).pngs(), f"{path.name} wrote no figure"


@pytest.mark.parametrize("path", [p for p in TUTORIALS if p.stem[:2] in CLAIMS],
                         ids=lambda p: p.stem)
def test_tutorial_claims_hold(path):
    CLAIMS[path.stem[:2]](run(path.name).text)


def test_a_tutorial_runs_as_plain_python():
    """The plain-Python path: Agg, figures written to files, the same numbers.

    Tutorial 03 (its figures and claims; one of the shorter tutorials: the path is the
    same for all)."""
    plain = run_as_python(PLAIN)
    names = ["03_cylindrical.png", "03_edges_alignment.png", "03_mosaic.png",
             "03_registered.png", "03_scan_cylinder.png", "03_views.png"]
    assert [p.name for p in plain.pngs()] == names
    assert [p.name for p in run(PLAIN).pngs()] == names
    claims_03(plain.text)
    notebook = run(PLAIN)  # a notebook prints what the script prints (its own folder aside)
    assert plain.text.replace(str(plain.figures), "FIGURES") == notebook.text.replace(
        str(notebook.figures), "FIGURES")


@pytest.mark.parametrize("path", TUTORIALS, ids=lambda p: p.stem)
def test_tutorial_states_before_and_after_and_ends_with_exercises(path):
    source = path.read_text(encoding="utf-8")
    assert "**Before this tutorial**" in source and "**After it**" in source
    exercises = source.split("# ## Exercises")
    assert len(exercises) == 2, f"{path.name} has no '## Exercises' section"
    numbered = re.findall(r"^# (\d)\. ", exercises[1], flags=re.M)
    assert 2 <= len(numbered) <= 3, f"{path.name}: {len(numbered)} exercises"
    assert f"tutorials/solutions/{path.name}" in exercises[1]
    assert (TUTORIALS_DIR / "solutions" / path.name).is_file(), f"no solutions for {path.name}"


@pytest.mark.parametrize("path", SOLUTIONS, ids=lambda p: p.stem)
def test_solutions_run_and_their_answers_hold(path):
    proc = run_solution(path.name)  # python tutorials/solutions/NAME.py in a fresh folder
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    assert proc.stdout.strip(), f"{path.name} printed nothing"
