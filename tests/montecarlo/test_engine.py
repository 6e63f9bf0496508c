"""Monte Carlo engine: exact sufficient-statistic path against full simulation, seeding, curves, sweep JSON."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from carav_stream.detect.detector import detect
from carav_stream.montecarlo.engine import PaperSource, curves_from_q, eta_grid, simulate_q, sweep
from carav_stream.montecarlo.paper_model import paper_scene, sample_q_fast, sample_rms, simulate_frames
from carav_stream.radar.activation import balanced_rows


@pytest.mark.parametrize("attack,rarms,iq", [("none", 0.0, False), ("random", 1.0, True), ("smart", 1.2, False)])
def test_energy_path_matches_full_sample_simulation_in_ks_test(attack, rarms, iq):
    scene = paper_scene("table1", n_samples=48, n_chirps=16, iq=iq)
    rng = np.random.default_rng(21)
    rho = balanced_rows(rng, 3000, 16)
    q_full = detect(simulate_frames(scene, rho, rng, attack, rarms), rho, 1.0).q
    rho = balanced_rows(rng, 30_000, 16)
    from carav_stream.detect.detector import detect_from_rms
    q_energy = detect_from_rms(sample_rms(scene, rho, rng, attack, rarms), rho, 1.0).q
    assert stats.ks_2samp(q_full, q_energy).pvalue > 1e-3


def test_ks_test_has_power_to_see_a_wrong_energy_law():
    # guard against a vacuous KS test: a 5 % error in the attack level must be detected
    scene = paper_scene("table1", n_samples=48, n_chirps=16)
    rng = np.random.default_rng(22)
    rho = balanced_rows(rng, 3000, 16)
    q_full = detect(simulate_frames(scene, rho, rng, "random", 1.0), rho, 1.0).q
    from carav_stream.detect.detector import detect_from_rms
    rho = balanced_rows(rng, 30_000, 16)
    q_wrong = detect_from_rms(sample_rms(scene, rho, rng, "random", 1.05), rho, 1.0).q
    assert stats.ks_2samp(q_full, q_wrong).pvalue < 1e-3


@pytest.mark.parametrize("attack,rarms", [("none", 0.0), ("random", 0.8)])
def test_fast_q_path_matches_general_energy_path(attack, rarms):
    scene = paper_scene("table1", n_samples=64, n_chirps=32)
    rng = np.random.default_rng(5)
    q_fast, _ = sample_q_fast(scene, 40_000, rng, attack, rarms)
    rho = balanced_rows(rng, 40_000, 32)
    from carav_stream.detect.detector import detect_from_rms
    q_gen = detect_from_rms(sample_rms(scene, rho, rng, attack, rarms), rho, 1.0).q
    assert stats.ks_2samp(q_fast, q_gen).pvalue > 1e-3


def test_simulate_q_is_reproducible_and_independent_of_worker_count():
    src = PaperSource(paper_scene("table1", n_samples=32, n_chirps=16))
    a = simulate_q(src, "random", 1.0, 500, np.random.SeedSequence(7), method="samples", workers=1)
    b = simulate_q(src, "random", 1.0, 500, np.random.SeedSequence(7), method="samples", workers=2)
    c = simulate_q(src, "random", 1.0, 500, np.random.SeedSequence(8), method="samples", workers=1)
    np.testing.assert_array_equal(a.q, b.q)
    assert not np.array_equal(a.q, c.q)


def test_curves_count_alarm_at_equality_and_give_intervals():
    out = curves_from_q(np.array([1.0, 2.0, 3.0]), np.array([1.5, 2.5]), np.array([2.0, 2.5]))
    np.testing.assert_allclose(out["pf"], [2 / 3, 1 / 3])      # Q0 >= eta is an alarm
    np.testing.assert_allclose(out["pm"], [0.5, 0.5])          # Qa < eta is a miss
    assert np.all(out["pf_ci"][:, 0] <= out["pf"]) and np.all(out["pf"] <= out["pf_ci"][:, 1])


def test_eta_grid_parses_and_rejects():
    np.testing.assert_allclose(eta_grid("1:2:0.25"), [1, 1.25, 1.5, 1.75, 2])
    with pytest.raises(ValueError, match="eta: expected START:STOP:STEP, got '1:2'"):
        eta_grid("1:2")


def test_sweep_json_has_required_fields_and_separates_strong_attacks():
    src = PaperSource(paper_scene("table1", n_samples=128, n_chirps=32))
    eta = eta_grid("0.8:3.0:0.05")
    res = sweep(src, attacks=["random"], rarms=[0.3, 3.0], n_trials=400, eta=eta, seed=3)
    json.dumps(res)
    strong = next(c for c in res["curves"] if c["rarms"] == 3.0)
    for key in ("attack", "rarms", "trials", "eta", "pf", "pm", "pf_ci", "pm_ci"):
        assert key in strong
    i = int(np.argmin(np.abs(eta - 1.5)))
    assert strong["pm"][i] == 0 and strong["pf"][i] == 0
    weak = next(c for c in res["curves"] if c["rarms"] == 0.3)
    assert weak["thresholds"]["minimax"]["value"] > 0.05           # weak attack: PF and PM overlap
    for name in ("minimax", "cfar", "min_sum"):
        assert {"eta", "pf", "pm"} <= set(res["thresholds"][name])
    assert res["closed_form"]["pf_at_eta_1_5"] < 1e-10


def test_radar_source_energy_path_matches_radar_samples():
    import carav_stream.radar.scene_loader as radar
    from carav_stream.montecarlo.radar_source import RadarSource
    scene = radar.load_scene("table1", {"snr_db": 0.0, "adc_bits": 0, "n_chirps": 16, "n_samples": 64})
    src = RadarSource(scene)
    a = simulate_q(src, "smart", 1.0, 1500, np.random.SeedSequence(1), method="samples")
    b = simulate_q(src, "smart", 1.0, 20_000, np.random.SeedSequence(2), method="energy")
    assert a.method == "samples" and b.method == "energy"
    assert stats.ks_2samp(a.q, b.q).pvalue > 1e-3


def test_radar_source_falls_back_to_samples_for_quantised_adc():
    import carav_stream.radar.scene_loader as radar
    from carav_stream.montecarlo.radar_source import RadarSource
    src = RadarSource(radar.load_scene("table1", {"n_chirps": 8, "n_samples": 32}))
    assert simulate_q(src, "random", 1.0, 10, np.random.SeedSequence(1)).method == "samples"
    with pytest.raises(ValueError, match="no exact energy path for attack 'random'"):
        simulate_q(src, "random", 1.0, 10, np.random.SeedSequence(1), method="energy")


def test_radar_source_scores_the_opt_in_detectors_on_a_receiver_array():
    # every receiver judged: a ghost one receiver's integrated test misses in most cycles shows on four in all
    import carav_stream.radar.scene_loader as radar
    from carav_stream.montecarlo.radar_source import RadarSource

    def stat(n_rx: int, rarms: float) -> np.ndarray:
        scene = radar.load_scene("table1", {"n_rx": n_rx, "n_chirps": 32, "n_samples": 64})
        src = RadarSource(scene, fidelity="beat")
        return src.draw_stat(60, "ghost", rarms, np.random.default_rng(4), "integrated")

    assert stat(4, 0.0).max() < 1.0 and (stat(4, 0.3) >= 1.0).all()
    assert (stat(1, 0.3) >= 1.0).mean() < 0.2


@pytest.mark.parametrize("activation", ["seeded", "lfsr", "secure"])
def test_radar_source_activates_whole_tdm_loops(activation):
    """A TDM scene's activation is drawn per loop (radar/activation.py): every active loop fires the whole virtual
    array, exactly half the loops active, on the samples path and the energy path alike."""
    import carav_stream.radar.scene_loader as radar
    from carav_stream.montecarlo.radar_source import RadarSource

    scene = radar.load_scene("awr1642_mimo", {"n_chirps": 32, "n_samples": 32})
    src = RadarSource(scene, fidelity="beat", activation=activation)
    rhos = [src.draw_frames(5, "none", 0.0, np.random.default_rng(2))[1]]
    if activation == "seeded":
        rhos.append(src.draw(5, "none", 0.0, np.random.default_rng(3), "energy")[1])
    for rho in rhos:
        loops = rho.reshape(5, -1, scene.n_slots)
        assert (loops == loops[:, :, :1]).all(), rho.astype(int)
        assert (loops[:, :, 0].sum(axis=1) == loops.shape[1] // 2).all()
