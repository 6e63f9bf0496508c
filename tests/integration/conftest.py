"""The integration tests' fixture: the test kit's `carav` (carav_stream.testing.graphs.Graphs), with the toy blocks
of tests/toy_blocks on every graph written by `carav.graph` and the repository on the processes' import path.
Every wait waits on progress (carav_stream.testing.waiting), every process group is killed after the test."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
import zmq.auth

from carav_stream.console.errors import Exit
from carav_stream.testing.graphs import GraphRun, Graphs, read_jsonl, wait_for

__all__ = ["PACED", "ROOT", "TOYS", "carav", "exit_code_after_a_kill", "keys", "read_jsonl", "wait_until"]

ROOT = Path(__file__).resolve().parents[2]
TOYS = ROOT / "tests" / "toy_blocks"
# A radar graph run until stopped, paced: its test waits for some tens of cycles, and an unpaced source would burn
# both cores meanwhile (the other pytest worker's too). Every wait still waits on progress, never on this rate.
PACED = ("--set", "source.cycles_per_s=200")


class ProjectGraphs(Graphs):
    def graph(self, body: str, name: str = "g.toml", block_paths=(TOYS,)) -> Path:
        return super().graph(body, name, block_paths=block_paths)


@pytest.fixture
def carav(tmp_path, request):
    """carav.run(graph, *args) starts a graph; carav.cli(*args) runs a short command; all torn down after.

    Parametrised indirectly with a data plane (`@pytest.mark.parametrize("carav", TRANSPORTS, indirect=True)`),
    every graph it runs carries its arrays over that plane (run.transport); carav.transport says which."""
    graphs = ProjectGraphs(tmp_path, transport=getattr(request, "param", None),
                           env={"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))})
    yield graphs
    graphs.close()


@pytest.fixture
def keys(tmp_path):
    """CURVE certificates in tmp_path: certs/{server,client}.key[_secret], authorized/client.key."""
    certs = tmp_path / "certs"
    certs.mkdir()
    server_public, server_secret = zmq.auth.create_certificates(certs, "server")
    client_public, client_secret = zmq.auth.create_certificates(certs, "client")
    (tmp_path / "authorized").mkdir()
    shutil.copy(client_public, tmp_path / "authorized" / "client.key")
    rogue = tmp_path / "rogue"
    rogue.mkdir()
    rogue_public, rogue_secret = zmq.auth.create_certificates(rogue, "rogue")
    return {"server": zmq.auth.load_certificate(server_secret), "client": zmq.auth.load_certificate(client_secret),
            "rogue": zmq.auth.load_certificate(rogue_secret)}


def exit_code_after_a_kill(summary: dict, killed: str) -> int:
    """What `carav run` must exit with after `killed` was SIGKILLed mid-run and restarted, and nothing else failed:
    1 (failed) when the summary counts lost frames, 0 when it counts none. A node's counts are those of its last
    heartbeat (runtime.node.HEARTBEAT_S), so the frames it took, or had queued, since then die with it and are
    counted lost; whether there were any depends on when the kill fell (none, if it fell just after a heartbeat
    and no frame had come since). Asserts that every loss is on an edge of the killed node, or inside it."""
    def nodes(edge: str) -> set[str]:
        if edge.startswith("inside "):
            return {edge.removeprefix("inside ").split(" ")[0]}
        return {end.strip().split(".")[0] for end in edge.split("->")}
    elsewhere = {edge: n for edge, n in summary["lost_by_edge"].items() if killed not in nodes(edge)}
    assert elsewhere == {}, f"frames lost away from the killed node {killed!r}: {elsewhere}"
    return Exit.FAILED if summary["lost"] else Exit.OK


def wait_until(predicate, what: str, *runs: GraphRun, interval_s: float = 0.05):
    """The predicate's first true value, waiting while `runs` make progress (carav_stream.testing.waiting)."""
    return wait_for(predicate, what, *runs, interval_s=interval_s)
