"""Scenes: presets against the paper's tables and closed forms, validation messages, warnings."""
import math

import pytest

from carav_stream.radar.scene import SceneError
from carav_stream.radar.scene_loader import load_scene, scene_from_dict

C = 299_792_458.0


def test_table1_matches_paper_table_i():
    s = load_scene("table1")
    assert (s.fc_hz, s.bandwidth_hz, s.fs_hz, s.n_chirps) == (77e9, 150e6, 150e6, 64)
    assert s.t_sweep_s == pytest.approx(7.33e-6)
    # the ADC starts 16 samples into the sweep (the IF filter settled) and keeps a fast FFT length of what is left
    assert s.t_adc_start_s == pytest.approx(16 / 150e6) and s.n_samples == 1080 == 2 ** 3 * 3 ** 3 * 5
    assert 0 <= s.t_sweep_s - (s.t_adc_start_s + s.n_samples / s.fs_hz) < 5 / s.fs_hz   # within the ramp, 4.5 short
    assert s.radar_speed_mps == pytest.approx(100 / 3.6)
    (car,) = s.targets
    assert (car.range_m, car.rcs_m2) == (43.0, 100.0)
    assert car.velocity_mps == pytest.approx(96 / 3.6)
    assert s.warnings == ()


def test_table1_car_beats_at_5_87_mhz():
    s = load_scene("table1")
    range_beat_hz = 2 * 150e6 * 43.0 / (7.33e-6 * C)           # 2 B R / (T c)
    assert range_beat_hz == pytest.approx(5.87e6, abs=0.005e6)
    doppler_hz = 2 * (100 - 96) / 3.6 / (C / 77e9)             # closing at 4 km/h
    assert s.beat_hz(s.targets[0]) == pytest.approx(range_beat_hz - doppler_hz, rel=1e-9)


def test_table1_radar_equation_gives_plus_2_2_db_snr():
    # MATLAB FMCWExample hardware; receive gain applies to echo and noise alike, so it cancels.
    lam = C / 77e9
    pr = 3.16e-3 * 10 ** 3.6 * 100 * lam ** 2 / ((4 * math.pi) ** 3 * 43.0 ** 4)
    pn = 1.380649e-23 * 290 * 150e6 * 10 ** 0.45
    assert 10 * math.log10(pr / pn) == pytest.approx(2.2, abs=0.05)
    for iq in (False, True):
        s = load_scene("table1", {"iq": iq})
        assert s.snr_db() == pytest.approx(10 * math.log10(pr / pn), abs=1e-9)


def test_snr_override_sets_sigma_n_and_replaces_noise_figure():
    s = load_scene("table1", {"snr_db": 0.0})
    assert s.snr_db() == pytest.approx(0.0, abs=1e-12)
    assert s.sigma_n ** 2 == pytest.approx(s.echo_power_w(s.targets[0]))


def test_overrides_change_chirps_and_iq():
    s = load_scene("table1", {"n_chirps": 32, "iq": True})
    assert s.n_chirps == 32 and s.iq
    assert s.t_cycle_s == pytest.approx(32 * 7.33e-6)


def test_awr1642_consistent_reading_keeps_target_in_band_but_warns_on_doppler():
    s = load_scene("awr1642")
    assert (s.n_chirps, s.n_samples, s.t_chirp_s) == (128, 256, 160e-6)
    assert 0 < s.beat_hz(s.targets[0]) < s.max_beat_hz
    assert s.range_rate_mps(s.targets[0]) == pytest.approx(-300 / 3.6)
    assert len(s.warnings) == 1 and "unambiguous" in s.warnings[0]


def test_awr1642_literal_warns_that_target_folds_to_under_a_metre():
    s = load_scene("awr1642_literal")
    assert s.slope_hz_per_s == pytest.approx(78.125e12)
    range_beat = s.slope_hz_per_s * 2 * 20.0 / C
    assert range_beat == pytest.approx(10.4e6, rel=0.01)
    beat_warning = [w for w in s.warnings if "targets[0].range_m" in w]
    assert len(beat_warning) == 1
    assert "beyond" in beat_warning[0] and "folds" in beat_warning[0]
    folded_m = float(beat_warning[0].split("appears at about ")[1].split(" m")[0])
    assert 0.6 < folded_m < 0.9
    assert any("300 km/h" in w and "unambiguous" in w for w in s.warnings)


def test_scene_error_lists_every_problem_with_location(tmp_path):
    f = tmp_path / "myscene.toml"
    f.write_text('fc_hz = 77e9\nbandwidth_hz = 150e6\nt_sweep_s = 7.33e-6\nfs_hz = 150e6\nn_chirps = 63\n'
                 'colour = "red"\n[[targets]]\nrange_m = -3\nrcs_m2 = 10\nswerling = 7\n')
    with pytest.raises(SceneError) as exc:
        load_scene(str(f))
    problems = exc.value.problems
    assert "myscene.toml: targets[0].range_m: must be > 0, got -3" in problems
    assert any(p.startswith("myscene.toml: n_chirps: must be an even number") and "63" in p for p in problems)
    assert any(p.startswith("myscene.toml: colour: unknown key") for p in problems)
    swerling = "myscene.toml: targets[0].swerling: must be one of [0, 1, 2, 3, 4], got 7"
    assert any(p.startswith(swerling) for p in problems)
    assert len(problems) == 4


def test_scene_error_names_missing_keys_and_wrong_types():
    with pytest.raises(SceneError) as exc:
        scene_from_dict({"fc_hz": "77 GHz", "bandwidth_hz": 1e6, "n_chirps": 4, "fs_hz": 1e6}, "x.toml")
    msg = str(exc.value)
    assert "x.toml: fc_hz: must be float, got str '77 GHz'" in msg
    assert "x.toml: t_sweep_s: missing (required)" in msg


def test_unknown_key_suggests_the_close_one():
    with pytest.raises(SceneError, match=r"fs_hzz: unknown key \(did you mean 'fs_hz'\?\)"):
        load_scene("table1", {"fs_hzz": 1.0})


def test_unknown_preset_lists_presets():
    with pytest.raises(SceneError, match="table1"):
        load_scene("no_such_scene")


def test_attacker_errors_are_located_in_the_scene():
    d = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 64,
         "attackers": [{"kind": "random", "rarms": -1}, {"kind": "smrt"}]}
    with pytest.raises(SceneError) as exc:
        scene_from_dict(d, "a.toml")
    assert "a.toml: attackers[0].rarms: must be >= 0, got -1" in exc.value.problems
    assert any(p.startswith("a.toml: attackers[1].kind: unknown attacker kind 'smrt' (did you mean 'smart'?)")
               for p in exc.value.problems)


def test_saturating_attacker_is_warned_about():
    d = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 64,
         "sigma_n": 1.0, "adc_full_scale": 10.0, "attackers": [{"kind": "random", "rarms": 5.0}]}
    s = scene_from_dict(d, "sat.toml")
    assert any("attackers[0]" in w and "clip" in w for w in s.warnings)
    d["attackers"][0]["rarms"] = 2.0
    assert scene_from_dict(d, "sat.toml").warnings == ()


def test_scene_is_hashable_and_equal_for_equal_content():
    assert hash(load_scene("table1")) == hash(load_scene("table1"))
    assert load_scene("table1") != load_scene("table1", {"n_chirps": 32})


def test_derived_properties_follow_closed_forms():
    s = load_scene("table1", {"iq": True})
    lam = C / 77e9
    assert s.wavelength_m == pytest.approx(lam)
    assert s.max_velocity_mps == pytest.approx(lam / (4 * 7.33e-6))
    assert s.max_range_m == pytest.approx(150e6 * C / (2 * s.slope_hz_per_s))   # complex: fs
    assert load_scene("table1").max_range_m == pytest.approx(s.max_range_m / 2)  # real: fs / 2
    assert s.range_resolution_m == pytest.approx(C / (2 * s.slope_hz_per_s * 1080 / 150e6))


def test_located_overrides_change_one_target_or_attacker():
    s = load_scene("table1", {"targets[0].range_m": 60.0, "targets[0].velocity_kmh": None})
    assert s.targets[0].range_m == 60.0 and s.targets[0].velocity_mps == 0.0
    assert load_scene("table1").targets[0].range_m == 43.0          # the preset is untouched
    with pytest.raises(SceneError, match=r"override targets\[3\].range_m: the scene has 1 targets"):
        load_scene("table1", {"targets[3].range_m": 1.0})


def test_interferer_sweeping_beyond_the_waveform_grid_is_warned_about():
    d = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 8,
         "attackers": [{"kind": "secondary_antenna", "slope_hz_per_s": 200e12}]}
    (w,) = scene_from_dict(d, "i.toml").warnings
    assert w.startswith("i.toml: attackers[0]: its mixer product sweeps up to") and "waveform_oversample" in w
    d["attackers"][0]["slope_hz_per_s"] = 25e12                  # 5 MHz/us off: 33 MHz, inside +-300 MHz
    assert scene_from_dict(d, "i.toml").warnings == ()


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from carav_stream.radar.scene_loader import SCENE_PARAMS, TARGET_PARAMS  # noqa: E402

BASE = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 8,
        "targets": [{"range_m": 43.0, "rcs_m2": 10.0}]}
BAD = st.sampled_from(["x", -1, 0, True, float("nan"), float("inf"), [1], {"a": 1}, -1e300])


@settings(max_examples=50, deadline=None)
@given(key=st.sampled_from(sorted(p.name for p in SCENE_PARAMS)), value=BAD)
def test_any_bad_radar_value_gives_a_scene_error_or_a_scene(key, value):
    try:
        scene_from_dict({**BASE, key: value}, "b.toml")
    except SceneError as exc:
        assert all(p.startswith("b.toml: ") for p in exc.problems)


@settings(max_examples=50, deadline=None)
@given(key=st.sampled_from(sorted(p.name for p in TARGET_PARAMS)), value=BAD)
def test_any_bad_target_value_gives_a_located_scene_error_or_a_scene(key, value):
    try:
        scene_from_dict({**BASE, "targets": [{"range_m": 43.0, key: value}]}, "b.toml")
    except SceneError as exc:
        assert any(p.startswith("b.toml: targets[0].") for p in exc.problems)


# Table I written as MATLAB's example writes it: no ADC start, no sample count
MATLAB = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 64,
          "radar_speed_kmh": 100.0, "targets": [{"range_m": 7.0, "velocity_kmh": 96.0, "rcs_m2": 100.0}]}


def test_a_scene_that_does_not_say_when_its_adc_starts_starts_once_the_if_filter_has_settled():
    s = scene_from_dict(MATLAB, "matlab.toml")
    assert s.t_adc_start_s == pytest.approx(16 / 150e6) and s.adc_start_default
    assert s.n_samples == round((7.33e-6 - 16 / 150e6) * 150e6) == 1084            # what is left of the ramp
    assert s.t_adc_start_s == load_scene("table1").t_adc_start_s                       # the preset's own reasoning


def test_a_scene_that_says_zero_samples_from_the_ramps_reset():
    s = scene_from_dict({**MATLAB, "t_adc_start_s": 0.0}, "reset.toml")
    assert s.t_adc_start_s == 0.0 and not s.adc_start_default and s.n_samples == 1100


def test_a_sample_count_the_default_start_cannot_hold_is_refused_naming_the_default():
    with pytest.raises(SceneError) as exc:
        scene_from_dict({**MATLAB, "n_samples": 1100}, "matlab.toml")
    (problem,) = exc.value.problems
    assert problem.startswith("matlab.toml: n_samples: 1100 samples at 1.5e+08 Hz from t_adc_start_s = 1.06667e-07 s "
                              "(not given: the default, 16 samples in") and "t_adc_start_s = 0 samples from" in problem
