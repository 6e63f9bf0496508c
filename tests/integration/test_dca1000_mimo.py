"""A 4-receiver TDM capture through a real graph: a TI profile firing TX1, TX2 in turn with four receivers becomes
a MIMO scene (`carav scenes --from-ti-cfg`), a DCA1000 capture of it is written from TI's layout (complex, 2
lanes), and `carav run` sends every whole cycle with its four receivers on the receiver axis, each receiver's samples
where the radar put them, with the profile's activation pattern; a graph whose capture has fewer receivers than the
scene is refused by `carav validate` in one line."""
from __future__ import annotations

import numpy as np
import pytest

from tests.capture.ti_dca1000 import capture_bytes
from tests.integration.conftest import read_jsonl

pytestmark = pytest.mark.integration
CYCLES, N_CHIRPS, N_SAMPLES = 10, 32, 32
# 4 chirps a frame (TX1, TX2, then two silent), 8 loops: 32 chirps, TDM loops of 2 slots, every other one silent
PROFILE = """% xWR16xx TDM MIMO: TX1, TX2, two silent chirps
sensorStop
channelCfg 15 3 0
adcCfg 2 1
profileCfg 0 77 7 6 60 0 0 20 1 32 5000 0 0 30
chirpCfg 0 0 0 0 0 0 0 1
chirpCfg 1 1 0 0 0 0 0 2
chirpCfg 2 3 0 0 0 0 0 0
frameCfg 0 3 8 0 40 1 0
sensorStart
"""


def graph(carav, capture: str, n_rx: int = 4) -> str:
    return str(carav.graph(f"""
scene = "mimo.toml"
batch = 4
connections = ["source.frames -> log.inp", "source.rho -> log.extra"]
[blocks]
source = {{ type = "dca1000_source", path = "{capture}", n_rx = {n_rx}, lanes = 2, pattern = "{'1100' * 8}" }}
log = {{ type = "jsonl_sink", path = "frames.jsonl", max_values = 100000 }}
""", f"mimo_{n_rx}.toml"))


def test_a_four_receiver_tdm_capture_runs_through_a_graph_with_every_receiver_of_every_cycle(carav):
    (carav.workdir / "mimo.cfg").write_text(PROFILE)
    done = carav.cli("scenes", "--from-ti-cfg", "mimo.cfg", "--out", "mimo.toml")
    assert done.returncode == 0, done.stderr
    assert "activation pattern " + "1100" * 8 in done.stdout and "x 4 RX: 8 virtual elements" in done.stdout
    x = np.random.default_rng(5).integers(-2048, 2048, size=(CYCLES, N_CHIRPS, 4, N_SAMPLES, 2)).astype(np.int16)
    (carav.workdir / "adc_data.bin").write_bytes(capture_bytes(x.reshape(-1, 4, N_SAMPLES, 2), complex_data=True))
    run = carav.run(graph(carav, "adc_data.bin"))
    assert run.wait() == 0, run.stderr()
    lines = read_jsonl(carav.workdir / "frames.jsonl")
    frames = [line for line in lines if line["port"] == "inp"]
    rho = [line for line in lines if line["port"] == "extra"]
    got = {}
    for line in frames:
        data = np.asarray(line["data"], dtype=np.int16)
        assert data.shape == (line["cycles"], 4, N_CHIRPS, N_SAMPLES, 2)
        got.update({line["cycle"] + i: data[i] for i in range(line["cycles"])})
    assert sorted(got) == list(range(CYCLES))
    for c in range(CYCLES):
        np.testing.assert_array_equal(got[c], np.moveaxis(x[c], 1, 0))    # (receiver, chirp, sample, I|Q)
    pattern = np.array([int(d) for d in "1100" * 8], dtype=bool)
    assert sum(line["cycles"] for line in rho) == CYCLES
    assert all((np.asarray(line["data"], dtype=bool) == pattern).all() for line in rho)
    assert run.summary()["lost"] == 0


def test_a_capture_with_fewer_receivers_than_the_scene_is_refused_before_anything_runs(carav):
    (carav.workdir / "mimo.cfg").write_text(PROFILE)
    assert carav.cli("scenes", "--from-ti-cfg", "mimo.cfg", "--out", "mimo.toml").returncode == 0
    (carav.workdir / "adc_data.bin").write_bytes(bytes(CYCLES * N_CHIRPS * 2 * N_SAMPLES * 4))
    done = carav.cli("validate", graph(carav, "adc_data.bin", n_rx=2))
    assert done.returncode != 0
    refusal = [line for line in done.stderr.splitlines() if "contradict" in line]
    assert len(refusal) == 1 and "the capture's receivers [0, 1] (n_rx = 2) contradict the scene mimo's 4" in refusal[0]


def test_the_detector_and_gate_judge_every_cycle_of_a_four_receiver_capture_on_all_its_receivers(carav):
    """The capture's cycles through rms_detector and gate: one verdict per cycle, its Q over all four receivers'
    samples of each chirp (the combined RMS of detect(receivers=True), recomputed here from the written codes); a
    cycle whose silent chirps hold the same noise as its active ones is clean, one with a loud silent chirp on a
    single receiver is refused."""
    (carav.workdir / "mimo.cfg").write_text(PROFILE)
    assert carav.cli("scenes", "--from-ti-cfg", "mimo.cfg", "--out", "mimo.toml").returncode == 0
    x = np.random.default_rng(9).normal(0, 200, size=(CYCLES, N_CHIRPS, 4, N_SAMPLES, 2)).round().astype(np.int16)
    x[3, 2, 1] *= 8                                # cycle 3: receiver 1 of a silent chirp (the pattern's 3rd) loud
    (carav.workdir / "adc_data.bin").write_bytes(capture_bytes(x.reshape(-1, 4, N_SAMPLES, 2), complex_data=True))
    lsb = 1.0 / 2 ** 15                            # the profile's scene: full scale 1, 16 bits
    sigma = 200 * np.sqrt(2) * lsb                 # the noise RMS of a complex sample, given to the detector
    path = carav.graph(f"""
scene = "mimo.toml"
batch = 4
connections = ["source.frames -> detector.frames", "source.rho -> detector.rho", "source.frames -> gate.frames",
               "detector.verdict -> gate.verdict", "gate.alarms -> log.inp"]
[blocks]
source = {{ type = "dca1000_source", path = "adc_data.bin", n_rx = 4, lanes = 2, pattern = "{'1100' * 8}" }}
detector = {{ type = "rms_detector", sigma_n = {float(sigma)!r}, eta = 1.5 }}
gate = {{ type = "gate" }}
log = {{ type = "jsonl_sink", path = "alarms.jsonl", max_values = 0 }}
""", "mimo_judged.toml")
    run = carav.run(str(path))
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["lost"] == 0 and s["per_node"]["detector"]["cycles"] == s["per_node"]["gate"]["cycles"] == CYCLES, s
    refused = [c for line in read_jsonl(carav.workdir / "alarms.jsonl")
               for c in line.get("per_cycle", {}).get("cycle_index", [])]
    assert refused == [3]
