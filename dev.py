#!/usr/bin/env python3
"""Set-up-free entry point: creates (and reuses) ./.venv, installs the project into it, then runs.

    python3 dev.py demo [carav run options]   run the default graph graphs/demo.toml and print its summary
    python3 dev.py test [pytest options]      run the whole test suite on one pytest-xdist worker per core (up to 4;
                                              -n 0 runs it in one process; under CI=true the 20 slowest are listed)
    python3 dev.py test --quick [options]     the quick loop: every test that starts no process and takes no
                                              noticeable time (-m "not integration and not slow")
    python3 dev.py bench NAME [options]       a benchmark of bench/ (`python3 dev.py bench --help` lists them)
    python3 dev.py lint                       ruff: lint and import order of the whole tree
    python3 dev.py carav ARGS...              any carav command inside the project's environment

The environment is rebuilt when pyproject.toml changes (its hash is stamped into .venv). Before every command the
project's modules are byte-compiled (those changed since only), so that no process compiles them at its start.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
STAMP = VENV / ".carav-install-stamp"
QUICK = "not integration and not slow"     # the markers of pyproject.toml: starts processes, takes noticeable time
MAX_WORKERS = 4      # pytest-xdist workers at most: each integration test starts a graph of about ten processes


def _fingerprint() -> str:
    return hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()


def ensure_env() -> None:
    if STAMP.exists() and STAMP.read_text() == _fingerprint() and (BIN / "carav").exists():
        return
    if not (BIN / "python").exists():
        print(f"dev.py: creating virtual environment {VENV}", file=sys.stderr)
        venv.EnvBuilder(with_pip=True, clear=True).create(VENV)
    print("dev.py: installing carav-stream and its dev extra into .venv", file=sys.stderr)
    pip = [str(BIN / "python"), "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run(pip + ["install", "-e", f"{ROOT}[dev]"], check=True)
    STAMP.write_text(_fingerprint())


def compile_sources() -> None:
    """Byte-compile the project's own modules, those changed since the last time only. pip compiles a regular
    install's modules but not an editable install's, and Python writes no bytecode itself where
    PYTHONDONTWRITEBYTECODE is set (as on this project's CI machines): every process of every graph would then
    compile them again at its start (`python3 dev.py bench startup` records how many had current bytecode)."""
    folders = [str(ROOT / f) for f in ("carav_stream", "blocks", "bench", "tests/toy_blocks")]
    subprocess.run([str(BIN / "python"), "-m", "compileall", "-qq", *folders], check=True)   # the venv's tag


def _workers(args: list[str]) -> list[str]:
    """pytest-xdist's options for a run on every core up to MAX_WORKERS ("worksteal": an idle worker takes tests
    queued on a busy one, so one long test does not leave a core idle), unless the options choose otherwise (-n,
    --numprocesses, --pdb, -p no:xdist) or there is a single core."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    chosen = any(a.startswith(("-n", "--numprocesses", "--pdb", "--dist")) or a == "no:xdist" for a in args)
    return [] if chosen or cores < 2 else ["-n", str(min(cores, MAX_WORKERS)), "--dist", "worksteal"]


def main(argv: list[str]) -> int:
    if not argv or argv[0] in {"-h", "--help"}:
        print(__doc__)
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    ensure_env()
    compile_sources()
    if command == "demo":
        cmd = [str(BIN / "carav"), "run", str(ROOT / "graphs" / "demo.toml"), *rest]
    elif command == "test":
        if "--quick" in rest:
            rest = [*(a for a in rest if a != "--quick"), "-m", QUICK]
        if os.environ.get("CI") == "true":
            rest = ["--durations=20", *rest]     # CI's log names the 20 slowest: a slow test shows the day it lands
        rest = [*_workers(rest), *rest]
        cmd = [str(BIN / "python"), "-m", "pytest", *rest]
    elif command == "bench":
        cmd = [str(BIN / "python"), "-m", "bench", *rest]
    elif command == "lint":
        cmd = [str(BIN / "ruff"), "check", *rest, str(ROOT)]
    elif command == "carav":
        cmd = [str(BIN / "carav"), *rest]
    else:
        print(f"dev.py: unknown command {command!r}; expected demo, test, bench, lint or carav", file=sys.stderr)
        return 2
    code = subprocess.run(cmd, cwd=ROOT).returncode
    if command == "test" and code == 5:
        # pytest's 5 means it collected no test at all: for this project that is a broken suite.
        print("dev.py: pytest collected no tests; treating that as a failure", file=sys.stderr)
        return 1
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
