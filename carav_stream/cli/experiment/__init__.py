"""`carav experiment NAME`: one module per experiment of carav_stream/experiments/, with its options (configure), its
printed tables and its JSON (run). The engines take plain arguments, return their numbers and hear of progress
through callbacks; what is printed, and how, is decided here."""
from __future__ import annotations

import json
from pathlib import Path

__all__ = ["write_json"]


def write_json(path: Path | None, data) -> None:
    """The results as JSON (indent 1) into the --json file, if one was given."""
    if path is not None:
        Path(path).write_text(json.dumps(data, indent=1))
