"""What the command modules share: exit codes, the error line, and finding and asking a running graph."""
from __future__ import annotations

import json
import os
import sys
from enum import IntEnum
from pathlib import Path
from typing import Any

from carav_stream.runtime.admin import request
from carav_stream.runtime.rundir import remove_stale_runs, run_root


class Exit(IntEnum):
    """One exit code per class of outcome, the same for every command (listed by `carav --help`)."""

    OK = 0
    FAILED = 1          # the work failed: a node crashed, frames were lost, a benchmark run broke, a swap refused
    USAGE = 2           # a bad command line: unknown option, bad value, output path that cannot be written
    INVALID = 3         # an invalid graph, scene or block parameter
    INTERRUPTED = 130   # stopped by Ctrl-C or SIGTERM before it finished


EXIT_CODES_HELP = "exit codes: " + ", ".join(f"{int(c)} {c.name.lower()}" for c in Exit)


class CommandError(Exception):
    """A user-facing error: one line, naming the option, file or field; `code` is its Exit class."""

    def __init__(self, text: str, code: Exit = Exit.USAGE) -> None:
        super().__init__(text)
        self.code = code


def fail(text: str, code: Exit = Exit.USAGE) -> int:
    print(f"carav: {text}", file=sys.stderr)
    return int(code)


def running_graphs() -> list[dict[str, Any]]:
    """The run.json of every graph running on this machine under this user (the folders of runs whose
    supervisor was killed are removed on the way)."""
    remove_stale_runs()
    runs = []
    for f in sorted(run_root().glob("*/run.json")):
        try:
            info = json.loads(f.read_text())
            os.kill(info["pid"], 0)
        except (OSError, ValueError, KeyError):
            continue   # a run that ended without cleaning up (killed): not running
        runs.append(info)
    return runs


def pick_run(which: str | None) -> dict[str, Any]:
    runs = running_graphs()
    if which:
        runs = [r for r in runs if r["run"] == which or Path(r["graph"]).stem == which or r["graph"] == which]
    if not runs:
        raise CommandError(f"no running graph{' matches ' + repr(which) if which else ''}")
    if len(runs) > 1:
        raise CommandError("several graphs are running; name one with its run id: " + ", ".join(r["run"] for r in runs))
    return runs[0]


def ask(run: dict[str, Any], kind: str, timeout_s: float = 40.0, **fields: Any) -> dict[str, Any]:
    """One admin request (protocol.Admin) to a running graph's supervisor, and its answer."""
    try:
        return request(run, kind, timeout_s, **fields)
    except TimeoutError as exc:
        raise CommandError(str(exc), Exit.FAILED) from None
