"""CARAV over a receiver array: per-receiver diagnostics, and the law of the combined statistic.

Frames of an array are (n_cycles, n_rx, n_chirps, n_samples). The detector judges a chirp by its RMS over all its
receivers' samples (`detector.chirp_rms(frames, receivers=True)`):

    ||R_k||_r^2 = (1 / (n_rx N_s)) sum_r sum_m |R_{k,r}[m]|^2  =  mean over r of ||R_{k,r}||_r^2

and D0, D1, Q and C(eta) as for one receiver. Per-receiver D0, D1 and Q (`per_receiver_detect`, by folding the
receiver axis into the cycle axis) are diagnostics: which receiver saw what.

Why the degrees of freedom add. A chirp of one receiver holds nu real Gaussian noise components (nu = N_s I-only,
2 N_s I/Q), each of variance s^2 = sigma_n^2 N_s / nu, so nu ||R||_r^2 / sigma_n^2 ~ chi2(nu). The receivers' noise
is independent, so a chirp of the array holds n_rx nu such components, all independent, and

    n_rx nu ||R_k||_r^2 / sigma_n^2 ~ chi2(n_rx nu)                     (silent chirp, no attack)

the one-receiver law with N_s -> n_rx N_s. A deterministic echo reaches receiver r as v_r x_k with |v_r| = 1 (unit
modulus steering), so every receiver holds the power of the first: the noncentrality is n_rx nu snr, again N_s ->
n_rx N_s with the same snr. PF(eta), its threshold and D0's spread (1 / sqrt(2 n_rx nu)) are the one receiver's
with n_rx times the samples (`stats.pf_pm_closed_form(..., n_rx=)`).

An attacker is one transmitter: its signal a reaches receiver r as v_r a, the same samples on every receiver up to
a phase, so its components do not add degrees of freedom the way the noise does. Per sample, the attack's covariance
over the receivers' real components is sigma_a^2 times a matrix whose non-zero eigenvalues, the *gains* g_j, sum to
n_rx (`steering_gains`): one gain n_rx for I/Q at any angle (v v^H has rank one); for I-only (the real part of the
steered analytic signal) the two eigenvalues (n_rx +- |sum_r v_r^2|) / 2 of Re(v v^H), one gain n_rx at broadside.
Each gain holds nu components, so the silent chirp's energy is a generalised chi-square,

    E = n_rx nu ||R_k||_r^2 / sigma_n^2 ~ sum_j (1 + g_j RARMS^2) chi2(nu) + chi2((n_rx - J) nu),

with the mean n_rx nu (1 + RARMS^2) of an attack independent on every receiver (gains 1, ..., 1: the dof-add law
(1 + RARMS^2) chi2(n_rx nu)) but a wider spread: the attack brings nu degrees of freedom, not n_rx nu.
`silent_log_cdf` computes log P(E < c) exactly: chi2's own function for equal weights, Imhof's inversion of the
characteristic function otherwise (absolute error below 1e-12).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import integrate, optimize, stats

from carav_stream.detect.detector import PAPER_ETA, Detection, check_rho, chirp_rms, detect_from_rms

__all__ = ["receiver_count", "per_receiver_from_rms", "per_receiver_detect", "per_receiver_q", "steering_gains",
           "silent_log_cdf"]


def receiver_count(n_rx) -> int:
    """`n_rx` as the int it must be (>= 1, not a bool); ValueError naming it otherwise."""
    if isinstance(n_rx, bool) or int(n_rx) != n_rx or n_rx < 1:
        raise ValueError(f"n_rx: must be an integer >= 1, got {n_rx!r}")
    return int(n_rx)


def per_receiver_from_rms(rms, rho, sigma_n, eta: float = PAPER_ETA) -> Detection:
    """The detector on every receiver alone: rms float (n_cycles, n_rx, n_chirps), each receiver's own chirp RMS
    (`chirp_rms` or `chirp_rms_codes` of the frames without receivers=True); rho (n_chirps,) or (n_cycles,
    n_chirps), shared by the receivers; sigma_n scalar or (n_cycles,). Returns a Detection whose per-cycle fields
    are (n_cycles, n_rx) and per-chirp fields (n_cycles, n_rx, n_chirps): receiver r of cycle i is judged as
    `detect_from_rms(rms[i, r], rho[i], sigma_n[i], eta)` (the receiver axis folded into the cycle axis)."""
    r = np.asarray(rms, dtype=np.float64)
    if r.ndim != 3:
        raise ValueError(f"rms: expected shape (n_cycles, n_rx, n_chirps), got {r.shape}")
    n_cycles, n_rx, n_chirps = r.shape
    rho_arr = check_rho(rho, n_chirps, n_cycles)
    if rho_arr.ndim == 2:
        rho_arr = np.repeat(rho_arr, n_rx, axis=0)
    sigma = np.asarray(sigma_n, dtype=np.float64)
    if sigma.ndim > 1 or (sigma.ndim == 1 and sigma.shape[0] not in (1, n_cycles)):
        raise ValueError(f"sigma_n: expected a scalar or one value per cycle ({n_cycles}), got shape {sigma.shape}")
    if sigma.ndim == 1 and sigma.shape[0] > 1:
        sigma = np.repeat(sigma, n_rx)
    d = detect_from_rms(r.reshape(n_cycles * n_rx, n_chirps), rho_arr, sigma if sigma.ndim else float(sigma), eta)

    def unfold(a: np.ndarray) -> np.ndarray:
        return a.reshape(n_cycles, n_rx, *a.shape[1:])

    return Detection(unfold(d.rms), unfold(d.d0), unfold(d.d1), unfold(d.d), unfold(d.rbar), unfold(d.q),
                     unfold(d.c), unfold(d.alarm), unfold(d.invalid), unfold(d.k_max), unfold(d.by_d1), d.eta)


def per_receiver_detect(frames, rho, sigma_n, eta: float = PAPER_ETA) -> Detection:
    """`per_receiver_from_rms` of float frames (n_cycles, n_rx, n_chirps, n_samples), or (n_rx, n_chirps,
    n_samples) for one cycle (fields then (n_rx,) and (n_rx, n_chirps))."""
    x = np.asarray(frames)
    if x.ndim not in (3, 4):
        raise ValueError(f"frames: expected shape (n_rx, n_chirps, n_samples) or (n_cycles, n_rx, n_chirps, "
                         f"n_samples), got {x.shape}")
    single = x.ndim == 3
    rho_arr = np.asarray(rho)
    if single and rho_arr.ndim == 2:
        raise ValueError(f"rho: got shape {rho_arr.shape} (a batch) for a single cycle of shape {x.shape}")
    d = per_receiver_from_rms(chirp_rms(x[None] if single else x), rho_arr, sigma_n, eta)
    if not single:
        return d
    return Detection(*(getattr(d, f)[0] for f in ("rms", "d0", "d1", "d", "rbar", "q", "c", "alarm", "invalid",
                                                     "k_max", "by_d1")), d.eta)


def per_receiver_q(frames, rho, sigma_n) -> np.ndarray:
    """Q of every receiver alone, float64 (n_cycles, n_rx) (+inf for a receiver whose chirps hold NaN or Inf)."""
    return per_receiver_detect(frames, rho, sigma_n, 1.0).q


def steering_gains(phases_rad, iq: bool) -> tuple[float, ...]:
    """The non-zero eigenvalues (largest first, summing to n_rx) of the attack's covariance over the receivers'
    real components per sample, in units of its power on one receiver, for the unit-modulus steering
    v_r = exp(j phases_rad[r]): (n_rx,) for I/Q; ((n_rx + |s|) / 2, (n_rx - |s|) / 2), s = sum_r v_r^2, for I-only
    (a zero dropped: broadside gives (n_rx,))."""
    phases = np.atleast_1d(np.asarray(phases_rad, dtype=np.float64))
    n = phases.size
    if n < 1 or not np.all(np.isfinite(phases)):
        raise ValueError(f"phases_rad: need at least one finite phase, got {phases_rad!r}")
    if iq:
        return (float(n),)
    s = min(float(abs(np.sum(np.exp(2j * phases)))), float(n))
    return tuple(g for g in ((n + s) / 2, (n - s) / 2) if g > 1e-9 * n)


def _check_gains(gains, n_rx: int) -> np.ndarray:
    g = np.asarray(gains, dtype=np.float64)
    if g.ndim != 1 or not 1 <= g.size <= n_rx or np.any(g <= 0) or abs(g.sum() - n_rx) > 1e-9 * n_rx:
        raise ValueError(f"attack_gains: expected 1 to {n_rx} positive gains summing to n_rx = {n_rx}, got {gains!r}")
    return g


def _imhof_sf(c: float, weights: np.ndarray, dofs: np.ndarray) -> float:
    """P(sum_j w_j chi2(k_j) > c) by Imhof's formula:  1/2 + (1/pi) int_0^inf sin(theta(u)) / (u rho(u)) du,
    theta(u) = (1/2) sum_j k_j atan(w_j u) - c u / 2,  rho(u) = prod_j (1 + w_j^2 u^2)^(k_j / 4); the integral stops
    where rho exceeds e^40 (the rest is below e^-40 / u)."""
    def log_rho(u: float) -> float:
        return 0.25 * float(np.sum(dofs * np.log1p((weights * u) ** 2)))

    def f(u: float) -> float:
        if u == 0.0:
            return 0.5 * (float(np.sum(dofs * weights)) - c)
        theta = 0.5 * float(np.sum(dofs * np.arctan(weights * u))) - 0.5 * c * u
        return math.sin(theta) / u * math.exp(-log_rho(u))

    u_max = 1.0 / float(weights.max())
    while log_rho(u_max) < 40.0:
        u_max *= 2.0
    u_max = optimize.brentq(lambda u: log_rho(u) - 40.0, 0.0, u_max)
    scale = 1.0 / math.sqrt(float(np.sum(dofs * weights ** 2)))          # the integrand's width near 0
    edges = [0.0, *(k * scale for k in (0.5, 1, 2, 4, 8) if k * scale < u_max), u_max]
    total = sum(integrate.quad(f, a, b, epsabs=1e-14, epsrel=1e-12, limit=400)[0] for a, b in zip(edges, edges[1:]))
    return min(max(0.5 + total / math.pi, 0.0), 1.0)


def silent_log_cdf(c, *, dof: int, n_rx: int, rarms: float, gains=None) -> np.ndarray:
    """log P(E < c) for a silent chirp's energy E = n_rx nu ||R_k||_r^2 / sigma_n^2 under the `random` attack of
    RARMS (0: none) on n_rx receivers: gains None for an attack independent on every receiver ((1 + RARMS^2)
    chi2(n_rx nu), exact), or the steering's gains (`steering_gains`) for one attacker on all of them (the
    generalised chi-square of the module docstring). c any shape; float64 like c; accurate down to
    probabilities of 1e-300 on the chi-square path, to an absolute 1e-12 on Imhof's."""
    c = np.asarray(c, dtype=np.float64)
    t = 1.0 + rarms ** 2
    weights = None
    if gains is not None and rarms > 0:
        g = _check_gains(gains, n_rx)
        if not np.allclose(g, 1.0, rtol=1e-12):
            weights = np.append(1.0 + g * rarms ** 2, 1.0)
            dofs = np.append(np.full(g.size, float(dof)), float((n_rx - g.size) * dof))
            weights, dofs = weights[dofs > 0], dofs[dofs > 0]
    if weights is None:
        nu = n_rx * dof
        sf = stats.chi2.sf(c / t, nu)
        with np.errstate(divide="ignore"):
            return np.where(sf < 0.5, np.log1p(-np.minimum(sf, 0.5)), stats.chi2.logcdf(c / t, nu))
    flat = c.ravel()
    uniq, inv = np.unique(flat, return_inverse=True)
    sf = np.array([_imhof_sf(float(x), weights, dofs) if x > 0 else 1.0 for x in uniq])
    with np.errstate(divide="ignore"):
        out = np.where(sf < 0.5, np.log1p(-np.minimum(sf, 0.5)), np.log(np.maximum(1.0 - sf, 0.0)))
    return out[inv].reshape(c.shape)
