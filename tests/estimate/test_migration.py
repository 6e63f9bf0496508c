"""Range migration compensated along each velocity alias's walk: the walk against the scene's own beat, the AWR1642
car (3.6 cells per cycle, Doppler aliased 7 times) refined to its true range and unaliased velocity from its CFAR
cell, scenes the compensation was not tuned on (a receding target, two targets, I/Q), the slow Table I car left
as it was, and the target list without the duplicates and sidelobes of the walk."""
import dataclasses

import numpy as np
import pytest

from carav_stream.detect.rdmap import rd_power
from carav_stream.estimate.estimators import estimate, refine_at
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.migration import alias_folds, walk
from carav_stream.firmware import cfar
from carav_stream.firmware.target_list import associate, gates, target_list
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene import Target
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles


def cycles(scene, n, seed):
    rng = np.random.default_rng(seed)
    rho = balanced_rows(rng, n, scene.n_chirps)
    return simulate_cycles(scene, rho, rng).frames, rho


def cells(x, rho, scene, geometry, n=1):
    det = cfar.detect_targets(rd_power(x, rho, scene.sigma_n, single=True), rho, pfa=1e-6, kind="os",
                              max_targets=8)
    ok = det.range_bin[:, :n] >= 0
    f0 = np.where(ok, (det.range_bin[:, :n] + (0 if geometry.iq else 1)) / x.shape[-1], np.nan)
    return f0, np.where(ok, det.doppler_bin[:, :n] / rho.shape[1], np.nan)


def test_the_walk_per_chirp_is_the_scenes_beat_one_chirp_later():
    scene = scene_of("awr1642")
    g = Geometry.from_scene(scene)
    car = scene.targets[0]
    v = scene.range_rate_mps(car)
    later = dataclasses.replace(car, range_m=car.range_m + v * g.t_chirp_s)
    assert walk(g, v) * g.fs_hz == pytest.approx(scene.beat_hz(later) - scene.beat_hz(car), rel=1e-9)
    # over the 128 chirps of a cycle: the 3.6 range cells DETECTION.md states
    assert abs(walk(g, v)) * scene.n_chirps * g.n_samples == pytest.approx(3.6, abs=0.05)
    folds = alias_folds(100.0, g)
    assert folds[0] < 0 < folds[-1] and abs(folds).max() * 2 * g.max_velocity_mps >= 100.0


@pytest.mark.parametrize("max_speed", [0.0, 100.0])
def test_the_awr1642_car_is_refined_to_its_range_and_unaliased_velocity_only_with_compensation(max_speed):
    scene = scene_of("awr1642")
    g = Geometry.from_scene(scene)
    x, rho = cycles(scene, 32, 3)
    car = scene.targets[0]
    r_true, v_true = car.range_m, scene.range_rate_mps(car)
    e = refine_at(x, rho, g, *cells(x, rho, scene, g), max_speed_mps=max_speed)
    r_err, v_err = e.range_m[:, 0] - r_true, e.velocity_mps[:, 0] - v_true
    if max_speed:
        assert np.all(np.abs(r_err) < 0.02) and np.all(np.abs(v_err) < 0.05)           # CRLB-scale (mm, mm/s)
    else:   # without: the alias and the centroid of the walk, as DETECTION.md states
        assert np.all(np.abs(v_err) > 80) and np.all(r_err < -0.8)


def test_scenes_it_was_not_tuned_on_a_receding_target_beside_a_slow_one_and_iq_samples():
    base = scene_of("awr1642")
    targets = (Target(range_m=35.0, velocity_mps=45.0 + base.radar_speed_mps, rcs_m2=100.0),    # receding 45 m/s
               Target(range_m=12.0, velocity_mps=base.radar_speed_mps - 3.0, rcs_m2=30.0))     # closing 3 m/s
    for iq in (False, True):
        scene = dataclasses.replace(base, targets=targets, iq=iq)
        g = Geometry.from_scene(scene)
        x, rho = cycles(scene, 16, 11)
        tl = target_list(x, rho, g, scene.sigma_n, detection="os_cfar", max_speed_mps=100.0)
        truth_r = [t.range_m for t in targets]
        truth_v = [scene.range_rate_mps(t) for t in targets]
        for c in range(16):
            k = tl.n_found[c]
            r, v = tl.range_m[c, :k], tl.velocity_mps[c, :k]
            assert k == 2, (iq, c, r, v)
            for tr, tv in zip(truth_r, truth_v):
                j = np.argmin(np.abs(r - tr))
                assert abs(r[j] - tr) < 0.05 and abs(v[j] - tv) < 0.1, (iq, c, r, v)      # unaliased: not mod 12 m/s


def test_the_slow_table1_car_is_refined_as_without_compensation():
    scene = scene_of("table1")
    g = Geometry.from_scene(scene)
    x, rho = cycles(scene, 16, 5)
    f0, nu0 = cells(x, rho, scene, g)
    plain = refine_at(x, rho, g, f0, nu0)
    walked = refine_at(x, rho, g, f0, nu0, max_speed_mps=100.0)
    assert np.allclose(walked.velocity_mps, plain.velocity_mps, atol=0.02)          # the k = 0 alias, always
    assert np.allclose(walked.range_m, plain.range_m, atol=0.005)


def test_strongest_detection_and_the_cfar_list_agree_and_the_list_has_no_walk_duplicates():
    scene = scene_of("awr1642")
    g = Geometry.from_scene(scene)
    x, rho = cycles(scene, 32, 7)
    car = scene.targets[0]
    r_true, v_true = car.range_m, scene.range_rate_mps(car)
    strongest = estimate(x, rho, g, max_speed_mps=100.0)
    assert np.all(np.abs(strongest.range_m[:, 0] - r_true) < 0.02)
    assert np.all(np.abs(strongest.velocity_mps[:, 0] - v_true) < 0.05)
    rg, vg = gates(g, scene.n_chirps, abs(v_true))
    for speed, pd_at_least, false_at_most in ((0.0, 0.0, None), (100.0, 1.0, 0.1)):
        tl = target_list(x, rho, g, scene.sigma_n, detection="os_cfar", max_speed_mps=speed)
        hits, false = 0, 0
        for c in range(32):
            k = tl.n_found[c]
            d, f = associate(tl.range_m[c, :k], tl.velocity_mps[c, :k], [r_true], [v_true], rg, vg, g.max_velocity_mps)
            hits, false = hits + int(d[0]), false + f
        if speed:
            assert hits / 32 >= pd_at_least and false / 32 <= false_at_most
        else:       # without: the walk's cells and sidelobes listed as targets (DETECTION.md: about 4 a cycle)
            assert false / 32 > 2


def test_a_cycle_is_refined_the_same_alone_and_in_a_batch_of_cycles_with_more_active_chirps():
    """Cycles of one call may have different numbers of active chirps (padding rows in the compacted data): each
    cycle's result must not depend on its neighbours; chirp 0 active in the short cycle."""
    scene = scene_of("awr1642")
    g = Geometry.from_scene(scene)
    x, rho = cycles(scene, 2, 9)
    rho[0, :] = False
    rho[0, :40] = True                                    # 40 active chirps, chirp 0 among them; cycle 1 has 64
    x = simulate_cycles(scene, rho, np.random.default_rng(4)).frames
    f0, nu0 = cells(x, rho, scene, g)
    both = refine_at(x, rho, g, f0, nu0, max_speed_mps=100.0)
    alone = refine_at(x[:1], rho[:1], g, f0[:1], nu0[:1], max_speed_mps=100.0)
    assert both.range_m[0, 0] == pytest.approx(alone.range_m[0, 0], abs=1e-9)
    assert both.velocity_mps[0, 0] == pytest.approx(alone.velocity_mps[0, 0], abs=1e-9)
    assert abs(both.velocity_mps[0, 0] - scene.range_rate_mps(scene.targets[0])) < 0.1


def test_a_walk_that_starts_a_hair_below_bin_zero_reads_bin_zero():
    # real samples whose walk puts a chirp's position a rounding error below 0: its float modulo is the FFT length
    # itself, one past the last bin (seed 49: a target at 3.5 m, -10.5 m/s on a 64-sample chirp)
    from carav_stream.estimate.tones import random_rho, synth_beat
    g = Geometry(fs_hz=20e6, slope_hz_per_s=4e12, fc_hz=77e9, t_chirp_s=50e-6, n_samples=64, iq=False)
    rng = np.random.default_rng(49)
    rho = random_rho(rng, 2, 32)
    x = synth_beat(g, rho, [rng.uniform(2, 30)], [rng.uniform(-20, 20)], snr_sample_db=10, rng=rng)
    e = estimate(x, rho, g, max_speed_mps=60.0)
    assert np.all(np.isfinite(e.range_m)) and np.all(np.abs(e.range_m - 3.475) < g.range_resolution_m)
