"""carav study on a real Dask cluster: a scheduler and two workers on loopback, one SIGKILLed mid-study; the results
equal a one-worker run bit for bit."""
import json
import os
import signal
import socket
import subprocess
import sys

import pytest

from carav_stream.testing.waiting import group_cpu_s, wait_until
from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration
pytest.importorskip("distributed")

STUDY = """
description = "every sample: one task per point, long enough to kill a worker in the middle"
seed = 5
trials = 600
eta = "0.5:3:0.05"
method = "samples"
[[scenes]]
preset = "table1"
[[attacks]]
kind = "random"
rarms = [0.5, 1.0, 1.1, 1.2, 2.0, 3.0]
[[attacks]]
kind = "smart"
rarms = [1.0, 3.0]
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def port_open(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), 1).close()
        return True
    except OSError:
        return False


def start(args: list[str], env: dict, log) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "dask", *args], env=env, stdout=log, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL, start_new_session=True)


def kill(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()                 # SIGKILL cannot be refused: it ends and is reaped


def test_a_worker_killed_mid_study_loses_nothing_and_changes_nothing(carav, tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(STUDY)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    port = free_port()
    log = open(tmp_path / "dask.log", "w")
    procs = [start(["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], env, log)]
    try:
        address = f"tcp://127.0.0.1:{port}"
        for i in range(2):
            procs.append(start(["worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                "--name", f"w{i}", "--host", "127.0.0.1"], env, log))
        from distributed import Client
        cluster_cpu_s = lambda: group_cpu_s(*(p.pid for p in procs))  # noqa: E731
        wait_until(lambda: port_open(port), "the scheduler", cluster_cpu_s)
        with Client(address, timeout="300s") as client:      # connecting: generous, the waits below are by progress
            wait_until(lambda: len(client.scheduler_info()["workers"]) >= 2, "two workers", cluster_cpu_s)
        out = tmp_path / "cluster"
        with open(tmp_path / "study.out", "w") as run_out, open(tmp_path / "study.err", "w") as run_err:
            run = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", "study", str(study), "--scheduler",
                                    address, "--out", str(out), "--quiet"], env=env, cwd=tmp_path, stdout=run_out,
                                   stderr=run_err, stdin=subprocess.DEVNULL, start_new_session=True)
        study_cpu_s = lambda: cluster_cpu_s() + group_cpu_s(run.pid)  # noqa: E731
        try:
            wait_until(lambda: len(list((out / "points").glob("*.npz"))) >= 1, "the first finished point",
                       study_cpu_s)
            assert len(list((out / "points").glob("*.npz"))) < 9, "the study ended before a worker could be killed"
            kill(procs[1])                                            # worker 0, mid-study, with its nanny
            wait_until(lambda: run.poll() is not None, "the study to end", study_cpu_s)
        finally:
            if run.poll() is None:
                os.killpg(run.pid, signal.SIGKILL)
        stdout, stderr = (tmp_path / "study.out").read_text(), (tmp_path / "study.err").read_text()
        assert run.returncode == 0, stderr
        alone = carav.cli("study", str(study), "--workers", "1", "--out", str(tmp_path / "alone"), "--quiet")
        assert alone.returncode == 0, alone.stderr
        a = json.loads((out / "study.json").read_text())
        b = json.loads((tmp_path / "alone" / "study.json").read_text())
        assert a["groups"] == b["groups"]                              # every curve, bit for bit
        assert (out / "study.csv").read_text() == (tmp_path / "alone" / "study.csv").read_text()
        assert "9 points" in stdout
        # carav sweep on the same cluster (one worker left): the numbers of the threaded sweep
        sweep = ["sweep", "--preset", "table1", "--attack", "random", "--rarms", "1,3", "--trials", "200",
                 "--seed", "4", "--eta", "0.5:3:0.05", "--quiet"]
        for name, extra in (("dask", ["--scheduler", address]), ("threads", [])):
            done = carav.cli(*sweep, *extra, "--json", str(tmp_path / f"{name}.json"))
            assert done.returncode == 0, done.stderr
        dask_curves, thread_curves = (json.loads((tmp_path / f"{n}.json").read_text())["curves"]
                                      for n in ("dask", "threads"))
        assert dask_curves == thread_curves
    finally:
        for p in reversed(procs):
            kill(p)
        log.close()


def test_an_interrupted_study_resumes_from_its_points(carav, tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(STUDY.replace("trials = 600", "trials = 100"))
    first = carav.cli("study", str(study), "--workers", "1", "--out", str(tmp_path / "r"), "--quiet")
    assert first.returncode == 0, first.stderr
    points = sorted((tmp_path / "r" / "points").glob("*.npz"))
    assert len(points) == 9
    for p in points[:4]:                                               # as if the run had stopped after 5 points
        p.unlink()
    kept = {p.name: p.stat().st_mtime_ns for p in points[4:]}
    before = (tmp_path / "r" / "study.json").read_text()
    again = carav.cli("study", str(study), "--workers", "1", "--out", str(tmp_path / "r"), "--quiet")
    assert again.returncode == 0, again.stderr
    assert "5 read back" in again.stderr and "4 to draw" in again.stderr
    assert {p: (tmp_path / "r" / "points" / p).stat().st_mtime_ns for p in kept} == kept   # not drawn again
    assert (tmp_path / "r" / "study.json").read_text() == before
