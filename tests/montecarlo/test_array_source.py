"""The paper model on a receiver array (montecarlo/array_source.py): its samples, and sweeps of PF and PM over 1, 2,
4 and 8 receivers against the closed form (nu -> n_rx nu, one attacker's steered signal) within binomial spread."""
from __future__ import annotations

import numpy as np
import pytest

from carav_stream.detect.stats import clopper_pearson, pf_pm_closed_form
from carav_stream.montecarlo.array_source import ArraySource, ula_positions_wl
from carav_stream.montecarlo.engine import simulate_q, sweep
from carav_stream.montecarlo.paper_model import paper_scene
from carav_stream.radar.activation import balanced_rows

ETA = np.round(np.arange(1.0, 1.8001, 0.05), 2)


def _small(iq: bool, n_rx: int, azimuth_deg: float = 20.0) -> ArraySource:
    return ArraySource(paper_scene("table1", n_chirps=16, n_samples=32, iq=iq), n_rx,
                       attacker_azimuth_deg=azimuth_deg)


def _inside(k: np.ndarray, n: int, p: np.ndarray) -> np.ndarray:
    """Whether each p lies in the 99.99 % Clopper-Pearson interval of k / n (where p is not within 1e-3 of 0 or 1:
    there every count is expected)."""
    lo, hi = clopper_pearson(k, n, 0.9999)
    return ((lo <= p) & (p <= hi)) | (p < 1e-3) | (p > 1 - 1e-3)


def test_the_attack_is_one_signal_steered_over_the_receivers_and_the_noise_independent():
    """Silent samples of I/Q frames: covariance over the receivers sigma^2 I + sigma_a^2 v v^H."""
    src = _small(True, 4, azimuth_deg=30.0)
    rng = np.random.default_rng(2)
    rho = balanced_rows(rng, 400, 16)
    x = src.frames(rho, rng, "random", 2.0)                        # (400, 4, 16, 32)
    silent = np.moveaxis(x, 1, -1)[~rho].reshape(-1, 4).astype(np.complex128)
    cov = silent.T @ silent.conj() / silent.shape[0]
    v = np.exp(1j * 2 * np.pi * np.asarray(ula_positions_wl(4)) * np.sin(np.radians(30.0)))
    want = np.eye(4) + 4.0 * np.outer(v, v.conj())                 # sigma_n = 1, sigma_a = 2
    assert np.abs(cov - want).max() < 0.12                          # 102400 samples: spread about 0.03
    assert src.closed_form("random")["attack_gains"] == (4.0,)
    assert src.closed_form("smart") is None and not src.energy_exact("random")


def test_an_i_only_array_at_broadside_has_the_one_receivers_echo_and_attack_on_every_receiver():
    src = _small(False, 3, azimuth_deg=0.0)
    rng = np.random.default_rng(4)
    rho = balanced_rows(rng, 2, 16)
    x = src.frames(rho, rng, "smart", 1e3)                          # the attack drowns the noise
    rel = np.abs(x[:, 1:] - x[:, :1]).max() / np.abs(x).max()
    assert rel < 1e-2 and x.dtype == np.float32 and x.shape == (2, 3, 16, 32)
    assert src.closed_form("none")["attack_gains"] == (3.0,)


@pytest.mark.slow
@pytest.mark.parametrize("iq", [False, True])
def test_sweep_pf_and_pm_over_1_2_4_8_receivers_match_the_closed_form(iq):
    """I-only off broadside has two gains (three weighted chi-squares), I/Q one; 3000 cycles per curve."""
    for n_rx in (1, 2, 4, 8):
        src = _small(iq, n_rx)
        res = sweep(src, attacks=["random"], rarms=[1.0], n_trials=3000, eta=ETA, seed=30 + n_rx, workers=1)
        curve, n = res["curves"][0], res["trials"]
        cf_pf, cf_pm = np.array(res["closed_form"]["pf"]), np.array(curve["closed_form"]["pm"])
        k_pf, k_pm = np.round(np.array(curve["pf"]) * n), np.round(np.array(curve["pm"]) * n)
        assert np.all(_inside(k_pf, n, cf_pf)), (n_rx, curve["pf"], cf_pf)
        assert np.all(_inside(k_pm, n, cf_pm)), (n_rx, curve["pm"], cf_pm)
        assert np.sum((cf_pm > 0.05) & (cf_pm < 0.95)) >= 2       # the comparison met the transition
        gains = src.closed_form("random")["attack_gains"]
        assert gains is None if n_rx == 1 else len(gains) == (1 if iq else 2)


@pytest.mark.slow
def test_one_attacker_on_eight_receivers_refutes_the_law_of_an_attack_independent_on_each():
    """The dof-add law for the attack (gains 1, ..., 1) predicts PM 0.81 at eta 1.5 (I/Q, RARMS 1); one attacker's
    signal keeps its nu degrees of freedom and is missed far less: the Monte Carlo tells the two laws apart."""
    src = _small(True, 8)
    n = 3000
    q = simulate_q(src, "random", 1.0, n, np.random.SeedSequence(9), workers=1).q
    cf = src.closed_form("random")
    k = int(np.sum(q < 1.5))
    steered = float(pf_pm_closed_form(1.5, **cf, rarms=1.0)["p_quiet"])
    independent = float(pf_pm_closed_form(1.5, **{**cf, "attack_gains": None}, rarms=1.0)["p_quiet"])
    assert _inside(np.array(k), n, np.array(steered)) and not _inside(np.array(k), n, np.array(independent))
    assert independent - steered > 0.3


def test_the_array_source_refuses_a_wrong_count_of_positions_and_the_energy_path():
    scene = paper_scene("table1", n_chirps=8, n_samples=16)
    with pytest.raises(ValueError, match="rx_positions_wl: 2 positions for n_rx = 3"):
        ArraySource(scene, 3, rx_positions_wl=(0.0, 0.5))
    with pytest.raises(ValueError, match="n_rx: must be an integer >= 1, got 0"):
        ArraySource(scene, 0)
    with pytest.raises(ValueError, match="no exact energy path"):
        simulate_q(ArraySource(scene, 2), "none", 0.0, 10, np.random.SeedSequence(1), method="energy")
