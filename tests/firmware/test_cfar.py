"""CFAR on the range-Doppler map: exact thresholds (Finn-Johnson, Rohling), the map's Exp(1) law on half-silent
cycles, Pd against the textbook curve, and targets found where the scene put them."""
from __future__ import annotations

import numpy as np
import pytest

from carav_stream.detect.rdmap import rd_power
from carav_stream.detect.stats import clopper_pearson
from carav_stream.estimate import Geometry
from carav_stream.firmware.cfar import (
    ca_alpha,
    cells_to_range_velocity,
    cfar_threshold,
    detect_targets,
    os_alpha,
    peak_sidelobe_ratio,
)
from carav_stream.radar.activation import balanced_rows


def _noise_maps(rng, c=200, m=32, n=128, iq=False):
    rho = balanced_rows(rng, c, m)
    x = rng.standard_normal((c, m, n))
    if iq:
        x = (x + 1j * rng.standard_normal((c, m, n))) / np.sqrt(2)
    return rd_power(x, rho, 1.0), rho


@pytest.mark.parametrize("iq", [False, True])
def test_every_cell_of_a_half_silent_noise_map_is_exp_1(iq):
    p, _ = _noise_maps(np.random.default_rng(1), iq=iq)
    assert p.shape[-1] == (128 if iq else 63)
    # mean 1, variance 1, and the tail of an exponential
    assert p.mean() == pytest.approx(1.0, abs=0.01) and p.var() == pytest.approx(1.0, abs=0.03)
    k = int(np.sum(p > np.log(100)))                               # P(Exp(1) > ln 100) = 0.01
    lo, hi = clopper_pearson(k, p.size, 0.999)
    assert lo <= 0.01 * 1.1 and hi >= 0.01 * 0.9                    # cells are correlated in Doppler: wider


def test_ca_and_os_multipliers_are_the_closed_forms():
    assert (1 + ca_alpha(1e-4, 24) / 24) ** -24 == pytest.approx(1e-4, rel=1e-10)
    n, k, a = 24, 18, os_alpha(1e-4, 24, 18)
    assert np.prod([(n - i) / (n - i + a) for i in range(k)]) == pytest.approx(1e-4, rel=1e-9)
    # independent route for CA: the threshold over the training mean is F(2, 2n) distributed (exp / mean of exp)
    from scipy import stats
    assert ca_alpha(1e-3, 16) == pytest.approx(stats.f.isf(1e-3, 2, 32), rel=1e-9)


@pytest.mark.parametrize("kind", ["ca", "os"])
def test_design_false_alarm_rate_holds_on_maps_and_at_the_range_edges(kind):
    p, _ = _noise_maps(np.random.default_rng(2), c=300)
    for pfa in (1e-2, 1e-3):
        t = cfar_threshold(p, pfa=pfa, train=8, kind=kind)
        rate = np.mean(p > t)
        assert rate == pytest.approx(pfa, rel=0.15), (kind, pfa, rate)
    t = cfar_threshold(p, pfa=1e-2, train=8, kind=kind)
    edges = np.r_[0:20, 43:63]                                      # windows cut by the ends of the range axis
    assert np.mean(p[..., edges] > t[..., edges]) == pytest.approx(1e-2, rel=0.25)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_os_threshold_is_the_kth_smallest_training_cell_times_its_multiplier_cell_by_cell(dtype):
    """Written out from the definition, one cell at a time: the training cells every third bin from `gap` on, `train`
    per side and none beyond the axis; the k-th smallest of the n there, k = ceil(0.75 n); times os_alpha(pfa, n, k)."""
    rng = np.random.default_rng(7)
    p = rng.exponential(size=(5, 4, 90)).astype(dtype)
    p[1, 2, 40] = 300.0                                             # a target among the training cells
    t = cfar_threshold(p, pfa=1e-4, gap=6, train=8, kind="os")
    assert t.dtype == dtype and t.shape == p.shape
    for j in range(p.shape[-1]):
        cells = [j + s * (6 + 3 * i) for s in (-1, 1) for i in range(8)]
        cells = [c for c in cells if 0 <= c < p.shape[-1]]
        k = int(np.ceil(0.75 * len(cells)))
        expected = os_alpha(1e-4, len(cells), k) * np.sort(p[..., cells], axis=-1)[..., k - 1]
        np.testing.assert_array_equal(t[..., j], expected.astype(dtype), err_msg=str(j))


def test_pd_of_a_swerling_1_cell_follows_the_textbook_ca_cfar_curve():
    """Exponential training cells and a cell under test of mean 1 + SNR: Pd = (1 + alpha / (n (1 + SNR)))^-n."""
    rng = np.random.default_rng(3)
    n, pfa, trials = 16, 1e-3, 40000
    alpha = ca_alpha(pfa, n)
    for snr_db in (10.0, 15.0, 20.0):
        snr = 10 ** (snr_db / 10)
        train = rng.exponential(size=(trials, n))
        cut = rng.exponential(1 + snr, size=trials)
        k = int(np.sum(cut > alpha * train.mean(axis=1)))
        lo, hi = clopper_pearson(k, trials, 0.999)
        textbook = (1 + alpha / (n * (1 + snr))) ** -n
        assert lo <= textbook <= hi, (snr_db, k / trials, textbook)


def test_the_table1_car_is_listed_at_its_range_and_velocity_and_noise_lists_almost_nothing():
    from carav_stream.radar.scene_loader import load_scene
    from carav_stream.radar.synth import simulate_cycles

    scene = load_scene("table1", {"snr_db": -10.0, "adc_bits": 0})   # 35 dB after integrating 32 x 1100 samples
    rng = np.random.default_rng(4)
    rho = balanced_rows(rng, 40, scene.n_chirps)
    cyc = simulate_cycles(scene, rho, rng)
    p = rd_power(cyc.frames, rho, scene.sigma_n)
    det = detect_targets(p, rho, pfa=1e-6)
    g = Geometry.from_scene(scene)
    r, v = cells_to_range_velocity(det, g, scene.n_chirps)
    assert np.all(det.n_found >= 1)
    assert np.all(np.abs(r[:, 0] - 43.0) < g.range_resolution_m)
    dv = g.wavelength_m / (2 * scene.t_chirp_s * scene.n_chirps)      # one Doppler bin
    assert np.all(np.abs(v[:, 0] - scene.range_rate_mps(scene.targets[0])) <= dv)
    # the car's slow-time sidelobes are not listed as targets; what else is listed is rare
    assert np.mean(det.n_found - 1) < 0.2
    quiet = rd_power(rng.standard_normal(cyc.frames.shape) * scene.sigma_n, rho, scene.sigma_n)
    assert detect_targets(quiet, rho, pfa=1e-6).n_found.sum() <= 2


def test_sidelobe_ratio_of_a_half_silent_pattern_is_about_one_over_the_active_count():
    rho = balanced_rows(np.random.default_rng(5), 500, 64)
    psl = peak_sidelobe_ratio(rho)
    assert np.all(psl < 1) and 1 / 32 < np.median(psl) < 0.3
    full = np.ones((1, 64), bool)
    assert peak_sidelobe_ratio(full)[0] == pytest.approx(0.0, abs=1e-20)


def test_bad_input_is_refused_by_name():
    with pytest.raises(ValueError, match="pfa"):
        ca_alpha(0.0, 10)
    with pytest.raises(ValueError, match="kind"):
        cfar_threshold(np.ones((1, 4, 40)), pfa=1e-3, kind="go")
    with pytest.raises(ValueError, match="without active chirps"):
        rd_power(np.ones((1, 4, 8)), np.zeros((1, 4), bool), 1.0)


def test_the_worst_off_grid_sidelobe_of_full_sampling_is_the_dirichlet_kernels_at_half_a_bin():
    from carav_stream.firmware.cfar import worst_sidelobe_ratio
    m = 64
    # all chirps: |P(u)| = |sin(pi u) / sin(pi u / M)|; the tone half a bin off, the cell two bins from the peak
    closed = (np.sin(np.pi * 0.5 / m) / np.sin(np.pi * 1.5 / m)) ** 2
    assert worst_sidelobe_ratio(np.ones((1, m), bool))[0] == pytest.approx(closed, rel=1e-9)
    rho = balanced_rows(np.random.default_rng(2), 300, m)
    worst, on_grid = worst_sidelobe_ratio(rho), peak_sidelobe_ratio(rho)
    assert np.median(worst) > 2 * np.median(on_grid)        # off the grid, sparse sidelobes are not nulled
