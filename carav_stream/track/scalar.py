"""A cycle's filter and association for a few tracks, written out in Python floats.

The equations are kalman.py's and association.py's; with F = [[1, dt], [0, 1]], H = I, R = diag(r0, r1) and the
symmetric P = [[a, b], [b, c]] they come to a few dozen float operations per track and per pair:

    predict    r- = r + dt v,   v- = v
               a- = (a + dt b) + dt (b + dt c) + Q00,   b- = (b + dt c) + Q01,   c- = c + Q11
    gate       S = [[a- + r0, b-], [b-, c- + r1]],   det = S00 S11 - S01^2
               d2 = (nu0 (S11 nu0 - S01 nu1) + nu1 (S00 nu1 - S01 nu0)) / det
    update     K = P- S^-1,   x = x- + K nu,   P = (I - K) P- (I - K)^T + K R K^T, symmetrised as kalman.update

Association is association.gnn's wherever its answer is provably the pairing below, else gnn itself on the same d2:

    one track                      its first measurement of least d2, if within the gate (gnn's own rule)
    no conflict, clear of the edge every measurement in some gate lies in only one, every gate holds at most one,
                                   and every such d2 lies below gamma by more than 1e-9 gamma: pairing a track
                                   lowers the assignment's cost by gamma - d2 > 0 and no pairing stands in the way
                                   of another, so the unique optimum pairs them all
    otherwise                      gnn (scipy's linear_sum_assignment)

One track and one measurement, a radar's usual cycle, is `track_one`: the same numbers without the lists.

Why by hand: at a radar cycle's one to three tracks and measurements, each numpy call costs more in dispatch than
its arithmetic, and a cycle of the array formulation is a few dozen such calls (measured with the tracker block on
table1_following's estimates: the plain-float cycle costs a small fraction of the array one). tracker.step takes
this path for a few tracks only (SCALAR_MAX_PAIRS) and the array formulation above it, where its cost per pair
falls below Python's; tests/track/test_scalar_equivalence.py holds the two to the same tracks.

States are tuples (r, v, a, b, c): range [m], range rate [m/s], var r [m^2], cov [m^2/s], var v [m^2/s^2].
"""
from __future__ import annotations

import numpy as np

from carav_stream.track.association import gnn

State = tuple[float, float, float, float, float]
EDGE = 1e-9        # relative margin below gamma that makes a conflict-free pairing the unique optimum


def predict(states: list[State], dt: float, q: tuple[float, float, float]) -> list[State]:
    """Every state one cycle ahead (module docstring); q = (Q00, Q01, Q11)."""
    return [predict_one(x, dt, q) for x in states]


def predict_one(state: State, dt: float, q: tuple[float, float, float]) -> State:
    """One state one cycle ahead."""
    r, v, a, b, c = state
    t = b + dt * c
    return (r + dt * v, v, (a + dt * b) + dt * t + q[0], t + q[1], c + q[2])


def track_one(state: State, z: tuple[float, float], dt: float, q: tuple[float, float, float],
              r: tuple[float, float], gamma: float) -> tuple[State, float | None]:
    """One track and one measurement (a radar's usual cycle): the state predicted and, when z lies within its gate,
    updated, with z's d2 (None outside the gate: the prediction only). filter_cycle's numbers for n = m = 1."""
    rp, vp, a, b, c = predict_one(state, dt, q)
    zr, zv = z
    r0, r1 = r
    s00, s11 = a + r0, c + r1
    det = s00 * s11 - b * b
    d2 = ((zr - rp) * (s11 * (zr - rp) - b * (zv - vp)) + (zv - vp) * (s00 * (zv - vp) - b * (zr - rp))) / det
    if d2 <= gamma:
        return _update((rp, vp, a, b, c), (s00, b, s11, det), z, r0, r1), d2
    return (rp, vp, a, b, c), None


def filter_cycle(states: list[State], zs: list[tuple[float, float]], dt: float, q: tuple[float, float, float],
                 r: tuple[float, float], gamma: float) -> tuple[list[State], list[float | None], list[bool]]:
    """Predict every track, associate the measurements zs and update the paired tracks.

    Returns the states after the cycle, each track's NIS (None when no measurement updated it) and, per measurement,
    whether a track took it.
    """
    if len(states) == 1 and len(zs) == 1:
        x, d2 = track_one(states[0], zs[0], dt, q, r, gamma)
        return [x], [d2], [d2 is not None]
    pred = predict(states, dt, q)
    n, m = len(pred), len(zs)
    r0, r1 = r
    nis: list[float | None] = [None] * n
    taken = [False] * m
    if not n or not m:
        return pred, nis, taken
    gates = []                                   # per track: (S00, S01, S11, det) and its d2 to every measurement
    for rp, vp, a, b, c in pred:
        s00, s11 = a + r0, c + r1
        det = s00 * s11 - b * b
        gates.append(((s00, b, s11, det), [((zr - rp) * (s11 * (zr - rp) - b * (zv - vp))
                                            + (zv - vp) * (s00 * (zv - vp) - b * (zr - rp))) / det
                                           for zr, zv in zs]))
    pairs = _pairs([d2 for _, d2 in gates], gamma)
    if pairs is None:
        d2 = np.array([row for _, row in gates])
        rows, cols = gnn(d2, np.log([g[3] for g, _ in gates]), gamma)
        pairs = list(zip(rows.tolist(), cols.tolist()))
    out = list(pred)
    for i, j in pairs:
        s, d2 = gates[i]
        out[i] = _update(pred[i], s, zs[j], r0, r1)
        nis[i], taken[j] = d2[j], True
    return out, nis, taken


def _pairs(d2: list[list[float]], gamma: float) -> list[tuple[int, int]] | None:
    """The GNN pairs where they are provably these (module docstring), else None (ask gnn)."""
    if len(d2) == 1:
        row = d2[0]
        best = min(row)
        return [(0, row.index(best))] if best <= gamma else []
    pairs, used = [], set()
    for i, row in enumerate(d2):
        within = [j for j, d in enumerate(row) if d <= gamma]
        if not within:
            continue
        j = within[0]
        if len(within) > 1 or j in used or gamma - row[j] <= EDGE * gamma:
            return None
        used.add(j)
        pairs.append((i, j))
    return pairs


def _update(x: State, s: tuple[float, float, float, float], z: tuple[float, float], r0: float,
            r1: float) -> State:
    """The Joseph-form update of one predicted state with the measurement z (module docstring)."""
    rp, vp, a, b, c = x
    s00, s01, s11, det = s
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    k00, k01 = a * i00 + b * i01, a * i01 + b * i11
    k10, k11 = b * i00 + c * i01, b * i01 + c * i11
    nu0, nu1 = z[0] - rp, z[1] - vp
    j00, j01, j10, j11 = 1.0 - k00, -k01, -k10, 1.0 - k11
    m00, m01 = j00 * a + j01 * b, j00 * b + j01 * c
    m10, m11 = j10 * a + j11 * b, j10 * b + j11 * c
    p00 = m00 * j00 + m01 * j01 + (k00 * k00 * r0 + k01 * k01 * r1)
    p01 = m00 * j10 + m01 * j11 + (k00 * k10 * r0 + k01 * k11 * r1)
    p10 = m10 * j00 + m11 * j01 + (k10 * k00 * r0 + k11 * k01 * r1)
    p11 = m10 * j10 + m11 * j11 + (k10 * k10 * r0 + k11 * k11 * r1)
    return (rp + (k00 * nu0 + k01 * nu1), vp + (k10 * nu0 + k11 * nu1), p00, 0.5 * (p01 + p10), p11)

