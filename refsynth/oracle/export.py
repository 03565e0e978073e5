"""``oracle export DIR``: write the golden cases as NPZ + JSON (format version 1).

Layout::

    DIR/manifest.json        format, version, contract, refsynth version, the list of cases
    DIR/schema.json          JSON Schema of manifest.json and of a case's JSON
    DIR/cases/<name>.json    kind, options, seed, and for each array its role, dtype and shape
    DIR/cases/<name>.npz     the arrays (``numpy.savez_compressed``, no pickles)

An array's role is ``input`` (what the function under test receives), ``prepared`` (the
contract's intermediate values: quantised data, the window, the tie permutation and the
Eq. 5 draws a port with another random generator replays), ``output`` or ``trace``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from refsynth.oracle.cases import Case, build_cases, expected_outputs

__all__ = ["FORMAT_VERSION", "CONTRACT_VERSION", "SCHEMA", "export_cases", "roles"]

FORMAT_VERSION = 1
CONTRACT_VERSION = 1

_PREPARED = {"q_intensity", "q_range", "window", "tie", "draws"}

SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$defs": {
        "array": {
            "type": "object",
            "required": ["role", "dtype", "shape"],
            "properties": {
                "role": {"enum": ["input", "prepared", "output", "trace"]},
                "dtype": {"type": "string"},
                "shape": {"type": "array", "items": {"type": "integer", "minimum": 0}},
            },
        },
        "case": {
            "type": "object",
            "required": ["name", "kind", "options", "seed", "arrays"],
            "properties": {
                "name": {"type": "string"},
                "kind": {"enum": ["np", "bp", "eq2", "eq5"]},
                "options": {"type": "object"},
                "seed": {"type": ["integer", "null"]},
                "arrays": {"type": "object", "additionalProperties": {"$ref": "#/$defs/array"}},
            },
        },
    },
    "type": "object",
    "required": ["format", "version", "contract", "cases"],
    "properties": {
        "format": {"const": "refsynth-oracle"},
        "version": {"const": FORMAT_VERSION},
        "contract": {"type": "integer"},
        "refsynth": {"type": "string"},
        "cases": {"type": "array", "items": {
            "type": "object", "required": ["name", "kind", "json", "npz", "sha256"]}},
    },
}


def roles(case: Case, outputs: dict) -> dict:
    """The role of every array of a case."""
    out = {key: "input" for key in case.inputs}
    for key in outputs:
        if key in _PREPARED:
            out[key] = "prepared"
        elif key.startswith(("step_", "cand_")) or key in ("messages", "change"):
            out[key] = "trace"
        else:
            out[key] = "output"
    return out


def export_cases(directory, cases: list[Case] | None = None) -> list[str]:
    """Write ``cases`` (default :func:`~refsynth.oracle.cases.build_cases`) under ``directory``.

    Returns the case names, in manifest order.
    """
    import refsynth

    root = Path(directory)
    (root / "cases").mkdir(parents=True, exist_ok=True)
    entries = []
    for case in build_cases() if cases is None else cases:
        outputs = expected_outputs(case)
        arrays = {**case.inputs, **outputs}
        npz = root / "cases" / f"{case.name}.npz"
        np.savez_compressed(npz, **arrays)
        role = roles(case, outputs)
        meta = dict(name=case.name, kind=case.kind, options=case.options, seed=case.seed,
                    arrays={key: dict(role=role[key], dtype=str(np.asarray(value).dtype),
                                      shape=list(np.shape(value)))
                            for key, value in arrays.items()})
        (root / "cases" / f"{case.name}.json").write_text(json.dumps(meta, indent=1) + "\n")
        entries.append(dict(name=case.name, kind=case.kind, json=f"cases/{case.name}.json",
                            npz=f"cases/{case.name}.npz",
                            sha256=hashlib.sha256(npz.read_bytes()).hexdigest()))
    manifest = dict(format="refsynth-oracle", version=FORMAT_VERSION, contract=CONTRACT_VERSION,
                    refsynth=getattr(refsynth, "__version__", "unknown"), cases=entries)
    (root / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    (root / "schema.json").write_text(json.dumps(SCHEMA, indent=1) + "\n")
    return [entry["name"] for entry in entries]
