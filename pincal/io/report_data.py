"""Report files as text: the indented JSON pincal writes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pincal.io.files import write_text


def write_json(path: str | Path, content: dict[str, Any]) -> None:
    """Write ``content`` as indented JSON (:func:`json_text`), whole or not at all."""
    write_text(path, json_text(content))


def json_text(content: dict[str, Any]) -> str:
    """``content`` as the indented JSON text of pincal's report files."""
    return json.dumps(content, indent=2, sort_keys=False) + "\n"
