"""Validation of ``refsynth.synthesize``: every bad input named before any work starts."""

import numpy as np
import pytest

import refsynth

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
        ({"edges": np.zeros((5, 5), bool)}, ValueError, "`edges` must have shape"),
        ({"edges": np.zeros((6, 6))}, TypeError, "`edges` must be a boolean"),
        ({"progress": 5}, TypeError, "`progress` must be callable"),
        ({"seed": "zero"}, TypeError, "`seed` must be an int"),
        ({"seed": 1.5}, TypeError, "`seed` must be an int"),
    ],
)
def test_bad_parameters_are_rejected(kwargs, error, match):
    with pytest.raises(error, match=match):
        refsynth.synthesize(IMAGE, PARTIAL, **kwargs)


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
