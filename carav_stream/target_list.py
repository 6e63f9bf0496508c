"""The radar's target list (Algorithm 1, step 6, as automotive radars decide what exists): CFAR detection on the
range-Doppler map of the active chirps (carav_stream/detect/cfar.py: exact design false-alarm rate per cell for
half-silent cycles), then every detection refined towards its Cramer-Rao bound from its cell
(carav_stream/estimate/estimators.refine_at: interpolation, then joint ML / MUSIC refinement of the targets of a
cycle, each with the others cancelled).

    cells    = CFAR(rd_power(frames, rho, sigma_n), pfa per cell, CA or OS)   strongest first, sidelobes removed
    targets  = refine_at(frames, rho, f = range bin / N, nu = Doppler bin / M)

This list is the "radar would report it" reference of the ghost and interference studies, and what the
range_estimator block sends with `detection = "ca_cfar" | "os_cfar"`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.detect import cfar
from carav_stream.estimate.estimators import DEFAULT_METHOD, refine_at
from carav_stream.estimate.geometry import Geometry

KINDS = {"ca_cfar": "ca", "os_cfar": "os"}


@dataclass(frozen=True)
class TargetList:
    """Targets per cycle, strongest first, NaN after the last (n_found) of a cycle.

    range_m, velocity_mps   float64 (C, K)  refined range (coupling removed) and radial velocity
    snr_db                  float64 (C, K)  SNR after integration, from the CFAR cell's normalised power
    amplitude               float64 (C, K)  tone amplitude per sample at the refined frequencies, input units
    n_found                 int64 (C,)
    """

    range_m: np.ndarray
    velocity_mps: np.ndarray
    snr_db: np.ndarray
    amplitude: np.ndarray
    n_found: np.ndarray


def target_list(frames, rho, geometry: Geometry, sigma_n: float, *, detection: str = "ca_cfar", pfa: float = 1e-6,
                method: str = DEFAULT_METHOD, max_targets: int = 8, n_newton: int = 1) -> TargetList:
    """CFAR target list of every cycle, refined by `method` (see the module docstring)."""
    if detection not in KINDS:
        raise ValueError(f"detection: expected one of {sorted(KINDS)}, got {detection!r}")
    x, r = np.asarray(frames), np.asarray(rho, dtype=bool)
    det = cfar.detect_targets(cfar.rd_power(x, r, sigma_n, single=True), r, pfa=pfa, kind=KINDS[detection],
                              max_targets=max_targets)
    width = max(1, int(det.n_found.max(initial=0)))
    ok = det.range_bin[:, :width] >= 0
    fft_bin = det.range_bin[:, :width] + (0 if geometry.iq else 1)        # I-only maps start at FFT bin 1
    f0 = np.where(ok, fft_bin / x.shape[-1], np.nan)
    nu0 = np.where(ok, det.doppler_bin[:, :width] / r.shape[1], np.nan)
    est = refine_at(x, r, geometry, f0, nu0, method=method, n_newton=n_newton)
    found = np.arange(width)[None, :] < est.n_found[:, None]
    return TargetList(est.range_m, est.velocity_mps, np.where(found, det.snr_db[:, :width], np.nan), est.amplitude,
                      est.n_found)


def gates(geometry: Geometry, n_chirps: int, speed_mps: float = 0.0) -> tuple[float, float]:
    """(range, velocity) association gates of one listed target with a true one: 1.5 range resolution cells plus
    half the range the target covers during a cycle of n_chirps (an estimate averages over the cycle), and
    1.5 Doppler bins."""
    doppler_bin = 2 * geometry.max_velocity_mps / n_chirps
    migration = abs(speed_mps) * n_chirps * geometry.t_chirp_s
    return 1.5 * geometry.range_resolution_m + migration / 2, 1.5 * doppler_bin


def associate(ranges, velocities, truth_ranges, truth_velocities, range_gate: float, velocity_gate: float,
              v_max: float) -> tuple[np.ndarray, int]:
    """One cycle's list against the scene's true targets, nearest pairs first (distance in gate units), each
    listed target used once: (detected bool per true target, listed targets that match none: false targets).
    Velocities are compared modulo 2 v_max (the Doppler FFT cannot tell aliases apart)."""
    r, v = np.asarray(ranges, dtype=float), np.asarray(velocities, dtype=float)
    tr, tv = np.asarray(truth_ranges, dtype=float), np.asarray(truth_velocities, dtype=float)
    detected = np.zeros(tr.size, dtype=bool)
    if r.size == 0:
        return detected, 0
    dr = (r[:, None] - tr[None, :]) / range_gate
    dv = ((v[:, None] - tv[None, :] + v_max) % (2 * v_max) - v_max) / velocity_gate
    inside = (np.abs(dr) <= 1) & (np.abs(dv) <= 1)
    dist = np.where(inside, np.hypot(dr, dv), np.inf)
    used = np.zeros(r.size, dtype=bool)
    for flat in np.argsort(dist, axis=None):
        i, t = divmod(int(flat), tr.size)
        if not np.isfinite(dist[i, t]):
            break
        if not used[i] and not detected[t]:
            used[i] = detected[t] = True
    return detected, int(r.size - used.sum())
