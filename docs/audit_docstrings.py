"""List the public API's docstring gaps: ``python docs/audit_docstrings.py``.

For every function and class in the ``__all__`` of each documented
subpackage, numpydoc's validator reports: no docstring (GL08), parameters
not documented (PR01; for classes their fields are under Attributes, so not
checked), documented parameters that do not exist (PR02) and no Examples
section (EX01). The Sphinx build does not fail on these; this list is for
the modules' owners. Needs the ``docs`` extra.
"""

from __future__ import annotations

import collections
import importlib
import inspect

from numpydoc.validate import validate

SUBPACKAGES = ["refsynth.acquisition", "refsynth.registration", "refsynth.synthesis",
               "refsynth.evaluation", "refsynth.model", "refsynth.oracle", "refsynth.scenes",
               "refsynth.plotting", "refsynth.io"]
CHECKS = {"GL08": "no docstring", "PR01": "parameters not documented",
          "PR02": "documented parameters that do not exist", "EX01": "no Examples section"}


def audit(name: str) -> tuple[int, dict[str, list[str]]]:
    """The number of functions and classes of a subpackage, and its findings by check."""
    module = importlib.import_module(name)
    found: dict[str, list[str]] = collections.defaultdict(list)
    count = 0
    for entry in getattr(module, "__all__", []):
        obj = getattr(module, entry)
        if not (inspect.isfunction(obj) or inspect.isclass(obj)):
            continue
        count += 1
        for code, message in validate(f"{obj.__module__}.{obj.__qualname__}")["errors"]:
            if code not in CHECKS or (code == "PR01" and inspect.isclass(obj)):
                continue
            detail = f" ({message.split('{', 1)[1].split('}')[0]})" if "{" in message else ""
            found[code].append(entry + detail)
    return count, found


def main() -> None:
    for name in SUBPACKAGES:
        try:
            count, found = audit(name)
        except ImportError:
            continue
        print(f"## {name}: {count} functions and classes")
        for code, entries in sorted(found.items()):
            print(f"- {code}, {CHECKS[code]} ({len(entries)}): {', '.join(entries)}")


if __name__ == "__main__":
    main()
