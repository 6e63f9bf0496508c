"""Closed forms, Clopper-Pearson, importance sampling and threshold design against independent references."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from carav_stream.detect.detector import detect_from_rms
from carav_stream.detect.stats import (
    cfar_eta_closed_form,
    clopper_pearson,
    pf_importance_sampling,
    pf_pm_closed_form,
    rms_moments,
)
from carav_stream.detect.thresholds import cfar, min_sum, minimax
from carav_stream.montecarlo.paper_model import paper_scene, sample_rms
from carav_stream.radar.activation import balanced_rows


def test_clopper_pearson_matches_scipy_binomtest():
    for k, n in [(0, 1000), (3, 1000), (500, 1000), (1000, 1000), (7, 20)]:
        lo, hi = clopper_pearson(k, n)
        ref = stats.binomtest(k, n).proportion_ci(0.95, method="exact")
        assert lo == pytest.approx(ref.low, abs=1e-12) and hi == pytest.approx(ref.high, abs=1e-12)


def test_clopper_pearson_zero_successes_has_rule_of_three_upper_bound():
    lo, hi = clopper_pearson(0, 1000)
    assert lo == 0 and hi == pytest.approx(1 - 0.025 ** (1 / 1000), rel=1e-12)   # ~3.7 / n


def test_pf_d0_part_is_the_chi_square_product_formula():
    # independent reference: P(one silent chirp below eta) by direct integration of the chi pdf
    from scipy import integrate
    nu, m, eta = 64, 32, 1.3
    p_one = integrate.quad(lambda r: stats.chi.pdf(r, nu), 0, eta * np.sqrt(nu))[0]
    cf = pf_pm_closed_form(eta, n_chirps=2 * m, dof=nu, snr=1.0)
    assert cf["p_alarm_d0"] == pytest.approx(1 - p_one ** m, rel=1e-9)


@pytest.mark.slow
def test_closed_form_pf_and_pm_agree_with_monte_carlo():
    scene = paper_scene("table1", n_samples=64)
    rng = np.random.default_rng(12)
    n = 60_000
    eta = np.array([1.15, 1.25, 1.35])
    for attack, rarms in [("none", 0.0), ("random", 0.4)]:
        rho = balanced_rows(rng, n, 64)
        q = detect_from_rms(sample_rms(scene, rho, rng, attack, rarms), rho, 1.0).q
        cf = pf_pm_closed_form(eta, n_chirps=64, dof=scene.dof, snr=scene.echo_snr, rarms=rarms)
        for i, e in enumerate(eta):
            k = int(np.sum(q >= e))
            lo, hi = clopper_pearson(k, n, confidence=0.999)
            assert lo <= cf["p_alarm"][i] <= hi, (attack, e, k / n, cf["p_alarm"][i])


def test_closed_form_d1_part_matters_for_small_eta_and_matches_monte_carlo():
    # with few samples per chirp and a weak echo the active RMS spreads enough for D1 to fire below eta = 0.6
    nu, n_chirps, snr = 4, 64, 0.5
    scene = paper_scene("table1", n_chirps=n_chirps, n_samples=nu, snr_db=10 * np.log10(snr))
    rng = np.random.default_rng(4)
    n = 20_000
    rho = np.zeros((n, n_chirps), bool)
    rho[:, : n_chirps // 2] = True
    rms = sample_rms(scene, rho, rng)
    det = detect_from_rms(rms, rho, 1.0)
    d1_max = det.d1[:, : n_chirps // 2].max(axis=1)
    for e in (0.3, 0.5):
        quiet_mc = np.mean(d1_max < e)
        quiet_cf = pf_pm_closed_form(e, n_chirps=n_chirps, dof=nu, snr=snr)["quiet_d1"]
        assert 0.02 < 1 - quiet_mc < 0.98
        assert quiet_cf == pytest.approx(quiet_mc, abs=0.015)      # approximation: normal leave-one-out mean


def test_rms_moments_match_sampling():
    rng = np.random.default_rng(1)
    x = np.sqrt(stats.ncx2.rvs(40, 12.0, size=400_000, random_state=rng) / 40)
    mean, var = rms_moments(40, 12.0)
    assert mean == pytest.approx(x.mean(), rel=1e-3) and var == pytest.approx(x.var(), rel=2e-2)


@pytest.mark.parametrize("nu, nonc", [(40, 12.0), (256, 3.3), (1080, 50.0), (2160, 1e4)])
def test_the_moments_quadrature_takes_the_numbers_of_ncx2_pdf(nu, nonc, monkeypatch):
    """rms_moments integrates the density ncx2.pdf evaluates, called directly: the same numbers on the support, by
    the ufunc of this scipy and by the fallback of another, so the moments are those of the pdf, bit for bit."""
    from carav_stream.detect import stats as cs

    lo, hi = stats.ncx2.ppf(1e-14, nu, nonc), stats.ncx2.isf(1e-14, nu, nonc)
    xs = np.linspace(lo, hi, 257)
    pdf = stats.ncx2.pdf(xs, nu, nonc)
    assert [cs._ncx2_density(nu, nonc)(float(x)) for x in xs] == pdf.tolist()
    monkeypatch.setattr(cs, "_scipy_ufuncs", SimpleNamespace())      # a scipy whose ufuncs have no _ncx2_pdf
    assert [float(cs._ncx2_density(nu, nonc)(float(x))) for x in xs] == pdf.tolist()
    cs.rms_moments.cache_clear()
    by_fallback = cs.rms_moments(nu, nonc)
    monkeypatch.undo()
    cs.rms_moments.cache_clear()
    assert cs.rms_moments(nu, nonc) == by_fallback


def test_cfar_closed_form_threshold_gives_target_pf():
    eta = cfar_eta_closed_form(1e-6, n_chirps=64, dof=1100)
    assert pf_pm_closed_form(eta, n_chirps=64, dof=1100, snr=1.0)["p_alarm"] == pytest.approx(1e-6, rel=1e-6)


def test_importance_sampling_reaches_1e_minus_12_and_matches_closed_form():
    rng = np.random.default_rng(9)
    eta = cfar_eta_closed_form(1e-12, n_chirps=64, dof=256)
    est = pf_importance_sampling(eta, n_chirps=64, dof=256, snr=1.0, n_trials=20_000, rng=rng)
    assert est["rel_err"] < 0.1
    assert est["pf"] == pytest.approx(1e-12, rel=4 * est["rel_err"])


def test_minimax_picks_centre_of_zero_band_and_reports_band():
    eta = np.linspace(1.0, 2.0, 11)
    pf = np.array([1, .5, .1, 0, 0, 0, 0, 0, 0, 0, 0.0])
    pm = np.array([0, 0, 0, 0, 0, 0, 0, .2, .6, 1, 1.0])
    out = minimax(eta, pf, pm)
    assert out["eta_range"] == [pytest.approx(1.3), pytest.approx(1.6)] and out["eta"] == pytest.approx(1.4)
    assert out["value"] == 0


def test_minimax_and_min_sum_differ_on_asymmetric_overlap():
    eta = np.array([1.0, 1.1, 1.2, 1.3])
    pf = np.array([0.9, 0.3, 0.1, 0.0])
    pm = np.array([0.0, 0.25, 0.35, 0.5])
    assert minimax(eta, pf, pm)["eta"] == pytest.approx(1.1)       # max = 0.3 beats 0.35
    assert min_sum(eta, pf, pm)["eta"] == pytest.approx(1.2)       # sum 0.45 beats 0.55


def test_cfar_takes_smallest_eta_meeting_target_and_flags_unverified():
    eta = np.array([1.0, 1.1, 1.2])
    pf = np.array([0.5, 0.004, 0.0])
    pm = np.zeros(3)
    out = cfar(eta, pf, pm, 0.01, pf_ci=[[0.4, 0.6], [0.001, 0.02], [0, 0.0037]])
    assert out["eta"] == pytest.approx(1.1) and out["verified"] is False


def test_thresholds_reject_non_increasing_eta():
    with pytest.raises(ValueError, match="eta must be strictly increasing"):
        minimax([1.0, 1.0], [0, 0], [0, 0])
