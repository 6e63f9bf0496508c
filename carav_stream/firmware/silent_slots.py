"""C(eta)'s exact false-alarm rate when echoes leak into the silent slots (pure functions: arrays in, numbers out).

A silent slot k that follows an active one holds what still arrives of chirp k-1's echo, its tail w_k (rendered by
`carav_stream.radar.physics` at either fidelity, as the channel adds it). The geometry is frozen per cycle, so
w_k is the same in every cycle; from slot to slot it changes as the Doppler turns the echo's phase. The chain takes
the chirp before chirp 0 as silent (cycles are independent, `carav_stream.radar.synth`), so slot 0 holds none.

Derivation. With n white Gaussian noise of RMS sigma_eff per sample at the ADC output, a silent slot's energy is
||w_k + n||^2, and (I only: nu = N_s real samples of variance sigma_eff^2; I/Q: nu = 2 N_s components of variance
sigma_eff^2 / 2)

    nu ||R_k||_r^2 / sigma_eff^2  ~  ncx2(nu, lambda_k),     lambda_k = (nu / N_s) ||w_k||^2 / sigma_eff^2.

D0(k) = ||R_k||_r / sigma_det stays below eta iff that variable stays below x = nu eta^2 (sigma_det / sigma_eff)^2:
with probability F_k = F_ncx2(nu, lambda_k)(x) for a silent slot after an active one, F_0 = F_chi2(nu)(x) for any
other. Given the activation rho, the silent slots are independent of each other (independent noise) and of the
active ones, so

    P(quiet | rho) = P_D1(quiet) F_0^M  prod_{k in L(rho)} r_k,     r_k = F_k / F_0,
    L(rho) = {k >= 1 : rho[k-1] and not rho[k]},

and P_D1(quiet) F_0^M = 1 - pf0 is the leak-free closed form (`carav_stream.firmware.design.pf_per_cycle`). The
tail lands in the active slots after an active one too; it moves their RMS by about half its share of the slot's
echo energy, far below what D1 = |rms - mean| / (mean + sigma_n) needs to reach eta, so D1's part is kept. Averaged
over the balanced random activation (every arrangement of M active chirps among N_r = 2M equally likely, as
`carav_stream.radar.activation.balanced_rows` draws them):

    PF = 1 - (1 - pf0) (1 - eps),    eps = E_rho[1 - prod_{k in L(rho)} r_k].

eps is computed exactly by a recursion over the slots (`mean_deficit`): given j active chirps among the first k,
chirp k is active with probability (M - j) / (N_r - k); a state (j, rho[k-1]) carries its probability and its
expected deficit d = 1 - prod r, and a silent slot after an active one maps d to q_k + (1 - q_k) d with
q_k = 1 - r_k = (S_k - S_0) / (1 - S_0) taken from the survival functions S, so a rate that exceeds pf0 by as
little as 1e-15 is resolved. O(N_r M) operations per rate.

The law is the design's (firmware/design.py): Gaussian noise with the ADC's quantisation as uniform noise, exact in
the limit sigma_n >> lsb.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import stats

from carav_stream.radar import physics
from carav_stream.radar.scene import Scene

__all__ = ["slot_energies", "noncentrality", "slot_deficits", "mean_deficit", "pf_with_leak"]


def slot_energies(scene: Scene, tau0_s: float, alpha: float, fidelity: str, amplitude: float = 1.0) -> np.ndarray:
    """Energy sum_m |w_k[m]|^2 of the tail a replica delayed by tau(t) = tau0_s + alpha t leaves in each slot k
    after its chirp k-1, float64 (n_chirps,), as the chain renders it at `fidelity` (beat | waveform); slot 0: 0."""
    bare = replace(scene, targets=(), attackers=())          # one key for the waveform grid's cache, whatever range
    render = physics.beat_replica if fidelity == "beat" else physics.waveform_replica
    tail = render(bare, tau0_s, alpha, amplitude)[1]
    out = np.zeros(scene.n_chirps)
    if tail is not None:
        t = np.asarray(tail[1:])
        out[1:] = np.sum(t.real.astype(np.float64) ** 2 + (t.imag.astype(np.float64) ** 2 if scene.iq else 0.0),
                         axis=-1)
    return out


def noncentrality(law, scene: Scene, energies) -> np.ndarray:
    """lambda_k = n_rx (nu / N_s) E_k / sigma_eff^2 for the tail energies E_k of one receiver (any shape): the tail
    reaches each of the law's n_rx receivers with the same energy (unit-modulus steering)."""
    return law.n_rx * (law.dof / scene.n_samples) * np.asarray(energies, dtype=np.float64) / law.sigma_eff ** 2


def slot_deficits(law, eta: float, lam, sigma_det: float | None = None) -> np.ndarray:
    """q_k = 1 - F_lambda_k(x) / F_0(x): how much less likely a silent slot with noncentrality lambda_k stays quiet
    at eta than a slot of noise alone (any shape; 0 where lambda = 0)."""
    nu = law.n_rx * law.dof                                  # every receiver's components of the chirp
    x = nu * (eta * (sigma_det or law.sigma_n) / law.sigma_eff) ** 2
    lam = np.asarray(lam, dtype=np.float64)
    sf0 = stats.chi2.sf(x, nu)
    if sf0 >= 1.0:
        return np.zeros_like(lam)
    sf = np.where(lam > 0, stats.ncx2.sf(x, nu, np.maximum(lam, 1e-300)), sf0)
    return np.clip((sf - sf0) / (1.0 - sf0), 0.0, 1.0)


def mean_deficit(q) -> np.ndarray:
    """eps = E_rho[1 - prod_{k in L(rho)} (1 - q_k)] over uniformly random balanced rho, exactly.

    q  float (..., N_r): slot k's deficit when it is silent after an active chirp (q[..., 0] is never used: the
       chirp before the cycle is silent). Returns float64 (...).
    """
    q = np.asarray(q, dtype=np.float64)
    n = q.shape[-1]
    m = n // 2
    j = np.arange(m + 1)
    prob = np.zeros(q.shape[:-1] + (m + 1, 2))      # P(j actives among the first k, rho[k-1] = b)
    deficit = np.zeros_like(prob)                   # E[(1 - prod r) ; that state]
    prob[..., 0, 0] = 1.0
    for k in range(n):
        active = np.minimum((m - j) / (n - k), 1.0)
        silent = 1.0 - active
        qk = q[..., k, None]
        p_all, d_all = prob.sum(axis=-1), deficit.sum(axis=-1)
        new_p, new_d = np.zeros_like(prob), np.zeros_like(deficit)
        new_p[..., 1:, 1] = (p_all * active)[..., :-1]
        new_d[..., 1:, 1] = (d_all * active)[..., :-1]
        new_p[..., 0] = p_all * silent
        new_d[..., 0] = (deficit[..., 0] + qk * prob[..., 1] + (1.0 - qk) * deficit[..., 1]) * silent
        prob, deficit = new_p, new_d
    return deficit[..., m, :].sum(axis=-1)


def pf_with_leak(law, eta: float, lam, pf0: float, sigma_det: float | None = None) -> np.ndarray:
    """C(eta)'s false-alarm rate per cycle with slot k's noncentrality lam[..., k] (N_r on the last axis), averaged
    over the balanced random activation; pf0: the leak-free rate at eta (`design.pf_per_cycle`)."""
    if pf0 >= 1.0:
        return np.ones(np.shape(lam)[:-1])
    eps = mean_deficit(slot_deficits(law, eta, lam, sigma_det))
    with np.errstate(divide="ignore"):
        return -np.expm1(math.log1p(-pf0) + np.log1p(-np.minimum(eps, 1.0)))
