"""Where an output came from: the pincal version, the robot and data files with their SHA-256, and the options.

Every file a calibration writes records its provenance, with no clock time, so that identical inputs give
byte-identical outputs: the report JSON under ``provenance``, the calibrated URDF as one element
``<pincal_provenance pincal_version="…" robot="…" robot_sha256="…" data="…" data_sha256="…" options="…"
fitted_range="…"/>`` inside ``<robot>`` (``fitted_range``: the fitted samples' range [min, max] [rad or m] of each
actuated joint, as JSON, the report's ``fitted_range``; URDF readers ignore elements they do not know). A file is
named by its path relative to the folder of the output that names it (a catalog robot by its name), so an output
moved with its inputs still finds them.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

from pincal.calibration.options import CalibrationOptions
from pincal.calibration.report_sections import FileDigest, ProvenanceRecord
from pincal.errors import DataError
from pincal.model.catalog import installed_version
from pincal.model.robot import Robot
from pincal.records import record

#: The element of a calibrated URDF that holds its provenance.
ELEMENT = "pincal_provenance"


def version() -> str:
    """The installed pincal's version (its package metadata: pyproject's ``version``), read without
    ``importlib.metadata`` (its e-mail parser, its look through every installed distribution)."""
    return installed_version("pincal")


def sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, in hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def file_digests(*paths: str | Path | None) -> dict[str, str]:
    """``{file: SHA-256}`` of the files among ``paths`` (a name that is no file, e.g. a known robot's, left out)."""
    return {str(p): sha256(p) for p in paths if p is not None and Path(p).is_file()}


def options_dict(options: CalibrationOptions) -> dict[str, Any]:
    """``options`` as JSON values (tuples as lists, a payload as its dict), in field order."""
    out: dict[str, Any] = {}
    for f in fields(options):
        value = getattr(options, f.name)
        if isinstance(value, tuple):
            value = list(value)
        elif hasattr(value, "as_dict"):
            value = value.as_dict()
        out[f.name] = value
    return out


@record(frozen=True)
class Source:
    """An input file: as the user named it (``name``: a catalog robot's name, or a path) and its SHA-256."""

    name: str
    path: Path | None
    sha256: str | None

    def named_from(self, folder: Path) -> str:
        """The file's name as an output in ``folder`` records it: its path relative to ``folder`` (absolute when
        no relative path leads there, e.g. another drive), or the catalog name."""
        if self.path is None:
            return self.name
        try:
            return Path(os.path.relpath(self.path.resolve(), folder.resolve())).as_posix()
        except ValueError:
            return self.path.resolve().as_posix()


def robot_source(given: str, robot: Robot) -> Source:
    """The robot as given (a catalog name or a URDF path) and its URDF's SHA-256."""
    is_file = Path(given).is_file()
    digest = sha256(robot.source) if robot.source is not None and Path(robot.source).is_file() else None
    return Source(given, Path(given) if is_file else None, digest)


def file_source(path: str | Path) -> Source:
    """A data or job file and its SHA-256."""
    return Source(str(path), Path(path), sha256(path))


@record(frozen=True)
class Provenance:
    """What made an output: the pincal version, the robot, the data (the files read: a job file and its data
    files), and the options."""

    robot: Source
    data: Sequence[Source]
    options: dict[str, Any]
    pincal_version: str = ""
    fitted_range: dict[str, list[float]] | None = None

    def record(self, folder: Path) -> ProvenanceRecord:
        """The report's ``provenance`` for an output in ``folder``."""
        return ProvenanceRecord(pincal_version=self.pincal_version or version(),
                                robot=FileDigest(self.robot.named_from(folder), self.robot.sha256),
                                data=[FileDigest(d.named_from(folder), d.sha256) for d in self.data],
                                options=self.options)

    def as_dict(self, folder: Path) -> dict[str, Any]:
        """The report's ``provenance`` for an output in ``folder``, as its JSON holds it (the other outputs' too)."""
        return self.record(folder).as_dict()

    def urdf_element(self, folder: Path, corrections: tuple[str, str] | None = None) -> str:
        """The ``<pincal_provenance …/>`` element of a calibrated URDF in ``folder``; ``corrections``: the name and
        SHA-256 of the corrections file written beside it (the joint corrections the URDF cannot hold)."""
        attributes = {"pincal_version": self.pincal_version or version(), "robot": self.robot.named_from(folder),
                      "robot_sha256": self.robot.sha256 or "",
                      "data": " ".join(d.named_from(folder) for d in self.data),
                      "data_sha256": " ".join(d.sha256 or "" for d in self.data),
                      "options": json.dumps(self.options, sort_keys=False)}
        if self.fitted_range is not None:
            attributes["fitted_range"] = json.dumps(self.fitted_range)
        if corrections is not None:
            attributes["corrections"], attributes["corrections_sha256"] = corrections
        return f"<{ELEMENT} " + " ".join(f"{k}={_quoted(v)}" for k, v in attributes.items()) + "/>"


def with_provenance(urdf_text: str, provenance: Provenance, folder: Path,
                    corrections: tuple[str, str] | None = None) -> str:
    """``urdf_text`` with its provenance element as the first child of ``<robot>`` (one it held is replaced);
    ``corrections`` as for :meth:`Provenance.urdf_element`."""
    # each old element removed with the blanks and the line break before it, found by hand: a pattern that matched
    # them too would rescan a run of blanks from each of its characters (1 MB of blanks took minutes)
    pieces: list[str] = []
    end = 0
    for element in re.finditer(rf"<{ELEMENT}\b[^>]*/>", urdf_text):
        before = urdf_text[end:element.start()].rstrip(" \t")
        pieces.append(before[:-1] if before.endswith("\n") else before)
        end = element.end()
    text = "".join(pieces) + urdf_text[end:]
    start = re.search(r"<robot\b[^>]*>", text)
    if start is None:
        raise DataError("the calibrated URDF has no <robot> element")
    return f"{text[:start.end()]}\n  {provenance.urdf_element(folder, corrections)}{text[start.end():]}"


@record(frozen=True)
class Recorded:
    """What an output records of its inputs: the nominal robot (a known name, or a URDF path resolved against the
    output's folder) and the data (the data file, or the job file, resolved likewise), each with its SHA-256; None
    where nothing is recorded."""

    robot: str | None = None
    robot_sha256: str | None = None
    data: Path | None = None
    data_sha256: str | None = None
    corrections: Path | None = None
    corrections_sha256: str | None = None
    fitted_range: dict[str, list[float]] | None = None

    def check_corrections(self, model: str | Path) -> None:
        """Refuse a calibrated URDF whose corrections file (named in its provenance) is missing or changed: without
        it the URDF predicts and commands the robot without its joint corrections, silently wrong.

        Raises:
            DataError: naming the file.
        """
        if self.corrections is None:
            return
        if not self.corrections.is_file():
            raise DataError(f"'{model}' was calibrated with joint corrections the URDF cannot hold, in "
                            f"'{self.corrections}', which is not there: put it back beside the URDF "
                            "(docs/calibrated_urdf.md, 'The corrections file')")
        if self.corrections_sha256 and sha256(self.corrections) != self.corrections_sha256:
            raise DataError(f"'{self.corrections}' is not the corrections file '{model}' was calibrated with (its "
                            "SHA-256 differs)")


def _resolved(entry: str, folder: Path) -> str:
    """A recorded robot: a path relative to ``folder`` when a file is there or the entry looks like a path, else the
    entry as it is (a known robot's name)."""
    candidate = folder / entry
    return str(candidate) if candidate.is_file() or Path(entry).suffix or "/" in entry else entry


#: What the summaries call the robot a calibration starts from, when it is one.
NOMINAL_WORDS = "the nominal robot"


def is_calibrated_urdf(path: str | Path) -> bool:
    """Whether the file at ``path`` is a URDF pincal calibrated: it carries a ``<pincal_calibration>`` element, or a
    ``<pincal_provenance>`` that records the data it was calibrated from (a simulation's ``truth.urdf`` records none);
    False for a file that cannot be read."""
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return False
    return re.search(r"<pincal_calibration\b|<pincal_provenance\b[^>]*\sdata=\"[^\"]", text) is not None


def labelled(means: str, source: str | Path | None) -> str:
    """``means``, words about the robot a calibration or check starts from (``"the nominal robot, …"``), with that
    robot named for what it is when its file ``source`` is a calibrated URDF given as the robot: a calibration, not a
    nominal robot (issue 37). Other words are returned as they are."""
    if source is None or not means.startswith(NOMINAL_WORDS) or not is_calibrated_urdf(source):
        return means
    return (f"the calibrated URDF '{Path(source).name}' given as the robot (a calibration, not a nominal robot)"
            + means[len(NOMINAL_WORDS):])


def read_provenance(path: str | Path) -> Recorded:
    """The provenance a calibrated URDF (its ``<pincal_provenance>`` element) or a report JSON (its ``provenance``)
    records; an empty one when it records none or cannot be read."""
    source = Path(path)
    folder = source.parent
    try:
        text = source.read_text(encoding="utf-8")
        if source.suffix.lower() == ".json":
            content = json.loads(text)
            recorded = content.get("provenance") if isinstance(content, dict) else None
            if not isinstance(recorded, dict):
                return Recorded()
            robot: dict[str, Any] = recorded.get("robot") or {}
            data = recorded.get("data") or [{}]
            first: dict[str, Any] = data[0] if isinstance(data, list) and isinstance(data[0], dict) else {}
            if not isinstance(robot, dict):
                robot = {}
            robot_name, robot_sha = robot.get("file"), robot.get("sha256")
            data_name, data_sha = first.get("file"), first.get("sha256")
            ranges = _ranges(content.get("fitted_range"))
        else:
            element = ET.fromstring(text).find(ELEMENT)
            if element is None:
                return Recorded()
            robot_name, robot_sha = element.get("robot"), element.get("robot_sha256")
            data_name = (element.get("data") or "").split(" ")[0]
            data_sha = (element.get("data_sha256") or "").split(" ")[0]
            corrections = element.get("corrections")
            return Recorded(_resolved(str(robot_name), folder) if robot_name else None, robot_sha or None,
                            folder / data_name if data_name else None, data_sha or None,
                            folder / corrections if corrections else None, element.get("corrections_sha256"),
                            _ranges(json.loads(element.get("fitted_range") or "null")))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, ET.ParseError):
        return Recorded()
    return Recorded(_resolved(str(robot_name), folder) if robot_name else None, robot_sha or None,
                    folder / str(data_name) if data_name else None, data_sha or None, fitted_range=ranges)


def _ranges(value: Any) -> dict[str, list[float]] | None:
    """A recorded ``fitted_range`` ({joint: [min, max]} [rad or m]) as it should be, else None."""
    if not isinstance(value, dict):
        return None
    good = {str(k): [float(v[0]), float(v[1])] for k, v in value.items()
            if isinstance(v, list) and len(v) == 2 and all(isinstance(e, int | float) for e in v)}
    return good if len(good) == len(value) else None


def _quoted(value: str) -> str:
    """``value`` as a quoted XML attribute value (``xml.sax.saxutils.quoteattr``'s rule, without importing it: it
    loads ``urllib``, a fiftieth of a second of every command's start)."""
    value = value.replace("&", "&amp;").replace(">", "&gt;").replace("<", "&lt;")
    value = value.replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;")
    if '"' not in value:
        return f'"{value}"'
    return f'"{value.replace(chr(34), "&quot;")}"' if "'" in value else f"'{value}'"
