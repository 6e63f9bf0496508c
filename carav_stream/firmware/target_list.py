"""The radar's target list (Algorithm 1, step 6, as automotive radars decide what exists): CFAR detection on the
range-Doppler map of the active chirps (carav_stream/firmware/cfar.py: exact design false-alarm rate per cell for
half-silent cycles), then every detection refined towards its Cramer-Rao bound from its cell
(carav_stream.estimate.estimators.refine_at: interpolation, then joint ML / MUSIC refinement of the targets of a
cycle, each with the others cancelled).

    cells    = CFAR(rd_power(frames, rho, sigma_n), pfa per cell, CA or OS)   strongest first, sidelobes removed
    targets  = refine_at(frames, rho, f = range bin / N, nu = Doppler bin / M)

This list is the "radar would report it" reference of the ghost and interference studies, and what the
range_estimator block sends with `detection = "ca_cfar" | "os_cfar"`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.detect.rdmap import rd_power
from carav_stream.estimate.estimators import DEFAULT_METHOD, refine_at
from carav_stream.estimate.geometry import Geometry
from carav_stream.firmware import cfar

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
                method: str = DEFAULT_METHOD, max_targets: int = 8, n_newton: int = 1,
                max_speed_mps: float = 0.0) -> TargetList:
    """CFAR target list of every cycle, refined by `method` (see the module docstring).

    max_speed_mps > 0: range migration compensated (estimate/migration.py): each listed cell is refined along the
    range walk of the velocity alias within +-max_speed_mps that integrates most power, so velocities come
    unaliased, and what a stronger target explains (the same target from another cell of its walk, or a slow-time
    sidelobe along the walk) is left out (_merged)."""
    if detection not in KINDS:
        raise ValueError(f"detection: expected one of {sorted(KINDS)}, got {detection!r}")
    x, r = np.asarray(frames), np.asarray(rho, dtype=bool)
    det = cfar.detect_targets(rd_power(x, r, sigma_n, single=True), r, pfa=pfa, kind=KINDS[detection],
                              max_targets=max_targets)
    width = max(1, int(det.n_found.max(initial=0)))
    ok = det.range_bin[:, :width] >= 0
    fft_bin = det.range_bin[:, :width] + (0 if geometry.iq else 1)        # I-only maps start at FFT bin 1
    f0 = np.where(ok, fft_bin / x.shape[-1], np.nan)
    nu0 = np.where(ok, det.doppler_bin[:, :width] / r.shape[1], np.nan)
    est = refine_at(x, r, geometry, f0, nu0, method=method, n_newton=n_newton, max_speed_mps=max_speed_mps)
    found = np.arange(width)[None, :] < est.n_found[:, None]
    tl = TargetList(est.range_m, est.velocity_mps, np.where(found, det.snr_db[:, :width], np.nan), est.amplitude,
                    est.n_found)
    return _merged(tl, geometry, r, det.range_bin[:, :width]) if max_speed_mps > 0 else tl


def _merged(tl: TargetList, geometry: Geometry, rho: np.ndarray, cells: np.ndarray) -> TargetList:
    """The list without what a stronger target of the same cycle explains, strongest first as listed: a target
    within 1.5 range cells and 1.5 Doppler bins of it (the same target, listed from two cells of its walk), or
    one whose map cell (`cells`, range bins (C, K)) lies within one bin plus the stronger one's walk over the
    cycle and is weaker than its worst slow-time sidelobe (cfar.worst_sidelobe_ratio x SIDELOBE_MARGIN: the CFAR's
    own sidelobe test, which on the map looks only at the range bins next to the peak, while a migrating target's
    sidelobes lie along its walk; a real target that close and that much weaker is left out with them)."""
    n_chirps = rho.shape[1]
    res, v_gate = geometry.range_resolution_m, 1.5 * 2 * geometry.max_velocity_mps / n_chirps
    psl_db = 10 * np.log10(cfar.worst_sidelobe_ratio(rho) * cfar.SIDELOBE_MARGIN)[:, None]
    keep = np.isfinite(tl.range_m)
    for j in range(1, keep.shape[1]):
        dr = np.abs(tl.range_m[:, :j] - tl.range_m[:, j:j + 1])
        walk_bins = np.abs(tl.velocity_mps[:, :j]) * n_chirps * geometry.t_chirp_s / res
        same = (dr <= 1.5 * res) & (np.abs(tl.velocity_mps[:, :j] - tl.velocity_mps[:, j:j + 1]) <= v_gate)
        sidelobe = ((np.abs(cells[:, :j] - cells[:, j:j + 1]) <= 1 + walk_bins)
                    & (tl.snr_db[:, j:j + 1] < tl.snr_db[:, :j] + psl_db))
        keep[:, j] &= ~((same | sidelobe) & keep[:, :j]).any(axis=1)
    order = np.argsort(~keep, axis=1, kind="stable")                     # kept targets first, in listed order
    n = keep.sum(axis=1)
    pad = np.arange(keep.shape[1])[None, :] >= n[:, None]

    def pick(a):
        return np.where(pad, np.nan, np.take_along_axis(a, order, axis=1))
    return TargetList(pick(tl.range_m), pick(tl.velocity_mps), pick(tl.snr_db), pick(tl.amplitude), n.astype(np.int64))


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
