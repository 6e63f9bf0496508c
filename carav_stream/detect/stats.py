"""Statistics of the CARAV detector: Clopper-Pearson intervals, closed-form PF/PM, importance sampling.

Closed forms hold for the paper's model (see `paper_model`): white Gaussian noise of RMS sigma_n, nu real degrees of
freedom per chirp (N_s for I-only, 2 N_s for I/Q), M = N_r / 2 silent and M active chirps, a deterministic echo of
power ratio snr = ||x||_r^2 / sigma_n^2 on every active chirp, and optionally the `random` attack of RMS
RARMS * sigma_n on every chirp (total Gaussian power ratio t = 1 + RARMS^2).

    ||R_k||_r^2 = sigma_n^2 t chi2(nu) / nu                    silent chirp
    ||R_k||_r^2 = sigma_n^2 t ncx2(nu, nu snr / t) / nu        active chirp

D0 part (EXACT):     P(max_silent D0 < eta) = F_chi2(nu)(nu eta^2 / t) ^ M
D1 part (APPROXIMATE, numerical integration): with S the mean RMS of the other M-1 active chirps,
    D1(k) >= eta  <=>  rms_k >= ((1+eta)(M-1) S + eta M sigma) / (M-1-eta)
                   or  rms_k <= ((1-eta)(M-1) S - eta M sigma) / (M-1+eta)
  S is replaced by a normal law with the exact mean and variance of the chi RMS (CLT over M-1 >= 31 chirps), the
  per-chirp probability is integrated by Gauss-Hermite quadrature, and the M chirps are treated as independent
  (1 - (1-p)^M). Silent and active chirps are independent, so the two parts combine exactly:
    P(Q < eta) = P(D0 part quiet) * P(D1 part quiet).
  With M = 1 (N_r = 2) the one active chirp is its own mean: D1 = 0 on every cycle, so the D1 part is quiet for
  every eta > 0 and alarms for eta <= 0 (as Q >= eta always does), EXACTLY; Q is then D0 of the one silent chirp.
PF(eta) = 1 - P(Q < eta) with t = 1; PM(eta) = P(Q < eta) under the attack.

A receiver array (n_rx receivers, the detector on each chirp's RMS over all of them, independent noise per
receiver, unit-modulus steering of the echo): the same laws with nu -> n_rx nu (`carav_stream.detect.receivers`
gives the argument). One attacker's signal on every receiver is not independent across them: with its steering's
gains (`receivers.steering_gains`) D0's part is that of a generalised chi-square, exactly (`receivers.
silent_log_cdf`); D1's part keeps the independent law's approximation there (it only counts where eta is so low
that D0's part already alarms on every attacked cycle: an attack adds about the same power to every chirp).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.special._ufuncs as _scipy_ufuncs
from scipy import integrate, special, stats

from carav_stream.detect.detector import detect_from_rms
from carav_stream.detect.receivers import receiver_count, silent_log_cdf

__all__ = ["clopper_pearson", "pf_pm_closed_form", "rms_moments", "cfar_eta_closed_form",
           "pf_importance_sampling"]


def clopper_pearson(k, n, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Exact (Clopper-Pearson) two-sided interval for a binomial proportion k / n; vectorised over k."""
    k = np.asarray(k, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    if np.any(k < 0) or np.any(k > n) or np.any(n <= 0):
        raise ValueError(f"clopper_pearson: need 0 <= k <= n and n > 0, got k={k}, n={n}")
    alpha = 1.0 - confidence
    with np.errstate(invalid="ignore"):
        low = np.where(k > 0, stats.beta.ppf(alpha / 2, k, n - k + 1), 0.0)
        high = np.where(k < n, stats.beta.isf(alpha / 2, k + 1, n - k), 1.0)
    return low, high


def _ncx2_density(nu: int, nonc: float):
    """x -> the density of ncx2(nu, nonc > 0) at a point of its support: the very function scipy.stats.ncx2.pdf
    evaluates there (its ufunc), the same numbers (tests/detect/test_stats.py), without pdf's handling of
    arguments, shapes and support, which a quadrature calling it one point at a time would pay at every point and
    which costs far more than the density itself."""
    ufunc = getattr(_scipy_ufuncs, "_ncx2_pdf", None)     # where this scipy's ncx2 takes its density from
    if ufunc is None:                                      # another scipy: its own per-distribution method
        return lambda x: stats.ncx2._pdf(np.float64(x), nu, nonc)

    def density(x: float) -> float:
        with np.errstate(over="ignore"):                  # as ncx2's own call of it
            return ufunc(x, nu, nonc)
    return density


@lru_cache(maxsize=256)
def rms_moments(nu: int, nonc: float, t: float = 1.0) -> tuple[float, float]:
    """Mean and variance of ||R||_r / sigma_n for ||R||_r^2 / sigma_n^2 = t ncx2(nu, nonc) / nu (cached: a threshold
    search asks the same moments at every eta, each one a quadrature)."""
    scale = np.sqrt(t / nu)
    if nonc == 0:
        mean1 = np.sqrt(2.0) * np.exp(special.gammaln((nu + 1) / 2) - special.gammaln(nu / 2))
    else:
        dist = stats.ncx2(nu, nonc)
        lo, hi = dist.ppf(1e-14), dist.isf(1e-14)
        pdf = _ncx2_density(nu, nonc)                      # ncx2.pdf's numbers on the support [lo, hi]
        mean1 = integrate.quad(lambda x: np.sqrt(x) * pdf(x), lo, hi, epsabs=0, epsrel=1e-12, limit=200)[0]
    second = nu + nonc
    return float(scale * mean1), float(scale ** 2 * max(second - mean1 ** 2, 0.0))


def _d1_quiet(eta: np.ndarray, nu: int, m: int, snr: float, t: float, n_nodes: int = 48) -> np.ndarray:
    """Approximate P(all M active chirps have D1 < eta) (normal leave-one-out mean, independent chirps); exact for
    M = 1, where D1 = 0."""
    if m == 1:
        return (eta > 0).astype(np.float64)
    nonc = nu * snr / t
    mu, var = rms_moments(nu, nonc, t)
    sd = np.sqrt(var / (m - 1))
    x, w = special.roots_hermitenorm(n_nodes)
    s_vals = np.maximum(mu + sd * x, 0.0)                        # (nodes,) values of the leave-one-out mean
    w = w / w.sum()
    dist = stats.ncx2(nu, nonc) if nonc > 0 else stats.chi2(nu)
    e = eta.reshape(-1, 1)                                       # (n_eta, 1) x (nodes,) grids, one sf call
    p = np.zeros((e.shape[0], s_vals.size))
    # arguments more than 60 standard deviations from the mean have tail probabilities below 1e-700: skip them
    centre, spread = nu + nonc, 60.0 * np.sqrt(2.0 * (nu + 2.0 * nonc))
    up = (m - 1 - e[:, 0]) > 0
    if np.any(up):
        u = ((1 + e[up]) * (m - 1) * s_vals + e[up] * m) / (m - 1 - e[up])       # RMS in sigma_n units
        x = nu * u ** 2 / t
        near = x < centre + spread
        block = np.zeros_like(x)
        block[near] = dist.sf(x[near])
        p[up] += block
    lo = ((1 - e) * (m - 1) * s_vals - e * m) / (m - 1 + e)
    pos = (lo > 0) & (nu * np.maximum(lo, 0) ** 2 / t > centre - spread)
    if np.any(pos):
        p[pos] += dist.cdf(nu * lo[pos] ** 2 / t)
    p1 = np.minimum(np.minimum(p, 1.0) @ w, 1.0)
    with np.errstate(divide="ignore"):
        out = np.where(p1 < 1, np.exp(m * np.log1p(-p1)), 0.0)
    return out.reshape(eta.shape)


def _half(n_chirps: int) -> int:
    """M = N_r / 2, for an even N_r >= 2 (the detector needs a silent and an active chirp)."""
    if n_chirps < 2 or n_chirps % 2:
        raise ValueError(f"n_chirps: must be an even number >= 2 (half the chirps are active), got {n_chirps}")
    return n_chirps // 2


def pf_pm_closed_form(eta, *, n_chirps: int, dof: int, snr: float = 1.0, rarms: float = 0.0, n_rx: int = 1,
                      attack_gains=None) -> dict:
    """P(alarm) (PF when rarms = 0) and P(no alarm) (PM when rarms > 0, `random` attack) over an eta grid.

    eta       thresholds, any shape
    n_chirps  N_r;  dof  nu (N_s I-only, 2 N_s I/Q) per receiver;  snr  echo power / noise power;
    rarms     sigma_a / sigma_n;  n_rx  receivers, the detector on each chirp's RMS over all of them
    attack_gains  None: the attack independent on every receiver (as the noise: nu -> n_rx nu); or the gains of one
              attacker's steering (`receivers.steering_gains`), the law of D0's part then a generalised chi-square
    returns   dict of float64 arrays like eta:
              quiet_d0 (exact), quiet_d1 (approximate), p_alarm = 1 - quiet_d0 * quiet_d1,
              p_alarm_d0 = 1 - quiet_d0 (exact), p_quiet = quiet_d0 * quiet_d1;
              computed through logs so that probabilities down to 1e-300 are resolved (1e-12 absolute on Imhof's
              path, for steering gains other than ones under an attack).
    """
    eta = np.asarray(eta, dtype=np.float64)
    m = _half(n_chirps)
    n_rx = receiver_count(n_rx)
    nu = dof * n_rx
    t = 1.0 + rarms ** 2
    # log F^M with F = cdf; 1 - F^M = -expm1(M log F) keeps tiny PF accurate (log F = log1p(-sf))
    log_cdf0 = silent_log_cdf(nu * eta ** 2, dof=dof, n_rx=n_rx, rarms=rarms, gains=attack_gains)
    quiet_d0 = np.exp(m * log_cdf0)
    quiet_d1 = _d1_quiet(eta, nu, m, snr, t)
    p_alarm_d0 = np.maximum(-np.expm1(m * log_cdf0), 0.0)
    log_quiet = m * log_cdf0 + np.log(np.maximum(quiet_d1, 1e-300))
    return {"quiet_d0": quiet_d0, "quiet_d1": quiet_d1, "p_quiet": np.exp(log_quiet),
            "p_alarm": np.maximum(-np.expm1(log_quiet), 0.0), "p_alarm_d0": p_alarm_d0}


def cfar_eta_closed_form(target_pf: float, *, n_chirps: int, dof: int, n_rx: int = 1) -> float:
    """Threshold eta with PF = target_pf for the D0 part, exactly:  F_chi2(nu)(nu eta^2)^M = 1 - target_pf, with
    nu = n_rx dof for n_rx receivers.

    The D1 part of PF is negligible at such thresholds (check it with `pf_pm_closed_form`).
    """
    if not 0 < target_pf < 1:
        raise ValueError(f"target_pf: must be in (0, 1), got {target_pf!r}")
    m = _half(n_chirps)
    nu = dof * receiver_count(n_rx)
    per_chirp_sf = -np.expm1(np.log1p(-target_pf) / m)
    return float(np.sqrt(stats.chi2.isf(per_chirp_sf, nu) / nu))


def pf_importance_sampling(eta, *, n_chirps: int, dof: int, snr: float, n_trials: int,
                           rng: np.random.Generator, tilt: float | None = None) -> dict:
    """PF(eta) of the full detector (D0 and D1) by importance sampling, for probabilities far below 1 / n_trials.

    Proposal: a defensive mixture over the M silent chirps. Each trial picks one silent chirp j uniformly and draws
    its energy from chi2(nu) scaled by `tilt` (default eta^2, which puts its RMS at the threshold); every other chirp
    (silent and active) keeps its nominal law. The likelihood ratio is exact:
        p / q = 1 / mean_j L_j,   log L_j = -(nu/2) log(tilt) + E_j (1 - 1/tilt) / 2     (E_j in noise units)
    returns dict(pf, std_err, rel_err, n_trials, method) for the scalar eta (noise units, sigma_n = 1).
    """

    eta = float(eta)
    tilt = eta ** 2 if tilt is None else float(tilt)
    if not tilt > 1:
        raise ValueError(f"tilt: must be > 1 (eta > 1), got {tilt!r}")
    m = n_chirps // 2
    rho = np.zeros(n_chirps, dtype=bool)
    rho[:m] = True
    silent_e = 2.0 * rng.standard_gamma(dof / 2.0, size=(n_trials, m))
    j = rng.integers(0, m, size=n_trials)
    silent_e[np.arange(n_trials), j] = tilt * 2.0 * rng.standard_gamma(dof / 2.0, size=n_trials)
    lam = dof * snr
    active_e = 2.0 * rng.standard_gamma((dof - 1) / 2.0, size=(n_trials, m)) \
        + (rng.standard_normal((n_trials, m)) + np.sqrt(lam)) ** 2
    log_l = -0.5 * dof * np.log(tilt) + silent_e * (1 - 1 / tilt) / 2
    log_w = np.log(m) - special.logsumexp(log_l, axis=-1)
    rms = np.sqrt(np.concatenate([active_e, silent_e], axis=-1) / dof)
    hit = detect_from_rms(rms, rho, 1.0, eta).alarm
    vals = np.where(hit, np.exp(log_w), 0.0)
    pf = float(vals.mean())
    se = float(vals.std(ddof=1) / np.sqrt(n_trials))
    return {"pf": pf, "std_err": se, "rel_err": se / pf if pf > 0 else float("inf"), "n_trials": n_trials,
            "method": "importance sampling"}
