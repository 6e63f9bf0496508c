"""Gating and global nearest neighbour (GNN) association of one cycle's measurements to the tracks.

    gate    d2_ij = (z_j - x-_i)^T S_i^-1 (z_j - x-_i)  <=  gamma,    gamma = chi2.ppf(P_G, 2)
    cost    c_ij = d2_ij + ln det S_i                  (minus twice the pair's log-likelihood, up to a constant)
    GNN     the one-to-one pairing that minimises the sum of c_ij over the pairs within their gates, every
            track left without a measurement costing gamma + ln det S_i (its gate's edge)

Leaving a track out at its gate's edge makes every pairing within the gate at least as cheap as none, so GNN pairs
as many tracks as the gates allow and among those pairings takes the likeliest. With one track, every pairing
and none carry the same ln det S: the track takes the measurement of the smallest d2 within its gate, found
without the assignment. The assignment is scipy's
linear_sum_assignment on the tracks x (measurements + one "no measurement" column per track), pairs outside the
gate at an infinite cost: a global optimum, where pairing each track with its nearest measurement in turn can
take a measurement another track needs more.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

from carav_stream.track.kalman import inv2, nis


def gate_threshold(probability: float, dof: int = 2) -> float:
    """gamma: a measurement of the track falls within d2 <= gamma with this probability (chi-square, dof)."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"gate_probability: must lie strictly between 0 and 1, got {probability!r}")
    return float(chi2.ppf(probability, dof))


def distances(x_pred: np.ndarray, s: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair's Mahalanobis distance and the innovations behind it.

    x_pred float64 (n, 2), s float64 (n, 2, 2) (innovation covariances), z (m, 2).
    Returns d2 (n, m), nu (n, m, 2) = z_j - x-_i and ln det S (n,).
    """
    s_inv, det = inv2(s)
    nu = np.asarray(z, dtype=float)[None, :, :] - x_pred[:, None, :]
    return nis(nu, s_inv[:, None, :, :]), nu, np.log(det)


def gnn(d2: np.ndarray, log_det_s: np.ndarray, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """The GNN pairs (module docstring): (track rows, measurement columns), int64 arrays of equal length.

    d2 float64 (n, m), log_det_s float64 (n,) = ln det S_i, gamma the gate threshold.
    """
    n, m = d2.shape
    if n == 0 or m == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    if n == 1:                 # one track: its cheapest measurement within the gate (module docstring)
        j = int(np.argmin(d2[0]))
        if d2[0, j] <= gamma:
            return np.zeros(1, np.int64), np.array([j], np.int64)
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    cost = np.full((n, m + n), np.inf)
    cost[:, :m] = np.where(d2 <= gamma, d2 + log_det_s[:, None], np.inf)
    cost[np.arange(n), m + np.arange(n)] = gamma + log_det_s
    rows, cols = linear_sum_assignment(cost)
    paired = cols < m
    return rows[paired].astype(np.int64), cols[paired].astype(np.int64)
