"""A cell refined (angle_refine) and the point cloud of a CFAR list (point_cloud): the TDM phase of a fast target
removed (and the bias it leaves when it is not), range, velocity and azimuth of CFAR detections on the awr1642
waveform, the velocity's TDM ambiguity, silent loops and empty cells."""
from dataclasses import replace

import numpy as np
import pytest

from carav_stream.core.units import C_MPS
from carav_stream.detect.rdmap import rd_power
from carav_stream.estimate.angle_crlb import azimuth_crlb, effective_snr
from carav_stream.estimate.angle_refine import refine_cells
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.point_cloud import point_cloud, point_cloud_of
from carav_stream.estimate.virtual_array import VirtualArray, tdm_max_velocity_mps
from carav_stream.firmware import cfar
from carav_stream.radar.scene_loader import load_scene
from tests.estimate import mimo_tones as mt

AWR1642 = VirtualArray(mt.AWR1642["rx"], mt.AWR1642["tx"], mt.AWR1642["schedule"])
SCENE = load_scene("awr1642")


def _balanced_loops(rng, n_cycles, n_loops=64, n_slots=2):
    """rho (C, n_loops n_slots): half the loops active, constant within a loop."""
    loops = np.zeros((n_cycles, n_loops), bool)
    for row in loops:
        row[rng.permutation(n_loops)[: n_loops // 2]] = True
    return np.repeat(loops, n_slots, axis=1)


@pytest.mark.slow
@pytest.mark.parametrize("iq", [True, False])
def test_the_tdm_compensation_removes_the_bias_a_fast_target_puts_on_the_angle(iq):
    # nu = 0.2 cycles/chirp (0.8 of the TDM's unambiguous velocity): the second slot's Doppler phase, 2 pi nu =
    # 1.26 rad on the upper half of the virtual array, looks like an angle of about nu 4 / 10.5 in sin(theta)
    n_cycles, az = 100, 10.0
    snr_db = SCENE.snr_db(0)
    rng = np.random.default_rng(21 + iq)
    x = mt.frames(rng, n_cycles, [mt.Tone(0.3137, 0.2, az)], snr_db=snr_db, iq=iq)
    f0, nu0 = np.full((n_cycles, 1), 80 / 256), np.full((n_cycles, 1), 26 / 128)
    on = np.degrees(np.arcsin(refine_cells(x, AWR1642, f0, nu0).sin_theta[:, 0])) - az
    off = np.degrees(np.arcsin(refine_cells(x, AWR1642, f0, nu0, tdm=False).sin_theta[:, 0])) - az
    bound = azimuth_crlb(effective_snr(snr_db, 256, 64, iq=iq), AWR1642.positions_wl, az)["deg"]
    predicted = np.degrees(np.arcsin(np.sin(np.radians(az)) + 0.2 * 4 / 10.5)) - az
    assert off.mean() == pytest.approx(predicted, rel=0.3) and off.mean() > 1000 * bound
    assert abs(on.mean()) < 4 * bound / np.sqrt(n_cycles)
    assert np.sqrt(np.mean(on ** 2)) < 1.3 * bound


def _truth(g, range_m, velocity_mps, azimuth_deg, amplitude=1.0):
    f = float(g.beat_from_range(range_m, velocity_mps)) / g.fs_hz
    nu = float(g.slow_freq_from_velocity(velocity_mps, sample=(g.n_samples - 1) / 2, delay_s=2 * range_m / C_MPS))
    return mt.Tone(f, nu, azimuth_deg, amplitude)


@pytest.mark.slow
@pytest.mark.parametrize("iq", [True, False])
def test_the_point_cloud_of_a_cfar_list_holds_each_targets_range_velocity_and_azimuth(iq):
    g = replace(Geometry.from_scene(SCENE), iq=iq)
    v_max = tdm_max_velocity_mps(g.wavelength_m, g.t_chirp_s, 2)
    truth = [(20.0, -0.61 * v_max, -25.0, 1.0), (41.3, 0.37 * v_max, 38.0, 0.5)]
    n_cycles, snr_db = 12, 15.0
    rng = np.random.default_rng(31 + iq)
    rho = _balanced_loops(rng, n_cycles)
    x = mt.frames(rng, n_cycles, [_truth(g, *t) for t in truth], snr_db=snr_db, iq=iq, rho=rho)
    sigma = mt.noise_sigma(snr_db, iq=iq)
    det = cfar.detect_targets(rd_power(x[:, 0, 0::2], rho[:, 0::2], sigma), rho[:, 0::2])   # rx 0, slot 0
    cloud = point_cloud_of(x, g, AWR1642, det, rho)
    assert np.array_equal(cloud.n_found, det.n_found) and np.all(cloud.n_found >= 2)
    for c in range(n_cycles):
        n = cloud.n_found[c]
        assert np.all(np.isfinite(cloud.azimuth_deg[c, :n])) and np.all(np.isnan(cloud.range_m[c, n:]))
        for r, v, az, _ in truth:
            j = np.argmin(np.abs(cloud.range_m[c, :n] - r))
            assert cloud.range_m[c, j] == pytest.approx(r, abs=0.01)
            assert cloud.velocity_mps[c, j] == pytest.approx(v, abs=0.005)
            assert cloud.azimuth_deg[c, j] == pytest.approx(az, abs=6 * cloud.azimuth_std_deg[c, j])
            assert cloud.snr_db[c, j] == det.snr_db[c, j]


def test_the_azimuths_deviation_is_the_bound_at_the_measured_snr():
    g = replace(Geometry.from_scene(SCENE), iq=True)
    x = mt.frames(np.random.default_rng(41), 30, [_truth(g, 30.0, 1.0, 12.0)], snr_db=0.0, iq=True)
    f = g.beat_from_range(30.0, 1.0) / g.fs_hz
    nu = float(g.slow_freq_from_velocity(1.0)) * 128                     # Doppler bin of 64 loops
    cloud = point_cloud(x, g, AWR1642, np.full((30, 1), int(round(f * 256))), np.full((30, 1), int(round(nu))),
                        np.zeros((30, 1)))
    bound = azimuth_crlb(effective_snr(0.0, 256, 64, iq=True), AWR1642.positions_wl, 12.0)["deg"]
    assert np.median(cloud.azimuth_std_deg) == pytest.approx(bound, rel=0.1)


def test_velocities_beyond_the_tdm_ambiguity_fold_by_twice_it():
    # twice it where the sums read the Doppler: at the window's centre the progression is scaled by
    # Geometry.doppler_scale_at, so the fold in velocity is 2 v_max / that scale
    g = replace(Geometry.from_scene(SCENE), iq=True)
    v_max = tdm_max_velocity_mps(g.wavelength_m, g.t_chirp_s, 2)
    x = mt.frames(np.random.default_rng(51), 4, [_truth(g, 25.0, 0.93 * v_max, 5.0),
                                                  _truth(g, 33.0, 1.2 * v_max, -5.0)], snr_db=10.0, iq=True)
    bins = [round(float(g.beat_from_range(r, v)) / g.fs_hz * 256) for r, v in ((25.0, 0.93 * v_max),
                                                                              (33.0, 1.2 * v_max))]
    dop = [round(float(g.slow_freq_from_velocity(v)) * 128) % 64 for v in (0.93 * v_max, 1.2 * v_max)]
    cloud = point_cloud(x, g, AWR1642, np.tile(bins, (4, 1)), np.tile(dop, (4, 1)), np.zeros((4, 2)))
    assert np.allclose(cloud.velocity_mps[:, 0], 0.93 * v_max, atol=0.002)
    scale = g.doppler_scale_at((g.n_samples - 1) / 2, 2 * 33.0 / C_MPS)
    assert np.allclose(cloud.velocity_mps[:, 1], 1.2 * v_max - 2.0 * v_max / scale, atol=0.002)


def test_cells_not_listed_are_nan_and_listed_ones_do_not_depend_on_them():
    x = mt.frames(np.random.default_rng(61), 3, [mt.Tone(0.2, 0.05, 15.0)], snr_db=10.0, iq=True)
    f0 = np.array([[51 / 256, np.nan], [51 / 256, 0.4], [np.nan, np.nan]])
    nu0 = np.array([[6 / 128, np.nan], [6 / 128, 0.1], [np.nan, np.nan]])
    cells = refine_cells(x, AWR1642, f0, nu0)
    assert np.isnan(cells.sin_theta[0, 1]) and np.all(np.isnan(cells.sin_theta[2]))
    assert np.isnan(cells.snapshots[2]).all()
    alone = refine_cells(x[:2], AWR1642, f0[:2, :1], nu0[:2, :1])
    assert np.allclose(alone.sin_theta[:, 0], cells.sin_theta[:2, 0], atol=1e-12)
    with pytest.raises(ValueError, match="f0"):
        refine_cells(x, AWR1642, f0[:2], nu0[:2])
    bad, rho = x.copy(), np.ones((3, 128), bool)
    bad[1, 2, 3, 4] = np.nan
    rho[0] = False
    broken = refine_cells(bad, AWR1642, f0, nu0, rho)
    assert np.isnan(broken.sin_theta[:2]).all() and np.isnan(broken.snr_eff[:2]).all()


def test_a_point_cloud_of_the_wrong_kind_of_samples_is_refused():
    g = Geometry.from_scene(SCENE)                                        # I-only
    x = np.zeros((1, 4, 128, 256), np.complex64)
    with pytest.raises(ValueError, match="iq=False"):
        point_cloud(x, g, AWR1642, np.zeros((1, 1), int), np.zeros((1, 1), int), np.zeros((1, 1)))
