"""A live DCA1000 stream through a real graph: the replayer sends an AWR1642-sized capture over loopback with one
packet lost and one duplicated, at the AWR1642's data rate at most and never more than a window of bytes ahead of
what the source has drained from its socket (a busy machine slows the stream instead of overflowing the socket);
`carav run` receives it with dca1000_udp_source, judges every whole cycle, refuses exactly the damaged ones as
invalid, counts no datagram dropped by this host, and ends when the sender stops."""
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


def window_bytes() -> int:
    """The most the sender runs ahead of the source's reading: the source asks for 8 MiB and the kernel grants at
    least 2 x min(8 MiB, rmem_max) >= 4 x the window (asserted after the run), so its socket is never near full."""
    with open("/proc/sys/net/core/rmem_max") as fh:
        return min(1 << 20, int(fh.read()) // 2)


def udp_socket(port: int) -> list[str] | None:
    """The /proc/net/udp fields of this machine's socket bound to the UDP port (local addresses in hex)."""
    with open("/proc/net/udp") as fh:
        return next((f for f in map(str.split, fh.readlines()[1:]) if f[1].endswith(f":{port:04X}")), None)


def bound(port: int) -> bool:
    return udp_socket(port) is not None


def queued_bytes(port: int) -> int:
    """The bytes waiting in the socket's receive buffer (the rx_queue column, hex; datagrams with their kernel
    overhead); 0 once no socket is bound to the port."""
    fields = udp_socket(port)
    return 0 if fields is None else int(fields[4].split(":")[1], 16)


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
    # starved of CPU for seconds on a busy machine does not end the stream early. Waiting for room does not silence
    # the sender for the source: it waits only while datagrams wait in the source's socket, and the source does not
    # take a sender for stopped while one does.
    run = carav.run(graph)
    wait_until(lambda: bound(port) or run.proc.poll() is not None, "the source to bind its port", run)
    assert run.proc.poll() is None, run.stderr()
    stream = np.rint(np.random.default_rng(2).standard_normal(CYCLES * B // 2) * 30).astype("<i2").tobytes()
    packets = packetize(stream)
    window = window_bytes()

    def room() -> bool:
        """True while the source's socket holds at most `window` bytes; past that, False once the source has drained
        it to half (waiting on the graph's progress), and the replayer restarts its pace from there."""
        if queued_bytes(port) <= window:
            return True
        wait_until(lambda: queued_bytes(port) <= window // 2, "the source to drain its socket", run, interval_s=0.01)
        return False

    tx = Replayer("127.0.0.1", port)
    tx.send(apply_faults(packets, Faults(lose=frozenset({100}), duplicate=frozenset({2000}))), B / 40e-3, room)
    tx.close()
    assert run.wait() == 0, run.stderr()
    summary = run.summary()
    hit = set()
    for i in (100, 2000):     # the cycles holding the lost and the duplicated packet's bytes
        hit |= set(range(i * 1456 // B, ((i + 1) * 1456 - 1) // B + 1))
    live = summary["live_capture"]
    assert live["cycles"] == CYCLES and live["lost"] == 1 and live["duplicated"] == 1
    assert live["damaged_cycles"] == len(hit) and live["sender_stopped"] is True
    assert live["dropped_by_host"] == 0, live                       # the pacing kept the socket from overflowing
    assert live["rcvbuf_granted_bytes"] >= 4 * window, live
    assert summary["cycles_judged"] == CYCLES
    assert summary["alarm_reasons"] == {"invalid": len(hit)}, summary["alarm_reasons"]
