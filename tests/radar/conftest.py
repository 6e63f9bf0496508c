import pytest

from carav_stream.radar.scene_loader import load_scene, scene_from_dict

SMALL = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "t_adc_start_s": 0.0,
         "n_chirps": 8, "n_samples": 256, "radar_speed_kmh": 100.0,
         "targets": [{"range_m": 43.0, "velocity_kmh": 96.0, "rcs_m2": 100.0}]}


@pytest.fixture
def small_scene():
    """Factory: the Table I radar cut to 8 chirps of 256 samples (fast tests), with changes."""
    def make(**changes):
        return scene_from_dict({**SMALL, **changes}, "small.toml")
    return make


@pytest.fixture
def table1():
    return load_scene("table1")
