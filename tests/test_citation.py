"""CITATION.cff is valid Citation File Format 1.2.0 and cites the software and the paper.

The schema, ``tests/data/cff-1.2.0.schema.json``, is the Citation File Format
project's JSON schema for version 1.2.0
(https://citation-file-format.github.io/1.2.0/schema.json, CC-BY-4.0), as the
``cffconvert`` package ships it; it is checked with ``jsonschema`` (draft 7,
with format checks). The README's and the docs' BibTeX entries must agree
with CITATION.cff.
"""

import json
import re
from pathlib import Path

import pytest

import refsynth

ROOT = Path(__file__).resolve().parent.parent
CFF = ROOT / "CITATION.cff"
SCHEMA = Path(__file__).parent / "data" / "cff-1.2.0.schema.json"
DOI = "10.1007/s11263-007-0108-2"


def load_cff() -> dict:
    yaml = pytest.importorskip("yaml", reason="needs PyYAML to read CITATION.cff")
    return yaml.safe_load(CFF.read_text(encoding="utf-8"))


def test_citation_cff_matches_the_schema():
    jsonschema = pytest.importorskip("jsonschema", reason="needs jsonschema")
    schema = json.loads(SCHEMA.read_text(encoding="utf-8"))
    validator = jsonschema.Draft7Validator(
        schema, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER)
    errors = [f"{'/'.join(map(str, error.path))}: {error.message}"
              for error in validator.iter_errors(load_cff())]
    assert not errors, errors


def test_citation_cff_cites_the_software_and_the_paper():
    cff = load_cff()
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert str(cff["version"]) == refsynth.__version__
    papers = [r for r in cff["references"] if r.get("doi") == DOI]
    assert len(papers) == 1
    paper = papers[0]
    assert paper["type"] == "article" and paper["year"] == 2008
    assert [a["family-names"] for a in paper["authors"]] == ["Torres-Méndez", "Dudek"]
    assert (paper["volume"], paper["start"], paper["end"]) == (79, 137, 158)


@pytest.mark.parametrize("path", ["README.md", "docs/citing.rst"])
def test_bibtex_entries_agree_with_citation_cff(path):
    text = (ROOT / path).read_text(encoding="utf-8")
    software = re.search(r"@software\{[^@]*?\n\s*\}", text, flags=re.S)
    article = re.search(r"@article\{[^@]*?\n\s*\}", text, flags=re.S)
    assert software and article, f"{path} must show a BibTeX entry for the software and the paper"
    assert f"version = {{{refsynth.__version__}}}" in re.sub(r" +", " ", software.group(0))
    assert DOI in article.group(0) and "137--158" in article.group(0)


def test_the_schema_check_rejects_a_broken_file():
    jsonschema = pytest.importorskip("jsonschema", reason="needs jsonschema")
    schema = json.loads(SCHEMA.read_text(encoding="utf-8"))
    broken = {key: value for key, value in load_cff().items() if key != "authors"}
    broken["references"] = [{**broken["references"][0], "doi": "not a doi"}]
    messages = [error.message for error in jsonschema.Draft7Validator(schema).iter_errors(broken)]
    assert any("'authors' is a required property" in m for m in messages)
    assert any("does not match" in m for m in messages)  # the DOI pattern
