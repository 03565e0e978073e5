"""The oracle: golden cases, ``oracle export`` and ``oracle check``, both ways.

refsynth's own functions pass (the literal reference; the fast code through
:func:`refsynth.synthesize`), and deliberately perturbed copies of the reference fail at the
step where the perturbation first changes something, with that step named in the report.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import refsynth.synthesis.reference as reference_module
from refsynth.oracle import (
    CASE_SET_VERSION,
    CONTRACT_VERSION,
    FORMAT_VERSION,
    KINDS,
    SCHEMA,
    build_cases,
    check_function,
    export_cases,
    load_case,
    refsynth_fast,
    refsynth_reference,
    resolve_function,
)
from refsynth.oracle.cases import select_cases
from refsynth.oracle.runs import run_outputs


@pytest.fixture(scope="module")
def cases_dir(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("oracle")
    export_cases(root)
    return root


def _golden(cases_dir, name):
    return load_case(cases_dir, name)[1]


# ----------------------------------------------------------------------------- the case set


def test_the_case_set_spans_every_kind_and_size():
    cases = build_cases()
    kinds = {c.kind for c in cases}
    assert kinds == set(KINDS)
    runs = [c for c in cases if c.kind in ("np", "bp")]
    sizes = {c.inputs["partial_range"].shape for c in runs}
    assert (8, 8) in sizes and (64, 64) in sizes
    names = [c.name for c in cases]
    assert len(names) == len(set(names))
    options = [c.options for c in runs]
    for key, value in [("ordering", "onion"), ("missing_range", "ignore"), ("product", "sum"),
                       ("confidence_update", "best"), ("colour", False),
                       ("edge_rule", "deaf"), ("use_isophotes", False)]:
        assert any(o.get(key) == value for o in options), key


def test_export_writes_the_documented_layout(cases_dir):
    jsonschema = pytest.importorskip("jsonschema")
    manifest = json.loads((cases_dir / "manifest.json").read_text())
    schema = json.loads((cases_dir / "schema.json").read_text())
    assert schema == json.loads(json.dumps(SCHEMA))
    jsonschema.validate(manifest, schema)
    assert (manifest["version"], manifest["contract"], manifest["case_set"]) == (
        FORMAT_VERSION, CONTRACT_VERSION, CASE_SET_VERSION)
    case_schema = {**schema["$defs"]["case"], "$defs": schema["$defs"]}
    for entry in manifest["cases"]:
        meta = json.loads((cases_dir / entry["json"]).read_text())
        jsonschema.validate(meta, case_schema)
        npz = (cases_dir / entry["npz"]).read_bytes()
        assert hashlib.sha256(npz).hexdigest() == entry["sha256"]
        with np.load(cases_dir / entry["npz"], allow_pickle=False) as data:
            assert set(data.files) == set(meta["arrays"])
            for key, spec in meta["arrays"].items():
                assert str(data[key].dtype) == spec["dtype"]
                assert list(data[key].shape) == spec["shape"]
        assert meta["tolerance"] == KINDS[meta["kind"]][2]


def test_export_is_byte_for_byte_reproducible(tmp_path):
    chosen = select_cases(build_cases(), ["np-8x8-noise", "bp-8x8-levels", "eq*"])
    first, second = tmp_path / "a", tmp_path / "b"
    export_cases(first, chosen)
    export_cases(second, chosen)
    manifest = json.loads((first / "manifest.json").read_text())
    assert manifest == json.loads((second / "manifest.json").read_text())
    for entry in manifest["cases"]:
        assert (first / entry["npz"]).read_bytes() == (second / entry["npz"]).read_bytes()


def test_np_trace_layout_and_the_random_numbers(cases_dir):
    arrays = _golden(cases_dir, "np-12x10-noise")
    steps = len(arrays["order"])
    assert steps == int(np.isnan(arrays["partial_range"]).sum())
    start = arrays["cand_start"]
    assert start[0] == 0 and start[-1] == len(arrays["cand_pixel"]) and len(start) == steps + 1
    for s in range(steps):
        rows = slice(start[s], start[s + 1])
        gamma = np.flatnonzero(arrays["cand_in_gamma"][rows])
        d = arrays["cand_distance"][rows]
        assert arrays["step_best"][s] == int(np.argmin(d))           # the first minimum
        assert gamma.tolist() == np.flatnonzero(d <= (1 + 0.1) * d.min()).tolist()
        chosen = gamma[int(arrays["step_draw"][s] * gamma.size)]     # floor(u |Γ'|)
        assert arrays["cand_pixel"][start[s] + chosen].tolist() == arrays["step_source"][s].tolist()
        assert arrays["step_draw"][s] == arrays["draws"][s]
        r, c = arrays["step_pixel"][s]
        assert arrays["step_tie"][s] == arrays["tie"][r, c]
        assert arrays["step_value"][s] == arrays["range"][r, c]
        assert arrays["step_confidence"][s] == arrays["confidence"][r, c]
    assert np.array_equal(arrays["step_pixel"], arrays["order"])
    np.testing.assert_array_equal(arrays["step_P"], arrays["step_C"] * np.maximum(
        arrays["step_D"], 0) + arrays["step_E"])


def test_widened_search_case_widens(cases_dir):
    arrays = _golden(cases_dir, "np-12x12-widened")
    start, pixel = arrays["cand_start"], arrays["cand_pixel"]
    far = [np.max(np.hypot(*(pixel[start[s]:start[s + 1]] - arrays["step_pixel"][s]).T))
           for s in range(len(start) - 1)]
    assert max(far) > 1.5   # beyond Eq. 3's radius: the search widened


def test_bp_on_nps_fill_carries_nps_random_numbers_and_fill(cases_dir):
    """BP's default observations: the case's ``tie`` and ``draws`` are those of NP at BP's
    ``neighbourhood``, ``radius`` and edges with the case's seed, and ``q_observation`` is
    that NP's result on the measured range's grid; the cases on the colorization fill carry
    no random numbers."""
    from refsynth.numeric import quantise_range

    case = next(c for c in build_cases() if c.name == "bp-14x18-planes-np-fill")
    arrays = _golden(cases_dir, case.name)
    shared = {k: case.options[k] for k in ("neighbourhood", "radius", "use_edges")}
    np_case = run_outputs("np", case.inputs, shared, case.seed)
    np.testing.assert_array_equal(arrays["tie"], np_case["tie"])
    np.testing.assert_array_equal(arrays["draws"], np_case["draws"])
    partial = case.inputs["partial_range"]
    q, low, span = quantise_range(partial)
    want = np.maximum(np.rint((np_case["range"] - low) / span * 2.0**16), 0)
    unknown = np.isnan(partial)
    np.testing.assert_array_equal(arrays["q_observation"][unknown], want[unknown])
    np.testing.assert_array_equal(arrays["q_observation"][~unknown], q[~unknown])
    assert "tie" not in _golden(cases_dir, "bp-14x18-planes")


def test_bp_trace_layout(cases_dir):
    arrays = _golden(cases_dir, "bp-12x10-noise")
    messages = arrays["sweep_messages"]
    assert messages.shape[0] == arrays["sweeps"].size == int(arrays["iterations"])
    np.testing.assert_array_equal(messages[-1], arrays["messages"])
    big = _golden(cases_dir, "bp-64x64-levels")
    assert big["sweeps"].tolist() == sorted({1, 2, 5, 10, int(big["iterations"])}
                                            & set(range(1, int(big["iterations"]) + 1)))


# ----------------------------------------------------------------------------- both ways


def test_the_reference_passes_every_case(cases_dir):
    report = check_function(refsynth_reference, cases_dir)
    assert report.passed, str(report)
    assert not report.skipped and len(report.checked) == len(build_cases())


def test_the_fast_code_passes_every_case_it_handles(cases_dir):
    report = check_function(refsynth_fast, cases_dir)
    assert report.passed, str(report)
    kinds = {load_case(cases_dir, name)[0]["kind"] for name in report.checked}
    assert {"np", "bp", "eq5", "eq6", "eq7"} <= kinds


def _perturbed(name: str, original: str, replacement: str):
    """A copy of the literal reference with one line changed, as a module."""
    source = Path(reference_module.__file__).read_text()
    assert source.count(original) == 1, original
    spec = importlib.util.spec_from_loader(f"perturbed_{name}", loader=None)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module   # dataclasses look their module up while being made
    try:
        exec(compile(source.replace(original, replacement), f"<perturbed {name}>", "exec"),
             module.__dict__)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def _adapter(module):
    """The perturbed reference in the checker's convention, with its trace."""

    def function(inputs, options):
        options = dict(options)
        kind, seed = options.pop("method"), options.pop("seed")
        if kind not in ("np", "bp"):
            return None
        names = ("intensity", "partial_range", "edges")
        return run_outputs(kind, {k: inputs[k] for k in names}, options, seed,
                           reference=module)

    return function


def test_eq5_draw_replaced_by_the_best_match_fails_at_the_first_real_draw(cases_dir):
    module = _perturbed("eq5", "members = [i for i, d in enumerate(distances) if d <= threshold]",
                        "members = [best]")
    report = check_function(_adapter(module), cases_dir, case="np-8x8-noise")
    golden = _golden(cases_dir, "np-8x8-noise")
    start, gamma = golden["cand_start"], golden["cand_in_gamma"]
    first = next(s for s in range(len(start) - 1) if gamma[start[s]:start[s + 1]].sum() > 1)
    mismatch = report.mismatch
    assert mismatch is not None and mismatch.key == "cand_in_gamma"
    assert mismatch.step == first
    assert mismatch.pixel == tuple(golden["step_pixel"][first])
    assert f"step {first} pixel {mismatch.pixel}" in str(report)


def test_dropped_confidence_factor_fails_at_the_first_partial_window(cases_dir):
    module = _perturbed(
        "confidence",
        'new = c_best if confidence_update == "best" else confidence_term(conf, r, c, n) * c_best',
        "new = c_best")
    report = check_function(_adapter(module), cases_dir, case="np-16x16-noise")
    golden = _golden(cases_dir, "np-16x16-noise")
    first = int(np.flatnonzero(golden["step_C"] < 1.0)[0])
    assert report.mismatch.key == "step_confidence" and report.mismatch.step == first


def test_bp_fixed_neighbour_sides_swapped_fail_on_a_unary_term(cases_dir):
    module = _perturbed(
        "sides",
        "ms = overlap_mean_square(*((patch, fixed) if node_first else (fixed, patch)),",
        "ms = overlap_mean_square(*((fixed, patch) if node_first else (patch, fixed)),")
    report = check_function(_adapter(module), cases_dir, case="bp-16x16-noise")
    mismatch = report.mismatch
    assert mismatch is not None and mismatch.key == "unary"
    golden = _golden(cases_dir, "bp-16x16-noise")
    known = np.isfinite(golden["partial_range"])
    r, c = mismatch.pixel
    assert any(0 <= r + dr < 16 and 0 <= c + dc < 16 and known[r + dr, c + dc]
               for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)))


def test_bp_sum_instead_of_max_fails_in_the_first_sweep(cases_dir):
    module = _perturbed("sum", "        m = t.max(axis=axis)\n        return m - m.max()",
                        "        m = t.sum(axis=axis)\n        return m - m.max()")
    report = check_function(_adapter(module), cases_dir, case="bp-12x10-noise")
    assert report.mismatch.key == "sweep_messages" and report.mismatch.step == 1


def test_a_float32_port_passes_only_at_the_float32_tolerance(cases_dir):
    def rounded(inputs, options):
        out = refsynth_reference(inputs, options)
        if options["method"] != "np":
            return None
        return {k: out[k].astype(np.float32) if k == "confidence" else out[k]
                for k in ("range", "confidence", "order")}

    assert not check_function(rounded, cases_dir, case="np-8x8-noise").passed
    assert not check_function(rounded, cases_dir, case="np-8x8-noise", tolerance="float64").passed
    assert check_function(rounded, cases_dir, case="np-8x8-noise", tolerance="float32").passed


def test_report_of_missing_outputs_raising_functions_and_nothing_handled(cases_dir):
    def partial(inputs, options):
        return {"range": inputs["partial_range"]} if options["method"] == "np" else None

    report = check_function(partial, cases_dir, case="np-8x8-noise")
    assert report.mismatch.key == "confidence" and report.mismatch.got == "nothing"

    def broken(inputs, options):
        raise RuntimeError("boom")

    report = check_function(broken, cases_dir, case="eq7")
    assert "RuntimeError: boom" in str(report) and not report.passed
    report = check_function(lambda inputs, options: None, cases_dir)
    assert not report.passed and "handled none" in str(report)


def test_an_integer_output_off_by_one_is_reported_with_its_item(cases_dir):
    def off(inputs, options):
        if options["method"] != "eq5":
            return None
        out = refsynth_reference(inputs, options)
        out["chosen"] = out["chosen"].copy()
        out["chosen"][5] += 1
        return out

    report = check_function(off, cases_dir, case="eq5-ties")
    assert report.mismatch.key == "chosen" and "item 5" in str(report)


def test_user_errors(cases_dir, tmp_path):
    for spec in ("nocolon", "a:b:c", ":f", "no_such_module_xyz:f", "refsynth.oracle:nothing"):
        with pytest.raises(ValueError, match="MODULE:FUNCTION|Cannot import|no callable"):
            resolve_function(spec)
    with pytest.raises(FileNotFoundError, match="No such case folder"):
        check_function(refsynth_reference, tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match="no manifest.json"):
        check_function(refsynth_reference, tmp_path)
    with pytest.raises(ValueError, match="No case 'nope'"):
        check_function(refsynth_reference, cases_dir, case="nope")
    with pytest.raises(ValueError, match="tolerance"):
        check_function(refsynth_reference, cases_dir, tolerance="loose")
    with pytest.raises(ValueError, match="No case matches"):
        select_cases(build_cases(), ["zz*"])


# ----------------------------------------------------------------------------- the contract


def _edited_reference(kind: str, edit):
    """The reference's arrays for ``kind``'s cases, changed by ``edit(out)`` (None otherwise)."""

    def port(inputs, options):
        if options["method"] != kind:
            return None
        out = {k: np.array(v, copy=True) for k, v in refsynth_reference(inputs, options).items()}
        edit(out)
        return out

    return port


def test_a_wrong_pixel_is_named_before_the_arrays_that_follow_from_it(cases_dir):
    """A step that fills another pixel has other candidates and distances: the report names
    the pixel (expected vs got) first, not the alphabetically first array (cand_distance)."""
    golden = _golden(cases_dir, "np-8x8-noise")

    def edit(out):
        out["step_pixel"][3] = out["step_pixel"][4]
        out["cand_distance"][out["cand_start"][3]] += 1.0

    report = check_function(_edited_reference("np", edit), cases_dir, case="np-8x8-noise")
    mismatch = report.mismatch
    assert mismatch.key == "step_pixel" and mismatch.step == 3
    assert mismatch.expected == tuple(golden["step_pixel"][3].tolist())
    assert mismatch.got == tuple(golden["step_pixel"][4].tolist())
    assert str(report).startswith(f"FAIL case np-8x8-noise: step_pixel step 3 pixel "
                                  f"{mismatch.expected}: expected {mismatch.expected}, got "
                                  f"{mismatch.got}; also cand_distance candidate 0")


def test_a_wrong_source_is_named_before_the_distances_behind_it(cases_dir):
    golden = _golden(cases_dir, "np-8x8-noise")
    start = golden["cand_start"]
    step = next(s for s in range(len(start) - 1) if start[s + 1] - start[s] > 1)
    other = next(tuple(p) for p in golden["cand_pixel"][start[step]:start[step + 1]].tolist()
                 if tuple(p) != tuple(golden["step_source"][step].tolist()))

    def edit(out):
        out["step_source"][step] = other
        out["cand_distance"][start[step]] += 1.0

    mismatch = check_function(_edited_reference("np", edit), cases_dir,
                              case="np-8x8-noise").mismatch
    assert (mismatch.key, mismatch.step, mismatch.got) == ("step_source", step, other)
    assert mismatch.also.startswith("cand_distance candidate 0")


def test_bp_ports_receive_the_exported_sweeps_and_may_return_every_sweep(cases_dir):
    golden = _golden(cases_dir, "bp-64x64-levels")
    sweeps = golden["sweeps"]
    assert len(sweeps) < sweeps.max()          # a subset: 1, 2, 5, 10 and the last
    received = []

    def port(inputs, options, wrong=None):
        if options["method"] != "bp":
            return None
        received.append(inputs["sweeps"].tolist())
        every = np.zeros(int(inputs["sweeps"].max()))
        every[inputs["sweeps"] - 1] = golden["sweep_change"]
        if wrong is not None:
            every[wrong - 1] += 1.0
        return {k: golden[k] for k in ("range", "confidence", "order")} | dict(
            sweep_change=every)

    assert check_function(port, cases_dir, case="bp-64x64-levels", timeout=None).passed
    assert received == [sweeps.tolist()]
    report = check_function(lambda i, o: port(i, o, wrong=int(sweeps[2])), cases_dir,
                            case="bp-64x64-levels", timeout=None)
    assert (report.mismatch.key, report.mismatch.step) == ("sweep_change", int(sweeps[2]))
    meta = load_case(cases_dir, "bp-64x64-levels")[0]
    assert meta["arrays"]["sweeps"]["role"] == "prepared"


def test_run_cases_carry_every_option_with_its_default(cases_dir):
    from refsynth.oracle.cases import BP_DEFAULTS, NP_DEFAULTS

    for case in build_cases():
        if case.kind not in ("np", "bp"):
            continue
        meta = load_case(cases_dir, case.name)[0]
        defaults = NP_DEFAULTS if case.kind == "np" else BP_DEFAULTS
        assert set(meta["options"]) == set(defaults), case.name
        assert meta["options"] == json.loads(json.dumps(case.options))
        if case.kind == "bp":
            assert isinstance(meta["options"]["offset_tolerance"], float)
    # the offset's agreement follows the observation unless the case sets it
    tolerance = {name: load_case(cases_dir, name)[0]["options"]["offset_tolerance"]
                 for name in ("bp-14x18-planes-np-fill", "bp-14x18-planes",
                              "bp-16x16-np-fill-tolerance")}
    assert tolerance == {"bp-14x18-planes-np-fill": 2.0**-3, "bp-14x18-planes": 2.0**-7,
                         "bp-16x16-np-fill-tolerance": 2.0**-7}


def test_filling_the_defaults_kept_the_cases_arrays_bit_for_bit(tmp_path):
    """The NPZ of these cases (inputs, expected outputs, trace) as case set 6 wrote them."""
    golden = {
        "np-8x8-noise": "2a027cb6dfccfd0ff88b87d5f884732531ca558a34d62f004ac9b56a00c6bfd3",
        "bp-8x8-noise": "4d81c0fe37e7fbdf13c40ac87ba5766f64d2177111c4887952c09c41e8a211ae",
        "np-10x12-best-grey": "cf4faebf1041ed21cb2d4e791b54c857963bd1e8ed1d8bc5d712754785ebef8e",
        "bp-16x16-fig6": "20d4fd09d3f27bb7847b8061c4ca8305e487e3295233bc3f528881b103af04c5",
        "bp-16x16-np-fill-tolerance":
            "41fd44761908cf7dfd37d84c513e80d626e493b3bc1aa02169ade895c71f1d8c",
    }
    export_cases(tmp_path, select_cases(build_cases(), list(golden)))
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert {entry["name"]: entry["sha256"] for entry in manifest["cases"]} == golden


def test_a_wrong_bp_label_is_named_by_its_centre_before_its_terms(cases_dir):
    golden = _golden(cases_dir, "bp-8x8-noise")

    def edit(out):
        out["candidates"][2, 1] = out["candidates"][2, 1] + 1
        out["unary"][0, 0] += 1.0

    mismatch = check_function(_edited_reference("bp", edit), cases_dir,
                              case="bp-8x8-noise").mismatch
    centre = tuple(golden["candidates"][2, 1].tolist())
    assert mismatch.key == "candidates"
    assert (mismatch.expected, mismatch.got) == (centre, tuple(v + 1 for v in centre))
    node = tuple(golden["order"][2].tolist())
    assert str(mismatch).startswith(f"case bp-8x8-noise: candidates node 2 pixel {node}, "
                                    f"label 1: expected {centre}")


def test_the_format_docs_state_the_real_versions_and_count():
    import refsynth.oracle.export as export_module

    doc = " ".join(export_module.__doc__.split())
    assert f'"version": {FORMAT_VERSION}, "contract": {CONTRACT_VERSION}, "case_set": ' \
           f"{CASE_SET_VERSION}," in doc
    assert f"The whole set is {len(build_cases())} cases" in doc


def test_without_step_pixel_the_order_is_the_steps_pixel_decision(cases_dir):
    """A port that returns ``order`` and ``step_source`` only: a wrong pixel at step 3 is
    named as the order's, not as the source drawn for another pixel."""

    def port(inputs, options):
        if options["method"] != "np":
            return None
        out = refsynth_reference(inputs, options)
        order, source = out["order"].copy(), out["step_source"].copy()
        order[[3, 4]], source[[3, 4]] = order[[4, 3]], source[[4, 3]]
        return dict(range=out["range"], confidence=out["confidence"], order=order,
                    step_source=source)

    mismatch = check_function(port, cases_dir, case="np-8x8-noise").mismatch
    assert (mismatch.key, mismatch.step) == ("order", 3)
    assert mismatch.also.startswith("step_source")
