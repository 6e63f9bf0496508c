"""range_estimator on an antenna array: every target's azimuth per cycle, from its cell over the whole virtual array
(carav_stream/estimate/target_azimuth.py), beside range and velocity; with a CFAR list one azimuth per detection; a
one-receiver scene's records carry no azimuth."""
import numpy as np
import pytest

from carav_blocks.range_estimator import RangeEstimator
from carav_stream.estimate.target_azimuth import target_azimuths
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.adc import adc_codes, from_codes
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire

SCENE = "awr1642_mimo"       # the car at 20 m and 20 degrees


def _clean(scene, n, seed):
    rng = np.random.default_rng(seed)
    rho = balanced_rows(rng, n, scene.n_chirps, scene.n_slots)
    codes, _, _ = adc_codes(scene, simulate_cycles(scene, rho, rng, fidelity="beat").frames)
    frame = Frame.of(codes, cycles=n, verdict="clean", per_cycle={"attack_active": [False] * n})
    return rho, codes, frame.derive(keep_data=True, arrays={"rho": rho})


def test_each_cycle_reports_the_cars_azimuth_and_its_bound():
    scene = load_scene(SCENE)
    rho, codes, frame = _clean(scene, 4, seed=5)
    block = RangeEstimator(scene=SCENE, method="ml")
    block.start()
    per = block.process(wire(frame, 0)).header["per_cycle"]
    azimuth, std = np.array(per["azimuth_deg"]), np.array(per["azimuth_std_deg"])
    assert azimuth.shape == std.shape == (4, 1)
    want, want_std = target_azimuths(from_codes(scene, codes), rho, scene, np.array(per["range_m"]),
                                     np.array(per["velocity_mps"]))
    np.testing.assert_array_equal(azimuth, want)
    np.testing.assert_array_equal(std, want_std)
    # 27 dB per sample over 256 samples, 32 loops and 8 channels: a bound of about 1.4e-3 degrees
    assert np.all((std > 5e-4) & (std < 5e-3))
    assert np.all(np.abs(azimuth - 20.0) < 6 * std)


@pytest.mark.parametrize("azimuth_deg", [-35.0, 0.0])
def test_the_cfar_list_gives_every_detection_its_azimuth(azimuth_deg):
    scene = load_scene(SCENE, {"targets[0].azimuth_deg": azimuth_deg})
    _, _, frame = _clean(scene, 3, seed=6)
    block = RangeEstimator(scene=SCENE, detection="ca_cfar", pfa=1e-6)
    block.scene_obj = scene          # the preset's car turned to azimuth_deg
    block.start()
    per = block.process(wire(frame, 0)).header["per_cycle"]
    for ranges, azimuths, stds in zip(per["range_m"], per["azimuth_deg"], per["azimuth_std_deg"]):
        assert len(ranges) == len(azimuths) == len(stds) >= 1
        assert abs(ranges[0] - 20.0) < 0.1 and abs(azimuths[0] - azimuth_deg) < 0.05


def test_a_one_receiver_scene_reports_no_azimuth():
    scene = load_scene("awr1642")
    _, _, frame = _clean(scene, 2, seed=7)
    block = RangeEstimator(scene="awr1642", method="ml")
    block.start()
    per = block.process(wire(frame, 0)).header["per_cycle"]
    assert "azimuth_deg" not in per and "azimuth_std_deg" not in per and len(per["range_m"]) == 2
