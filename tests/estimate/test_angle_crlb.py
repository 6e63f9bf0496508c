"""The azimuth's Cramer-Rao bound: the closed form against a numerical Fisher information of the raw samples
(computed here from the signal's equations by finite differences)."""
import numpy as np
import pytest

from carav_stream.estimate.angle_crlb import attacker_azimuth_crlb, azimuth_crlb, effective_snr
from carav_stream.estimate.virtual_array import VirtualArray
from tests.estimate import mimo_tones as mt

AWR1642 = VirtualArray(mt.AWR1642["rx"], mt.AWR1642["tx"], mt.AWR1642["schedule"])


def _numerical_var_theta(layout, theta, f, nu, snr_db, n_samples, n_chirps, iq):
    """[J^-1]_theta,theta of the samples x[r, k, n] = Re?(b exp(j (2 pi (f n + nu k + x sin theta) + phi))) in white
    noise, parameters (b, phi, theta), J by central differences of the mean."""
    rx, tx, sched = (np.asarray(layout[k]) for k in ("rx", "tx", "schedule"))
    k, n = np.arange(n_chirps), np.arange(n_samples)
    pos = tx[sched[k % sched.size]][None, :] + rx[:, None]

    def mean(p):
        b, phi, th = p
        m = b * np.exp(1j * (2 * np.pi * (f * n[None, None, :] + nu * k[None, :, None] + pos[..., None] * np.sin(th))
                             + phi))
        return m.ravel() if iq else m.real.ravel()

    p0 = np.array([1.0, 0.3, theta])
    steps = np.array([1e-6, 1e-6, 1e-7])
    d = np.stack([(mean(p0 + e) - mean(p0 - e)) / (2 * e[i]) for i, e in enumerate(np.diag(steps))], axis=1)
    sigma2 = mt.noise_sigma(snr_db, iq=iq) ** 2
    fisher = 2.0 * np.real(d.conj().T @ d) / sigma2 if iq else d.T @ d / sigma2
    return np.linalg.inv(fisher)[2, 2]


@pytest.mark.parametrize("iq", [True, False])
@pytest.mark.parametrize("layout", [mt.AWR1642,
                                    {"rx": (0.0, 0.5, 1.0), "tx": (0.0, 0.5), "schedule": (0, 1)},   # duplicates
                                    {"rx": (0.0, 0.6, 1.7), "tx": (0.0, 2.3, 0.4), "schedule": (0, 2, 1)}])
def test_the_closed_form_bound_is_the_numerical_fisher_informations(layout, iq):
    # f = 10 / 64: sum_n exp(j 4 pi f n) = 0, so a real tone's image is orthogonal to it and the bound is exact
    n_samples, n_loops, theta = 64, 8, np.radians(23.0)
    n_chirps = n_loops * len(layout["schedule"])
    num = _numerical_var_theta(layout, theta, 10 / 64, 0.0137, 5.0, n_samples, n_chirps, iq)
    array = VirtualArray(layout["rx"], layout["tx"], layout["schedule"])
    closed = azimuth_crlb(effective_snr(5.0, n_samples, n_loops, iq=iq), array.positions_wl, 23.0)
    assert np.degrees(np.sqrt(num)) == pytest.approx(closed["deg"], rel=1e-4)
    assert closed["var_u"] == pytest.approx(num * (2 * np.pi * np.cos(theta)) ** 2, rel=1e-4)


def test_the_attackers_bound_tends_to_the_deterministic_one_for_a_loud_attack():
    p = (0.0, 0.5, 1.0, 1.5)
    loud = attacker_azimuth_crlb(1e6, 1000, p, 30.0)["var_u"]
    assert loud == pytest.approx(azimuth_crlb(1e6 * 1000, p, 30.0)["var_u"], rel=1e-5)
    assert attacker_azimuth_crlb(0.1, 1000, p, 30.0)["var_u"] > 3 * azimuth_crlb(100.0, p, 30.0)["var_u"]
