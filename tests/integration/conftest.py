"""Fixtures that run real `carav` processes: every wait waits on progress (tests/waiting.py), every process group
is killed."""
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

from tests.waiting import group_cpu_s
from tests.waiting import wait_until as wait_on_progress

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

    def progress(self) -> float:
        """CPU seconds used by the run's process group: it rises while the graph works (tests/waiting.py)."""
        return group_cpu_s(self.pgid)

    def wait(self) -> int:
        """The exit code, once the run ends; fails when the run stops making progress (tests/waiting.py)."""
        wait_on_progress(lambda: self.proc.poll() is not None, "the run to end", self.progress)
        return self.proc.returncode

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
        _kill_group(self.pgid)
        self.proc.wait()          # SIGKILL cannot be refused: the direct child ends and is reaped
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
        def cli(*args: str) -> subprocess.CompletedProcess:
            """A `carav` command in its own process group, waited on by progress; its group killed after."""
            with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
                proc = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", *args], env=env, cwd=tmp_path,
                                        stdout=out, stderr=err, stdin=subprocess.DEVNULL, text=True,
                                        start_new_session=True)
                try:
                    # a command may wait on a running graph (swap, stop): that graph's work is its progress too
                    wait_on_progress(lambda: proc.poll() is not None, f"carav {' '.join(args)}",
                                     lambda: group_cpu_s(proc.pid, *(p.pgid for p in started)))
                finally:
                    _kill_group(proc.pid)
                    proc.wait()
                out.seek(0)
                err.seek(0)
                return subprocess.CompletedProcess(proc.args, proc.returncode, out.read(), err.read())

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


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def wait_until(predicate, what: str, *runs: CaravProcess, interval_s: float = 0.05):
    """The predicate's first true value, waiting while `runs` make progress (tests/waiting.py)."""
    return wait_on_progress(predicate, what, lambda: sum(r.progress() for r in runs), interval_s=interval_s)


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
