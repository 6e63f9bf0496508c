"""The radar's target list: CFAR cells refined to the bound, the same numbers as the single-target estimator where
both see one target, a weak target beside a loud one still listed, and association against the truth."""
import numpy as np
import pytest

from carav_stream.estimate.crlb import fmcw_crlb
from carav_stream.estimate.estimators import estimate, refine_at
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.tones import centroid_ranges, synth_beat
from carav_stream.firmware.target_list import associate, gates, target_list
from carav_stream.montecarlo.engine import balanced_rows
from carav_stream.radar.scene_loader import load_scene


def scene_data(preset, snr_db, n, seed, ranges=None, vels=None, amplitudes=1.0, iq=None):
    scene = load_scene(preset)
    g = Geometry.from_scene(scene)
    if iq is not None:
        g = Geometry(g.fs_hz, g.slope_hz_per_s, g.fc_hz, g.t_chirp_s, g.n_samples, iq)
    rng = np.random.default_rng(seed)
    rho = balanced_rows(rng, n, scene.n_chirps)
    snr_s = snr_db - 10 * np.log10(scene.n_chirps // 2)
    ranges = np.full((n, 1), 0.5 * g.max_range_m) if ranges is None else ranges
    vels = np.full(ranges.shape, 0.3 * g.max_velocity_mps) if vels is None else vels
    # echoes as the radar hears them: from their round trips on, their ranges walking over the cycle
    x = synth_beat(g, rho, ranges, vels, amplitudes=amplitudes, snr_sample_db=snr_s, rng=rng, migrate=True, gate=True)
    sigma = 10 ** (-snr_s / 20) / (1.0 if g.iq else np.sqrt(2.0))     # noise RMS for target 0 of amplitude 1
    return g, rho, x, sigma, snr_s


@pytest.mark.parametrize("preset, iq", [("table1", None), ("awr1642", None), ("table1", True)])
def test_a_listed_target_is_refined_exactly_as_the_single_target_estimator_refines_it(preset, iq):
    g, rho, x, sigma, _ = scene_data(preset, 20.0, 48, 3, iq=iq)
    tl = target_list(x, rho, g, sigma, method="ml")
    ref = estimate(x, rho, g, method="ml")
    one = tl.n_found == 1
    assert one.sum() >= 40                                             # the target, and rarely a false one
    # the same cell, the same interpolation and ML steps: equal to rounding (batches of other sizes)
    np.testing.assert_allclose(tl.range_m[one, 0], ref.range_m[one, 0], rtol=1e-13)
    np.testing.assert_allclose(tl.velocity_mps[one, 0], ref.velocity_mps[one, 0], rtol=1e-13)


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["table1", "awr1642"])
def test_two_targets_one_20_db_louder_are_both_listed_by_os_cfar_and_measured_near_their_bounds(preset):
    g0 = Geometry.from_scene(load_scene(preset))
    n = 120
    ranges = np.tile([0.3 * g0.max_range_m, 0.3 * g0.max_range_m + 12 * g0.range_resolution_m], (n, 1))
    vels = np.tile([0.2 * g0.max_velocity_mps, -0.4 * g0.max_velocity_mps], (n, 1))
    g, rho, x, sigma, snr_s = scene_data(preset, 20.0, n, 5, ranges, vels, amplitudes=np.array([1.0, 10.0]))
    tl = target_list(x, rho, g, sigma, method="ml", detection="os_cfar")
    vmax = g.max_velocity_mps
    seen = centroid_ranges(g, rho, ranges, vels)                     # what a beat measures of a walking range
    for t, snr in ((0, snr_s), (1, snr_s + 20)):
        hit = np.abs(tl.range_m - seen[:, t:t + 1]) < g.range_resolution_m
        assert hit.any(axis=1).mean() >= 0.97, f"target {t} listed in {hit.any(axis=1).mean():.2%} of cycles"
        err_r = np.where(hit, tl.range_m - seen[:, t:t + 1], np.nan)
        err_v = np.where(hit, (tl.velocity_mps - vels[:, t:t + 1] + vmax) % (2 * vmax) - vmax, np.nan)
        bound = fmcw_crlb(g, snr, rho, range_m=ranges[:, t])
        assert np.sqrt(np.nanmean(np.nansum(err_r, axis=1) ** 2)) <= 1.3 * np.sqrt(np.mean(bound["range_m"] ** 2))
        assert (np.sqrt(np.nanmean(np.nansum(err_v, axis=1) ** 2))
                <= 1.3 * np.sqrt(np.mean(bound["velocity_mps"] ** 2)))
    assert np.mean(tl.n_found - 2) < 0.2                               # sidelobes of the loud one are not listed


@pytest.mark.slow
def test_ca_cfar_masks_a_weak_target_whose_training_cells_hold_a_loud_ones_slow_time_sidelobes():
    # half-silent cycles spread a target over every Doppler bin of its range bin at about 1/A of its power: a
    # target 20 dB louder 12 range bins away sits in the weak one's training cells and raises its CA threshold
    g0 = Geometry.from_scene(load_scene("table1"))
    n = 120
    ranges = np.tile([0.3 * g0.max_range_m, 0.3 * g0.max_range_m + 12 * g0.range_resolution_m], (n, 1))
    vels = np.tile([0.2 * g0.max_velocity_mps, -0.4 * g0.max_velocity_mps], (n, 1))
    g, rho, x, sigma, _ = scene_data("table1", 20.0, n, 5, ranges, vels, amplitudes=np.array([1.0, 10.0]))
    listed = {kind: (np.abs(target_list(x, rho, g, sigma, detection=kind).range_m - ranges[:, :1])
                     < g.range_resolution_m).any(axis=1).mean() for kind in ("ca_cfar", "os_cfar")}
    assert listed["ca_cfar"] < 0.9 and listed["os_cfar"] >= 0.97, listed


def test_noise_alone_lists_about_what_the_design_rate_allows():
    g, rho, x, sigma, _ = scene_data("table1", 20.0, 40, 7, amplitudes=0.0)
    tl = target_list(x, rho, g, sigma, pfa=1e-4)
    cells = 64 * (1100 // 2 - 1)
    assert tl.n_found.mean() <= 3 * cells * 1e-4                       # local maxima only: fewer than every cell


def test_refine_at_refuses_lists_with_holes():
    g, rho, x, _, _ = scene_data("table1", 20.0, 2, 1)
    with pytest.raises(ValueError, match="targets first"):
        refine_at(x, rho, g, np.array([[np.nan, 0.1], [0.1, np.nan]]), np.array([[np.nan, 0.1], [0.1, np.nan]]))


def test_association_takes_nearest_pairs_once_and_compares_velocities_modulo_the_ambiguity():
    detected, false = associate([43.0, 43.1, 80.0], [-26.0, -26.1, 5.0], [43.05], [-26.05], 0.5, 1.0, 132.8)
    assert detected.tolist() == [True] and false == 2                 # one of the two near ones is a false target
    detected, false = associate([20.0], [10.0 - 2 * 132.8], [20.0], [10.0], 0.5, 1.0, 132.8)
    assert detected.tolist() == [True] and false == 0                 # an alias is the same Doppler
    detected, false = associate([], [], [20.0, 30.0], [0.0, 0.0], 0.5, 1.0, 10.0)
    assert detected.tolist() == [False, False] and false == 0
    g = Geometry.from_scene(load_scene("awr1642"))
    r_gate, v_gate = gates(g, 128, 83.3)
    assert r_gate == pytest.approx(1.5 * g.range_resolution_m + 83.3 * 128 * 160e-6 / 2)
    assert v_gate == pytest.approx(1.5 * 2 * g.max_velocity_mps / 128)
