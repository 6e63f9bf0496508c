"""The attacker's direction through the blocks (rms_detector -> gate -> run_summary) on frames of the radar chain:
awr1642_mimo (2 TX x 4 RX, I-only codes, the car at 20 m and 20 degrees) under the graph's secondary antenna at 30
degrees (10 mW at 30 m: RARMS about 3), and a ghost planted at the car's range from another azimuth with a detector
threshold CARAV cannot reach (so the gate passes every cycle): its detection is flagged by azimuth alone."""
import numpy as np
import pytest

from carav_blocks.gate import ATTACKER_FIELDS, Gate
from carav_blocks.rms_detector import RmsDetector
from carav_blocks.run_summary import RunSummary
from carav_stream.cli.run import _radar_lines
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of, seed_streams
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from carav_stream.testing.harness import wire
from tests.blocks import jig
from tests.blocks.helpers import SCENE as ONE_RX

SCENE = "awr1642_mimo"
N, START = 24, 8


def chain(model: str, azimuth_deg: float, fidelity: str, seed: int, **params):
    """(frames Frame of int16 codes, rho Frame, attack_active): N cycles, the attacker on from cycle START."""
    scene = scene_of(SCENE)
    streams = seed_streams(seed)
    rho = streams.activation.next(N, scene.n_chirps, scene.n_slots)
    attacker = make_attacker(model, scene, azimuth_deg=azimuth_deg, start_cycle=START, **params)
    c = simulate_cycles(scene, rho, streams.noise, attacker=attacker, rng_attack=streams.attack, fidelity=fidelity)
    frames = Frame.of(c.codes, cycles=N, per_cycle={"attack_active": c.attack_active.tolist()})
    return wire(frames, 0), wire(Frame.of(rho, cycles=N), 0), c.attack_active


@pytest.mark.slow
def test_the_secondary_antenna_is_found_at_30_degrees_on_every_attacked_cycle_and_nowhere_on_clean_ones():
    frames, rho, attacked = chain("secondary_antenna", 30.0, "waveform", seed=21, range_m=30.0, tx_power_w=1e-2)
    assert attacked.tolist() == [False] * START + [True] * (N - START)
    verdict = wire(RmsDetector(scene=SCENE, eta=1.5).process(frames, rho), 0)
    per = verdict.header["per_cycle"]
    az, reason = np.array(per["attack_azimuth_deg"]), np.array(per["attack_reason"])
    assert (reason[attacked] == "estimated").all() and np.abs(az[attacked] - 30.0).max() < 2.0
    assert abs(np.median(az[attacked]) - 30.0) < 2.0
    assert (reason[~attacked] == "no_attack").all() and np.isnan(az[~attacked]).all()
    assert np.isnan(np.array(per["attack_azimuth_std_deg"])[~attacked]).all()
    # the gate carries the columns on: the refused cycles' (the attack raises alarms) to the run summary
    out = Gate().process(frames, verdict)
    alarms = out["alarms"].header["per_cycle"]
    assert alarms["attack_azimuth_deg"] == [per["attack_azimuth_deg"][i] for i in alarms["cycle_index"]]
    summary = RunSummary(scene=SCENE)
    summary.start()
    summary.process(None, wire(out["alarms"], 0))
    d = summary.run_figures()["attacker_direction"]
    assert d["attacked_cycles_with_azimuth"] == N - START and abs(d["median_azimuth_deg"] - 30.0) < 2.0
    assert d["cycles_by_reason"]["attacked"] == {"estimated": N - START}
    assert any("attacker's azimuth on 16 attacked cycles: median 30" in line for line in
               _radar_lines({**summary.run_figures(), "cycles": N}))


@pytest.mark.slow
def test_a_ghost_at_the_cars_range_that_carav_passes_is_flagged_by_its_azimuth():
    scene = scene_of(SCENE)
    car = scene.targets[0]
    ghost_deg = -15.0
    frames, rho, attacked = chain("ghost", ghost_deg, "beat", seed=5, range_m=car.range_m, rarms=3.0)
    # a threshold CARAV never reaches: every cycle passes the gate, the ghost's with it
    verdict = wire(RmsDetector(scene=SCENE, eta=1e9).process(frames, rho), 0)
    per = verdict.header["per_cycle"]
    assert not any(per["alarm"])
    az = np.array(per["attack_azimuth_deg"])
    assert np.abs(az[attacked] - ghost_deg).max() < 2.0 and np.isnan(az[~attacked]).all()
    out = Gate().process(frames, verdict)
    assert "alarms" not in out
    clean = out["clean"].header["per_cycle"]
    assert all(clean[k] == per[k] for k in ATTACKER_FIELDS)
    # what an angle-resolving ranging reports at the car's range: the car at its azimuth and, where the ghost is
    # on, a detection from the ghost's (built here from the truth: ranging's azimuths are its own block's matter)
    detections = [[car.azimuth_deg, ghost_deg + 0.4] if a else [car.azimuth_deg] for a in attacked]
    est = Frame.of(None, cycles=N, per_cycle={**clean, "range_m": [[car.range_m] * len(d) for d in detections],
                                              "azimuth_deg": detections,
                                              "azimuth_std_deg": [[0.5] * len(d) for d in detections]})
    summary = RunSummary(scene=SCENE)
    summary.start()
    summary.process(wire(est, 0), None)
    flags = summary.run_figures()["attacker_direction"]["flagged_detections"]
    assert flags["attacked"] == {"compared": 2 * (N - START), "flagged": N - START, "cycles_flagged": N - START}
    assert flags["clean"] == {"compared": 0, "flagged": 0, "cycles_flagged": 0}
    assert summary.run_figures()["detected"] == 0          # CARAV saw nothing; the azimuth flag did
    shifted = Frame.of(None, cycles=N, per_cycle={**clean, "azimuth_deg": [[ghost_deg + 8.0]] * N})
    other = RunSummary(scene=SCENE)
    other.start()
    other.process(wire(shifted, 0), None)
    assert other.run_figures()["attacker_direction"]["flagged_detections"]["attacked"]["flagged"] == 0


def test_a_one_receiver_scenes_verdict_has_no_attacker_columns_and_the_gate_adds_none():
    vector = jig.vectors("rms_detector")["attacks"]
    frames = wire(Frame.of(vector["inputs"]["frames"], cycles=3), 0)
    rho = wire(Frame.of(vector["inputs"]["rho"], cycles=3), 0)
    verdict = RmsDetector(scene=ONE_RX, eta=1.5).process(frames, rho)
    assert set(verdict.header["per_cycle"]) == {"q", "c", "alarm", "invalid", "raised_by", "k_max", "rbar"}
    out = Gate().process(frames, wire(verdict, 0))
    assert not set(ATTACKER_FIELDS) & set(out["alarms"].header["per_cycle"])
