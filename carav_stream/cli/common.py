"""What the commands that steer a running graph share: finding it and asking its supervisor."""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from carav_stream.console.errors import CommandError, Exit
from carav_stream.runtime.admin import request
from carav_stream.runtime.rundir import RunRootError, remove_stale_runs, run_root


def running_graphs() -> list[dict[str, Any]]:
    """The run.json of every graph running on this machine under this user (the folders of runs whose
    supervisor was killed are removed on the way); CommandError (Exit.FAILED) if the run root is not the user's own."""
    try:
        remove_stale_runs()
        found = sorted(run_root().glob("*/run.json"))
    except RunRootError as exc:
        raise CommandError(str(exc), Exit.FAILED) from None
    runs = []
    for f in found:
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
