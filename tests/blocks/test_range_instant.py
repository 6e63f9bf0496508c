"""The instant a cycle's range estimate refers to: the chain moves the target during the cycle, the estimator says
at which instant its range holds (range_time_s), and the run summary scores the range against the target there.

Checked on the chain at both fidelities, with one receiver and with the 2 TX x 4 RX array, with and without
migration compensation: against the truth at range_time_s the mean error is within a millimetre; against the truth
at the cycle's start (what the summary scored before) it is off by the walk, tens of millimetres."""
import numpy as np
import pytest

from carav_blocks.range_estimator import RangeEstimator
from carav_blocks.run_summary import RunSummary
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.virtual_element import range_instant_s
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.adc import adc_codes
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire


def test_the_instant_is_the_active_chirps_mean_start_plus_twice_the_fast_time_centre():
    g = Geometry(fs_hz=10e6, slope_hz_per_s=1e13, fc_hz=77e9, t_chirp_s=100e-6, n_samples=11, t_adc_start_s=2e-6)
    rho = np.zeros((3, 8), bool)
    rho[0, :4] = True                   # chirps 0..3: mean start 1.5 chirps
    rho[1, ::2] = True                  # 0, 2, 4, 6: 3 chirps
    rho[2, 7] = True
    centre = 2 * (2e-6 + 10 / (2 * 10e6))
    np.testing.assert_allclose(range_instant_s(rho, g), centre + np.array([1.5, 3.0, 7.0]) * 100e-6, rtol=1e-12)
    np.testing.assert_array_equal(range_instant_s(rho, g, migration=True), np.full(3, centre))
    assert range_instant_s(np.zeros((1, 8), bool), g)[0] == centre


def _estimates(scene_name: str, overrides: dict, fidelity: str, max_speed_mps: float, n: int = 6):
    scene = load_scene(scene_name, overrides)
    rng = np.random.default_rng(11)
    rho = balanced_rows(rng, n, scene.n_chirps, scene.n_slots)
    codes, _, _ = adc_codes(scene, simulate_cycles(scene, rho, rng, fidelity=fidelity).frames)
    frame = Frame.of(codes, cycles=n, verdict="clean", per_cycle={"attack_active": [False] * n,
                                                                   "cycle_index": list(range(n))})
    block = RangeEstimator(scene=scene_name, method="ml", max_speed_mps=max_speed_mps)
    block.scene_obj = scene
    block.check_params()
    block.start()
    out = block.process(wire(frame.derive(keep_data=True, arrays={"rho": rho}), 0))
    return scene, out


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
@pytest.mark.parametrize("scene_name,range_rate,max_speed", [
    ("awr1642_mimo", -2.5, 0.0),         # 8 virtual channels, the reference element's loops 320 us apart
    ("awr1642", 5.0, 0.0),               # one receiver, a receding car
    ("awr1642", -83.3, 90.0),            # the preset's car, 3.6 cells of walk: migration-compensated
])
def test_the_range_holds_at_the_reported_instant_and_the_summary_scores_it_there(
        fidelity, scene_name, range_rate, max_speed):
    radar = load_scene(scene_name).radar_speed_mps
    scene, out = _estimates(scene_name, {"targets[0].velocity_kmh": (radar + range_rate) * 3.6}, fidelity,
                             max_speed)
    per = out.header["per_cycle"]
    r0, v = scene.targets[0].range_m, scene.range_rate_mps(scene.targets[0])
    ranges, instants = np.array([r[0] for r in per["range_m"]]), np.array(per["range_time_s"])
    at_instant, at_start = ranges - (r0 + v * instants), ranges - r0
    assert abs(at_instant.mean()) < 1e-3, at_instant
    # the walk to the cycle's middle: what scoring at the cycle's start would have called an error
    walk = abs(v) * scene.n_chirps * scene.t_chirp_s / 2
    if max_speed == 0.0:
        assert walk > 0.02 and abs(at_start.mean()) > walk / 2, (at_start, walk)

    summary = RunSummary(scene=scene_name)
    summary.check_params = lambda: None
    summary.scene_obj = scene
    summary.true_range_m, summary.true_velocity_mps, summary.true_azimuth_deg = r0, v, None
    summary.start()
    summary.process(wire(out, 1), None)
    err = summary.summary()["run"]["range_error_m"]
    assert err["n"] == len(ranges) and err["mean"] == pytest.approx(at_instant.mean(), abs=1e-12)
