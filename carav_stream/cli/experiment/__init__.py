"""`carav experiment NAME`: one module per experiment of carav_stream/experiments/, with its options (configure), its
printed tables and its JSON (run). The engines take plain arguments, return their numbers and hear of progress
through callbacks; what is printed, and how, is decided here."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from carav_stream.console.progress import ProgressBar

__all__ = ["write_json", "quiet_option", "progress_bar"]


def quiet_option(parser: argparse.ArgumentParser) -> None:
    """--quiet: every experiment shows its progress on stderr unless told not to."""
    parser.add_argument("--quiet", action="store_true", help="no progress (on stderr: a bar on a terminal, else a "
                        "line every 10 s with the time left)")


def progress_bar(args: argparse.Namespace, label: str, unit: str = "cycles") -> ProgressBar | None:
    """The progress bar an engine's progress(done, total) callback is given, None with --quiet."""
    return ProgressBar(label, unit=unit) if ProgressBar.wanted(args.quiet) else None


def write_json(path: Path | None, data) -> None:
    """The results as JSON (indent 1) into the --json file, if one was given."""
    if path is not None:
        Path(path).write_text(json.dumps(data, indent=1))
