"""tcp edges are authenticated unless the graph says otherwise in so many words, with real `carav run`s.

A graph placed on hosts of this machine, run whole, gets CURVE keys made for the run: a process without them
(another user on the machine) gets nothing into its tcp inputs, and each attempt is refused and counted. A wrong
key fails the run at once, in one line naming the edge and the key. `tcp = "plain"` is a warning, at validation
and in the summary; a graph run in parts needs its own keys. (tests/integration/test_curve_tcp.py: the graph's
own keys, rogue peers on both ends of an edge.)"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import zmq
import zmq.auth

from carav_stream.radar.streams import scene_of
from carav_stream.runtime.frames import Frame, encode
from carav_stream.runtime.protocol import NodeSpec
from tests.integration.conftest import PACED, read_jsonl, wait_until
from tests.integration.test_curve_tcp import sink_seqs, two_ports, write_graph
from tests.integration.test_forgery import TAPS, advancing, header

pytestmark = pytest.mark.integration

# the radar chain with taps, its RF front end on host front and detection and ranging on host back, both this
# machine (as graphs/two_hosts.toml): adc.frames -> detector.frames, adc.frames -> gate.frames and
# source.rho -> detector.rho go over tcp
RADAR_ON_TWO_HOSTS = """\
include = {taps}
[hosts.front]
address = "127.0.0.1"
port_base = {front}
[hosts.back]
address = "127.0.0.1"
port_base = {back}
[blocks]
source = {{ host = "front" }}
channel = {{ host = "front" }}
attacker = {{ host = "front" }}
adc = {{ host = "front" }}
alog = {{ host = "front" }}
rlog = {{ host = "front" }}
detector = {{ host = "back" }}
gate = {{ host = "back" }}
ranging = {{ host = "back" }}
summary = {{ host = "back" }}
vlog = {{ host = "back" }}
elog = {{ host = "back" }}
csv = {{ host = "back" }}
"""


def forged_pairs(last: int, n: int, k: int) -> tuple[list, list]:
    """`k` (ADC frame, rho) pairs of `n` cycles for the seqs after `last`: quiet frames with balanced activation
    rows, well formed for the detector."""
    scene = scene_of("table1")
    frames, rhos = [], []
    rho = np.zeros((n, scene.n_chirps), bool)
    rho[:, ::2] = True
    for seq in range(last + 1, last + 1 + k):
        at = {"cycle": n * seq, "cycles": n}
        frames.append(encode(Frame.of(np.zeros((n, scene.n_chirps, scene.n_samples), np.int16)),
                             **header(seq, **at, stream="adc.frames", node="adc", block="adc_framer")))
        rhos.append(encode(Frame.of(rho), **header(seq, **at, stream="source.rho", node="source",
                                                   block="chirp_source")))
    return frames, rhos


def test_forged_frames_into_the_tcp_inputs_of_a_graph_run_whole_are_refused_at_the_handshake(carav, tmp_path):
    """graphs/two_hosts.toml's layout with no [security], run whole on this machine: 20 forged (frame, rho) pairs
    with seqs just ahead of the stream are pushed from a process without the run's keys into the detector's tcp
    inputs. Each connection is refused with its reason and counted; nothing of it is taken, and the detector
    judges every cycle on the real frames."""
    front, back = two_ports()
    graph = tmp_path / "radar_two_hosts.toml"
    graph.write_text(RADAR_ON_TWO_HOSTS.format(taps=json.dumps(str(TAPS / "radar_taps.toml")), front=front,
                                               back=back))
    verdicts = carav.workdir / "verdicts.jsonl"
    run = carav.run(graph, "--cycles", "0", "--set", "attacker.model='smart'", "--set", "attacker.rarms=3.0",
                    "--set", "attacker.start_cycle=0", "--set", "batch=16", *PACED)
    wait_until(lambda: read_jsonl(verdicts), "the radar graph to start (14 processes importing numpy)", run)
    advancing(carav, verdicts, "verdicts to flow", more=3)
    (spec,) = carav.run_root.glob("carav-*/*/detector.spec")
    inputs = NodeSpec.from_wire(spec.read_bytes()).inputs
    assert inputs["frames"].startswith("tcp://") and inputs["rho"].startswith("tcp://"), inputs
    last = read_jsonl(verdicts)[-1]
    frames, rhos = forged_pairs(last["seq"], last["cycles"], 20)
    ctx = zmq.Context()
    rogues = []
    try:
        for port, messages in (("frames", frames), ("rho", rhos)):
            rogues.append(rogue := ctx.socket(zmq.PUSH))
            rogue.linger = 0
            rogue.connect(inputs[port])
            for parts in messages:
                try:
                    rogue.send_multipart(parts, flags=zmq.NOBLOCK)   # taken only once a handshake succeeds
                except zmq.Again:
                    pass
        advancing(carav, verdicts, "the detector to judge past the forged seqs", more=40)
    finally:
        ctx.destroy(linger=0)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["lost"] == 0 and s["rejected"] == 0 and not s["failures"], (s["lost_by_edge"], s["failures"])
    assert s["missed"] == 0 and s["attacked_cycles"] == s["detected"] > 100, (s["missed"], s["detected"])
    sec = s["security"]
    assert (sec["tcp"], sec["keys"], sec["warnings"]) == ("curve", "run", [])
    refused = sec["refused_connections"]
    assert refused.get("detector.frames", 0) >= 1 and refused.get("detector.rho", 0) >= 1, refused
    for port in ("frames", "rho"):
        assert f"node 'detector' input '{port}': refused connection #1: refused a tcp connection: " in run.stderr()
    d = s["per_node"]["detector"]
    assert d["in"]["frames"] == s["per_node"]["adc"]["sent"]["adc.frames -> detector.frames"]
    assert d["in"]["rho"] == s["per_node"]["source"]["sent"]["source.rho -> detector.rho"]


def test_a_client_key_the_consumer_does_not_authorize_fails_the_run_at_once_naming_edge_and_key(tmp_path, carav,
                                                                                                 keys):
    """curve_authorized holds another client's key: every tcp producer's handshake is refused, and the run ends
    non-zero before its ready deadline, each producer naming its edge and its key, each input the key it
    refused."""
    for f in (tmp_path / "authorized").iterdir():
        f.unlink()
    shutil.copy(tmp_path / "rogue" / "rogue.key", tmp_path / "authorized" / "rogue.key")
    ports = two_ports()
    run = carav.run(write_graph(tmp_path, cycles=0, ports=ports, curve=True))
    assert run.wait() == 1, run.stderr()
    err, client = run.stderr(), keys["client"][0].decode()
    # whichever producer's handshake comes first fails the run (the other may be stopped before its own comes)
    lines = [line for line in err.splitlines() if "failed: exited with status 1: BlockError: edge" in line]
    expected = {f"carav: node '{edge.split('.')[0]}' ({block}) failed: exited with status 1: BlockError: edge "
                f"'{edge}' (tcp://127.0.0.1:{port}): the consumer refused this node's CURVE key {client} "
                f"(curve_client_cert {tmp_path}/certs/client.key_secret): it is not in the consumer's "
                "curve_authorized"
                for edge, block, port in (("src.out -> t.inp", "counter_source", ports[1]),
                                          ("t.out -> log.inp", "tagger", ports[0]))}
    assert lines and set(lines) <= expected, (lines, expected)
    refusal = (f"refused connection #1: refused a tcp connection from 127.0.0.1: its CURVE key {client} is not "
               f"in curve_authorized ({tmp_path}/authorized)")
    assert f"node 't' input 'inp': {refusal}" in err or f"node 'log' input 'inp': {refusal}" in err, err
    s = run.summary()
    assert not any("not ready" in f for f in s["failures"]), s["failures"]
    assert s["failures"] and all("the consumer refused this node's CURVE key" in f for f in s["failures"]), \
        s["failures"]
    assert sum(s["security"]["refused_connections"].values()) >= 1, s["security"]


def test_plain_tcp_is_said_in_so_many_words_and_flagged_at_validation_and_in_the_summary(tmp_path, carav):
    n = 100
    graph = write_graph(tmp_path, cycles=n, ports=two_ports(), curve='[security]\ntcp = "plain"\n')
    checked = carav.cli("validate", str(graph))
    assert checked.returncode == 0 and "warning: security.tcp = \"plain\": 2 tcp edge(s)" in checked.stderr
    run = carav.run(graph)
    assert run.wait() == 0, run.stderr()
    assert sink_seqs(tmp_path) == list(range(n))
    s = run.summary()
    assert (s["security"]["tcp"], s["security"]["keys"]) == ("plain", None)
    (warning,) = s["security"]["warnings"]
    assert warning.startswith("security.tcp = \"plain\": 2 tcp edge(s) ('src.out -> t.inp', 't.out -> log.inp') "
                              "carry frames unauthenticated and in the clear"), warning
    assert f"WARNING: {warning}" in run.stdout() and f"carav run: warning: {warning}" in run.stderr()


def test_a_graph_run_in_parts_without_its_own_keys_is_refused_naming_the_edge(tmp_path, carav):
    graph = write_graph(tmp_path, cycles=10, ports=two_ports(), curve=False)
    refused = carav.cli("run", str(graph), "--host", "a")
    assert refused.returncode == 3, refused.stderr
    assert ("g.toml: --host a: edge 'src.out -> t.inp' joins a host that another supervisor runs" in refused.stderr
            and "make them with `carav keys DIR`" in refused.stderr), refused.stderr
    assert not Path(tmp_path / "out.jsonl").exists()
