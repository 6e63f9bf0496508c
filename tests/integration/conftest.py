"""Fixtures that run real `carav` processes: every wait has a deadline, every process group is killed."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TOYS = ROOT / "tests" / "toy_blocks"


class CaravProcess:
    """One `carav run` in its own session (process group), with output in files."""

    def __init__(self, workdir: Path, env: dict[str, str], graph: Path, args: list[str]) -> None:
        tag = time.monotonic_ns()              # several runs in one test keep their own files
        self.summary_path = workdir / f"summary-{tag}.json"
        self.out = open(workdir / f"stdout-{tag}.txt", "w+")
        self.err = open(workdir / f"stderr-{tag}.txt", "w+")
        self.proc = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", "run", str(graph),
                                      "--json", str(self.summary_path), "--no-progress", *args],
                                     cwd=workdir, env=env, stdout=self.out, stderr=self.err,
                                     stdin=subprocess.DEVNULL, start_new_session=True)
        self.pgid = self.proc.pid

    def wait(self, timeout_s: float = 60) -> int:
        return self.proc.wait(timeout_s)

    def stderr(self) -> str:
        self.err.flush()
        return Path(self.err.name).read_text()

    def stdout(self) -> str:
        return Path(self.out.name).read_text()

    def summary(self) -> dict:
        return json.loads(self.summary_path.read_text())

    def group_alive(self) -> bool:
        try:
            os.killpg(self.pgid, 0)
        except ProcessLookupError:
            return False
        # zombies of our own direct child count as gone once reaped
        return True

    def kill(self) -> None:
        try:
            os.killpg(self.pgid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            pass
        self.out.close()
        self.err.close()


@pytest.fixture
def carav(tmp_path, request):
    """carav.run(graph, *args) starts a graph; carav.cli(*args) runs a short command; all torn down after.

    Parametrised indirectly with a data plane (`@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)`),
    every graph it runs carries its arrays over that plane (run.transport); carav.transport says which."""
    transport = getattr(request, "param", None)
    # ipc paths must stay short (Unix sockets hold 107 bytes): a short private run folder per test
    run_dir = Path(tempfile.mkdtemp(prefix="cr", dir="/tmp"))
    env = {**os.environ, "CARAV_RUN_DIR": str(run_dir), "PYTHONPATH": str(ROOT)}
    started: list[CaravProcess] = []

    class Api:
        workdir = tmp_path
        run_root = run_dir

        @staticmethod
        def run(graph: Path, *args: str) -> CaravProcess:
            plane = ["--set", f"run.transport={transport}"] if transport else []
            p = CaravProcess(tmp_path, env, graph, [*args, *plane])
            started.append(p)
            return p

        @staticmethod
        def cli(*args: str, timeout_s: float = 60) -> subprocess.CompletedProcess:
            return subprocess.run([sys.executable, "-m", "carav_stream.cli", *args], env=env, cwd=tmp_path,
                                  capture_output=True, text=True, timeout=timeout_s)

        @staticmethod
        def graph(body: str, name: str = "g.toml") -> Path:
            path = tmp_path / name
            path.write_text(f'block_paths = ["{TOYS}"]\n' + body)
            return path

    Api.transport = transport or "zmq"
    yield Api
    for p in started:
        p.kill()
    shutil.rmtree(run_dir, ignore_errors=True)


def wait_until(predicate, timeout_s: float, what: str, interval_s: float = 0.05):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def read_jsonl(path: Path) -> list[dict]:
    if not path.exists():
        return []
    lines = path.read_text().splitlines()
    out = []
    for line in lines:
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            break   # a line still being written
    return out
