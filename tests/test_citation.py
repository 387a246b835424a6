"""CITATION.cff and LICENSE agree with pyproject.toml: the citation file parses as YAML, has the keys Citation
File Format 1.2.0 requires, the package's version and licence, and the five design papers of
docs/bibliography.md as references, each with the keys a CFF reference requires."""

import re
import tomllib

import yaml

from tests.conftest import REPO


def _project() -> dict:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def test_citation_file_has_the_required_keys_and_the_package_version():
    citation = yaml.safe_load((REPO / "CITATION.cff").read_text())
    assert isinstance(citation, dict)
    for key in ("cff-version", "message", "title", "authors"):
        assert citation.get(key), key
    assert citation["cff-version"] == "1.2.0"
    assert citation["version"] == _project()["version"]
    assert citation["license"] == _project()["license"]  # an SPDX identifier: MIT
    assert citation["authors"] and all(isinstance(a, dict) and (a.get("name") or a.get("family-names"))
                                       for a in citation["authors"])
    assert "repository-code" not in citation  # the repository states no address of its own


def test_citation_references_are_the_five_papers_of_the_bibliography():
    citation = yaml.safe_load((REPO / "CITATION.cff").read_text())
    references = citation["references"]
    assert len(references) == 5
    bibliography = (REPO / "docs" / "bibliography.md").read_text()
    titles = re.findall(r"\*\*Title:\*\* \*(.*?)\*\.", " ".join(bibliography.split()))
    assert [r["title"] for r in references] == titles
    for reference in references:
        assert reference["type"] and reference["authors"] and reference["title"]
        if "doi" in reference:  # a DOI only where the page (from our copy) gives one
            assert reference["doi"] in bibliography


def test_license_is_the_mit_text_pyproject_names():
    assert _project()["license"] == "MIT"  # PEP 639: an SPDX expression, the file in license-files
    text = (REPO / "LICENSE").read_text()
    assert text.startswith("MIT License") and "Permission is hereby granted, free of charge" in text
