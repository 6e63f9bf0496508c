"""Scenes with antenna arrays: layouts, virtual array, TDM velocity, and their validation."""
import numpy as np
import pytest

from carav_stream.core.units import C_MPS
from carav_stream.radar.scene import SceneError
from carav_stream.radar.scene_loader import load_scene


def test_single_antenna_scene_has_no_array_and_keeps_the_three_axis_frame():
    s = load_scene("table1")
    assert (s.n_rx, s.n_tx, s.n_slots, s.has_array) == (1, 1, 1, False)
    assert s.frame_shape(5) == (5, 64, 1080)
    assert s.max_velocity_mps == C_MPS / s.fc_hz / (4 * s.t_chirp_s)


def test_awr1642_layout_is_a_filled_eight_element_virtual_ula_and_halves_the_unambiguous_velocity():
    one = load_scene("awr1642")
    s = load_scene("awr1642_mimo")
    assert (s.n_rx, s.n_tx, s.n_slots, s.n_loops) == (4, 2, 2, 64)
    np.testing.assert_array_equal(s.virtual_positions_wl, np.arange(8) * 0.5)
    assert s.frame_shape(3) == (3, 4, 128, 256)
    assert s.max_velocity_mps == pytest.approx(one.max_velocity_mps / 2, rel=1e-12)
    assert s.targets[0].azimuth_deg == 20.0
    assert abs(s.range_rate_mps(s.targets[0])) < s.max_velocity_mps


def test_ula_from_counts_and_awr1243_with_shared_positions():
    s = load_scene("table1", {"n_rx": 3, "n_tx": 2})
    np.testing.assert_array_equal(s.virtual_positions_wl, np.arange(6) * 0.5)
    a = load_scene("table1", {"array": "awr1243", "n_chirps": 66})
    v = a.virtual_positions_wl
    assert v.size == 12 and np.unique(v).size == 8
    assert a.max_velocity_mps == pytest.approx(C_MPS / a.fc_hz / (4 * 3 * a.t_chirp_s))


def test_explicit_positions_and_schedule_override_the_layout():
    s = load_scene("table1", {"rx_positions_wl": [0, 0.5, 2.0], "tx_positions_wl": [0, 3.0],
                              "tdm_schedule": [1, 0]})
    np.testing.assert_array_equal(s.virtual_positions_wl, [3.0, 3.5, 5.0, 0.0, 0.5, 2.0])


@pytest.mark.parametrize("overrides, where", [
    ({"n_tx": 3}, "n_chirps"),                                     # 64 chirps are not whole loops of 3
    ({"n_tx": 2, "n_chirps": 6}, "n_chirps"),                      # 3 loops: odd, the activation cannot balance
    ({"array": "awr1642", "n_rx": 8}, "n_rx"),
    ({"tdm_schedule": [0, 2]}, "tdm_schedule"),
    ({"rx_positions_wl": [0, float("nan")]}, "rx_positions_wl"),
    ({"rx_positions_wl": []}, "rx_positions_wl"),
    ({"array": "upa"}, "array"),
    ({"targets[0].azimuth_deg": 95.0}, "targets[0].azimuth_deg"),
])
def test_bad_array_keys_are_refused_and_located(overrides, where):
    with pytest.raises(SceneError) as err:
        load_scene("table1", overrides)
    assert any(f"table1.toml: {where}:" in p for p in err.value.problems), err.value.problems


def test_attacker_azimuth_is_the_scenes_not_the_models():
    s = load_scene("table1", {"attackers": [{"kind": "random", "rarms": 2, "azimuth_deg": -30.0}]})
    assert s.attackers[0].azimuth_deg == -30.0
    assert dict(s.attackers[0].params) == {"rarms": 2}
    with pytest.raises(SceneError) as err:
        load_scene("table1", {"attackers": [{"kind": "random", "azimuth_deg": 120}]})
    assert any("attackers[0].azimuth_deg" in p for p in err.value.problems)


def test_tdm_velocity_warning_names_the_transmitters_repetition():
    s = load_scene("awr1642_mimo", {"targets[0].velocity_kmh": 60.0})
    text = " ".join(s.warnings)
    assert "2 TDM slots x 160 us = 320 us" in text and "+-3.04 m/s" in text
