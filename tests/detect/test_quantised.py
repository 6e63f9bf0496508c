"""The energy of quantised Gaussian noise (detect/quantised.py) against a direct convolution and against codes drawn
through the same rounding."""
import math

import numpy as np
import pytest
from scipy import stats

from carav_stream.detect.quantised import code_log_pmf, quantised_energy_logsf


def _direct_sf(nu: int, r: float, length: int = 4000) -> np.ndarray:
    """P(S >= s) for s < length by nu direct (not FFT) convolutions of the law of c^2, from the normal tail (which
    keeps its precision where the cdf rounds to 1)."""
    k = np.arange(60)
    p = stats.norm.sf((k - 0.5) / r) - stats.norm.sf((k + 0.5) / r)
    p[1:] *= 2
    y = np.zeros(length)
    inside = k * k < length
    y[(k * k)[inside]] = p[inside]
    law = np.zeros(length)
    law[0] = 1.0
    for _ in range(nu):
        law = np.convolve(law, y)[:length]
    return np.cumsum(law[::-1])[::-1]


def test_the_code_law_sums_to_one_and_is_the_normal_cdf_between_half_steps():
    p = np.exp(code_log_pmf(0.7, 40))
    assert p.sum() == pytest.approx(1.0, abs=1e-14)
    assert p[2] == pytest.approx(2 * (stats.norm.cdf(2.5 / 0.7) - stats.norm.cdf(1.5 / 0.7)), rel=1e-12)


@pytest.mark.parametrize("nu, r", [(20, 0.245), (20, 0.5), (30, 0.3), (50, 1.0)])
def test_the_tail_is_the_direct_convolutions_down_to_tiny_probabilities(nu, r):
    direct = _direct_sf(nu, r)
    s = np.array([1, 3, 10, 20, 40, 80])
    ours = np.exp(quantised_energy_logsf(s, nu, r))
    keep = direct[s] > 1e-290
    assert np.allclose(ours[keep], direct[s][keep], rtol=1e-8, atol=0)


def test_the_tail_is_what_rounded_gaussian_noise_gives():
    rng = np.random.default_rng(4)
    nu, r = 1080, 0.245
    codes = np.rint(rng.standard_normal((20000, nu)) * r)
    energy = np.sum(codes * codes, axis=1)
    for s in (40, 49, 60):
        p = float(np.exp(quantised_energy_logsf(s, nu, r)))
        assert stats.binomtest(int(np.sum(energy >= s)), energy.size, p).pvalue > 1e-3, s


def test_an_energy_beyond_every_code_of_the_table_has_the_tables_bound_not_a_root_finding_error():
    """A detector given a noise RMS far above the scene's (sigma_c = 0.24 lsb, threshold at 400 lsb a component):
    the energy cannot be reached within the codes the law keeps; its log tail is the bound log(nu) - 2000."""
    r, nu = 0.24, 64
    far = nu * 400.0 ** 2
    assert quantised_energy_logsf(far, nu, r) == pytest.approx(math.log(nu) - 2000.0)
    near = quantised_energy_logsf(nu * 1.5 ** 2, nu, r)
    assert -2000 < float(near) < 0
