"""The readings presets (:mod:`refsynth.synthesis.readings`) and ``synthesize(readings=...)``."""

from __future__ import annotations

import numpy as np
import pytest

import refsynth
from refsynth.synthesis.readings import (
    BP_READINGS,
    NP_READINGS,
    PRESETS,
    Readings,
    resolve_readings,
    split_options,
)

IMAGE = np.tile(np.linspace(0.0, 1.0, 7), (7, 1)) + 0.2 * (np.arange(7)[:, None] % 2)
PARTIAL = np.where(np.arange(7) % 3 == 0, 1.0 + 0.1 * np.arange(7)[:, None], np.nan)

#: The paper as printed, field by field (the table in the module's docstring).
PAPER = {"range_weight": 1.0, "missing_range": "ignore", "colour": True, "channels": "sum",
         "range_copy": "value", "confidence_update": "best", "edges_last": True,
         "observation": "measured", "training_radius": "fixed", "compatibility": "overlap",
         "proximity": 0.0, "sigma_i": 0.1, "sigma_s": 0.2, "product": "max", "tolerance": 0.0,
         "edge_rule": "silent", "offset_tolerance": None, "proposals": None,
         "proposal_runs": 1, "gaps": "copy", "median": 0, "window": "fixed"}
#: refsynth's departures from it (the default preset).
DEPARTURES = {"missing_range": "mean", "range_copy": "offset", "observation": "np",
              "training_radius": "gap", "tolerance": 1e-4, "gaps": "gate", "median": 3,
              "window": "gaps"}


def test_the_paper_preset_is_the_paper_as_printed():
    assert Readings.paper().as_dict() == PAPER
    assert Readings.preset("paper") == Readings.paper()


def test_the_default_preset_differs_from_the_paper_by_its_departures_only():
    assert Readings() == Readings.refsynth() == Readings.preset("refsynth")
    assert Readings().departures() == DEPARTURES
    assert Readings.paper().departures("refsynth") == {name: PAPER[name] for name in DEPARTURES}
    assert set(PRESETS) == {"paper", "refsynth"}


def test_every_reading_is_used_by_a_method():
    assert set(NP_READINGS) | set(BP_READINGS) == set(Readings.names())
    assert Readings.paper().for_method("np") == {name: PAPER[name] for name in NP_READINGS}


def test_replace_turns_one_departure_on_and_checks_it():
    one = Readings.paper().replace(range_copy="offset")
    assert one.range_copy == "offset" and one.departures() == {"range_copy": "offset"}
    assert Readings.paper().range_copy == "value"   # frozen: the preset is unchanged
    with pytest.raises(ValueError, match="`range_copy` must be one of 'value', 'offset'"):
        Readings.paper().replace(range_copy="shift")


@pytest.mark.parametrize("make", [
    lambda: Readings().replace(rangecopy="value"),
    lambda: resolve_readings({"rangecopy": "value"}),
    lambda: refsynth.synthesize(IMAGE, PARTIAL, readings={"rangecopy": "value"}),
])
def test_an_unknown_reading_is_named_with_the_valid_ones(make):
    with pytest.raises(ValueError, match=r"Unknown reading `rangecopy`; the readings are: "
                                         r"range_weight, missing_range, .*, proposal_runs, gaps, "
                                         r"median, window$"):
        make()


@pytest.mark.parametrize(("changes", "error", "match"), [
    ({"range_weight": -1.0}, ValueError, "`range_weight`"),
    ({"colour": 1}, TypeError, "`colour` must be a bool"),
    ({"sigma_s": 0.0}, ValueError, "`sigma_s`"),
    ({"tolerance": -1.0}, ValueError, "`tolerance`"),
    ({"offset_tolerance": 0.1}, ValueError, "`offset_tolerance`"),
    ({"proposals": "bp"}, ValueError, "`proposals` must be one of"),
    ({"proposal_runs": 2}, ValueError, "`proposal_runs` needs `proposals`"),
    ({"proposals": "np", "proposal_runs": 0}, ValueError, "`proposal_runs` must be >= 1"),
])
def test_a_bad_reading_is_refused_by_name(changes, error, match):
    with pytest.raises(error, match=match):
        Readings(**changes)


def test_synthesize_refuses_bad_readings_before_any_work():
    calls = []
    for readings, error in [("papers", ValueError), (3, TypeError), ({"colour": "no"}, TypeError)]:
        with pytest.raises(error, match="`readings`|`colour`"):
            refsynth.synthesize(IMAGE, PARTIAL, readings=readings,
                                progress=lambda *a: calls.append(a))
    assert calls == []


@pytest.mark.parametrize("method", ["np", "bp"])
def test_the_refsynth_preset_is_the_default_bit_for_bit(method):
    plain = refsynth.synthesize(IMAGE, PARTIAL, method=method, seed=3, radius=3.0)
    for readings in ("refsynth", Readings(), {}, Readings.paper().replace(**DEPARTURES)):
        same = refsynth.synthesize(IMAGE, PARTIAL, method=method, seed=3, radius=3.0,
                                   readings=readings)
        np.testing.assert_array_equal(same.range, plain.range)
        np.testing.assert_array_equal(same.confidence, plain.confidence)
        np.testing.assert_array_equal(same.order, plain.order)
        assert same.params == plain.params


@pytest.mark.parametrize("method", ["np", "bp"])
def test_the_paper_preset_is_its_readings_as_overrides(method):
    """"paper" = the default preset with each departure turned off by name."""
    paper = refsynth.synthesize(IMAGE, PARTIAL, method=method, seed=3, radius=3.0,
                                readings="paper")
    used = NP_READINGS if method == "np" else BP_READINGS
    overrides = {name: PAPER[name] for name in DEPARTURES if name in used}
    same = refsynth.synthesize(IMAGE, PARTIAL, method=method, seed=3, radius=3.0,
                               readings=overrides)
    np.testing.assert_array_equal(same.range, paper.range)
    np.testing.assert_array_equal(same.confidence, paper.confidence)
    recorded = [name for name in used  # (offset_tolerance is recorded resolved)
                if name not in ("proposals", "proposal_runs", "offset_tolerance")]
    assert {name: paper.params[name] for name in recorded} == {n: PAPER[n] for n in recorded}


def test_split_options_separates_keywords_from_readings():
    keywords, readings = split_options({"method": "bp", "radius": 3.0, "observation": "measured",
                                        "proposals": None, "candidates": 4})
    assert keywords == {"method": "bp", "radius": 3.0, "candidates": 4}
    assert readings == {"observation": "measured"}


def test_the_docstrings_table_gives_each_presets_value():
    """Every field has a row in the module's table, with the two presets' values as set."""
    import refsynth.synthesis.readings as module

    rows = {}
    for line in module.__doc__.splitlines():
        cells = line.split()
        if len(cells) >= 3 and cells[0].startswith("``") and cells[0].strip("`") in PAPER:
            rows[cells[0].strip("`")] = (cells[1].strip("`"), cells[2].strip("`"))
    assert set(rows) == set(Readings.names())

    def as_written(value):   # numbers compare as numbers ("1e-4" is 0.0001), the rest as text
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        return float(value) if number else str(value)

    def parse(cell):
        return float(cell) if cell[0].isdigit() else cell

    for name, (paper, ours) in rows.items():
        assert (parse(paper), parse(ours)) == (as_written(getattr(Readings.paper(), name)),
                                               as_written(getattr(Readings(), name))), name
