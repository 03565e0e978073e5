"""An exported case folder: reading it back, verified, and what may be exported over.

- :func:`load_manifest`: ``manifest.json``, checked entry by entry (case names confined to
  ``cases/``, kinds known, checksums present);
- :func:`load_cases`: the chosen cases, every file's SHA-256 checked against the manifest
  **before** anything is read or run, then each case's JSON and NPZ checked against each
  other;
- :func:`load_case`: one case's JSON and arrays;
- :func:`check_export_target`: a folder ``oracle export`` may write into (new, empty, or an
  earlier export, and nothing else).

Every problem is a ``ValueError`` (or ``FileNotFoundError``) of one line naming the file:
a folder that was changed, truncated or corrupted is reported as such, never as a
difference between the function under test and the reference.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import stat
from pathlib import Path

import numpy as np

from refsynth.oracle.equations import KINDS

__all__ = ["FORMAT_VERSION", "ROLES", "load_manifest", "load_case", "load_cases",
           "check_export_target", "is_case_name"]

#: The version of the file format (the layout of export.py and the roles).
FORMAT_VERSION = 2
#: The role of an array in a case.
ROLES = ("input", "prepared", "output", "trace")

_CASE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")
_ARRAY_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_SHA256 = re.compile(r"[0-9a-f]{64}")
_ENTRY_KEYS = ("name", "kind", "json", "npz", "sha256", "json_sha256")
#: The arrays every whole run has, and those the comparison of a trace relies on.
_RUN_ARRAYS = ("intensity", "partial_range", "edges", "range", "confidence", "order")
_NEEDS = {"step_": ("step_pixel", "cand_start", "cand_pixel"), "sweep_": ("sweeps",)}


def is_case_name(name) -> bool:
    """A case name: letters, digits, ``_``, ``.`` and ``-``, not starting with a dot.

    >>> is_case_name("np-8x8-noise"), is_case_name("../../x"), is_case_name(".hidden")
    (True, False, False)
    """
    return isinstance(name, str) and _CASE_NAME.fullmatch(name) is not None


def _cannot_read(path: Path, error: OSError) -> Exception:
    """An OSError naming ``path`` (a ValueError if the error carries no errno)."""
    reason = error.strerror or str(error) or type(error).__name__
    if error.errno is None:
        return ValueError(f"cannot read '{path}': {reason}")
    return OSError(error.errno, f"cannot read '{path}': {reason}")


def _read_json(path: Path, what: str):
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileNotFoundError(f"'{path}' is missing ({what})") from None
    except UnicodeDecodeError:
        raise ValueError(f"'{path}' is not valid JSON: not UTF-8 text") from None
    except OSError as error:
        raise _cannot_read(path, error) from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"'{path}' is not valid JSON: {error}") from None
    except (ValueError, RecursionError) as error:
        raise ValueError(f"'{path}' is not valid JSON: {type(error).__name__}") from None


def _entry_problem(index: int, entry) -> str:
    """What is wrong with the manifest's ``cases[index]``, or ""."""
    if not isinstance(entry, dict):
        return (f"cases[{index}] is {json.dumps(entry)[:40]}, not an object with "
                + ", ".join(_ENTRY_KEYS))
    missing = [key for key in _ENTRY_KEYS if key not in entry]
    if missing:
        return f"cases[{index}] lacks {', '.join(missing)}"
    name = entry["name"]
    if not is_case_name(name):
        return (f"cases[{index}]: the name {name!r} is not a case name (letters, digits, "
                "'_', '.', '-'; no folders)")
    if entry["kind"] not in KINDS:
        return f"cases[{index}] ({name}): unknown kind {entry['kind']!r}"
    for key, suffix in (("json", ".json"), ("npz", ".npz")):
        if entry[key] != f"cases/{name}{suffix}":
            return f"cases[{index}] ({name}): {key} must be 'cases/{name}{suffix}'"
    for key in ("sha256", "json_sha256"):
        if not (isinstance(entry[key], str) and _SHA256.fullmatch(entry[key])):
            return f"cases[{index}] ({name}): {key} is not a SHA-256 (64 hex digits)"
    return ""


def load_manifest(directory) -> dict:
    """The manifest of an exported case set, checked (one-line errors naming the file).

    Parameters
    ----------
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.

    Returns
    -------
    dict
        ``manifest.json``: ``format`` (``"refsynth-oracle"``), ``version``
        (:data:`FORMAT_VERSION`), ``contract``, ``case_set``, the
        ``refsynth`` and ``numpy`` versions and ``cases``, a non-empty list of
        dicts (``name``, ``kind``, ``json``, ``npz``, ``sha256`` of the NPZ,
        ``json_sha256`` of the JSON).

    Raises
    ------
    FileNotFoundError
        If the folder or its ``manifest.json`` does not exist.
    ValueError
        If the manifest is not valid JSON, not a refsynth oracle manifest, of
        another format version, or lists a case wrongly (a name that is not a
        plain file name, an unknown kind, a file outside ``cases/``, a missing
        checksum, a name twice).

    Examples
    --------
    >>> from tempfile import mkdtemp
    >>> from refsynth.oracle import build_cases, export_cases
    >>> folder = mkdtemp()
    >>> export_cases(folder, build_cases()[:1])   # the first case, an 8×8 NP run
    ['np-8x8-noise']
    >>> manifest = load_manifest(folder)
    >>> manifest["format"], [entry["kind"] for entry in manifest["cases"]]
    ('refsynth-oracle', ['np'])
    """
    root = Path(directory)
    if root.exists() and not root.is_dir():
        raise NotADirectoryError(f"'{root}' is a file, not a case folder (write one with "
                                 "`python -m refsynth oracle export DIR`)")
    if not root.is_dir():
        raise FileNotFoundError(f"No such case folder: '{root}' (write it with "
                                "`python -m refsynth oracle export DIR`)")
    path = root / "manifest.json"
    if not path.is_file():
        raise FileNotFoundError(f"'{root}' holds no manifest.json: not an exported case set")
    manifest = _read_json(path, "the case set's manifest")
    if not isinstance(manifest, dict) or manifest.get("format") != "refsynth-oracle":
        raise ValueError(f"'{path}' is not a refsynth oracle manifest")
    version = manifest.get("version")
    if version != FORMAT_VERSION:
        raise ValueError(f"'{path}' is of format version {version!r}; this refsynth reads "
                         f"version {FORMAT_VERSION}: export the cases again "
                         "(python -m refsynth oracle export DIR)")
    cases = manifest.get("cases")
    if not isinstance(cases, list) or not cases:
        raise ValueError(f"'{path}' lists no cases (its 'cases' must be a non-empty list)")
    seen = set()
    for index, entry in enumerate(cases):
        problem = _entry_problem(index, entry)
        if not problem and entry["name"] in seen:
            problem = f"cases[{index}]: the case {entry['name']!r} is listed twice"
        if problem:
            raise ValueError(f"'{path}': {problem}")
        seen.add(entry["name"])
    return manifest


def _case_file(root: Path, relative: str) -> Path:
    """The case file ``relative`` (``cases/<name>.<ext>``), a regular file inside the folder."""
    path = root / relative
    try:
        mode = path.lstat().st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"'{path}' is missing (listed in '{root / 'manifest.json'}')"
                                ) from None
    if not stat.S_ISREG(mode):
        raise ValueError(f"'{path}' is not a regular file (a case file must be one)")
    return path


def _verify(root: Path, entry: dict) -> None:
    for key, checksum in (("json", "json_sha256"), ("npz", "sha256")):
        path = _case_file(root, entry[key])
        try:
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError as error:
            raise _cannot_read(path, error) from None
        if digest != entry[checksum]:
            raise ValueError(f"'{path}' does not match its SHA-256 in the manifest: it was "
                             "changed, truncated or corrupted after the export (export the "
                             "cases again)")


def _check_meta(path: Path, meta, entry: dict) -> None:
    if not isinstance(meta, dict):
        raise ValueError(f"'{path}' is not a case (a JSON object)")
    if "arrays" not in meta:
        raise ValueError(f"'{path}' has no 'arrays' (each array's role, dtype and shape)")
    for key in ("name", "kind", "options", "seed"):
        if key not in meta:
            raise ValueError(f"'{path}' has no {key!r}")
    if meta["name"] != entry["name"] or meta["kind"] != entry["kind"]:
        raise ValueError(f"'{path}' is the case {meta['name']!r} of kind {meta['kind']!r}; "
                         f"the manifest lists {entry['name']!r} of kind {entry['kind']!r}")
    if not isinstance(meta["options"], dict):
        raise ValueError(f"'{path}': 'options' must be an object")
    seed = meta["seed"]
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise ValueError(f"'{path}': 'seed' must be an integer or null, got {seed!r}")
    if meta.get("tolerance", "exact") not in ("exact", "float64"):
        raise ValueError(f"'{path}': 'tolerance' must be 'exact' or 'float64'")
    arrays = meta["arrays"]
    if not isinstance(arrays, dict) or not arrays:
        raise ValueError(f"'{path}': 'arrays' must be a non-empty object")
    for key, spec in arrays.items():
        if not (_ARRAY_NAME.fullmatch(key) and isinstance(spec, dict)
                and spec.get("role") in ROLES and isinstance(spec.get("dtype"), str)
                and isinstance(spec.get("shape"), list)
                and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0
                        for n in spec["shape"])):
            raise ValueError(f"'{path}': array {key!r} must be an identifier with a role "
                             f"({', '.join(ROLES)}), a dtype and a shape")
    roles = {spec["role"] for spec in arrays.values()}
    if "output" not in roles:
        raise ValueError(f"'{path}' lists no output array")
    needed = list(_RUN_ARRAYS) if meta["kind"] in ("np", "bp") else []
    for prefix, keys in _NEEDS.items():
        if any(key.startswith(prefix) for key in arrays):
            needed += keys
    missing = [key for key in needed if key not in arrays]
    if missing:
        raise ValueError(f"'{path}' lacks the arrays {', '.join(missing)}")


def _read_npz(path: Path) -> dict:
    try:
        with open(path, "rb") as stream:   # closed whatever np.load meets
            data = np.load(stream, allow_pickle=False)
            if not isinstance(data, np.lib.npyio.NpzFile):
                raise ValueError("a bare array, not an archive")
            with data:
                return {key: data[key] for key in data.files}
    except OSError as error:
        raise _cannot_read(path, error) from None
    except Exception as error:   # BadZipFile, zlib.error, EOFError, ValueError …
        reason = str(error).splitlines()[0] if str(error) else ""
        raise ValueError(f"'{path}' is not a readable NPZ archive: "
                         f"{type(error).__name__}{': ' + reason if reason else ''}") from None


def load_case(directory, name: str, entry: dict | None = None) -> tuple[dict, dict]:
    """The case's JSON metadata and its arrays, checked against each other.

    Parameters
    ----------
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.
    name : str
        The case's name (one of the manifest's).
    entry : dict, optional
        The case's manifest entry (default: looked up in the manifest).

    Returns
    -------
    meta : dict
        ``cases/<name>.json``: ``name``, ``kind``, ``equation``,
        ``function``, ``tolerance``, ``options``, ``seed`` and ``arrays``
        (each array's ``role``, ``dtype`` and ``shape``).
    arrays : dict of str to ndarray
        ``cases/<name>.npz``: the inputs, the prepared arrays, the expected
        outputs and the trace.

    Raises
    ------
    ValueError
        Naming the file, if the JSON or the NPZ cannot be read, or they
        disagree (names, dtypes, shapes), or a run lacks an array the check
        relies on.

    Examples
    --------
    An Eq. 2 case (§3.2.2): 32 pairs of quantised 3×3 neighbourhoods in
    (index 0 the target, the pixel being filled; index 1 the candidate), the
    integer Gaussian window prepared, their distances out.

    >>> import tempfile
    >>> from refsynth.oracle.cases import build_cases, select_cases
    >>> from refsynth.oracle.export import export_cases
    >>> folder = tempfile.mkdtemp()
    >>> written = export_cases(folder, select_cases(build_cases(), ["eq2-n3*"]))
    >>> meta, arrays = load_case(folder, "eq2-n3-c1")
    >>> {key: meta["arrays"][key]["role"] for key in ("q_range", "window", "distance_mean")}
    {'q_range': 'input', 'window': 'prepared', 'distance_mean': 'output'}
    >>> arrays["q_intensity"].shape, meta["tolerance"]
    ((32, 2, 3, 3, 1), 'exact')
    """
    root = Path(directory)
    if entry is None:
        found = [e for e in load_manifest(root)["cases"] if e["name"] == name]
        if not found:
            raise ValueError(f"No case {name!r} in '{root}'")
        entry = found[0]
    json_path = _case_file(root, entry["json"])
    meta = _read_json(json_path, "a case")
    _check_meta(json_path, meta, entry)
    npz_path = _case_file(root, entry["npz"])
    arrays = _read_npz(npz_path)
    if set(arrays) != set(meta["arrays"]):
        extra = sorted(set(arrays) ^ set(meta["arrays"]))
        raise ValueError(f"'{npz_path}' and its JSON list different arrays ({', '.join(extra)})")
    for key, spec in meta["arrays"].items():
        value = arrays[key]
        if str(value.dtype) != spec["dtype"] or list(value.shape) != spec["shape"]:
            raise ValueError(f"'{npz_path}': array {key!r} is {value.dtype} of shape "
                             f"{value.shape}; its JSON says {spec['dtype']} of shape "
                             f"{tuple(spec['shape'])}")
        if value.dtype.kind not in "biuf":
            raise ValueError(f"'{npz_path}': array {key!r} is not numeric ({value.dtype})")
    return meta, arrays


def load_cases(directory, case: str | None = None) -> list[tuple[dict, dict]]:
    """Every case (or the one named), verified: checksums first, then each file's contents.

    Parameters
    ----------
    directory : str or Path
        A folder written by :func:`~refsynth.oracle.export.export_cases`.
    case : str, optional
        Only this case.

    Returns
    -------
    list of (meta, arrays)
        As :func:`load_case`, in manifest order.

    Raises
    ------
    ValueError
        For an unknown case, a file that does not match its checksum, or a
        malformed case (one line naming the file).
    """
    root = Path(directory)
    entries = load_manifest(root)["cases"]
    if case is not None:
        names = [entry["name"] for entry in entries]
        if case not in names:
            raise ValueError(f"No case {case!r} in '{root}'; the cases are " + ", ".join(names))
        entries = [entry for entry in entries if entry["name"] == case]
    for entry in entries:
        _verify(root, entry)
    return [load_case(root, entry["name"], entry) for entry in entries]


# ----------------------------------------------------------------------------- export target


_TEMPORARY = re.compile(r"\..+\.tmp")
_TOP = ("manifest.json", "schema.json", "cases")


def _foreign(root: Path) -> str:
    """The first thing in ``root`` that an oracle export does not write, or ""."""
    for entry in sorted(os.scandir(root), key=lambda e: e.name):
        if _TEMPORARY.fullmatch(entry.name) and entry.is_file(follow_symlinks=False):
            continue
        if entry.name not in _TOP or entry.is_symlink():
            return entry.name
        if (entry.name == "cases") != entry.is_dir(follow_symlinks=False):
            return entry.name
    cases = root / "cases"
    if cases.is_dir():
        for entry in sorted(os.scandir(cases), key=lambda e: e.name):
            stem, dot, ext = entry.name.rpartition(".")
            ours = (dot and ext in ("json", "npz") and is_case_name(stem)) or (
                _TEMPORARY.fullmatch(entry.name))
            if not ours or not entry.is_file(follow_symlinks=False):
                return f"cases/{entry.name}"
    return ""


def check_export_target(directory) -> Path:
    """Check, before any work, that ``oracle export`` may write into ``directory``.

    It may if the folder does not exist yet, is empty, or holds an earlier
    export and nothing else: ``manifest.json`` of the format
    ``"refsynth-oracle"`` (any version), ``schema.json``, ``cases/`` with
    case files (``<name>.json``, ``<name>.npz``), and temporary files an
    interrupted export left.

    Raises
    ------
    ValueError
        If the folder holds anything else (named), or a ``manifest.json`` that
        is not an oracle export's.
    NotADirectoryError
        If ``directory`` is a file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "manifest.json").write_text('{"format": "refsynth-scan"}')
    >>> check_export_target(folder)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ValueError: refusing to export into '...': its manifest.json is not an oracle export's ...
    """
    root = Path(directory)
    if not os.path.lexists(root):
        return root
    if not root.is_dir():
        raise NotADirectoryError(f"The case folder must be a folder, got the file '{root}'")
    manifest = root / "manifest.json"
    if os.path.lexists(manifest) and not manifest.is_symlink() and manifest.is_file():
        try:
            fmt = json.loads(manifest.read_text(encoding="utf-8")).get("format")
        except (ValueError, UnicodeDecodeError, RecursionError, AttributeError, OSError):
            fmt = None
        if fmt != "refsynth-oracle":
            raise ValueError(f"refusing to export into '{root}': its manifest.json is not an "
                             f"oracle export's (format {fmt!r}); choose an empty or new folder")
    foreign = _foreign(root)
    if foreign:
        raise ValueError(f"refusing to export into '{root}': it holds '{foreign}', which an "
                         "oracle export does not write; choose an empty or new folder")
    return root
