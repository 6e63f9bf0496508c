"""A live DCA1000 stream through a real graph: the replayer sends an AWR1642-sized capture over loopback at the
AWR1642's data rate with one packet lost and one duplicated; `carav run` receives it with dca1000_udp_source,
judges every whole cycle, refuses exactly the damaged ones as invalid, and ends when the sender stops."""
from __future__ import annotations

import numpy as np
import pytest

from carav_stream.capture.dca1000_udp import Faults, Replayer, apply_faults, packetize
from tests.integration.conftest import wait_until

pytestmark = pytest.mark.integration
CYCLES, B = 30, 128 * 4 * 256 * 2          # 4 receivers x 128 chirps x 256 real 16-bit samples
SCENE = """name = "live"
fc_hz = 77e9
bandwidth_hz = 2.0e9
t_sweep_s = 160e-6
fs_hz = 10e6
n_chirps = 128
n_samples = 256
t_cycle_s = 40e-3
iq = false
adc_bits = 16
adc_full_scale = 1.0
sigma_n = 9.1552734375e-4
"""   # sigma_n = 30 codes x 2^-15


def bound(port: int) -> bool:
    """A socket of this machine is bound to the UDP port (/proc/net/udp lists local addresses in hex)."""
    with open("/proc/net/udp") as fh:
        return any(line.split()[1].endswith(f":{port:04X}") for line in fh.readlines()[1:])


def test_a_live_stream_at_the_awr1642_rate_is_judged_and_its_damaged_cycles_refused(carav, tmp_path):
    import socket
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    (tmp_path / "live.toml").write_text(SCENE)
    graph = carav.graph(f"""
scene = "live.toml"
batch = 8
connections = ["radar.frames -> detector.frames", "radar.rho -> detector.rho", "radar.frames -> gate.frames",
               "detector.verdict -> gate.verdict", "gate.clean -> ranging.frames",
               "ranging.estimates -> summary.estimates", "gate.alarms -> summary.alarms"]
[blocks]
detector = {{ type = "rms_detector", eta = 3.0 }}
gate = {{ type = "gate" }}
ranging = {{ type = "range_estimator" }}
summary = {{ type = "run_summary" }}
[blocks.radar]
type = "dca1000_udp_source"
port = {port}
n_rx = 4
rx = 2
pattern = "{'10' * 64}"
idle_timeout_s = 10.0
""", "live_graph.toml")
    # idle_timeout_s is how the source learns that the sender stopped; 10 s, so that a sender (this test's process)
    # starved of CPU for seconds on a busy machine does not end the stream early
    run = carav.run(graph)
    wait_until(lambda: bound(port) or run.proc.poll() is not None, "the source to bind its port", run)
    assert run.proc.poll() is None, run.stderr()
    stream = np.rint(np.random.default_rng(2).standard_normal(CYCLES * B // 2) * 30).astype("<i2").tobytes()
    packets = packetize(stream)
    tx = Replayer("127.0.0.1", port)
    tx.send(apply_faults(packets, Faults(lose=frozenset({100}), duplicate=frozenset({2000}))), B / 40e-3)
    tx.close()
    assert run.wait() == 0, run.stderr()
    summary = run.summary()
    hit = set()
    for i in (100, 2000):     # the cycles holding the lost and the duplicated packet's bytes
        hit |= set(range(i * 1456 // B, ((i + 1) * 1456 - 1) // B + 1))
    live = summary["live_capture"]
    assert live["cycles"] == CYCLES and live["lost"] == 1 and live["duplicated"] == 1
    assert live["damaged_cycles"] == len(hit) and live["sender_stopped"] is True
    assert summary["cycles_judged"] == CYCLES
    assert summary["alarm_reasons"] == {"invalid": len(hit)}, summary["alarm_reasons"]
