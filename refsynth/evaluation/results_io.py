"""The aggregated rows as files: JSON (to reload with ``evaluate --load``) and CSV.

Floats are written exactly (``repr``), so two runs of the same grid give
byte-identical files once the timing column is left out
(:func:`refsynth.evaluation.aggregation.without_timing`).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path

__all__ = ["CSV_FIELDS", "write_json", "read_json", "write_csv"]


def _json_value(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str | Path, rows: Sequence[dict]) -> None:
    """Write the rows as a JSON list (one object per scene × sampling × method)."""
    clean = [{k: _json_value(v) for k, v in row.items()} for row in rows]
    Path(path).write_text(json.dumps(clean, indent=1, ensure_ascii=False) + "\n",
                          encoding="utf-8")


def read_json(path: str | Path) -> list[dict]:
    """Read rows written by :func:`write_json` (``--json``).

    Raises
    ------
    OSError
        If the file cannot be read.
    ValueError
        If it is not a JSON list of rows.
    """
    try:
        rows = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON: {error}") from None
    needed = {"scene", "sampling", "method", "mar", "mar_sd", "seeds", "units"}
    if not isinstance(rows, list) or not all(
        isinstance(r, dict) and needed <= r.keys() for r in rows
    ):
        raise ValueError(f"{path} is not a list of rows written by `evaluate --json`")
    return rows


#: CSV columns, in order (lists are joined with spaces).
CSV_FIELDS = ("scene", "size", "units", "sampling", "unknown_percent", "known", "evaluated",
              "method", "seeds", "mar", "mar_sd", "mar_min", "mar_max", "mar_per_seed",
              "rmse", "bad1", "bad3", "seconds")


def write_csv(path: str | Path, rows: Sequence[dict]) -> None:
    """Write the rows as CSV, one line per scene × sampling × method."""
    fields = [f for f in CSV_FIELDS if not rows or f in rows[0]]
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(fields)
        for row in rows:
            cells = []
            for field in fields:
                value = row[field]
                if isinstance(value, list):
                    value = " ".join(repr(v) for v in value)
                elif value is None:
                    value = ""
                elif isinstance(value, float):
                    value = repr(value)
                cells.append(value)
            writer.writerow(cells)

