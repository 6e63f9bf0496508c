"""Geometry: duck-typed construction, conversions against the FMCW closed forms, error messages."""
import dataclasses
import types

import numpy as np
import pytest

from carav_stream.core.units import C_MPS
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.matlab_reference import fmcw_example_geometry as table1_geometry


def _scene(**over):
    d = dict(fs_hz=150e6, slope_hz_per_s=2e13, fc_hz=77e9, t_chirp_s=7.33e-6, n_samples=1100, iq=False,
             n_chirps=64, sigma_n=1.0)
    d.update(over)
    return types.SimpleNamespace(**d)


def test_geometry_from_scene_reads_attributes_by_name():
    g = Geometry.from_scene(_scene())
    assert (g.fs_hz, g.slope_hz_per_s, g.fc_hz, g.t_chirp_s, g.n_samples, g.iq) == \
        (150e6, 2e13, 77e9, 7.33e-6, 1100, False)


def test_geometry_from_scene_names_missing_attribute():
    s = _scene()
    del s.fc_hz
    with pytest.raises(TypeError, match="fc_hz"):
        Geometry.from_scene(s)


@pytest.mark.parametrize("field,value", [("fs_hz", 0.0), ("slope_hz_per_s", -1.0), ("t_chirp_s", np.nan),
                                         ("n_samples", 2)])
def test_geometry_rejects_bad_field_naming_it(field, value):
    kw = dict(fs_hz=1e6, slope_hz_per_s=1e12, fc_hz=77e9, t_chirp_s=1e-5, n_samples=64, iq=True)
    kw[field] = value
    with pytest.raises(ValueError, match=field):
        Geometry(**kw)


def test_table1_range_doppler_coupling_is_minus_4_mm():
    # MATLAB's FMCWExample: the 1.111 m/s closing speed shows up as -0.004 m in the beat-only range
    g = table1_geometry()
    v = -(100 - 96) / 3.6
    beat = g.beat_from_range(43.0, v)
    assert C_MPS * beat / (2 * g.slope_hz_per_s) - 43.0 == pytest.approx(-0.0042, abs=2e-4)
    assert g.range_from_beat(beat, v) == pytest.approx(43.0, abs=1e-9)
    assert g.range_resolution_m == pytest.approx(1.0, rel=0.01)


def test_velocity_conversion_matches_phase_progression_closed_form():
    g = table1_geometry()
    v = 3.0
    # phase progression 4 pi v T / lambda per chirp, in cycles: 2 v T / lambda
    assert g.slow_freq_from_velocity(v) == pytest.approx(2 * v * g.t_chirp_s * g.fc_hz / C_MPS)
    assert g.velocity_from_slow_freq(g.slow_freq_from_velocity(v)) == pytest.approx(v)
    assert g.max_velocity_mps == pytest.approx(C_MPS / g.fc_hz / (4 * g.t_chirp_s))


def test_geometry_matches_radar_scene_when_available():
    import carav_stream.radar.scene_loader as scene_mod
    sc = scene_mod.load_scene("table1")
    g = Geometry.from_scene(sc)
    assert g.wavelength_m == pytest.approx(sc.wavelength_m)
    assert g.range_resolution_m == pytest.approx(sc.range_resolution_m)
    assert g.beat_from_range(sc.targets[0].range_m, sc.range_rate_mps(sc.targets[0])) == \
        pytest.approx(sc.beat_hz(sc.targets[0]), rel=1e-9)


def test_the_echo_onset_is_the_first_sample_after_the_round_trip():
    from carav_stream.radar.scene_loader import load_scene
    base = load_scene("table1")
    car = base.targets[0].range_m                      # 43 m: a round trip of 43.03 samples at 150 MHz
    for start, onset in ((0, 44), (16, 28), (50, 0)):
        g = dataclasses.replace(Geometry.from_scene(base), t_adc_start_s=start / base.fs_hz)
        assert g.echo_onset(car) == onset
    assert Geometry.from_scene(base).echo_onset(1e9) == base.n_samples     # never past the window


def test_the_doppler_scale_is_where_it_is_read_and_conversions_invert():
    g = Geometry(fs_hz=10e6, slope_hz_per_s=12.5e12, fc_hz=77e9, t_chirp_s=160e-6, n_samples=256,
                 t_adc_start_s=7e-6)
    assert g.doppler_scale_at(0.0) == g.doppler_scale
    # read at the window's middle, 12.75 us later, and for an echo 0.133 us late: 1 + S (7 + 12.75 - 0.133) us / fc
    assert g.doppler_scale_at(127.5, 0.133e-6) == pytest.approx(1 + 12.5e12 * 19.617e-6 / 77e9, rel=1e-12)
    nu = g.slow_freq_from_velocity(-1.94, sample=127.5, delay_s=0.133e-6)
    assert g.velocity_from_slow_freq(nu, sample=127.5, delay_s=0.133e-6) == pytest.approx(-1.94, rel=1e-12)
    # read as if at the first sample, no delay: 2.0e-3 too fast
    assert g.velocity_from_slow_freq(nu) == pytest.approx(-1.94 * g.doppler_scale_at(127.5, 0.133e-6)
                                                          / g.doppler_scale, rel=1e-12)
    assert g.doppler_scale_at(127.5, 0.133e-6) / g.doppler_scale == pytest.approx(1.0020, abs=1e-4)
