"""Sufficient-statistic draws of the paper model: sample_rms's stream pinned bit for bit, sample_q_smart's law
against the full-sample simulation and the per-chirp path, its generators against scipy's closed forms."""
from __future__ import annotations

import threading
from decimal import Decimal, getcontext

import numpy as np
import pytest
from scipy import stats

from carav_stream.detect.detector import detect, detect_from_rms
from carav_stream.montecarlo import paper_model, samplers
from carav_stream.montecarlo.paper_model import PaperScene, paper_scene, sample_q_smart, sample_rms, simulate_frames
from carav_stream.radar.activation import balanced_rows


def reference_rms(scene, rho, rng, attack, rarms):
    """sample_rms written from the module docstring's equations, whole arrays, in the documented stream order:
    smart: g (n, d) normals, w (n,) gammas; then (n, N) float32 gammas for chi2(nu - 1); then (n, N) normals."""
    nu = scene.n_samples * (2 if scene.iq else 1)
    s2 = scene.sigma_n ** 2 * scene.n_samples / nu
    x = np.concatenate([scene.echo.real, scene.echo.imag], axis=-1) if scene.iq else scene.echo
    n = rho.shape[0]
    if attack == "smart" and rarms > 0:
        evals, evecs = np.linalg.eigh(x @ x.T)
        keep = evals > max(float(evals.max()), 0.0) * 1e-12
        c = evecs[:, keep] * np.sqrt(evals[keep]) / np.sqrt(s2)
        d = c.shape[1]
        g = rng.standard_normal((n, d)) * np.sqrt(rarms ** 2)
        w = rarms ** 2 * 2.0 * rng.standard_gamma((nu - d) / 2.0, size=n)
        lam = np.where(rho, np.sum((c[None] + g[:, None, :]) ** 2, axis=-1) + w[:, None],
                       (np.sum(g ** 2, axis=-1) + w)[:, None])
        scale = 1.0
    else:
        scale = 1.0 + (rarms ** 2 if attack == "random" else 0.0)
        lam = np.where(rho, np.sum(x ** 2, axis=-1) / s2 / scale, 0.0)
    energy = (2.0 * rng.standard_gamma((nu - 1) / 2.0, size=rho.shape, dtype=np.float32)).astype(np.float64)
    energy += (rng.standard_normal(rho.shape) + np.sqrt(lam)) ** 2
    return scene.sigma_n * np.sqrt(energy * (scale / nu))


def loud_chirp_scene() -> PaperScene:
    """16 chirps, one with an echo 30 times louder and one with none: D1 then wins whenever chirp 0 is active."""
    base = paper_scene("table1", n_chirps=16, n_samples=24)
    gain = np.ones((16, 1))
    gain[0], gain[5] = 30.0, 0.0
    return PaperScene("loud chirp 0", 16, 24, False, 1.0, base.echo * gain)


def two_target_scene() -> PaperScene:
    """Echoes spanning four dimensions (two beat frequencies), which sample_rms sums with np.sum."""
    base = paper_scene("table1", n_chirps=16, n_samples=40)
    m = np.arange(40)
    echo = base.echo + 0.5 * np.cos(0.9 * m[None, :] + 0.4 * np.arange(16)[:, None])
    return PaperScene("two targets", 16, 40, False, 0.8, echo)


@pytest.mark.parametrize("scene_name", ["table1", "table1 iq", "two targets", "no echo"])
@pytest.mark.parametrize("attack,rarms", [("none", 0.0), ("random", 0.7), ("smart", 1.3), ("smart", 0.0)])
def test_sample_rms_draws_the_documented_stream_bit_for_bit(monkeypatch, scene_name, attack, rarms):
    scene = {"table1": lambda: paper_scene("table1", n_chirps=16, n_samples=64, sigma_n=0.3),
             "table1 iq": lambda: paper_scene("table1", n_chirps=16, n_samples=32, iq=True),
             "two targets": two_target_scene,
             "no echo": lambda: PaperScene("no echo", 8, 16, False, 1.0, np.zeros((8, 16)))}[scene_name]()
    monkeypatch.setattr(paper_model, "RMS_CHUNK_CYCLES", 7)          # several chunks and a short last one
    rho = balanced_rows(np.random.default_rng(1), 45, scene.n_chirps)
    got = sample_rms(scene, rho, np.random.default_rng(2), attack, rarms)
    ref = reference_rms(scene, rho, np.random.default_rng(2), attack, rarms)
    assert got.dtype == np.float64 and got.shape == rho.shape
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("k", [1079, 255, 20, 9])
def test_chi2_and_normal_follow_their_laws_in_the_bulk_and_the_tails(k):
    # k = 20 sits just above the squeeze's limit (c x_max < 1 from k = 18 on); k = 9 takes numpy's gamma
    rng = np.random.default_rng(k)
    chi2, z = np.empty((500, 1000), np.float32), np.empty((500, 1000), np.float32)
    samplers.chi2_and_normal(rng, k, chi2, z)
    chi2, z = chi2.ravel().astype(np.float64), z.ravel().astype(np.float64)
    assert stats.kstest(chi2, stats.chi2(k).cdf).pvalue > 1e-3
    assert stats.kstest(z, stats.norm.cdf).pvalue > 1e-3
    edges = np.array([1e-4, 1e-3, 0.01, 0.05, 0.2, 0.5, 0.8, 0.95, 0.99, 0.999, 0.9999])
    for sample, law in ((chi2, stats.chi2(k)), (z, stats.norm)):
        counts = np.bincount(np.searchsorted(law.ppf(edges), sample), minlength=edges.size + 1)
        expected = np.diff(np.concatenate([[0.0], edges, [1.0]])) * sample.size
        assert stats.chisquare(counts, expected).pvalue > 1e-3
    assert abs(stats.spearmanr(chi2, z).statistic) < 4.5 / np.sqrt(chi2.size)     # independent pair


def test_chi2_tests_see_a_scale_error_of_two_per_mille():
    # guard against vacuous tests above: chi2 values 0.2 % too large must fail them
    rng = np.random.default_rng(3)
    chi2, z = np.empty(500_000, np.float32), np.empty(500_000, np.float32)
    samplers.chi2_and_normal(rng, 1079, chi2, z)
    assert stats.kstest(1.002 * chi2.astype(np.float64), stats.chi2(1079).cdf).pvalue < 1e-3


@pytest.mark.parametrize("k", [18, 20, 40, 255, 1079, 100_000])
def test_marsaglia_tsang_squeeze_never_exceeds_the_acceptance_probability(k):
    # 1 - K x^4 <= exp(x^2/2 + b (1 - v + ln v)), v = (1 + c x)^3, in 40-digit decimal arithmetic on |x| <= x_max
    getcontext().prec = 40
    b = Decimal(k) / 2 - Decimal(1) / 3
    c = 1 / (9 * b).sqrt()
    x_max = Decimal(samplers.X_MAX)
    assert c * x_max < 1
    big_k = c * c / (12 * (1 - c * x_max))
    for x in [Decimal(float(v)) for v in np.concatenate([np.linspace(-1, 1, 3) * samplers.X_MAX,
                                                          np.geomspace(1e-3, samplers.X_MAX, 300)])]:
        for xs in (x, -x):
            v = (1 + c * xs) ** 3
            accept = (xs * xs / 2 + b * (1 - v + v.ln())).exp()
            assert 1 - big_k * xs ** 4 <= accept, (k, xs)
    assert np.sqrt(-2.0 * np.log(2.0 ** -53)) < samplers.X_MAX        # the largest |x| Box-Muller gives


@pytest.mark.parametrize("bit_generator", [np.random.PCG64, np.random.SFC64, np.random.MT19937])
def test_balanced_mask_is_uniform_over_the_balanced_patterns(bit_generator):
    rng = np.random.Generator(bit_generator(4))
    mask = samplers.balanced_mask(rng, np.empty((6, 60_000), np.float32))
    assert np.all(mask.sum(axis=0) == 3)
    patterns = (2 ** np.arange(6)) @ mask
    counts = np.unique(patterns, return_counts=True)[1]
    assert counts.size == 20 and stats.chisquare(counts).pvalue > 1e-3        # C(6, 3) patterns, equally likely


@pytest.mark.parametrize("n_chirps", [2, 16, 64, 70, 128])
def test_balanced_mask_rows_are_balanced_for_any_word_count(n_chirps):
    mask = samplers.balanced_mask(np.random.default_rng(n_chirps), np.empty((n_chirps, 3000), np.float32))
    assert set(np.unique(mask)) <= {0.0, 1.0}
    assert np.all(mask.sum(axis=0) == n_chirps // 2)
    assert np.all(np.abs(mask.mean(axis=1) - 0.5) < 0.05)                      # every chirp half of the time


def test_popcount_fallback_counts_bits_like_python(monkeypatch):
    words = np.random.default_rng(5).bit_generator.random_raw(1000)
    want = np.array([bin(int(w)).count("1") for w in words])
    np.testing.assert_array_equal(samplers.popcount(words), want)
    monkeypatch.delattr(np, "bitwise_count", raising=False)
    np.testing.assert_array_equal(samplers.popcount(words), want)


@pytest.mark.parametrize("scene_name,rarms", [("small", 1.2), ("small iq", 0.8), ("loud chirp", 0.7)])
def test_sample_q_smart_matches_the_full_sample_simulation(scene_name, rarms):
    scene = {"small": lambda: paper_scene("table1", n_chirps=16, n_samples=48),
             "small iq": lambda: paper_scene("table1", n_chirps=16, n_samples=24, iq=True),
             "loud chirp": loud_chirp_scene}[scene_name]()
    rng = np.random.default_rng(6)
    rho = balanced_rows(rng, 8000, scene.n_chirps)
    full = detect(simulate_frames(scene, rho, rng, "smart", rarms), rho, scene.sigma_n, 1.0)
    q, by_d1 = sample_q_smart(scene, 100_000, rng, rarms)
    assert q.dtype == np.float64 and by_d1.dtype == bool and q.shape == by_d1.shape == (100_000,)
    assert stats.ks_2samp(full.q, q).pvalue > 1e-3
    k = np.array([full.by_d1.sum(), by_d1.sum()])
    n = np.array([full.by_d1.size, by_d1.size])
    assert k.sum() == 0 or stats.chi2_contingency(np.stack([k, n - k])).pvalue > 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("rarms", [0.5, 1.0, 3.0])
def test_sample_q_smart_matches_the_per_chirp_path_on_table1(rarms):
    scene = paper_scene("table1")
    rng = np.random.default_rng(7)
    q, _ = sample_q_smart(scene, 200_000, rng, rarms)
    rho = balanced_rows(rng, 200_000, scene.n_chirps)
    q_rms = detect_from_rms(sample_rms(scene, rho, rng, "smart", rarms), rho, scene.sigma_n, 1.0).q
    assert stats.ks_2samp(q, q_rms).pvalue > 1e-3


def test_q_comparison_sees_a_two_percent_error_in_the_attack_level():
    # guard against vacuous comparisons above: RARMS 1.0 against 1.02 must be told apart
    scene = paper_scene("table1")
    rng = np.random.default_rng(8)
    q, _ = sample_q_smart(scene, 100_000, rng, 1.02)
    rho = balanced_rows(rng, 100_000, scene.n_chirps)
    q_rms = detect_from_rms(sample_rms(scene, rho, rng, "smart", 1.0), rho, scene.sigma_n, 1.0).q
    assert stats.ks_2samp(q, q_rms).pvalue < 1e-3


def test_sample_q_smart_is_seeded_and_threads_do_not_share_buffers(monkeypatch):
    monkeypatch.setattr(paper_model, "SMART_CHUNK_CYCLES", 300)
    scene = paper_scene("table1", n_chirps=32, n_samples=100)
    alone = [sample_q_smart(scene, 5000, np.random.default_rng(s), 1.5) for s in range(4)]
    together = [None] * 4

    def run(s):
        together[s] = sample_q_smart(scene, 5000, np.random.default_rng(s), 1.5)

    threads = [threading.Thread(target=run, args=(s,)) for s in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for (q_a, d_a), (q_t, d_t) in zip(alone, together):
        np.testing.assert_array_equal(q_a, q_t)
        np.testing.assert_array_equal(d_a, d_t)
    assert not np.array_equal(alone[0][0], alone[1][0])
    assert np.all(np.isfinite(alone[0][0])) and np.all(alone[0][0] > 0)


@pytest.mark.parametrize("rarms,message", [(-1.0, "rarms: must be finite and >= 0, got -1.0"),
                                           (1e16, r"rarms: 1e\+16 is beyond the float32 energies of sample_q_smart")])
def test_sample_q_smart_names_a_bad_level(rarms, message):
    with pytest.raises(ValueError, match=message):
        sample_q_smart(paper_scene("table1", n_chirps=8, n_samples=16), 10, np.random.default_rng(0), rarms)


def test_sample_q_smart_stays_finite_up_to_its_largest_level():
    q, _ = sample_q_smart(paper_scene("table1", n_chirps=16, n_samples=32), 3000, np.random.default_rng(9), 1e15)
    assert np.all(np.isfinite(q)) and np.all(q > 1e14)
