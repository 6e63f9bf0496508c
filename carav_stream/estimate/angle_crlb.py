"""Cramer-Rao bounds of an azimuth over an arbitrary array: one target over the virtual array (deterministic signal),
and one attacker over the receivers (stochastic signal, from the silent slots' snapshots).

Target. After the range and Doppler sums at the target's beat and Doppler (both known; the TDM phase removed), virtual
channel v holds one snapshot

    z_v = b exp(j (phi + u x_v)) + w_v,     u = 2 pi sin(theta),   w_v circular, E|w_v|^2 = sigma^2 i.i.d.

with x_v the virtual positions [wavelengths] (any, duplicates allowed). Unknown (b, phi, u). The Fisher information
of a complex Gaussian mean mu(p) is J = (2 / sigma^2) Re(d mu^H d mu); with d mu / d phi = j mu, d mu / d u = j x mu,
d mu / d b = mu / b:

    J_bb = 2 V / sigma^2,   J_phi,phi = 2 b^2 V / sigma^2,   J_phi,u = 2 b^2 sum x / sigma^2,
    J_uu = 2 b^2 sum x^2 / sigma^2,

and b decouples (Re(conj(mu) j mu) = 0). The Schur complement of the phase gives

    var(u) >= 1 / (2 SNR_eff sum_v (x_v - mean x)^2),     SNR_eff = b^2 / sigma^2,

the single-tone frequency bound of crlb.py with the positions as sample times; sin(theta) has var(u) / (2 pi)^2 and
theta var(u) / (2 pi cos(theta))^2.

SNR_eff. A tone of amplitude a over N samples and L active loops, per-sample noise variance sigma_n^2: the sum
sum_{l,n} x exp(-j ..) holds a N L against noise of variance N L sigma_n^2 for I/Q samples, SNR_eff = SNR N L
(SNR = a^2 / sigma_n^2); a real tone a cos(.) in real noise has SNR = a^2 / (2 sigma_n^2) (the scene's per-sample
SNR) and the LS amplitude of its positive-frequency part (angle_refine.py) SNR_eff = SNR N L / 2, the bound twice the
I/Q one, as crlb.py's. Estimating the Doppler too couples it to u through the slots' times, which correlate with the
positions; the slots span one loop and the Doppler's information the L loops, so the bound grows by a fraction of
order 1 / L^2.

Attacker. T snapshots y_t = a(u) s_t + w_t over m receivers at positions p, s_t circular with power P, noise sigma^2;
INR = P / sigma^2. The stochastic bound for one source (Stoica and Nehorai 1990),
CRB = sigma^2 / (2 T) [Re((D^H P_a^perp D) (P a^H R^-1 a P))]^-1 with a^H R^-1 a = m / (sigma^2 (1 + m INR)):

    var(u) >= (1 + m INR) / (2 T m INR^2 sum_r (p_r - mean p)^2),

which tends to the deterministic 1 / (2 T INR sum (p - mean p)^2) when m INR >> 1.
"""
from __future__ import annotations

import numpy as np

__all__ = ["effective_snr", "azimuth_crlb", "attacker_azimuth_crlb", "position_spread"]


def position_spread(positions_wl) -> float:
    """sum (x - mean x)^2 [wavelengths^2] of the positions (P,)."""
    x = np.asarray(positions_wl, dtype=float)
    return float(np.sum((x - x.mean()) ** 2))


def effective_snr(snr_sample_db, n_samples: int, n_loops_active, *, iq: bool) -> np.ndarray:
    """SNR_eff per virtual channel after the range and Doppler sums (module docstring), float array broadcast over
    snr_sample_db (per-sample SNR [dB], the scene's definition) and n_loops_active."""
    snr = 10.0 ** (np.asarray(snr_sample_db, dtype=float) / 10.0)
    return snr * n_samples * np.asarray(n_loops_active, dtype=float) * (1.0 if iq else 0.5)


def _in_units(var_u, azimuth_deg) -> dict[str, np.ndarray]:
    cos = np.cos(np.radians(np.asarray(azimuth_deg, dtype=float)))
    std_sin = np.sqrt(var_u) / (2.0 * np.pi)
    with np.errstate(divide="ignore"):
        std_deg = np.degrees(std_sin / np.abs(cos))
    return {"var_u": var_u, "sin": std_sin, "deg": std_deg}


def azimuth_crlb(snr_eff, positions_wl, azimuth_deg) -> dict[str, np.ndarray]:
    """Bound of one target's azimuth over the virtual positions (P,) [wavelengths] at SNR_eff (linear, per channel):
    var_u (u = 2 pi sin theta, rad^2), sin (std of sin theta) and deg (std of theta [degrees]), float arrays
    broadcast over snr_eff and azimuth_deg."""
    with np.errstate(divide="ignore"):
        var_u = 1.0 / (2.0 * np.asarray(snr_eff, dtype=float) * position_spread(positions_wl))
    return _in_units(var_u, azimuth_deg)


def attacker_azimuth_crlb(inr, n_snapshots, rx_positions_wl, azimuth_deg) -> dict[str, np.ndarray]:
    """Stochastic bound of one attacker's azimuth from n_snapshots over the receivers (module docstring), inr its
    power over the noise's per receiver and snapshot (linear); the same keys as azimuth_crlb."""
    inr = np.asarray(inr, dtype=float)
    m = len(rx_positions_wl)
    with np.errstate(divide="ignore", invalid="ignore"):
        var_u = (1.0 + m * inr) / (2.0 * np.asarray(n_snapshots, dtype=float) * m * inr ** 2
                                   * position_spread(rx_positions_wl))
    return _in_units(var_u, azimuth_deg)
