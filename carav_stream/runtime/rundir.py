"""The run folder: where a running graph keeps its files, and how a process on the same machine finds a run.

    $CARAV_RUN_DIR (else the system temp folder) / carav-<uid>/ <run id>/    mode 0700

A run's folder holds the ipc endpoints, the node specs, each node's log, `pid` (the supervisor's) and `run.json`
(how `carav status|stop|swap` find the run); the supervisor removes it when the run ends, whatever the way it ends.
A node finds its own run through CARAV_RUN_ID (RUN_ID_ENV), which the supervisor sets for it.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

RUN_ID_ENV = "CARAV_RUN_ID"


def run_root() -> Path:
    """The folder of this user's runs, created (mode 0700) if missing."""
    base = Path(os.environ.get("CARAV_RUN_DIR") or tempfile.gettempdir())
    root = base / f"carav-{os.getuid()}"
    root.mkdir(mode=0o700, parents=True, exist_ok=True)
    return root


def remove_stale_runs(root: Path | None = None) -> list[str]:
    """Remove the folders of runs whose supervisor died without cleaning up (SIGKILL, power loss): its pid file
    names a process that no longer exists. Its nodes died with it (parent-death signal). Returns their names."""
    removed = []
    for folder in (root or run_root()).iterdir():
        try:
            pid = int((folder / "pid").read_text())
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder.name)
        except (OSError, ValueError):   # no pid file yet (a run starting), not ours, or unreadable: leave it
            continue
    return removed


def run_info(run_id: str) -> dict[str, Any]:
    """The run.json of run `run_id`; LookupError if no such run is running under this user."""
    path = run_root() / run_id / "run.json"
    try:
        info = json.loads(path.read_text())
        os.kill(info["pid"], 0)
    except (OSError, ValueError, KeyError):
        raise LookupError(f"no running graph with run id {run_id!r} (no readable {path})") from None
    return info
