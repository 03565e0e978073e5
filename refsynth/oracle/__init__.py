"""The correctness oracle: golden cases and step traces that a port replays.

- :mod:`refsynth.oracle.cases`: the versioned case set, whole NP and BP runs from 8×8 to
  64×64, and per-equation batches (:mod:`refsynth.oracle.equations`: Eqs. 2, 5, 6, 7, 10–12,
  13, Canny, 14–21), with their expected outputs from the literal reference
  (:mod:`refsynth.synthesis.reference`; :mod:`refsynth.oracle.runs` flattens its step traces).
- :mod:`refsynth.oracle.export`: ``python -m refsynth oracle export DIR`` (NPZ + JSON, with a
  JSON Schema).
- :mod:`refsynth.oracle.check`: ``python -m refsynth oracle check MODULE:FUNCTION``, each
  failing case's first mismatch (case, step, pixel, expected, got) and a summary line; the
  function runs in a worker process with a time limit per case
  (:mod:`refsynth.oracle.worker`), on a folder whose checksums are verified first
  (:mod:`refsynth.oracle.files`), and the arrays are compared by
  :mod:`refsynth.oracle.compare`.
- :mod:`refsynth.oracle.contract`: the porter's contract, every float sequence a port must
  reproduce (the numeric contract C1–C10, then NP and BP step by step), each with the case
  that fails when it is broken.
- :mod:`refsynth.oracle.adapters`: refsynth's own reference and fast code in the checker's
  calling convention (templates for a port's adapter).

The numeric contract behind the cases is :mod:`refsynth.oracle.contract` (its helpers live
in :mod:`refsynth.numeric`).
"""

from refsynth.oracle.adapters import refsynth_fast, refsynth_reference
from refsynth.oracle.cases import CASE_SET_VERSION, Case, build_cases, expected_outputs
from refsynth.oracle.check import (
    DEFAULT_TIMEOUT,
    TOLERANCES,
    CheckReport,
    Mismatch,
    check_function,
    load_case,
    load_manifest,
    resolve_function,
)
from refsynth.oracle.equations import KINDS
from refsynth.oracle.export import CONTRACT_VERSION, FORMAT_VERSION, SCHEMA, export_cases

__all__ = [
    "Case",
    "build_cases",
    "expected_outputs",
    "export_cases",
    "check_function",
    "CheckReport",
    "Mismatch",
    "load_case",
    "load_manifest",
    "resolve_function",
    "refsynth_fast",
    "refsynth_reference",
    "KINDS",
    "TOLERANCES",
    "DEFAULT_TIMEOUT",
    "FORMAT_VERSION",
    "CONTRACT_VERSION",
    "CASE_SET_VERSION",
    "SCHEMA",
]
