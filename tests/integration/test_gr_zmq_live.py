"""GNU Radio's ZMQ streams through real graphs, without GNU Radio: a Python sender that sends what a ZMQ PUSH Sink
with Pass Tags sends (the Table I radar's samples, one half-cycle message lost) feeds graphs/gnuradio.toml, which
judges every cycle, refuses exactly the damaged one as invalid and ranges the car; and a carav graph's gr_zmq_sink
(the activation in its tags, on loopback) feeds a second graph whose gr_zmq_source takes the activation from them,
which then raises the same alarms and makes the same estimates as the graph that sent the stream."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from carav_stream.capture.gr_stream import DEFAULT_TAGS, cycle_tags, layout_of
from carav_stream.capture.gr_zmq import Sender, encode
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import channel, transmit
from carav_stream.view.server import free_port
from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration
GRAPH = ROOT / "graphs" / "gnuradio.toml"
CYCLES = 12


def test_a_gnu_radio_stream_is_judged_and_ranged_and_its_damaged_cycle_refused(carav):
    scene = load_scene("table1")
    lay = layout_of(scene)
    pattern = tomllib.loads(GRAPH.read_text())["blocks"]["source"]["pattern"]          # the graph's activation
    rho = np.tile(np.array([d == "1" for d in pattern]), (CYCLES, 1))
    rx = channel(scene, transmit(scene, rho), np.random.default_rng(3)).reshape(-1)
    n = lay.items_per_cycle
    sender = Sender(f"tcp://127.0.0.1:{free_port('127.0.0.1')}", "push")
    run = carav.run(GRAPH, "--set", f"source.address={sender.address}", "--set", "source.idle_timeout_s=3.0")
    try:
        for c in range(CYCLES):
            for a, b in ((c * n, c * n + n // 2), (c * n + n // 2, (c + 1) * n)):
                if a == 5 * n + n // 2:
                    continue                                                # cycle 5's second half never comes
                tags = [t for t in cycle_tags(lay, c * n, c, frozenset(DEFAULT_TAGS), rate=c == 0)
                        if a <= t.offset < b]
                assert sender.send(encode(rx[a:b], offset=a, tags=tags), 60.0), run.stderr()
        assert run.wait() == 0, run.stderr()
    finally:
        sender.close(0)
    s = run.summary()
    live = s["gr_stream"]
    assert (live["cycles"], live["damaged_cycles"], live["lost"], live["lost_items"]) == (CYCLES, 1, 1, n // 2)
    assert live["sender_stopped"] is True and live["messages"] == 2 * CYCLES - 1
    assert s["cycles_judged"] == CYCLES and s["alarm_reasons"] == {"invalid": 1}
    assert s["range_error_m"]["n"] == CYCLES - 1 and s["range_error_m"]["rmse"] < 0.01    # the car, to the cm


def test_a_carav_stream_with_its_activation_raises_the_same_alarms_and_estimates_downstream(carav):
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    receiving = carav.graph(f"""
include = "{GRAPH}"
[blocks]
source = {{ address = "{address}", pattern = "", rho_from_tags = true, idle_timeout_s = 10.0 }}
""", "receiving.toml")
    sending = carav.graph(f"""
include = "{ROOT / 'graphs' / 'table1_smart.toml'}"
connections = ["adc.frames -> gr.frames", "source.rho -> gr.rho"]
[run]
cycles = 48
[blocks]
attacker = {{ start_cycle = 24 }}
gr = {{ type = "gr_zmq_sink", address = "{address}", pass_tags = true, tags = {list(DEFAULT_TAGS) + ['carav_rho']} }}
""".replace("'", '"'), "sending.toml")
    downstream = carav.run(receiving)
    upstream = carav.run(sending)
    assert upstream.wait() == 0, upstream.stderr()
    assert downstream.wait() == 0, downstream.stderr()
    up, down = upstream.summary(), downstream.summary()
    assert down["gr_stream"]["cycles"] == 48 and down["gr_stream"]["damaged_cycles"] == 0
    assert up["gr_stream_sent"]["cycles"] == 48
    assert down["cycles_judged"] == up["cycles_judged"] == 48
    assert up["alarms"] > 0 and down["alarms"] == up["alarms"] and down["alarm_reasons"] == up["alarm_reasons"]
    assert down["range_error_m"] == up["range_error_m"] and down["velocity_error_mps"] == up["velocity_error_mps"]
