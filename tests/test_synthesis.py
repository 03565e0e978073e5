"""Validation of ``refsynth.synthesize``: every bad input named before any work starts."""

import numpy as np
import pytest

import refsynth
from refsynth.synthesis.readings import split_options

IMAGE = np.zeros((6, 6))
PARTIAL = np.full((6, 6), np.nan)
PARTIAL[:, 0] = 1.0


@pytest.mark.parametrize(
    ("intensity", "partial", "error", "match"),
    [
        ([[0.0]], PARTIAL, TypeError, "`intensity` must be a numpy array"),
        (IMAGE, [[1.0]], TypeError, "`partial_range` must be a numpy array"),
        (IMAGE.astype(complex), PARTIAL, TypeError, "`intensity` must have a real numeric"),
        (IMAGE.astype(str), PARTIAL, TypeError, "`intensity` must have a real numeric"),
        (IMAGE, np.zeros((6, 6), dtype=int), TypeError, "`partial_range` must have a floating"),
        (np.zeros(6), PARTIAL, ValueError, "`intensity` must be a 2-D grey"),
        (np.zeros((6, 6, 2)), PARTIAL, ValueError, "`intensity` must be a 2-D grey"),
        (IMAGE, PARTIAL[None], ValueError, "`partial_range` must be a 2-D array"),
        (np.zeros((6, 5)), PARTIAL, ValueError, "same height and width"),
        (np.zeros((1, 6)), PARTIAL[:1], ValueError, "at least 2x2"),
        (np.full((6, 6), np.nan), PARTIAL, ValueError, "`intensity` must be finite"),
        (IMAGE, np.where(np.isnan(PARTIAL), np.inf, 1.0), ValueError, "got inf"),
        (IMAGE, np.full((6, 6), np.nan), ValueError, "no known range"),
        (IMAGE, np.ones((6, 6)), ValueError, "nothing to fill"),
    ],
)
def test_bad_arrays_are_rejected(intensity, partial, error, match):
    with pytest.raises(error, match=match):
        refsynth.synthesize(intensity, partial)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"method": "lbp"}, ValueError, "`method`"),
        ({"product": "min"}, ValueError, "`product`"),
        ({"candidates": 0}, ValueError, "`candidates` must be >= 1"),
        ({"iterations": -1}, ValueError, "`iterations` must be >= 0"),
        ({"sigma_i": 0.0}, ValueError, "`sigma_i`"),
        ({"sigma_s": -1.0}, ValueError, "`sigma_s`"),
        ({"tolerance": -1.0}, ValueError, "`tolerance`"),
        ({"method": 3}, ValueError, "`method`"),
        ({"ordering": "spiral"}, ValueError, "`ordering`"),
        ({"neighbourhood": 4}, ValueError, "`neighbourhood` must be odd"),
        ({"neighbourhood": 0}, ValueError, "`neighbourhood` must be >= 1"),
        ({"neighbourhood": 3.0}, TypeError, "`neighbourhood` must be an integer"),
        ({"neighbourhood": True}, TypeError, "`neighbourhood` must be an integer"),
        ({"radius": 0.5}, ValueError, "`radius` must be >= 1"),
        ({"radius": -2}, ValueError, "`radius` must be finite and > 0"),
        ({"radius": float("nan")}, ValueError, "`radius`"),
        ({"radius": "10"}, TypeError, "`radius` must be a real number"),
        ({"epsilon": -0.1}, ValueError, "`epsilon`"),
        ({"canny_sigma": float("inf")}, ValueError, "`canny_sigma`"),
        ({"range_weight": -1.0}, ValueError, "`range_weight`"),
        ({"missing_range": "zero"}, ValueError, "`missing_range`"),
        ({"use_edges": "yes"}, TypeError, "`use_edges` must be a bool"),
        ({"use_isophotes": 1}, TypeError, "`use_isophotes` must be a bool"),
        ({"colour": 1}, TypeError, "`colour` must be a bool"),
        ({"edges_last": "no"}, TypeError, "`edges_last` must be a bool"),
        ({"confidence_update": "sum"}, ValueError, "`confidence_update` must be one of"),
        ({"edge_rule": "none"}, ValueError, "`edge_rule` must be one of"),
        ({"edges": np.zeros((5, 5), bool)}, ValueError, "`edges` must have shape"),
        ({"edges": np.zeros((6, 6))}, TypeError, "`edges` must be a boolean"),
        ({"progress": 5}, TypeError, "`progress` must be callable"),
        ({"seed": "zero"}, TypeError, "`seed` must be an int"),
        ({"seed": 1.5}, TypeError, "`seed` must be an int"),
    ],
)
def test_bad_parameters_are_rejected(kwargs, error, match):
    keywords, readings = split_options(kwargs)   # the readings' names go in readings=
    with pytest.raises(error, match=match):
        refsynth.synthesize(IMAGE, PARTIAL, **keywords, readings=readings)


def test_result_fields_and_provenance():
    result = refsynth.synthesize(IMAGE, PARTIAL, seed=0)
    assert result.range.dtype == np.float64 and result.range.shape == (6, 6)
    assert result.confidence.dtype == np.float64
    assert result.order.dtype == np.int64 and result.order.shape == (30, 2)
    assert result.edges.dtype == np.bool_
    assert result.method == "np"
    assert result.params["radius"] == 10.0 and result.params["ordering"] == "priority"


def test_user_edge_map_is_used():
    edges = np.zeros((6, 6), dtype=bool)
    edges[:, 5] = True
    result = refsynth.synthesize(IMAGE, PARTIAL, seed=0, edges=edges)
    np.testing.assert_array_equal(result.edges, edges)
    # edge pixels come last
    last = {tuple(rc) for rc in result.order[-6:].tolist()}
    assert last == {(r, 5) for r in range(6)}


def test_integer_seed_types():
    a = refsynth.synthesize(IMAGE, PARTIAL, seed=np.int64(5))
    b = refsynth.synthesize(IMAGE, PARTIAL, seed=5)
    np.testing.assert_array_equal(a.order, b.order)


# --------------------------------------------------------------------------- the options split

NP_ONLY = {"epsilon": 0.2, "use_isophotes": False, "ordering": "onion"}
BP_ONLY = {"candidates": 4, "iterations": 3}
NP_READINGS_CHANGED = {"confidence_update": "product", "edges_last": False}
BP_READINGS_CHANGED = {"proximity": 1.0, "sigma_i": 0.3, "sigma_s": 0.1, "tolerance": 0.0,
                       "product": "sum", "edge_rule": "deaf", "offset_tolerance": 0.25,
                       "observation": "measured", "training_radius": "fixed",
                       "compatibility": "overlap-centres", "proposals": "np"}
#: Both methods' readings, changed from the default.
SHARED = {"range_copy": "value", "missing_range": "ignore", "channels": "mean",
          "range_weight": 2.0, "colour": False, "gaps": "copy", "median": 0, "window": "fixed"}


def test_synthesize_takes_at_most_fourteen_keyword_options():
    import inspect

    parameters = inspect.signature(refsynth.synthesize).parameters.values()
    keywords = [p.name for p in parameters if p.kind is p.KEYWORD_ONLY]
    assert len(keywords) <= 14 and "readings" in keywords
    assert not any(p.kind is p.VAR_KEYWORD for p in parameters)


def test_options_after_the_arrays_are_keyword_only():
    with pytest.raises(TypeError):
        refsynth.synthesize(IMAGE, PARTIAL, "bp")
    with pytest.raises(TypeError):
        refsynth.synthesize(IMAGE, PARTIAL, "np", 0)


@pytest.mark.parametrize(("name", "value"), NP_ONLY.items())
def test_an_np_option_given_to_bp_is_rejected(name, value):
    match = rf"`{name}` applies to method='np' only; method='bp' does not use it"
    with pytest.raises(ValueError, match=match):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", **{name: value})


@pytest.mark.parametrize(("name", "value"), BP_ONLY.items())
def test_a_bp_option_given_to_np_is_rejected(name, value):
    match = rf"`{name}` applies to method='bp' only; method='np' does not use it"
    with pytest.raises(ValueError, match=match):
        refsynth.synthesize(IMAGE, PARTIAL, method="np", **{name: value})


@pytest.mark.parametrize(("name", "value"), NP_READINGS_CHANGED.items())
def test_an_np_reading_given_to_bp_is_rejected(name, value):
    match = rf"reading `{name}` applies to method='np' only; method='bp' does not use it"
    with pytest.raises(ValueError, match=match):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", readings={name: value})


@pytest.mark.parametrize(("name", "value"), BP_READINGS_CHANGED.items())
def test_a_bp_reading_given_to_np_is_rejected(name, value):
    match = rf"reading `{name}` applies to method='bp' only; method='np' does not use it"
    with pytest.raises(ValueError, match=match):
        refsynth.synthesize(IMAGE, PARTIAL, method="np", readings={name: value})


def test_the_paper_example_of_an_ignored_option_is_now_an_error():
    with pytest.raises(ValueError, match="The parameter `ordering` applies to method='np' only; "
                                         "method='bp' does not use it"):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", ordering="onion")


def test_a_bad_value_is_reported_as_such_even_for_the_other_method():
    with pytest.raises(ValueError, match="`ordering` must be one of"):
        refsynth.synthesize(IMAGE, PARTIAL, method="bp", ordering="spiral")
    with pytest.raises(ValueError, match="`candidates` must be >= 1"):
        refsynth.synthesize(IMAGE, PARTIAL, method="np", candidates=0)
    with pytest.raises(ValueError, match="`observation` must be one of"):
        refsynth.synthesize(IMAGE, PARTIAL, method="np", readings={"observation": "nope"})


def test_the_other_methods_defaults_and_none_are_accepted_silently():
    np_defaults = {"epsilon": 0.1, "use_isophotes": True, "ordering": "priority"}
    bp_defaults = {"candidates": 8, "iterations": 50}
    np_readings = {"confidence_update": "best", "edges_last": True}
    bp_readings = {"proximity": 0.0, "sigma_i": 0.1, "sigma_s": 0.2, "tolerance": 1e-4,
                   "product": "max", "edge_rule": "silent", "observation": "np",
                   "training_radius": "gap", "proposals": None}
    plain_np = refsynth.synthesize(IMAGE, PARTIAL, method="np", seed=0)
    plain_bp = refsynth.synthesize(IMAGE, PARTIAL, method="bp")
    for extra in (bp_defaults, dict.fromkeys(bp_defaults)):
        other = refsynth.synthesize(IMAGE, PARTIAL, method="np", seed=0, **extra,
                                    readings=bp_readings)
        np.testing.assert_array_equal(other.range, plain_np.range)
        np.testing.assert_array_equal(other.order, plain_np.order)
        assert other.params == plain_np.params
    for extra in (np_defaults, dict.fromkeys(np_defaults)):
        other = refsynth.synthesize(IMAGE, PARTIAL, method="bp", **extra, readings=np_readings)
        np.testing.assert_array_equal(other.range, plain_bp.range)
        np.testing.assert_array_equal(other.confidence, plain_bp.confidence)
        assert other.params == plain_bp.params


def test_none_means_the_methods_default_and_params_hold_only_its_options():
    result = refsynth.synthesize(IMAGE, PARTIAL, method="bp", candidates=None,
                                 readings={"product": None})
    assert result.params["candidates"] == 8 and result.params["product"] == "max"
    assert not {"epsilon", "use_isophotes", "ordering"} & result.params.keys()
    assert not set(NP_READINGS_CHANGED) & result.params.keys()
    result = refsynth.synthesize(IMAGE, PARTIAL, seed=0, ordering=None, epsilon=None)
    assert result.params["ordering"] == "priority" and result.params["epsilon"] == 0.1
    assert not (set(BP_ONLY) | set(BP_READINGS_CHANGED)) & result.params.keys()


def test_the_options_tables_name_every_method_specific_option():
    from refsynth.synthesis import BP_OPTIONS, NP_OPTIONS
    from refsynth.synthesis.readings import BP_READINGS, NP_READINGS, Readings

    assert set(NP_OPTIONS) == set(NP_ONLY) and set(BP_OPTIONS) == set(BP_ONLY)
    assert set(NP_READINGS) == set(NP_READINGS_CHANGED) | set(SHARED)
    assert set(BP_READINGS) == set(BP_READINGS_CHANGED) | set(SHARED) | {"proposal_runs"}
    assert set(NP_READINGS) | set(BP_READINGS) == set(Readings.names())


@pytest.mark.parametrize("method", ["np", "bp"])
@pytest.mark.parametrize(("name", "value"), SHARED.items())
def test_a_shared_reading_is_taken_by_both_methods(method, name, value):
    result = refsynth.synthesize(IMAGE, PARTIAL, method=method, readings={name: value})
    assert result.params[name] == value
