"""NP's literal reference (refsynth.synthesis.nonparametric.reference) against the front door.

With its defaults it is ``synthesize(method="np", readings="paper")`` bit for bit; with any
of NP's readings it is ``synthesize`` under the same readings. It reads as the paper: short,
and importing no speed machinery.
"""

from __future__ import annotations

import ast
import inspect
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

import refsynth
from refsynth.synthesis.limits import normalise_intensity
from refsynth.synthesis.nonparametric import reference as npref
from refsynth.synthesis.readings import NP_READINGS, Readings
from refsynth.synthesis.window_reading import choose_neighbourhood

MANY = settings(max_examples=120, deadline=None, phases=[Phase.explicit, Phase.generate],
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

#: NP's readings and the values each takes.
READING_VALUES = {"range_weight": [0.0, 1.0, 16.0], "missing_range": ["ignore", "mean"],
                  "colour": [True, False], "channels": ["sum", "mean"],
                  "range_copy": ["value", "offset"], "confidence_update": ["best", "product"],
                  "edges_last": [True, False]}


@st.composite
def np_case(draw, readings: bool = False):
    """A small scene (4×4 to 16×16), its edges, the front door's options and, optionally,
    NP's readings drawn one by one (each departure on or off)."""
    seed = draw(st.integers(0, 2**32 - 1))
    g = np.random.default_rng(seed)
    H, W = draw(st.integers(4, 16)), draw(st.integers(4, 16))
    C = draw(st.sampled_from([1, 3]))
    kind = draw(st.sampled_from(["noise", "levels", "ramp"]))
    if kind == "noise":
        image = g.random((H, W, C))
    elif kind == "levels":   # few grey levels: exact ties in Eq. 2
        image = g.integers(0, 4, (H, W, C)) / 3.0
    else:
        image = np.tile(np.linspace(0.0, 1.0, W)[None, :, None], (H, 1, C))
    if draw(st.booleans()):  # 0 to 2 decimals: ties in Eq. 5
        truth = np.round(1.0 + 4.0 * g.random((H, W)), draw(st.integers(0, 2)))
    else:                    # slanted planes with a step: where the offset copy shifts
        rows, cols = np.mgrid[:H, :W]
        truth = 1.0 + g.random() * rows + g.random() * cols + np.where(
            cols > g.integers(W), 2.0 * g.random(), 0.0)
    known = g.random((H, W)) < draw(st.floats(0.15, 0.7))
    known[g.integers(H), g.integers(W)] = True
    if known.all():
        known[0, 0] = False
    edges = (g.random((H, W)) < 0.15) if draw(st.booleans()) else np.zeros((H, W), bool)
    options = dict(neighbourhood=draw(st.sampled_from([3, 5])),
                   radius=draw(st.sampled_from([1.0, 1.5, 3.0, 4.5])),
                   epsilon=draw(st.sampled_from([0.0, 0.1, 0.5])),
                   use_edges=draw(st.booleans()), use_isophotes=draw(st.booleans()),
                   ordering=draw(st.sampled_from(["priority", "priority", "onion"])))
    chosen = {name: draw(st.sampled_from(values)) for name, values in READING_VALUES.items()
              } if readings else {}
    image = image[:, :, 0] if C == 1 else image
    return image, np.where(known, truth, np.nan), edges, options, chosen, seed % 1000


def _same(fast, slow):
    np.testing.assert_array_equal(fast.order, slow.order)
    np.testing.assert_array_equal(fast.range, slow.range)
    np.testing.assert_array_equal(fast.confidence, slow.confidence)


def test_the_references_defaults_are_the_papers_readings():
    defaults = {name: p.default for name, p in inspect.signature(npref.np_reference).parameters
                .items() if name in NP_READINGS}
    # the reading `window` chooses the neighbourhood beside the reference, which takes it as
    # given: its default is the paper's 5 x 5
    paper = Readings.paper().for_method("np")
    assert paper.pop("window") == "fixed"
    assert defaults == paper
    assert inspect.signature(npref.np_reference).parameters["neighbourhood"].default == 5


@MANY
@given(np_case())
@example((np.tile([0.0, 1.0], (4, 3)), np.where(np.eye(4, 6) > 0, 2.0, np.nan),
          np.zeros((4, 6), bool), dict(neighbourhood=3, radius=1.0, epsilon=0.1,
                                       use_edges=True, use_isophotes=True,
                                       ordering="priority"), {}, 0))
def test_the_reference_is_the_paper_preset_bit_for_bit(case):
    image, partial, edges, options, _, seed = case
    fast = refsynth.synthesize(image, partial, seed=seed, edges=edges, readings="paper",
                               **options)
    slow = npref.np_reference(normalise_intensity(image), partial, edges,
                              np.random.default_rng(seed), **options)
    _same(fast, slow)


@MANY
@given(np_case(readings=True))
def test_the_reference_is_the_fill_under_every_reading(case):
    image, partial, edges, options, chosen, seed = case
    fast = refsynth.synthesize(image, partial, seed=seed, edges=edges,
                               readings=Readings.paper().replace(**chosen), **options)
    slow = npref.np_reference(normalise_intensity(image), partial, edges,
                              np.random.default_rng(seed), **options, **chosen)
    _same(fast, slow)


def test_refsynths_readings_give_the_default_synthesize():
    g = np.random.default_rng(5)
    image = g.random((10, 12))
    rows, cols = np.mgrid[:10, :12]
    partial = np.where(cols % 4 == 0, 1.0 + 0.1 * rows + 0.05 * cols, np.nan)
    fast = refsynth.synthesize(image, partial, seed=4, radius=4.0)
    readings = Readings.refsynth().for_method("np")
    side = choose_neighbourhood(partial, readings.pop("window"))   # beside the reference
    assert side == fast.params["neighbourhood"] == 3
    slow = npref.np_reference(normalise_intensity(image), partial, fast.edges,
                              np.random.default_rng(4), radius=4.0, neighbourhood=side,
                              **readings)
    _same(fast, slow)


# -- hand-built cases ---------------------------------------------------------------------


def test_one_hole_copies_the_value_of_its_unique_best_match():
    """Stripes 0/1 with one unknown voxel on a 0 stripe: Eq. 2 is 0 only at the other 0
    stripes' voxels with the same range around them; ε = 0 keeps that one, and the paper's
    copy gives its centre value exactly."""
    image = np.tile(np.arange(7) % 2, (7, 1)).astype(np.float64)[:, :, None]
    truth = 1.0 + 0.0 * image[:, :, 0]
    truth[3, 4] = 9.0                 # a distinct value at the only exact match of (3, 2)
    truth[2:5, 1] = truth[2:5, 3] = truth[2:5, 5] = 5.0
    partial = truth.copy()
    partial[3, 2] = np.nan
    result = npref.np_reference(image, partial, np.zeros((7, 7), bool),
                                np.random.default_rng(0), neighbourhood=3, radius=2.0,
                                epsilon=0.0)
    assert result.range[3, 2] == 9.0 and result.order.tolist() == [[3, 2]]
    assert result.confidence[3, 2] == 1.0      # C(N_best): its window is all measured


def test_priority_terms_by_hand():
    """A vertical front with range rising down the filled column: the isophote runs along
    the front, so D = 1 − |g_row m_col| / |m| = 1 − 1/2 = 0.5 with g_row = 2**15 / 2**16."""
    filled = np.zeros((3, 3), bool)
    filled[:, 0] = True
    qr = np.full((3, 3), -1)
    qr[:, 0] = [0, 2**15, 2**16]
    conf = filled.astype(np.float64)
    C, D, E = npref.priority_terms(1, 1, filled, qr, conf, 2, 3)
    assert (C, D, E) == (3 / 9, 0.5, 1 / 3)
    assert npref.priority_terms(1, 1, filled, qr, conf, None, 3, use_isophotes=False) == (
        3 / 9, 1.0, 1.0)


def test_eq12_divides_by_the_norm_once_at_the_end():
    """The contract's Eq. 12: ``1 − |g_row m_col − g_col m_row| / ‖m‖`` with ``m`` the
    un-normalised Sobel vector. Normalising ``m`` first is the same number in exact
    arithmetic but not in floating point: this window tells the two apart by one ulp."""
    filled = np.array([[1, 0, 0, 1, 1], [0, 0, 1, 0, 1], [1, 0, 0, 1, 1], [0, 0, 0, 1, 1],
                       [1, 1, 0, 1, 1]], dtype=bool)
    qr = np.array([[31879, -1, -1, 41944, 5877], [-1, -1, 4483, -1, 5239],
                   [31781, -1, -1, 37772, 21818], [-1, -1, -1, 9150, 18558],
                   [26839, 54034, -1, 48887, 55393]])
    _, D, _ = npref.priority_terms(2, 2, filled, qr, filled.astype(np.float64), None, 5)
    g_row, g_col = (60631 * 2.0**-16) / 6, (-8912 * 2.0**-16) / 5   # the pairs' mean slopes
    m_row, m_col = -1, 3                                            # Sobel of the mask
    norm = math.sqrt(m_row * m_row + m_col * m_col)
    assert D == 1.0 - abs(g_row * m_col - g_col * m_row) / norm
    assert D != 1.0 - abs(g_row * (m_col / norm) - g_col * (m_row / norm))


def test_eq10_counts_a_negative_data_term_as_zero():
    """A range gradient steeper than the span per pixel across the front makes D < 0:
    here (1, 1) sees a rise of the whole span down column 0 and along row 2."""
    filled = np.zeros((3, 3), bool)
    filled[0, 0] = filled[1, 0] = filled[2, 1] = filled[2, 2] = True
    qr = np.where(filled, [[0, 0, 0], [2**16, 0, 0], [0, 0, 2**16]], -1)
    C, D, E = npref.priority_terms(1, 1, filled, qr, filled.astype(np.float64), 0, 3)
    assert D == 1.0 - 4 / math.sqrt(8) < 0
    assert npref.priority(C, D, E) == E == 1.0
    assert npref.priority(0.5, 0.5, 0.25) == 0.5


def test_a_gap_wider_than_r_widens_the_search_to_d_plus_r():
    """r = 1 and the only measured voxel diagonal to the first front voxel: A_p is empty,
    and the search takes every filled voxel within d + r."""
    partial = np.full((4, 4), np.nan)
    partial[0, 0] = 2.5
    result = npref.np_reference(np.zeros((4, 4, 1)), partial, np.zeros((4, 4), bool),
                                np.random.default_rng(0), neighbourhood=3, radius=1.0)
    assert np.all(result.range == 2.5) and len(result.order) == 15


def test_the_offset_copy_fills_a_slanted_plane_exactly():
    """A gap across a plane sloping along the columns: the shifted copy continues the plane
    exactly (its values lie within the measured span), where the paper's copy repeats
    measured values."""
    rows, cols = np.mgrid[:6, :9]
    truth = 1.0 + cols / 8.0
    partial = np.where((cols < 3) | (cols > 5), truth, np.nan)
    image, edges = np.zeros((6, 9, 1)), np.zeros((6, 9), bool)
    options = dict(neighbourhood=3, radius=3.0, use_edges=False)
    value = npref.np_reference(image, partial, edges, np.random.default_rng(1), **options)
    offset = npref.np_reference(image, partial, edges, np.random.default_rng(1),
                                range_copy="offset", missing_range="mean", **options)
    unknown = np.isnan(partial)
    np.testing.assert_array_equal(offset.range, truth)
    assert set(np.unique(value.range[unknown])) <= set(np.unique(partial[~unknown]))
    assert np.abs(value.range - truth)[unknown].max() == 0.375


def test_the_offset_shift_needs_every_difference_to_agree():
    """Δ = round(B / A) (half to even) when every δ is within 2**9 of the mean, else 0."""
    window = np.ones((3, 3), dtype=np.int64)

    def shift(p_values, q_values):
        q_pad = np.full((3, 7), -1)
        q_pad[:, 0:3], q_pad[:, 4:7] = p_values, q_values   # windows of (0, 0) and (0, 4)
        return npref.offset_shift(q_pad, window, (0, 0), (0, 4))

    base = np.arange(9).reshape(3, 3) * 100
    assert shift(base + 5, base) == 5
    far = base + 5
    far[1, 1] += 2000
    assert shift(far, base) == 0                   # one difference disagrees
    assert shift(base + 5, np.full((3, 3), -1)) == 0   # no range shared
    only = np.full((3, 3), -1)
    only[0, :2] = [10, 20]
    assert shift(only + np.array([1, 2, 0]), np.where(only < 0, -1, only)) in (1, 2)
    pair = np.full((3, 3), -1)
    pair[0, :2] = [0, 0]
    assert shift(np.where(pair < 0, -1, [[1, 2, 0]] * 3), pair) == 2   # 1.5 → 2 (even)
    assert shift(np.where(pair < 0, -1, [[2, 3, 0]] * 3), pair) == 2   # 2.5 → 2 (even)


def test_the_reference_imports_no_speed_machinery_and_is_short():
    path = Path(npref.__file__)
    tree = ast.parse(path.read_text())
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names}
    assert imported <= {"__future__", "math", "dataclasses", "fractions", "numpy",
                        "refsynth.numeric", "refsynth.synthesis.neighbourhood",
                        "refsynth.synthesis.similarity", "refsynth.synthesis.gap_readings",
                        "refsynth.synthesis.median_pass"}
    assert len(path.read_text().splitlines()) <= 400


@pytest.mark.parametrize("ordering", ["priority", "onion"])
def test_the_reference_is_deterministic_and_leaves_its_inputs(ordering):
    image = np.random.default_rng(0).random((6, 7, 1))
    partial = np.where(np.arange(7) % 3 == 0, 2.0 + np.arange(6)[:, None], np.nan)
    before = partial.copy()
    a = npref.np_reference(image, partial, np.zeros((6, 7), bool), np.random.default_rng(3),
                           ordering=ordering)
    b = npref.np_reference(image, partial, np.zeros((6, 7), bool), np.random.default_rng(3),
                           ordering=ordering)
    _same(a, b)
    np.testing.assert_array_equal(partial, before)
