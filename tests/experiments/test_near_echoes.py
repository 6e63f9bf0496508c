"""`carav experiment near-echoes`: as the presets sample, the near car raises no false alarm on any detector at
either fidelity; sampled from the ramp's reset it does, at waveform fidelity, and the leak's closed form says so."""
import pytest

from carav_stream.experiments.near_echoes import RANGES_M, cell


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
@pytest.mark.parametrize("range_m", RANGES_M)
def test_as_the_preset_samples_no_detector_alarms_on_the_near_car(range_m, fidelity):
    c = cell("preset", range_m, fidelity, 150, seed=4)
    assert c["alarms"] == dict.fromkeys(c["alarms"], 0) and c["cusum_first_alarm"] is None
    assert not c["warned"] and c["leak_pf"] < 1.01e-6 and c["n_samples"] == 1080


def test_sampled_from_the_reset_the_near_car_trips_c_at_waveform_fidelity_only():
    wave, beat = (cell("from the reset", 7.0, fid, 100, seed=4) for fid in ("waveform", "beat"))
    assert wave["alarms"]["C(eta)"] >= 90 and wave["warned"] and wave["leak_pf"] > 0.5
    assert beat["alarms"]["C(eta)"] == 0 and beat["n_samples"] == 1100
