"""The correctness oracle: golden cases and step traces a port replays (issue #11).

- :mod:`refsynth.oracle.cases`: the versioned case set (whole NP and BP runs from 8×8 up, and
  per-equation batches) and their expected outputs, from the literal reference
  :mod:`refsynth.synthesis.reference`.
- :mod:`refsynth.oracle.export`: ``oracle export DIR`` (NPZ + JSON, with a JSON Schema).
- :mod:`refsynth.oracle.check`: ``oracle check MODULE:FUNCTION``, the first mismatch.

The numeric contract behind the cases is stated in :mod:`refsynth.synthesis.reference`.
"""

from refsynth.oracle.cases import Case, build_cases, expected_outputs
from refsynth.oracle.check import (
    Mismatch,
    check_function,
    load_case,
    refsynth_fast,
    refsynth_reference,
    resolve_function,
)
from refsynth.oracle.export import CONTRACT_VERSION, FORMAT_VERSION, SCHEMA, export_cases

__all__ = [
    "Case",
    "build_cases",
    "expected_outputs",
    "export_cases",
    "check_function",
    "load_case",
    "resolve_function",
    "refsynth_fast",
    "refsynth_reference",
    "Mismatch",
    "FORMAT_VERSION",
    "CONTRACT_VERSION",
    "SCHEMA",
]
