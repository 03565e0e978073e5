"""The aggregated rows as files: JSON (to reload with ``evaluate --load``) and CSV.

Floats are written exactly (``repr``), so two runs of the same grid give
byte-identical files once the timing column is left out
(:func:`refsynth.evaluation.aggregation.without_timing`).
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from pathlib import Path

from refsynth._files import write_atomic

__all__ = ["CSV_FIELDS", "ROW_FIELDS", "write_json", "read_json", "write_csv"]


def _json_value(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str | Path, rows: Sequence[dict]) -> None:
    """Write the rows as a JSON list (one object per scene × sampling × method).

    Parameters
    ----------
    path : str or Path
        The file to write; an existing file is replaced only once the new one
        is complete (:func:`refsynth._files.write_atomic`).
    rows : sequence of dict
        Rows of :func:`refsynth.evaluation.aggregation.aggregate`; NaN is
        written as ``null``.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "rows.json"
    >>> write_json(path, [{"method": "np", "mar": float("nan")}])
    >>> print(path.read_text())
    [
     {
      "method": "np",
      "mar": null
     }
    ]
    <BLANKLINE>
    """
    clean = [{k: _json_value(v) for k, v in row.items()} for row in rows]
    write_atomic(path, (json.dumps(clean, indent=1, ensure_ascii=False) + "\n")
                 .encode("utf-8"))


#: The fields of a row and their types, as :func:`refsynth.evaluation.aggregation.aggregate`
#: writes them: "str", "int", "real" (a number, or null for NaN), "real?" (null allowed
#: as such), "ints" / "reals" (lists). ``seconds`` may be absent (``--no-timing``).
ROW_FIELDS = {
    "scene": "str", "scene_spec": "str", "size": "str", "units": "str", "sampling": "str",
    "unknown_percent": "real", "known": "int", "evaluated": "int", "method": "str",
    "seeds": "ints", "mar": "real", "mar_sd": "real?", "mar_min": "real", "mar_max": "real",
    "mar_per_seed": "reals", "rmse": "real", "bad1": "real", "bad3": "real", "seconds": "real",
}
_OPTIONAL = {"seconds"}


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _field_ok(kind: str, value) -> bool:
    if kind == "str":
        return isinstance(value, str)
    if kind == "int":
        return isinstance(value, int) and not isinstance(value, bool) and value >= 0
    if kind in ("real", "real?"):
        return value is None or _is_number(value)
    if kind == "ints":
        return (isinstance(value, list) and len(value) > 0
                and all(_field_ok("int", v) for v in value))
    return isinstance(value, list) and all(_field_ok("real", v) for v in value)


def _row(path, index: int, row) -> dict:
    """One row, checked; null reals (NaN written as null) come back as NaN."""
    if not isinstance(row, dict):
        raise ValueError(f"{path} is not a list of rows written by `evaluate --json`: "
                         f"row {index} is a {type(row).__name__}")
    missing = [name for name in ROW_FIELDS if name not in row and name not in _OPTIONAL]
    if missing:
        raise ValueError(f"{path} is not a list of rows written by `evaluate --json`: "
                         f"row {index} lacks {', '.join(missing)}")
    clean = {}
    for name, value in row.items():
        kind = ROW_FIELDS.get(name)
        if kind is None:
            raise ValueError(f"{path}: row {index} has an unknown field {name!r}")
        if not _field_ok(kind, value):
            raise ValueError(f"{path}: row {index} has a bad {name!r}: {value!r:.60}")
        if kind == "real" and value is None:
            value = math.nan
        elif kind == "reals":
            value = [math.nan if v is None else float(v) for v in value]
        elif kind.startswith("real") and value is not None:
            value = float(value)
        clean[name] = value
    if len(clean["mar_per_seed"]) != len(clean["seeds"]):
        raise ValueError(f"{path}: row {index} has {len(clean['seeds'])} seeds but "
                         f"{len(clean['mar_per_seed'])} MARs")
    return clean


def read_json(path: str | Path) -> list[dict]:
    """Read rows written by :func:`write_json` (``--json``), checking every field.

    Parameters
    ----------
    path : str or Path
        A JSON file of :func:`write_json`.

    Returns
    -------
    list of dict
        The rows, with ``null`` reals read back as NaN.

    Raises
    ------
    OSError
        If the file cannot be read.
    ValueError
        If it is not UTF-8 JSON, nests too deeply, or is not a list of rows
        with the fields and types of :data:`ROW_FIELDS` (the message names
        the file, and the row and field at fault).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "rows.json"
    >>> row = dict(scene="room", scene_spec="synthetic-0", size="16x16", units="m", sampling="x78",
    ...            unknown_percent=75.0, known=64, evaluated=192, method="np", seeds=[0],
    ...            mar=0.2, mar_sd=float("nan"), mar_min=0.2, mar_max=0.2, mar_per_seed=[0.2],
    ...            rmse=0.3, bad1=0.0, bad3=0.0)
    >>> write_json(path, [row])
    >>> read_json(path)[0]["mar_sd"]
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
        rows = json.loads(text)
    except UnicodeDecodeError as error:
        raise ValueError(f"{path} is not UTF-8 text: {error.reason}") from None
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON: {error}") from None
    except RecursionError:
        raise ValueError(f"{path} is not a list of rows: it nests too deeply") from None
    if not isinstance(rows, list):
        raise ValueError(f"{path} is not a list of rows written by `evaluate --json`")
    if not rows:
        raise ValueError(f"{path} holds no rows")
    return [_row(path, index, row) for index, row in enumerate(rows)]


#: CSV columns, in order (lists are joined with spaces).
CSV_FIELDS = ("scene", "size", "units", "sampling", "unknown_percent", "known", "evaluated",
              "method", "seeds", "mar", "mar_sd", "mar_min", "mar_max", "mar_per_seed",
              "rmse", "bad1", "bad3", "seconds")


def write_csv(path: str | Path, rows: Sequence[dict]) -> None:
    """Write the rows as CSV, one line per scene × sampling × method.

    Parameters
    ----------
    path, rows
        As for :func:`write_json`; the columns are those of :data:`CSV_FIELDS`
        that the first row has (lists joined with spaces, None left empty).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "rows.csv"
    >>> write_csv(path, [dict.fromkeys(CSV_FIELDS, 1)])
    >>> path.read_text().splitlines()[0].split(",")[:4]
    ['scene', 'size', 'units', 'sampling']
    """
    fields = [f for f in CSV_FIELDS if not rows or f in rows[0]]
    handle = io.StringIO(newline="")
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
    write_atomic(path, handle.getvalue().encode("utf-8"))

