"""Threshold design from PF(eta) and PM(eta) curves: minimax (the paper's), CFAR, minimum PF + PM.

Every function takes the eta grid and the curves (float arrays of the same length, PF non-increasing and PM
non-decreasing in eta for the CARAV detector) and optionally their Clopper-Pearson intervals ((n, 2) arrays), and
returns a JSON-ready dict: eta, pf, pm, pf_ci, pm_ci (when given) and design-specific fields.
"""
from __future__ import annotations

import numpy as np

__all__ = ["minimax", "cfar", "min_sum", "design_thresholds"]


def _check(eta, pf, pm):
    eta = np.asarray(eta, dtype=np.float64)
    pf = np.asarray(pf, dtype=np.float64)
    pm = np.asarray(pm, dtype=np.float64)
    if eta.ndim != 1 or eta.size == 0 or pf.shape != eta.shape or pm.shape != eta.shape:
        raise ValueError(f"thresholds: eta, pf and pm must be 1-D of one length, got shapes "
                         f"{eta.shape}, {pf.shape}, {pm.shape}")
    if np.any(np.diff(eta) <= 0):
        raise ValueError("thresholds: eta must be strictly increasing")
    return eta, pf, pm


def _pick(eta, pf, pm, i, pf_ci, pm_ci, **extra) -> dict:
    out = {"eta": float(eta[i]), "pf": float(pf[i]), "pm": float(pm[i])}
    if pf_ci is not None:
        out["pf_ci"] = [float(v) for v in np.asarray(pf_ci)[i]]
    if pm_ci is not None:
        out["pm_ci"] = [float(v) for v in np.asarray(pm_ci)[i]]
    out.update(extra)
    return out


def _centre_of_longest_run(mask: np.ndarray) -> tuple[int, int, int]:
    """Index at the centre of the longest run of True in mask, and the run's first and last index."""
    idx = np.flatnonzero(mask)
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    j = int(np.argmax(ends - starts))
    return int((starts[j] + ends[j]) // 2), int(starts[j]), int(ends[j])


def minimax(eta, pf, pm, pf_ci=None, pm_ci=None) -> dict:
    """eta minimising max(PF, PM). Ties (e.g. a whole band with PF = PM = 0 in the Monte Carlo) are broken by the
    centre of the longest band of minimisers, which keeps the largest margin on both sides; the band is reported
    as eta_range."""
    eta, pf, pm = _check(eta, pf, pm)
    worst = np.maximum(pf, pm)
    best = worst.min()
    i, lo, hi = _centre_of_longest_run(worst <= best)
    return _pick(eta, pf, pm, i, pf_ci, pm_ci, value=float(best), eta_range=[float(eta[lo]), float(eta[hi])])


def cfar(eta, pf, pm, target_pf: float, pf_ci=None, pm_ci=None) -> dict:
    """Smallest eta with PF <= target_pf (the most sensitive threshold meeting the false-alarm budget).

    `verified` says whether the upper end of PF's interval also meets the target (it cannot when target_pf is
    below about 3 / trials: use the closed form or importance sampling there).
    """
    eta, pf, pm = _check(eta, pf, pm)
    ok = np.flatnonzero(pf <= target_pf)
    if ok.size == 0:
        return {"eta": None, "pf": None, "pm": None, "target_pf": target_pf, "verified": False,
                "note": "no eta on the grid meets the target"}
    i = int(ok[0])
    verified = bool(pf_ci is not None and np.asarray(pf_ci)[i][1] <= target_pf)
    return _pick(eta, pf, pm, i, pf_ci, pm_ci, target_pf=float(target_pf), verified=verified)


def min_sum(eta, pf, pm, pf_ci=None, pm_ci=None) -> dict:
    """eta minimising PF + PM (centre of the longest band of minimisers)."""
    eta, pf, pm = _check(eta, pf, pm)
    total = pf + pm
    i, lo, hi = _centre_of_longest_run(total <= total.min())
    return _pick(eta, pf, pm, i, pf_ci, pm_ci, value=float(total.min()), eta_range=[float(eta[lo]), float(eta[hi])])


def design_thresholds(eta, pf, pm, *, target_pf: float = 0.01, pf_ci=None, pm_ci=None) -> dict:
    """All three designs: {"minimax": ..., "cfar": ..., "min_sum": ...}."""
    return {"minimax": minimax(eta, pf, pm, pf_ci, pm_ci),
            "cfar": cfar(eta, pf, pm, target_pf, pf_ci, pm_ci),
            "min_sum": min_sum(eta, pf, pm, pf_ci, pm_ci)}
