"""The attacker's direction from the silent slots, and which detections lie in it.

A silent slot holds noise and the attack only, on every receiver: y_r(t) = exp(j 2 pi p_r s_a) a(t) + w_r(t), one
steering vector over the receive positions p (one-way; the transmitters play no part), s_a = sin(theta_a). Per cycle,
from all its silent slots' samples (T snapshots over the m receivers):

    R = 1 / T sum_t y_t y_t^H = P a a^H + sigma^2 I  (expected),   eigenvalues l_1 >= .. >= l_m, eigenvectors e_i

Snapshots: the samples themselves for I/Q (Parseval: the same R as their FFT bins); for I-only samples the bins
1 .. ceil(N/2) - 1 of each silent chirp's real FFT (the analytic signal): a real receiver's sample is
Re(a(t) exp(j psi_r)), whose positive beats carry exp(+j psi_r) for the part of the attack above the receiver's
local oscillator and exp(-j psi_r) for the part below, so the analytic covariance is
P_+ a(s_a) a(s_a)^H + P_- a(-s_a) a(-s_a)^H + sigma^2 I.

    attack present   the MDL order d of the eigenvalues (spectral.information_criterion_order, T snapshots) > 0;
                     d = 0: NaN, reason NO_ATTACK (a cycle without silent slots: NO_SILENT)
    noise            sigma^2 = the mean of the m - d smallest eigenvalues
    azimuth          I/Q, or I-only with d = 1: the ML single-source fit to the principal eigenvector, s maximising
                     |a(s)^H e_1|^2 (grid, parabolic vertex, Newton steps); I-only with d >= 2: the peak of
                     ||E_s^H a(s)||^2 over the two-dimensional signal subspace E_s (peaks at +-s_a, where both
                     a(+-s_a) lie in it), then P_+ and P_- by least squares of R - sigma^2 I on a a^H and
                     conj(a) conj(a)^H at +|s|: the sign of the side holding at least SIGN_RATIO times the other's
                     power; otherwise the sign is not observable (a white attack is as strong on both sides of the
                     oscillator, and a real receiver cannot tell them apart): |theta| is reported, reason MIRRORED
    confidence       INR = (sum_{i <= d} l_i - d sigma^2) / (m sigma^2): the attack's power over the noise per receiver;
                     l_1 / sigma^2; and the azimuth's stochastic Cramer-Rao deviation at that INR and T
                     (angle_crlb.attacker_azimuth_crlb)

With max_chirps, only the first max_chirps silent chirps of each cycle make R (T = max_chirps x the snapshots of a
chirp): samples gathered, transformed and multiplied in single precision, for a detector that must keep up with
the radar; the attacker transmits in every slot, so a few of its silent chirps hold as much of it as the others.

An echo's tail in a silent slot after an active one (firmware/leak.py) is a source too; the awr1642 preset's ADC
start leaves none, a scene that starts sampling earlier may.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

from carav_stream.estimate import spectral
from carav_stream.estimate.angle import sin_grid
from carav_stream.estimate.angle_crlb import attacker_azimuth_crlb
from carav_stream.estimate.virtual_array import steering

__all__ = ["ESTIMATED", "NO_SILENT", "NO_ATTACK", "MIRRORED", "REASONS", "REASON_KEYS", "AttackerDirection",
           "attacker_direction", "matches_attacker"]

ESTIMATED, NO_SILENT, NO_ATTACK, MIRRORED = 0, 1, 2, 3
REASONS = ("estimated", "no silent slot in the cycle", "no attack in the silent slots",
           "I-only: the attack is as strong on both sides of the oscillator, the azimuth's sign is not observable")
REASON_KEYS = ("estimated", "no_silent", "no_attack", "mirrored")   # the reasons' names in records
SIGN_RATIO = 2.0        # the stronger side's power over the weaker's that decides the sign (3 dB)
N_GRID = 1024           # the azimuth search grid in sin(theta) (then its parabolic vertex and Newton steps)
CHUNK_SAMPLES = 1 << 22  # cycles are taken in chunks of about this many samples (bounded memory)


@dataclass(frozen=True)
class AttackerDirection:
    """Per cycle, float64 (C,) but the counts; NaN where reason is NO_SILENT or NO_ATTACK.

    azimuth_deg      the attacker's azimuth (|azimuth| where reason is MIRRORED)
    azimuth_std_deg  its stochastic Cramer-Rao standard deviation at the measured INR
    inr_db           the attack's power over the noise's, per receiver sample
    eigen_ratio      l_1 / sigma^2
    n_sources        int64: the MDL order of the silent slots' covariance
    reason           int8: ESTIMATED, NO_SILENT, NO_ATTACK or MIRRORED (REASONS[reason] says it in words)
    """

    azimuth_deg: np.ndarray
    azimuth_std_deg: np.ndarray
    inr_db: np.ndarray
    eigen_ratio: np.ndarray
    n_sources: np.ndarray
    reason: np.ndarray


def _first_silent(x, silent, max_chirps):
    """(R, T) from the first max_chirps silent chirps of each cycle (module docstring): the chirps gathered cycle by
    cycle into float32 (C, m, k, N), transformed in place of the bins kept (the others zeroed, so the reshape to
    snapshots copies nothing) and multiplied in complex64."""
    n_cycles, n_rx, _, n_samp = x.shape
    n_silent = silent.sum(axis=1)
    k = int(min(max_chirps, n_silent.max(initial=0)))
    order = np.argsort(~silent, axis=1, kind="stable")[:, :k]                     # silent chirps first, in order
    taken = np.minimum(n_silent, k)
    part = x[np.arange(n_cycles)[:, None], :, order]                                # (C, k, m, N)
    part = np.transpose(part, (0, 2, 1, 3)).astype(np.complex64 if np.iscomplexobj(x) else np.float32, order="C")
    if (taken < k).any():                                                           # cycles with fewer silent chirps
        part *= (np.arange(k)[None, :] < taken[:, None])[:, None, :, None]
    if np.iscomplexobj(x):
        snap, per_chirp = part, n_samp
    else:
        per_chirp = (n_samp + 1) // 2 - 1
        snap = scipy.fft.rfft(part, axis=-1, overwrite_x=True)
        snap[..., 0] = 0
        snap[..., per_chirp + 1:] = 0
    snap = snap.reshape(n_cycles, n_rx, -1)
    cov = np.matmul(snap, np.swapaxes(snap.conj(), 1, 2)).astype(complex)
    count = taken * per_chirp
    return cov / np.maximum(count, 1)[:, None, None], count


def silent_covariance(frames, rho, max_chirps: int | None = None):
    """(R complex128 (C, m, m), T (C,)): the silent slots' spatial covariance per cycle and its snapshot count
    (module docstring). frames (C, m, M, N) float32 | complex64 (or int16 ADC codes of I-only receivers: R in
    codes^2), rho bool (C, M); max_chirps: the first max_chirps silent chirps of each cycle only."""
    x = np.asarray(frames)
    if max_chirps is not None:
        return _first_silent(x, ~np.asarray(rho, dtype=bool), max_chirps)
    n_cycles, n_rx, n_chirps, n_samp = x.shape
    silent = ~np.asarray(rho, dtype=bool)
    iq = np.iscomplexobj(x)
    per_chirp = n_samp if iq else (n_samp + 1) // 2 - 1
    cov = np.zeros((n_cycles, n_rx, n_rx), dtype=complex)
    step = max(1, CHUNK_SAMPLES // (n_rx * n_chirps * n_samp))
    for c0 in range(0, n_cycles, step):
        part = x[c0: c0 + step] * silent[c0: c0 + step, None, :, None]
        snap = part if iq else scipy.fft.rfft(part, axis=-1)[..., 1: per_chirp + 1]
        snap = snap.reshape(snap.shape[0], n_rx, -1)
        stacked = np.concatenate([snap.real, snap.imag], axis=1).astype(float)     # (c, 2m, T): real products
        g = np.matmul(stacked, np.swapaxes(stacked, 1, 2))
        cov[c0: c0 + step] = (g[:, :n_rx, :n_rx] + g[:, n_rx:, n_rx:]) + 1j * (g[:, n_rx:, :n_rx] - g[:, :n_rx, n_rx:])
    count = silent.sum(axis=1) * per_chirp
    return cov / np.maximum(count, 1)[:, None, None], count


def _peak(q, grid):
    """Parabolic vertex [sin theta] of the largest of q (C, G) on the grid (G,)."""
    i = np.argmax(q, axis=-1)
    three = np.take_along_axis(q, np.clip(i[:, None] + np.arange(-1, 2), 0, grid.size - 1), axis=-1)
    return np.clip(grid[i] + spectral.parabolic_delta(three[:, 0], three[:, 1], three[:, 2]) * (grid[1] - grid[0]),
                   -1.0, 1.0)


def _mirror_sign(cov, sigma2, s, p):
    """+1 / -1 where one side holds SIGN_RATIO times the other's power at +-s, 0 where neither does."""
    a = steering(p, s)                                                               # (C, m)
    m = p.size
    r = cov - sigma2[:, None, None] * np.eye(m)
    plus = np.einsum("ci,cij,cj->c", a.conj(), r, a).real
    minus = np.einsum("ci,cij,cj->c", a, r, a.conj()).real
    cross = np.abs((a * a).sum(axis=-1)) ** 2                                       # |a^H conj(a)|^2
    det = m ** 4 - cross ** 2
    safe = det > 1e-6 * m ** 4
    p_plus = np.where(safe, (m ** 2 * plus - cross * minus) / np.where(safe, det, 1.0), plus)
    p_minus = np.where(safe, (m ** 2 * minus - cross * plus) / np.where(safe, det, 1.0), 0.0)
    return np.where(p_plus >= SIGN_RATIO * p_minus, 1, np.where(p_minus >= SIGN_RATIO * p_plus, -1, 0))


def attacker_direction(frames, rho, rx_positions_wl, *, criterion: str = "mdl",
                       max_chirps: int | None = None) -> AttackerDirection:
    """The attacker's azimuth per cycle from its silent slots (module docstring). frames (C, m, M, N) float32 |
    complex64 (or I-only int16 codes) with m >= 2 receivers at rx_positions_wl [wavelengths]; rho bool (C, M),
    constant within a TDM loop; max_chirps: only the first max_chirps silent chirps of each cycle (None: all)."""
    x = np.asarray(frames)
    p = np.asarray(rx_positions_wl, dtype=float)
    if x.ndim != 4 or x.shape[1] != p.size or p.size < 2:
        raise ValueError(f"attacker_direction: frames must be (n_cycles, n_rx, n_chirps, n_samples) with n_rx = "
                         f"{p.size} >= 2 receivers, got shape {x.shape}")
    if np.shape(rho) != (x.shape[0], x.shape[2]):
        raise ValueError(f"attacker_direction: rho must be {(x.shape[0], x.shape[2])}, got {np.shape(rho)}")
    iq, m = np.iscomplexobj(x), p.size
    cov, count = silent_covariance(x, rho, max_chirps)
    lam, vec = np.linalg.eigh(cov)                                                  # ascending
    d = spectral.information_criterion_order(lam, np.maximum(count, 1), criterion=criterion, max_order=m - 1)
    d = np.where(count > 0, d, 0)
    below = np.arange(m)[None, :] < (m - d)[:, None]
    sigma2 = (lam * below).sum(axis=1) / below.sum(axis=1)
    grid = sin_grid(N_GRID)
    a = steering(p, grid)                                                           # (G, m)
    one = np.abs(vec[:, :, -1].conj() @ a.T) ** 2                                   # |e_1^H a(s)|^2 (C, G)
    s = spectral.newton_refine(vec[:, :, -1], _peak(one, grid), n_iter=3, max_step=0.5 / (p.max() - p.min()),
                               times=p)
    reason = np.where(count == 0, NO_SILENT, np.where(d == 0, NO_ATTACK, ESTIMATED)).astype(np.int8)
    two = (not iq) & (d >= 2)
    if two.any():
        sub = vec[two][:, :, -2:]
        q = (np.abs(np.swapaxes(sub.conj(), 1, 2) @ a.T) ** 2).sum(axis=1)
        s_abs = np.abs(_peak(q, grid))
        sign = _mirror_sign(cov[two], sigma2[two], s_abs, p)
        s[two] = np.where(sign == 0, s_abs, sign * s_abs)
        reason[two] = np.where(sign == 0, MIRRORED, ESTIMATED)
    top = np.arange(m)[None, :] >= (m - d)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        inr = ((lam * top).sum(axis=1) - d * sigma2) / (m * sigma2)
        azimuth = np.degrees(np.arcsin(np.clip(s, -1.0, 1.0)))
        std = attacker_azimuth_crlb(inr, count, p, azimuth)["deg"]
        ratio = lam[:, -1] / sigma2
        inr_db = 10 * np.log10(inr)
    none = reason == NO_SILENT
    none |= reason == NO_ATTACK

    def keep(v):
        return np.where(none, np.nan, v)
    return AttackerDirection(keep(azimuth), keep(std), keep(inr_db), keep(ratio), d.astype(np.int64), reason)


def matches_attacker(azimuth_deg, azimuth_std_deg, attacker: AttackerDirection, *, n_sigma: float = 3.0,
                     floor_deg: float = 0.0) -> np.ndarray:
    """bool (C, K): a detection whose azimuth (C, K) lies within n_sigma sqrt(std_det^2 + std_att^2) + floor_deg of
    its cycle's attacker (|azimuths| compared where the attacker's sign is not observable); False where either is
    NaN."""
    det, det_std = np.asarray(azimuth_deg, dtype=float), np.asarray(azimuth_std_deg, dtype=float)
    att, att_std = attacker.azimuth_deg[:, None], attacker.azimuth_std_deg[:, None]
    mirrored = (attacker.reason == MIRRORED)[:, None]
    diff = np.where(mirrored, np.abs(np.abs(det) - np.abs(att)), np.abs(det - att))
    with np.errstate(invalid="ignore"):
        return diff <= n_sigma * np.hypot(det_std, att_std) + floor_deg
