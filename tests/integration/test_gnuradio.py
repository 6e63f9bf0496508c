"""carav and GNU Radio 3.10 itself, both ways, over gr-zeromq: a headless flowgraph (tests/integration/gnuradio/, run
by the system's Python) sends a known signal tagged packet_len, rx_rate and rx_time through a ZMQ PUSH Sink (or a
REP Sink, answering gr_zmq_source's requests) into gr_zmq_source, and the cycles carav records are the very items
the flowgraph's File Sink wrote; and gr_zmq_sink's stream reaches a flowgraph's ZMQ PULL Source (or its REQ Source,
asking) as the very samples carav recorded, with every tag on the item it was put on. The examples' flowgraphs
compile with grcc, and the one that feeds carav, run headless, gives graphs/gnuradio.toml a stream it judges clean
and ranges to the millimetre. gr-radar's own FMCW radar, run headless from its example flowgraph, is framed, judged
and ranged by graphs/gr_radar.toml. CI installs GNU Radio and gr-radar (.ci/run); a local run without them skips
these tests and says why."""
from __future__ import annotations

import json
import os
import select
import subprocess
from pathlib import Path

import numpy as np
import pytest

from carav_stream.core.units import C_MPS
from carav_stream.radar.adc import from_codes
from carav_stream.radar.scene_loader import load_scene
from carav_stream.testing.waiting import group_cpu_s, wait_until
from carav_stream.view.server import free_port
from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration
SYSTEM_PYTHON = "/usr/bin/python3"
SCRIPTS = Path(__file__).with_name("gnuradio")
EXAMPLES = ROOT / "examples" / "gnuradio"
IDEAL = """name = "gr_ideal"
fc_hz = 77e9
bandwidth_hz = 150e6
t_sweep_s = 7.33e-6
fs_hz = 150e6
t_adc_start_s = 0.0
n_chirps = 8
n_samples = 64
iq = true
adc_bits = 0          # an ideal ADC: the flowgraph's samples are kept as they came
sigma_n = 1e-3
"""
ADC_SCENE = ROOT / "tests" / "golden" / "adc_small_iq.toml"      # 4 chirps x 256 I/Q samples, a 12-bit ADC
GR_RADAR_EXAMPLE = EXAMPLES / "gr_radar_to_carav.grc"
GR_RADAR_C_MPS = 3e8            # gr-radar's speed of light (its static target simulator's c_light)


def gnuradio(modules: str = "zeromq, blocks, gr", package: str = "gnuradio") -> None:
    """Nothing if the system's Python imports GNU Radio's `modules` (its ZeroMQ blocks by default); else a skip (a
    fail under CI, which must run these tests) naming what is missing and the Debian package that brings it."""
    try:
        found = subprocess.run([SYSTEM_PYTHON, "-c", f"from gnuradio import {modules}"],
                               capture_output=True, text=True, timeout=120)
        why = None if found.returncode == 0 else found.stderr.strip().splitlines()[-1]
    except (OSError, subprocess.TimeoutExpired) as exc:
        why = str(exc)
    if why:
        why = f"GNU Radio's {modules} not importable by {SYSTEM_PYTHON}: {why} (apt-get install {package})"
        if os.environ.get("CI"):
            pytest.fail(f"CI must run the GNU Radio tests; {why}")
        pytest.skip(why)


def printed(proc: subprocess.Popen, lines: list[str]) -> bool:
    """Whether the process has printed a line yet (lines read so far are added to `lines`), without blocking."""
    while select.select([proc.stdout], [], [], 0)[0]:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line.strip())
    return bool(lines)


@pytest.fixture
def flowgraph():
    """start(script, *args) runs a script of tests/integration/gnuradio under the system's Python in its own process
    group; every one is killed after the test."""
    gnuradio()
    started: list[subprocess.Popen] = []

    def start(script: str, *args: str) -> subprocess.Popen:
        p = subprocess.Popen([SYSTEM_PYTHON, str(SCRIPTS / script), *map(str, args)], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        started.append(p)
        return p
    yield start
    for p in started:
        if p.poll() is None:
            os.killpg(p.pid, 9)
        p.wait()


@pytest.mark.parametrize("gr_sink, socket", [("push", "pull"), ("rep", "req")])
def test_a_gnu_radio_stream_is_recorded_by_carav_as_the_items_gnu_radio_wrote_to_a_file(carav, flowgraph, tmp_path,
                                                                                        gr_sink, socket):
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    (tmp_path / "gr_ideal.toml").write_text(IDEAL)
    (tmp_path / "rec").mkdir()
    cycles, n = 9, 8 * 64
    where = f'address = "{address}", socket = "{socket}"'
    graph = carav.graph(f"""
scene = "gr_ideal.toml"
batch = 4
connections = ["source.frames -> rec.frames", "source.rho -> rec.rho"]
[blocks]
source = {{ type = "gr_zmq_source", {where}, pass_tags = true, pattern = "10101010" }}
rec = {{ type = "sigmf_sink", path = "rec/received" }}
""", "received.toml")
    sent = tmp_path / "sent.cf32"
    sender = flowgraph("gr_send.py", address, sent, cycles * n + 100, 64, 150e6, gr_sink)   # and a part of a cycle
    run = carav.run(graph)
    said: list[str] = []
    wait_until(lambda: printed(sender, said) or sender.poll() is not None or run.proc.poll() is not None,
               "the flowgraph to send its stream", lambda: run.progress() + group_cpu_s(sender.pid))
    assert said == ["sent"], sender.stderr.read()
    assert run.wait() == 0, run.stderr()    # the stream ended: the flowgraph's sockets may close now
    sender.stdin.close()
    assert sender.wait() == 0, sender.stderr.read()
    items = np.fromfile(sent, np.complex64)
    received = np.fromfile(tmp_path / "rec" / "received.sigmf-data", "<c8")
    assert len(items) == cycles * n + 100 and len(received) == (cycles + 1) * n
    assert np.array_equal(received[:cycles * n], items[:cycles * n])          # bit for bit
    assert np.array_equal(received[cycles * n:cycles * n + 100], items[cycles * n:])
    live = run.summary()["gr_stream"]
    assert (live["cycles"], live["damaged_cycles"], live["incomplete"]) == (cycles + 1, 1, 1)
    assert live["tags"] == -(-(cycles * n + 100) // 64) + 2           # packet_len on every chirp, rx_rate, rx_time


@pytest.mark.parametrize("socket, gr_source", [("push", "pull"), ("rep", "req")])
def test_carav_s_stream_reaches_gnu_radio_as_the_samples_carav_recorded_with_its_tags(carav, flowgraph, tmp_path,
                                                                                      socket, gr_source):
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    (tmp_path / "rec").mkdir()
    cycles, n = 12, 4 * 256
    scene = load_scene(str(ADC_SCENE))
    got, tags_path = tmp_path / "got.cf32", tmp_path / "tags.json"
    receiver = flowgraph("gr_receive.py", address, got, tags_path, cycles * n, gr_source)
    graph = carav.graph(f"""
scene = "{ADC_SCENE}"
seed = 5
batch = 5
connections = ["source.tx -> channel.tx", "channel.rx -> adc.rx", "adc.frames -> gr.frames",
               "adc.frames -> rec.frames", "source.rho -> rec.rho"]
[run]
cycles = {cycles}
[blocks]
source = {{ type = "chirp_source" }}
channel = {{ type = "channel" }}
adc = {{ type = "adc_framer" }}
gr = {{ type = "gr_zmq_sink", address = "{address}", socket = "{socket}", pass_tags = true }}
rec = {{ type = "sigmf_sink", path = "rec/sent" }}
""", "sending.toml")
    run = carav.run(graph)
    assert run.wait() == 0, run.stderr()
    wait_until(lambda: receiver.poll() is not None, "the flowgraph's end", lambda: group_cpu_s(receiver.pid))
    assert receiver.returncode == 0, receiver.stderr.read()
    codes = np.fromfile(tmp_path / "rec" / "sent.sigmf-data", "<i2").reshape(cycles, 4, 256, 2)
    assert np.array_equal(np.fromfile(got, np.complex64), from_codes(scene, codes).reshape(-1))
    tags: dict[str, list] = {}
    for offset, key, value, srcid in json.loads(tags_path.read_text()):
        assert srcid == "carav"
        tags.setdefault(key, []).append((offset, value))
    assert tags["packet_len"] == [(256 * k, 256) for k in range(4 * cycles)]
    assert tags["carav_chirp"] == [(256 * k, k % 4) for k in range(4 * cycles)]
    assert tags["carav_cycle"] == [(n * c, c) for c in range(cycles)]
    assert tags["carav_seq"] == [(n * 5 * s, s) for s in range(3)]                  # frames of 5, 5 and 2 cycles
    assert tags["rx_rate"] == [(0, 150e6)]
    assert [o for o, _ in tags["rx_time"]] == [n * c for c in range(cycles)]
    assert [s + f for _, (s, f) in tags["rx_time"]] == pytest.approx([c * scene.t_cycle_s for c in range(cycles)])
    assert "carav_rho" not in tags                                                   # the secret stays home


def fed_by_flowgraph(carav, script: Path, graph: str, cycles: int) -> dict:
    """Run a compiled flowgraph `script` (GNU Radio's Python) sending `cycles` cycles to the carav graph
    graphs/`graph`, whose source connects to it; the carav run's summary once both ended well."""
    address = f"tcp://127.0.0.1:{free_port('127.0.0.1')}"
    sender = subprocess.Popen([SYSTEM_PYTHON, str(script), "--address", address, "--n-cycles", str(cycles),
                               "--slowdown", "10"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              start_new_session=True)
    try:
        run = carav.run(ROOT / "graphs" / graph, "--set", f"source.address={address}")
        assert run.wait() == 0, run.stderr()
        wait_until(lambda: sender.poll() is not None, "the flowgraph's end", lambda: group_cpu_s(sender.pid))
        assert sender.returncode == 0, sender.stderr.read()
    finally:
        if sender.poll() is None:
            os.killpg(sender.pid, 9)
            sender.wait()
    return run.summary()


def test_the_example_flowgraphs_compile_and_the_feeding_one_is_judged_clean_and_ranged(carav, flowgraph, tmp_path):
    for grc in sorted(set(EXAMPLES.glob("*.grc")) - {GR_RADAR_EXAMPLE}):       # that one needs gr-radar: below
        done = subprocess.run(["grcc", "-o", str(tmp_path), str(grc)], capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        assert (tmp_path / f"{grc.stem}.py").is_file()
    s = fed_by_flowgraph(carav, tmp_path / "gnuradio_to_carav.py", "gnuradio.toml", 20)
    assert s["gr_stream"]["cycles"] == 20 and s["gr_stream"]["damaged_cycles"] == 0
    assert s["cycles_judged"] == 20 and s["alarms"] == 0
    assert s["range_error_m"]["rmse"] < 0.01 and s["velocity_error_mps"]["rmse"] < 0.1


def test_gr_radar_s_fmcw_radar_is_framed_into_cycles_judged_and_ranged_by_carav(carav, tmp_path):
    """gr-radar's Signal Generator FMCW and Static Target Simulator, dechirped in GNU Radio (the example
    flowgraph, run headless), reach graphs/gr_radar.toml: every cycle framed whole, judged, none alarmed, and the
    car found at gr-radar's range within a resolution cell, off by what gr-radar's c = 3e8 m/s makes of it."""
    gnuradio("zeromq, blocks, gr, radar", "gr-radar")
    done = subprocess.run(["grcc", "-o", str(tmp_path), str(GR_RADAR_EXAMPLE)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    cycles = 20
    s = fed_by_flowgraph(carav, tmp_path / "gr_radar_to_carav.py", "gr_radar.toml", cycles)
    scene = load_scene(str(ROOT / "examples" / "gnuradio" / "gr_radar_fmcw.toml"))
    n = scene.n_chirps * scene.n_samples
    assert s["gr_stream"]["cycles"] == cycles and s["gr_stream"]["damaged_cycles"] == 0
    assert s["gr_stream"]["items"] == cycles * n and s["gr_stream"]["tags"] == cycles * scene.n_chirps
    assert s["cycles_judged"] == cycles and s["alarms"] == 0
    r = s["range_error_m"]
    assert r["n"] == cycles and r["rmse"] < scene.range_resolution_m
    bias_m = scene.targets[0].range_m * (C_MPS / GR_RADAR_C_MPS - 1)       # -30 mm at 43 m
    assert abs(r["mean"] - bias_m) < 0.01 * scene.range_resolution_m, (r, bias_m)
    assert s["velocity_error_mps"]["rmse"] < 0.1
