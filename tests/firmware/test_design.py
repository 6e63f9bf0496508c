"""Thresholds per scene (carav_stream.firmware.design, `carav design`): closed forms checked against scipy's
chi-square directly and against the full sample chain (ADC included) by Monte Carlo."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.detect.stats import clopper_pearson, pf_pm_closed_form
from carav_stream.firmware.design import SceneLaw, pf_per_cycle, rms_threshold, scene_law, threshold_warning
from carav_stream.montecarlo.engine import simulate_q
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.scene_loader import load_scene


def test_pf_of_eta_1_5_on_a_short_chirp_scene_is_the_chi_square_tail_of_its_silent_chirps():
    """256 chirps of 32 I-only samples: eta = 1.5 is not a safe threshold there (PF ~ 8e-3 per cycle)."""
    law = scene_law(load_scene("table1", {"n_chirps": 256, "n_samples": 32}))
    scale = law.sigma_n / law.sigma_eff           # the ADC's quantisation noise (tiny, but in the law)
    d0 = 1 - stats.chi2.cdf(32 * (1.5 * scale) ** 2, 32) ** 128
    assert pf_per_cycle(law, 1.5) == pytest.approx(d0, rel=1e-3)
    assert 7e-3 < d0 < 9e-3


@pytest.mark.parametrize("preset", ["table1", "awr1642"])
def test_the_designed_eta_gives_the_target_pf_by_the_chi_square_law(preset):
    law = scene_law(load_scene(preset))
    for pf in (1e-2, 1e-6, 1e-9):
        eta = rms_threshold(law, pf) * law.sigma_n / law.sigma_eff
        m = law.n_chirps // 2
        d0 = -np.expm1(m * stats.chi2.logcdf(law.dof * eta ** 2, law.dof))     # D1 adds nothing at these etas
        assert d0 == pytest.approx(pf, rel=1e-6)


def test_the_designed_eta_holds_its_pf_on_the_full_sample_chain():
    """Samples, 12-bit ADC, the echo: the detector's false alarms at the designed eta match the design."""
    scene = load_scene("table1", {"n_chirps": 32, "n_samples": 24})
    law = scene_law(scene)
    pf = 0.02
    eta = rms_threshold(law, pf)
    n = 20000
    q = simulate_q(RadarSource(scene), "none", 0.0, n, np.random.SeedSequence(5), method="samples").q
    k = int(np.sum(q >= eta))
    lo, hi = clopper_pearson(k, n, 0.999)
    assert lo <= pf <= hi, (k, n, eta)


def test_threshold_warning_only_above_one_in_a_million():
    law = scene_law(load_scene("table1"))
    assert threshold_warning(law, 1.5) is None
    text = threshold_warning(law, 1.05, who="rms_detector", design_hint="carav design --preset table1")
    designed = f"{rms_threshold(law, 1e-6):.4g}"            # 1.118 for table1's 64 x 1080 samples
    assert text.startswith("rms_detector eta = 1.05 raises false alarms on") and f"eta = {designed} for 1e-06" in text


def test_design_command_prints_and_writes_every_threshold(tmp_path, capsys):
    out = tmp_path / "d.json"
    assert carav(["design", "--preset", "awr1642", "--rarms", "1,3", "--trials", "300", "--seed", "2",
                  "--json", str(out)]) == Exit.OK
    text = capsys.readouterr().out
    d = json.loads(out.read_text())
    assert f"eta = {d['rms_detector']['eta']:.4f}" in text
    assert d["rms_detector"]["pf_at_eta"] == pytest.approx(1e-6, rel=1e-6)
    assert d["spectral_silent_test"]["bins_tested"] == 64 * 127
    assert [row["rarms"] for row in d["misses"]] == [1.0, 3.0]
    # RARMS 3 is caught at both thresholds; the smart attack at RARMS 1 is missed more at 1.5 than at the design eta
    assert d["misses"][1]["paper"]["smart"] == 0 and d["misses"][1]["design"]["random"] < 1e-12
    assert d["misses"][0]["paper"]["smart"] > d["misses"][0]["design"]["smart"]
    # the weakest ghost each detector catches: printed, and the integrated test sees fainter ghosts than C
    w = d["ghost"]["weakest_caught"]
    assert set(w) == {"C(eta)", "spectral", "integrated", "coherent"} and f"integrated {w['integrated']:g}" in text
    assert w["integrated"] is not None and (w["C(eta)"] is None or w["integrated"] < w["C(eta)"])


def test_design_refuses_a_pf_outside_0_1_and_an_unknown_scene(capsys):
    assert carav(["design", "--pf", "2"]) == Exit.USAGE
    assert "--pf: must be in (0, 1)" in capsys.readouterr().err
    assert carav(["design", "--scene", "/nonexistent.toml"]) == Exit.INVALID
    assert "/nonexistent.toml" in capsys.readouterr().err


def test_validate_and_sweep_warn_when_eta_is_loose_for_the_scene(capsys):
    from pathlib import Path

    graph = str(Path(__file__).resolve().parents[2] / "graphs" / "table1_random.toml")
    assert carav(["validate", graph, "--set", "detector.eta=1.05"]) == Exit.OK
    err = capsys.readouterr().err
    assert err.count("rms_detector eta = 1.05 raises false alarms") == 1
    designed = rms_threshold(scene_law(load_scene("table1")), 1e-6)
    assert f"`carav design --preset table1` gives eta = {designed:.4g}" in err
    assert carav(["validate", graph]) == Exit.OK
    assert "warning" not in capsys.readouterr().err
    assert carav(["sweep", "--nr", "256", "--ns", "32", "--rarms", "1", "--trials", "20", "--quiet"]) == Exit.OK
    assert "the paper's eta = 1.5 raises false alarms on 0.0083" in capsys.readouterr().err


@pytest.mark.slow
def test_design_checks_the_scenes_own_benign_cycles_and_warns_when_a_near_echo_sets_the_false_alarm_rate(
        tmp_path, capsys):
    """The table1 car at 7 m, sampled from the ramp's reset: the closed form sees noise and the beat fidelity's
    echo, so at beat fidelity the benign cycles raise no alarm at the designed eta; at waveform fidelity the echo's
    smeared edge in the silent slots does, and the design says so instead of printing a threshold that does not
    hold."""
    scene = str(Path(__file__).parents[2] / "examples" / "table1_car_7m.toml")
    found = {}
    for fidelity in ("beat", "waveform"):
        out = tmp_path / f"{fidelity}.json"
        assert carav(["design", "--scene", scene, "--fidelity", fidelity, "--benign-trials", "60", "--rarms", "3",
                      "--trials", "20", "--seed", "4", "--json", str(out)]) == Exit.OK
        found[fidelity] = (json.loads(out.read_text()), capsys.readouterr().out)
    beat, text = found["beat"]
    assert beat["benign"]["design"]["alarms"] == 0 and not beat["benign"]["above_design"]
    assert "WARNING: the scene's own echo" not in text
    # the leak's closed form looks at both fidelities whichever one simulates: the radar has the IF filter
    assert "WARNING: that leak, not the noise, sets the false-alarm rate" in text and beat["leaks"][0]["pf"] > 0.5
    wave, text = found["waveform"]
    assert wave["scene"]["fidelity"] == "waveform" and wave["benign"]["design"]["alarms"] >= 10
    assert wave["benign"]["above_design"] and "WARNING: the scene's own echo raises false alarms" in text
    assert wave["rms_detector"]["eta"] == beat["rms_detector"]["eta"]          # the closed form is the same


def _near_car(range_m: float, **over):
    """The table1 car moved close: its echo lifts the 12-bit ADC's full scale until a step exceeds the noise."""
    return load_scene("table1", {"targets[0].range_m": range_m, **over})


@pytest.mark.parametrize("range_m, over", [(3.0, {}), (4.0, {}), (3.0, {"iq": True})])
def test_where_the_adc_step_exceeds_the_noise_the_design_is_what_the_chain_measures(range_m, over):
    # the table1 car at 3 m: lsb = 4.1 sigma_n, most silent samples quantise to 0 and the silent RMS falls below
    # sigma_n; the chain's false alarms at thresholds between two of the law's steps are the design's
    scene = _near_car(range_m, **over)
    law = scene_law(scene)
    assert law.steps() < 0.65
    lsb = scene.adc_full_scale / 2 ** (scene.adc_bits - 1)
    s = scene.n_samples * (rms_threshold(law, 0.1) * scene.sigma_n / lsb) ** 2
    etas = [lsb / scene.sigma_n * np.sqrt((np.floor(s) + d + 0.5) / scene.n_samples) for d in (-2, 0, 2)]
    n = 600
    q = simulate_q(RadarSource(scene), "none", 0.0, n, np.random.SeedSequence(9), method="samples").q
    for eta in etas:
        pf = float(pf_per_cycle(law, eta))
        assert 0.01 < pf < 0.9
        assert stats.binomtest(int(np.sum(q >= eta)), n, pf).pvalue > 1e-3, (eta, pf)


def test_the_paper_eta_is_quiet_for_the_car_at_3_m_and_the_design_eta_holds_its_pf():
    law = scene_law(_near_car(3.0))
    assert pf_per_cycle(law, 1.5) < 1e-30                   # not 1: the noise quantises below sigma_n
    eta = rms_threshold(law, 1e-6)
    assert 1.1 < eta < 1.2 and pf_per_cycle(law, eta) <= 1e-6


def _laws(steps: float) -> tuple[SceneLaw, SceneLaw]:
    """table1's law with an ADC step of sigma_n / steps: as the design takes it, and with the uniform model only."""
    base = scene_law(load_scene("table1"))
    lsb = base.sigma_n / steps
    sigma_eff = float(np.sqrt(base.sigma_n ** 2 + lsb ** 2 / 12))
    law = SceneLaw(base.name, base.n_chirps, base.dof, base.snr, base.sigma_n, sigma_eff, lsb, False)
    return law, SceneLaw(base.name, base.n_chirps, base.dof, base.snr, base.sigma_n, sigma_eff)


def test_the_quantised_law_meets_the_uniform_one_where_it_takes_over():
    # just above and below sigma_c = 0.65 lsb (design.QUANTISED_BELOW) the two laws' thresholds agree within 0.1 %;
    # at 0.5 lsb the uniform model's is 0.6 % off
    assert rms_threshold(_laws(0.6499)[0], 1e-6) == pytest.approx(rms_threshold(_laws(0.6501)[0], 1e-6), rel=1e-3)
    quantised, uniform = _laws(0.5)
    assert rms_threshold(uniform, 1e-6) / rms_threshold(quantised, 1e-6) - 1 == pytest.approx(0.006, abs=0.002)


def _design_json(tmp_path, name: str, *extra: str) -> dict:
    out = tmp_path / f"{name}.json"
    assert carav(["design", "--preset", "awr1642", "--rarms", "0.5", "--trials", "20", "--benign-trials", "0",
                  "--ghost-trials", "0", "--seed", "3", "--quiet", "--json", str(out), *extra]) == Exit.OK
    return json.loads(out.read_text())


@pytest.mark.slow
def test_design_for_four_receivers_is_the_one_receiver_design_with_four_times_the_samples(tmp_path, capsys):
    """C combines the receivers' samples per chirp: its threshold is that of 4 x 256 samples, and both are the
    chi-square law of their 1024 degrees of freedom (scipy, directly) to four digits."""
    four = _design_json(tmp_path, "four", "--receivers", "4")
    text = capsys.readouterr().out
    long = _design_json(tmp_path, "long", "--ns", "1024")
    eta4, eta_long = four["rms_detector"]["eta"], long["rms_detector"]["eta"]
    assert f"{eta4:.4g}" == f"{eta_long:.4g}"
    assert four["rms_detector"]["pf_at_paper_eta"] == pytest.approx(long["rms_detector"]["pf_at_paper_eta"], rel=1e-4)
    m, nu, infl = 64, 4 * 256, four["scene"]["noise_inflation_by_adc"]
    per_chirp = -np.expm1(np.log1p(-1e-6) / m)                         # D1 adds nothing at this eta
    eta_chi2 = infl * np.sqrt(stats.chi2.isf(per_chirp, nu) / nu)
    assert f"{eta4:.4g}" == f"{eta_chi2:.4g}"
    assert four["scene"]["n_rx"] == 4 and four["scene"]["array_paper_model"] and four["leaks"] == []
    assert "nu = 256 per receiver, 4 receivers: 1024 per chirp" in text
    # the spectral test sums each bin over the receivers: the max of 64 x 127 Gamma(4, 1) bins
    assert four["spectral_silent_test"]["threshold"] == pytest.approx(
        stats.gamma.isf(-np.expm1(np.log1p(-1e-6) / (64 * 127)), 4), rel=1e-9)
    assert "over 8128 bins, each bin's power summed over the 4 receivers" in text
    assert "the scene has 1 receiver, the radar chain renders no other count" in text
    # the random attack: one attacker on the four receivers, not an attack independent on each
    law = scene_law(load_scene("awr1642"), 4)
    cf = pf_pm_closed_form(eta4 / infl, n_chirps=128, dof=256, snr=law.snr, rarms=0.5 / infl, n_rx=4,
                           attack_gains=(4.0,))
    assert four["misses"][0]["design"]["random"] == pytest.approx(float(cf["p_quiet"]), rel=1e-6)


def test_the_scene_law_takes_the_receivers_from_the_scene_or_the_caller():
    scene = load_scene("awr1642")
    assert scene_law(scene).n_rx == getattr(scene, "n_rx", 1)
    law = scene_law(scene, 8)
    assert law.n_rx == 8 and law.attack_gains == (8.0,) and law.dof == scene_law(scene).dof
    assert threshold_warning(law, 1.01).startswith("C(eta) eta = 1.01 raises") and "nu = 256 per receiver, 8" in \
        threshold_warning(law, 1.01)
    with pytest.raises(ValueError, match="n_rx: must be an integer >= 1, got 0"):
        scene_law(scene, 0)
