"""``oracle export DIR``: write the golden cases as NPZ + JSON (format version 1).

Layout::

    DIR/manifest.json        format, version, contract, case set, refsynth and numpy versions,
                             the list of cases (name, kind, files, SHA-256 of the NPZ)
    DIR/schema.json          JSON Schema (draft 2020-12) of manifest.json; $defs.case is a
                             case's JSON
    DIR/cases/<name>.json    kind, equation, function, tolerance, options, seed, and for each
                             array its role, dtype and shape
    DIR/cases/<name>.npz     the arrays (an ``.npz`` as ``numpy.savez_compressed`` writes it,
                             no pickles, fixed timestamps: the same bytes on every export)

An array's role is ``input`` (what the function under test receives), ``prepared`` (the
contract's intermediate values: quantised data, the integer window, the tie permutation and
the Eq. 5 draws that a port with another random generator replays), ``output`` or
``trace`` (NP's per-step rows, BP's messages per sweep).
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from pathlib import Path

import numpy as np

from refsynth.oracle.cases import CASE_SET_VERSION, Case, build_cases, expected_outputs
from refsynth.oracle.equations import KINDS

__all__ = ["FORMAT_VERSION", "CONTRACT_VERSION", "SCHEMA", "export_cases", "roles", "write_npz"]

#: The version of the file format (this module's layout and the roles).
FORMAT_VERSION = 1
#: The version of the numeric contract the expected values follow (README, "The oracle").
CONTRACT_VERSION = 1

_PREPARED = {"q_intensity", "q_range", "q_observation", "window", "tie", "draws", "onion_tie"}
_TRACE = ("step_", "cand_", "sweep")

SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://refsynth.invalid/oracle/schema/1",
    "title": "refsynth oracle: golden cases (manifest.json; $defs.case: cases/<name>.json)",
    "$defs": {
        "array": {
            "type": "object",
            "required": ["role", "dtype", "shape"],
            "additionalProperties": False,
            "properties": {
                "role": {"enum": ["input", "prepared", "output", "trace"]},
                "dtype": {"type": "string", "description": "numpy dtype name, e.g. int64"},
                "shape": {"type": "array", "items": {"type": "integer", "minimum": 0}},
            },
        },
        "case": {
            "type": "object",
            "required": ["name", "kind", "equation", "function", "tolerance", "options",
                         "seed", "arrays"],
            "properties": {
                "name": {"type": "string", "pattern": "^[A-Za-z0-9_.-]+$"},
                "kind": {"enum": sorted(KINDS)},
                "equation": {"type": "string"},
                "function": {"type": "string",
                             "description": "the refsynth function behind the expected values"},
                "tolerance": {"enum": ["exact", "float64"],
                              "description": "the loosest comparison this case needs"},
                "options": {"type": "object",
                            "description": "keyword arguments (synthesize's for np and bp)"},
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
        "cases": {"type": "array", "items": {
            "type": "object", "required": ["name", "kind", "json", "npz", "sha256"],
            "properties": {"sha256": {"type": "string", "pattern": "^[0-9a-f]{64}$"}}}},
    },
}


def roles(case: Case, outputs: dict) -> dict:
    """The role of every array of a case."""
    out = {key: "input" for key in case.inputs}
    for key in outputs:
        if key in _PREPARED:
            out[key] = "prepared"
        elif key.startswith(_TRACE):
            out[key] = "trace"
        else:
            out[key] = "output"
    return out


def write_npz(path, arrays: dict) -> None:
    """``numpy.savez_compressed`` with fixed zip timestamps: the same arrays, the same bytes."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for key, value in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(info, "w", force_zip64=True) as stream:
                np.lib.format.write_array(stream, np.asanyarray(value), allow_pickle=False)


def _json_value(value):
    """Options as JSON: tuples become lists, numpy scalars Python numbers."""
    if isinstance(value, (tuple, list)):
        return [_json_value(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def export_cases(directory, cases: list[Case] | None = None) -> list[str]:
    """Write ``cases`` (default :func:`~refsynth.oracle.cases.build_cases`) under ``directory``.

    The layout is the module's: ``manifest.json``, ``schema.json`` and, per
    case, ``cases/<name>.json`` and ``cases/<name>.npz``, its inputs with the
    expected values of :func:`~refsynth.oracle.cases.expected_outputs`.

    Parameters
    ----------
    directory : str or Path
        Created if needed; files already there are overwritten.
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
        If a case's outputs are named as its inputs.

    Examples
    --------
    One Eq. 7 case (``log Φ = −d / 2σ_i²``, §3.2.3):

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> phi = Case("phi", "eq7", {"distances": np.array([[0.0, 0.5, 2.0]])}, {"sigma_i": 0.5})
    >>> export_cases(folder, [phi])
    ['phi']
    >>> sorted(path.name for path in folder.rglob("*.*"))
    ['manifest.json', 'phi.json', 'phi.npz', 'schema.json']
    """
    import refsynth

    root = Path(directory)
    (root / "cases").mkdir(parents=True, exist_ok=True)
    entries = []
    for case in build_cases() if cases is None else cases:
        outputs = expected_outputs(case)
        clash = sorted(set(outputs) & set(case.inputs))
        if clash:
            raise ValueError(f"Case {case.name}: outputs named as inputs: {clash}")
        arrays = {key: np.asarray(value) for key, value in {**case.inputs, **outputs}.items()}
        npz = root / "cases" / f"{case.name}.npz"
        write_npz(npz, arrays)
        role = roles(case, outputs)
        equation, function, tolerance = KINDS[case.kind]
        meta = dict(name=case.name, kind=case.kind, equation=equation,
                    function=f"refsynth.{function}", tolerance=tolerance,
                    options={k: _json_value(v) for k, v in case.options.items()},
                    seed=case.seed,
                    arrays={key: dict(role=role[key], dtype=str(value.dtype),
                                      shape=list(value.shape))
                            for key, value in arrays.items()})
        (root / "cases" / f"{case.name}.json").write_text(json.dumps(meta, indent=1) + "\n")
        entries.append(dict(name=case.name, kind=case.kind, json=f"cases/{case.name}.json",
                            npz=f"cases/{case.name}.npz",
                            sha256=hashlib.sha256(npz.read_bytes()).hexdigest()))
    manifest = dict(format="refsynth-oracle", version=FORMAT_VERSION, contract=CONTRACT_VERSION,
                    case_set=CASE_SET_VERSION,
                    refsynth=getattr(refsynth, "__version__", "unknown"),
                    numpy=np.__version__, cases=entries)
    (root / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    (root / "schema.json").write_text(json.dumps(SCHEMA, indent=1) + "\n")
    return [entry["name"] for entry in entries]
