"""The run folder: where a running graph keeps its files, and how a process on the same machine finds a run.

    $CARAV_RUN_DIR (else the system temp folder) / carav-<uid>/ <run id>/    mode 0700

A run's folder holds the ipc endpoints, the node specs, each node's log, `pid` (the supervisor's) and `run.json`
(how `carav status|stop|swap` find the run); the supervisor removes it when the run ends, whatever the way it ends.
A node finds its own run through CARAV_RUN_ID (RUN_ID_ENV), which the supervisor sets for it.

The root `carav-<uid>` is used only if it is a folder (not a link) that belongs to the user with mode 0700:
another local user who created it first would otherwise receive the user's runs, status, swaps and stops.
"""
from __future__ import annotations

import json
import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Any

RUN_ID_ENV = "CARAV_RUN_ID"


class RunRootError(Exception):
    """The run root is not the user's own private folder; the message (one line) says which folder and what to do."""


def run_root() -> Path:
    """The folder of this user's runs, created (mode 0700) if missing; RunRootError if it exists but is not a
    folder of this user's with mode 0700."""
    base = Path(os.environ.get("CARAV_RUN_DIR") or tempfile.gettempdir())
    root = base / f"carav-{os.getuid()}"
    base.mkdir(parents=True, exist_ok=True)
    try:
        root.mkdir(mode=0o700)
        root.chmod(0o700)                 # ours, just made: whatever the umask took away
    except FileExistsError:               # made before, by whoever: checked below
        pass
    st = os.lstat(root)
    problem = ("is not a folder" if not stat.S_ISDIR(st.st_mode)
               else f"belongs to uid {st.st_uid}, not to you (uid {os.getuid()})" if st.st_uid != os.getuid()
               else f"has mode {stat.S_IMODE(st.st_mode):04o}, not 0700" if stat.S_IMODE(st.st_mode) != 0o700
               else None)
    if problem:
        raise RunRootError(f"run folder {root} {problem}: someone else may read or plant runs in it; remove it "
                           f"(or set CARAV_RUN_DIR to a folder of your own) and run again")
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
