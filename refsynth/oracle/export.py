"""``oracle export DIR``: write the golden cases as NPZ + JSON (format version 2).

Layout::

    DIR/manifest.json        {"format": "refsynth-oracle", "version": 2, "contract": 1,
                              "case_set": 9, "refsynth": "…", "numpy": "…",
                              "cases": [{"name", "kind", "json", "npz", "sha256",
                                         "json_sha256"}, …]}
    DIR/schema.json          JSON Schema (draft 2020-12) of manifest.json; $defs.case is a
                             case's JSON
    DIR/cases/<name>.json    {"name", "kind", "equation", "function", "tolerance", "options",
                              "seed", "arrays": {"<key>": {"role", "dtype", "shape"}}}
    DIR/cases/<name>.npz     the arrays (an ``.npz`` as ``numpy.savez_compressed`` writes it,
                             no pickles, fixed timestamps: the same bytes on every export)

``version`` is :data:`FORMAT_VERSION` (this layout and the roles), ``contract``
:data:`CONTRACT_VERSION` (the numeric contract, :mod:`refsynth.numeric`), ``case_set``
:data:`~refsynth.oracle.cases.CASE_SET_VERSION` (the cases' inputs and options). ``sha256``
and ``json_sha256`` are the SHA-256 of the case's NPZ and JSON: ``oracle check`` verifies
them before any case runs. The whole set is 64 cases (``--large`` adds a 48×64 NP run);
``--cases PATTERN …`` writes a subset. Every file is written atomically
(:func:`refsynth._files.write_atomic`), and only into a new or empty folder or over an
earlier export (:func:`~refsynth.oracle.files.check_export_target`).

An array's role is ``input`` (what the function under test receives), ``prepared`` (the
contract's intermediate values, received too: quantised data, the integer window, the tie
permutation and the Eq. 5 draws that a port with another random generator replays, BP's
observations and its exported ``sweeps``), ``output`` or ``trace`` (NP's per-step rows, BP's
messages per sweep).

**Whole runs** (``kind`` ``"np"``, ``"bp"``; ``options`` hold every option of
:func:`refsynth.synthesize` that the method takes, defaults filled in; ``seed`` the run's):

- inputs ``intensity`` (H, W) or (H, W, 3) float64, ``partial_range`` (H, W) float64 (NaN
  unknown), ``edges`` (H, W) bool (used with ``use_edges``);
- prepared ``q_intensity`` (H, W, C) int64 (the intensity Eq. 2 uses: the grey level, C = 1,
  with ``colour=False``), ``q_range`` (H, W) int64 (−1 unknown), ``window`` (n, n) int64;
  NP's random numbers ``tie`` (H, W) int64, ``draws`` (N,) float64 and, in the onion order,
  ``onion_tie`` (N,) int64 (BP's cases too when ``observation="np"``, whose NP fill draws
  them: NP at :data:`~refsynth.oracle.cases.NP_DEFAULTS` with BP's ``neighbourhood``,
  ``radius``, ``use_edges``, ``range_weight``, ``missing_range``, ``colour`` and
  ``channels``); BP's ``q_observation`` (H, W) int64 (the observations on the measured range's grid)
  and ``sweeps`` (T,) int64 (the 1-based sweeps whose messages the trace holds: all of them
  up to 32×32 pixels, else 1, 2, 5, 10 and the last);
- outputs ``range``, ``confidence`` (H, W) float64, ``order`` (N, 2) int64 (the N unknown
  pixels in synthesis order); BP's ``labels`` (N,), ``candidates`` (N, k, 2) (the labels'
  centre pixels), ``candidate_values`` (N, k), ``unary`` (N, k), ``pairs`` (E, 2),
  ``log_psi`` (E, k, k), ``messages`` (2E, k), ``beliefs`` (N, k), ``iterations`` ();
- trace, NP: one row per step, ``step_pixel`` (N, 2), ``step_tier``, ``step_tie``,
  ``step_C``, ``step_D``, ``step_E`` (the term 1/(1+E)), ``step_P`` (the terms NaN in the
  onion order), ``step_best``, ``step_draw``, ``step_source`` (N, 2), ``step_value``,
  ``step_confidence``, and the candidates in CSR form: ``cand_start`` (N + 1,), step ``s``'s
  rows ``cand_start[s] : cand_start[s + 1]`` of ``cand_pixel`` (M, 2), ``cand_distance``
  (M,) and ``cand_in_gamma`` (M,) bool; BP: ``sweep_messages`` (T, 2E, k) and
  ``sweep_change`` (T,) at the ``sweeps``.

**Per-equation batches** (the table of :mod:`refsynth.oracle.equations`; ``seed`` null).
Eq. 2's ``q_intensity`` (B, 2, n, n, C) and ``q_range`` (B, 2, n, n) hold at index 0 of
axis 1 the target (the pixel being filled: the mean-filled range term weighs its known
pixels) and at index 1 the candidate; its outputs are ``distance_mean``,
``distance_ignore`` (the channel sum) and ``distance_mean_channel_mean``,
``distance_ignore_channel_mean`` (the channel mean), with ``window`` prepared.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile

import numpy as np

from refsynth._files import write_atomic
from refsynth.oracle.cases import CASE_SET_VERSION, Case, build_cases, expected_outputs
from refsynth.oracle.equations import KINDS
from refsynth.oracle.files import FORMAT_VERSION, ROLES, check_export_target

__all__ = ["FORMAT_VERSION", "CONTRACT_VERSION", "SCHEMA", "export_cases", "roles", "write_npz",
           "npz_bytes"]

#: The version of the numeric contract the expected values follow (:mod:`refsynth.numeric`).
CONTRACT_VERSION = 1

_PREPARED = {"q_intensity", "q_range", "q_observation", "window", "tie", "draws", "onion_tie",
             "sweeps"}
_TRACE = ("step_", "cand_", "sweep_")

SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": f"https://refsynth.invalid/oracle/schema/{FORMAT_VERSION}",
    "title": "refsynth oracle: golden cases (manifest.json; $defs.case: cases/<name>.json)",
    "$defs": {
        "array": {
            "type": "object",
            "required": ["role", "dtype", "shape"],
            "additionalProperties": False,
            "properties": {
                "role": {"enum": list(ROLES)},
                "dtype": {"type": "string", "description": "numpy dtype name, e.g. int64"},
                "shape": {"type": "array", "items": {"type": "integer", "minimum": 0}},
            },
        },
        "case": {
            "type": "object",
            "required": ["name", "kind", "equation", "function", "tolerance", "options",
                         "seed", "arrays"],
            "properties": {
                "name": {"type": "string", "pattern": "^[A-Za-z0-9_][A-Za-z0-9_.-]*$"},
                "kind": {"enum": sorted(KINDS)},
                "equation": {"type": "string"},
                "function": {"type": "string",
                             "description": "the refsynth function behind the expected values"},
                "tolerance": {"enum": ["exact", "float64"],
                              "description": "the loosest comparison this case needs"},
                "options": {"type": "object",
                            "description": "keyword arguments: for np and bp every option of "
                            "synthesize that the method takes, defaults filled in"},
                "seed": {"type": ["integer", "null"]},
                "arrays": {"type": "object",
                           "additionalProperties": {"$ref": "#/$defs/array"}},
            },
        },
    },
    "type": "object",
    "required": ["format", "version", "contract", "case_set", "refsynth", "cases"],
    "properties": {
        "format": {"const": "refsynth-oracle"},
        "version": {"const": FORMAT_VERSION},
        "contract": {"type": "integer"},
        "case_set": {"type": "integer"},
        "refsynth": {"type": "string"},
        "numpy": {"type": "string"},
        "cases": {"type": "array", "minItems": 1, "items": {
            "type": "object",
            "required": ["name", "kind", "json", "npz", "sha256", "json_sha256"],
            "properties": {
                "name": {"type": "string", "pattern": "^[A-Za-z0-9_][A-Za-z0-9_.-]*$"},
                "kind": {"enum": sorted(KINDS)},
                "json": {"type": "string", "description": "cases/<name>.json"},
                "npz": {"type": "string", "description": "cases/<name>.npz"},
                "sha256": {"type": "string", "pattern": "^[0-9a-f]{64}$",
                           "description": "SHA-256 of the NPZ"},
                "json_sha256": {"type": "string", "pattern": "^[0-9a-f]{64}$",
                                "description": "SHA-256 of the case's JSON"}}}},
    },
}


def roles(case: Case, outputs: dict) -> dict:
    """The role of every array of a case (``input``, ``prepared``, ``output``, ``trace``)."""
    out = {key: "input" for key in case.inputs}
    for key in outputs:
        if key in _PREPARED:
            out[key] = "prepared"
        elif key.startswith(_TRACE):
            out[key] = "trace"
        else:
            out[key] = "output"
    return out


def npz_bytes(arrays: dict) -> bytes:
    """``numpy.savez_compressed``'s archive with fixed zip timestamps: same arrays, same bytes."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(info, "w", force_zip64=True) as stream:
                np.lib.format.write_array(stream, np.asanyarray(value), allow_pickle=False)
    return buffer.getvalue()


def write_npz(path, arrays: dict) -> None:
    """Write :func:`npz_bytes` to ``path`` atomically."""
    write_atomic(path, npz_bytes(arrays))


def _json_value(value):
    """Options as JSON: tuples become lists, numpy scalars Python numbers."""
    if isinstance(value, (tuple, list)):
        return [_json_value(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _json_bytes(value) -> bytes:
    return (json.dumps(value, indent=1) + "\n").encode("utf-8")


def export_cases(directory, cases: list[Case] | None = None) -> list[str]:
    """Write ``cases`` (default :func:`~refsynth.oracle.cases.build_cases`) under ``directory``.

    The layout is the module's: ``manifest.json``, ``schema.json`` and, per
    case, ``cases/<name>.json`` and ``cases/<name>.npz``, its inputs with the
    expected values of :func:`~refsynth.oracle.cases.expected_outputs`.

    Parameters
    ----------
    directory : str or Path
        A new or empty folder (created if needed), or one that holds an
        earlier export and nothing else: its manifest is removed first, its
        case files are replaced.
    cases : list of Case, optional
        Default: the whole set, :func:`~refsynth.oracle.cases.build_cases`
        (several seconds: the reference runs every case).

    Returns
    -------
    list of str
        The case names, in manifest order.

    Raises
    ------
    ValueError
        If ``directory`` holds anything an export does not write (a scan
        folder, say), or a case's outputs are named as its inputs.
    OSError
        Naming the file, if one cannot be written (the previous file, if any,
        is then intact).

    Examples
    --------
    One Eq. 7 case (``log Φ = −d / 2σ_i²``, §3.2.3):

    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> phi = Case("phi", "eq7", {"distances": np.array([[0.0, 0.5, 2.0]])}, {"sigma_i": 0.5})
    >>> export_cases(folder, [phi])
    ['phi']
    >>> sorted(path.name for path in folder.rglob("*.*"))
    ['manifest.json', 'phi.json', 'phi.npz', 'schema.json']
    """
    import refsynth

    root = check_export_target(directory)
    cases = build_cases() if cases is None else cases
    (root / "cases").mkdir(parents=True, exist_ok=True)
    if (root / "manifest.json").is_file():   # an earlier export's: stale while this one runs
        os.unlink(root / "manifest.json")
    entries = []
    for case in cases:
        outputs = expected_outputs(case)
        clash = sorted(set(outputs) & set(case.inputs))
        if clash:
            raise ValueError(f"Case {case.name}: outputs named as inputs: {clash}")
        arrays = {key: np.asarray(value) for key, value in {**case.inputs, **outputs}.items()}
        npz = npz_bytes(arrays)
        role = roles(case, outputs)
        equation, function, tolerance = KINDS[case.kind]
        meta = _json_bytes(dict(
            name=case.name, kind=case.kind, equation=equation, function=f"refsynth.{function}",
            tolerance=tolerance, options={k: _json_value(v) for k, v in case.options.items()},
            seed=case.seed,
            arrays={key: dict(role=role[key], dtype=str(value.dtype), shape=list(value.shape))
                    for key, value in arrays.items()}))
        write_atomic(root / "cases" / f"{case.name}.npz", npz)
        write_atomic(root / "cases" / f"{case.name}.json", meta)
        entries.append(dict(name=case.name, kind=case.kind, json=f"cases/{case.name}.json",
                            npz=f"cases/{case.name}.npz",
                            sha256=hashlib.sha256(npz).hexdigest(),
                            json_sha256=hashlib.sha256(meta).hexdigest()))
    manifest = dict(format="refsynth-oracle", version=FORMAT_VERSION, contract=CONTRACT_VERSION,
                    case_set=CASE_SET_VERSION,
                    refsynth=getattr(refsynth, "__version__", "unknown"),
                    numpy=np.__version__, cases=entries)
    write_atomic(root / "schema.json", _json_bytes(SCHEMA))
    write_atomic(root / "manifest.json", _json_bytes(manifest))
    return [entry["name"] for entry in entries]
