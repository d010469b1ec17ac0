"""CHANGELOG.md is a Keep-a-Changelog history a user can read: ``## [Unreleased]`` first, then one heading per
release, newest first, the newest being the package's version; sections named by the kind of change; no internal
issue or stop numbers."""

from __future__ import annotations

import re
import tomllib

from conftest import ROOT

import pincal

CHANGELOG = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
RELEASE = re.compile(r"^## \[(\d+)\.(\d+)\.(\d+)\] - (\d{4}-\d{2}-\d{2})$")
KINDS = {"Added", "Changed", "Deprecated", "Removed", "Fixed", "Security"}
#: An internal reference: "issue 37", "issues 26-28", "stop 4", "#38".
INTERNAL = re.compile(r"\b(issues?|stops?)\s+\d+|#\d+\b", re.IGNORECASE)


def _releases() -> list[tuple[int, int, int]]:
    headings = [line for line in CHANGELOG.splitlines() if line.startswith("## ")]
    assert headings[0] == "## [Unreleased]", headings[0]
    versions = []
    for heading in headings[1:]:
        match = RELEASE.match(heading)
        assert match is not None, f"not a release heading '## [X.Y.Z] - YYYY-MM-DD': {heading}"
        versions.append((int(match[1]), int(match[2]), int(match[3])))
    return versions


def test_the_newest_release_is_the_package_version() -> None:
    newest = ".".join(map(str, _releases()[0]))
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]
    assert newest == declared == pincal.__version__


def test_releases_are_newest_first() -> None:
    versions = _releases()
    assert versions == sorted(versions, reverse=True) and len(set(versions)) == len(versions)


def test_sections_are_kinds_of_change() -> None:
    sections = {line[4:] for line in CHANGELOG.splitlines() if line.startswith("### ")}
    assert sections <= KINDS, sections - KINDS


def test_no_line_names_an_internal_issue_or_stop() -> None:
    found = [line for line in CHANGELOG.splitlines() if INTERNAL.search(line)]
    assert found == []


def test_the_check_catches_an_internal_reference() -> None:
    """The pattern finds what it is for (the test above would pass on any text otherwise)."""
    assert INTERNAL.search("### Changed (issue 37: trust beyond the data)")
    assert INTERNAL.search("fixed in stop 12") and INTERNAL.search("see #38")
    assert not INTERNAL.search("study 000's page; `--cv 5x4`; 64 robots")
