"""Multi-target tracking in range and range rate, one radar cycle at a time: filter, gate, associate, manage.

Each cycle is one of two kinds:

    measured     the detector passed the cycle and the estimator gave its list of (range, range rate)
    unmeasured   no measurement: the gate refused the cycle (an attack, an invalid frame, no verdict) or it was
                 lost on the way; the tracks are predicted only

An unmeasured cycle says nothing about the road: it is neither a hit nor a miss of any track, and no track is
born in it. Only a measured cycle without a measurement in a track's gate is a miss (evidence that the target is
not there). Per cycle, on every live track:

    predict      kalman.predict over dt
    associate    measured cycles: association.gnn within the chi-square gate; the paired tracks are updated
    birth        every measurement no track took starts a tentative track at x = z, P = R
    confirm      M of N: a tentative track with confirm_m hits among its first confirm_n measured cycles is
                 confirmed; one that can no longer reach confirm_m hits is deleted
    delete       a confirmed track at delete_misses consecutive misses; any track after coast_cycles consecutive
                 cycles without an update (measured or not): it coasts that long, and no longer
    NIS alarm    opt-in (nis_pfa > 0): over a track's last nis_window updates, the sum of the NIS is chi-square
                 with 2 nis_window degrees of freedom while the model holds (the innovations of a consistent
                 filter are white), so sum > chi2.isf(nis_pfa, 2 nis_window) raises the alarm with probability
                 nis_pfa per update on a target that moves as modelled

Status of a live track after its cycle: "tentative", "confirmed" (updated this cycle) or "coasting" (confirmed,
not updated this cycle). The tracks live in a `Tracks` value (one tuple per track, sorted by id, with array views);
`step` returns the next one and what the cycle did, without changing its inputs.

A run of a radar's usual cycles (one confirmed track updated by the one measurement in its gate or coasting
through an unmeasured cycle, or no track and no measurement: nothing born or deleted) can also go through `steady`,
which gives step's numbers for them without building a report per cycle.

The filter and the association come in two formulations, chosen by size. For n tracks and m measurements with
n (m + 1) <= SCALAR_MAX_PAIRS, scalar.py's plain Python floats: a radar's cycle holds one to three of each, where
numpy's dispatch on tiny arrays costs more than the arithmetic. Above it, kalman.py's and association.py's arrays
over all tracks at once, whose cost grows more slowly with the pairs. SCALAR_MAX_PAIRS is where the two cross
(measured with `step` on n targets, each measured every cycle, n from 1 to 48: the plain floats cost less up to about
24 tracks); tests/track/test_scalar_equivalence.py holds the two to the same tracks. Track management and the
cycle's report are one pass of plain Python over the tracks.

Written here rather than on Stone Soup (the field's tracking framework): Stone Soup keeps every track, state,
detection and hypothesis as a Python object and predicts, hypothesises and updates track by track, so its cost per
cycle grows with the tracks at Python's pace (measured against the array formulation with the same model, gate and
GNN association: slower per cycle for one track, and by a factor that grows with the number of tracks). The radar
gives a cycle every fraction of a millisecond (Table I), so per-cycle cost decides; the filter itself is a few lines
of textbook equations, which its tests check against closed forms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2

from carav_stream.track.association import distances, gate_threshold, gnn
from carav_stream.track.kalman import cv_model, measurement_noise, predict, update
from carav_stream.track.scalar import filter_cycle, predict_one, track_one

STATUSES = ("tentative", "confirmed", "coasting")
SCALAR_MAX_PAIRS = 512   # n tracks, m measurements: plain floats while n (m + 1) <= this, else arrays (docstring)


@dataclass(frozen=True)
class TrackerConfig:
    """The tracker's design: its model, its gate, its track management and its NIS alarm (module docstring)."""

    dt_s: float
    sigma_accel_mps2: float
    sigma_range_m: float
    sigma_velocity_mps: float
    gate_probability: float = 0.9999
    confirm_m: int = 3
    confirm_n: int = 5
    delete_misses: int = 3
    coast_cycles: int = 64
    nis_pfa: float = 0.0
    nis_window: int = 1
    f: np.ndarray = field(init=False, repr=False, compare=False)
    q: np.ndarray = field(init=False, repr=False, compare=False)
    r: np.ndarray = field(init=False, repr=False, compare=False)
    gamma: float = field(init=False, repr=False, compare=False)
    nis_threshold: float | None = field(init=False, repr=False, compare=False)
    plain: tuple = field(init=False, repr=False, compare=False)   # (dt, Q's entries, R's diagonal, gamma): floats

    def __post_init__(self) -> None:
        problems = [f"{name}: must be an int >= {low}, got {getattr(self, name)!r}"
                    for name, low in (("confirm_m", 1), ("confirm_n", 1), ("delete_misses", 1),
                                      ("coast_cycles", 0), ("nis_window", 1))
                    if not (isinstance(getattr(self, name), int) and getattr(self, name) >= low)]
        if not problems and self.confirm_m > self.confirm_n:
            problems.append(f"confirm_m: {self.confirm_m} hits cannot come in confirm_n = {self.confirm_n} cycles")
        if not 0.0 <= self.nis_pfa < 1.0:
            problems.append(f"nis_pfa: a false-alarm rate in [0, 1) (0: no NIS alarm), got {self.nis_pfa!r}")
        if problems:
            raise ValueError("; ".join(problems))
        f, q = cv_model(self.dt_s, self.sigma_accel_mps2)
        dof = 2 * self.nis_window
        for name, value in (("f", f), ("q", q), ("r", measurement_noise(self.sigma_range_m, self.sigma_velocity_mps)),
                            ("gamma", gate_threshold(self.gate_probability)),
                            ("nis_threshold", float(chi2.isf(self.nis_pfa, dof)) if self.nis_pfa > 0 else None)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "plain", (self.dt_s, (float(q[0, 0]), float(q[0, 1]), float(q[1, 1])),
                                           (float(self.r[0, 0]), float(self.r[1, 1])), self.gamma))


def _column(k: int, dtype: type, doc: str) -> property:
    """A property of `Tracks`: field k of every track's tuple, as an array over tracks."""
    return property(lambda self: np.array([t[k] for t in self.rows], dtype), doc=doc)


class Tracks:
    """The live tracks, sorted by id. Held as one tuple per track, (id, (r, v, var r, cov, var v), confirmed, hits,
    measured, misses, idle, nis window), which a cycle of a few tracks reads and writes at Python's speed; the
    properties give them as arrays over tracks (n,)."""

    __slots__ = ("rows", "next_id", "nis_window")

    def __init__(self, rows: tuple, next_id: int, nis_window: int) -> None:
        self.rows, self.next_id, self.nis_window = rows, next_id, nis_window

    @classmethod
    def empty(cls, config: TrackerConfig) -> Tracks:
        return cls((), 0, config.nis_window)

    def __len__(self) -> int:
        return len(self.rows)

    id = _column(0, np.int64, "int64 (n,)")
    x = property(lambda self: np.array([t[1][:2] for t in self.rows], float).reshape(-1, 2),
                 doc="float64 (n, 2): range [m], range rate [m/s]")
    p = property(lambda self: np.array([((a, b), (b, c)) for _, (_, _, a, b, c), *_ in self.rows],
                                       float).reshape(-1, 2, 2), doc="float64 (n, 2, 2): the state's covariance")
    confirmed = _column(2, bool, "bool (n,)")
    hits = _column(3, np.int64, "int64 (n,): measured cycles with an update, since birth (the birth counts)")
    measured = _column(4, np.int64, "int64 (n,): measured cycles since birth (the birth counts)")
    misses = _column(5, np.int64, "int64 (n,): consecutive measured cycles without an update")
    idle = _column(6, np.int64, "int64 (n,): consecutive cycles without an update, measured or not")

    @property
    def nis(self) -> np.ndarray:
        """float64 (n, nis_window): the last NIS values, newest last, NaN until there"""
        return np.array([t[7] for t in self.rows], float).reshape(-1, self.nis_window)


def _listed(name: str, dtype: type, doc: str) -> property:
    """A property of `CycleReport`: its list `name` as an array over tracks."""
    return property(lambda self: np.array(self.lists[name], dtype), doc=doc)


class CycleReport:
    """What one cycle did: the live tracks after it (in the order of `Tracks`) and the ids that were born or
    deleted in it. Held as plain lists (what a header takes); the properties give arrays over the tracks."""

    __slots__ = ("lists", "status", "born", "deleted", "measured")

    def __init__(self, lists: dict[str, list | None], status: tuple[str, ...], born: tuple[int, ...],
                 deleted: tuple[int, ...], measured: bool) -> None:
        self.lists = lists    # the per-track values as plain lists by the properties' names; nis NaN if not updated
        self.status, self.born, self.deleted, self.measured = status, born, deleted, measured

    id = _listed("id", np.int64, "int64 (n,)")
    range_m = _listed("range_m", float, "float64 (n,)")
    velocity_mps = _listed("velocity_mps", float, "float64 (n,)")
    var_range_m2 = _listed("var_range_m2", float, "float64 (n,)")
    var_velocity_m2ps2 = _listed("var_velocity_m2ps2", float, "float64 (n,)")
    updated = _listed("updated", bool, "bool (n,): a measurement of this cycle updated the track")
    nis = _listed("nis", float, "float64 (n,): this cycle's NIS of an updated track, else NaN")
    nis_alarm = property(lambda self: None if self.lists["nis_alarm"] is None
                         else np.array(self.lists["nis_alarm"], bool), doc="bool (n,), None when the alarm is off")

    def plain(self) -> dict[str, list | None]:
        """The live tracks' fields as plain lists, one value per track (NaN as None), for a header or a JSON line;
        keys PLAIN_KEYS, in that order."""
        lists = self.lists
        out = {"track_id": list(lists["id"]), "status": list(self.status)}
        for key in _FLOATS:
            values = lists[key]
            total = sum(values)      # finite: no NaN among them (nor an infinity), the usual case, copied at once
            out[key] = values[:] if total - total == 0.0 else [None if v != v else v for v in values]
        out["nis_alarm"] = None if lists["nis_alarm"] is None else list(lists["nis_alarm"])
        return out


_FLOATS = ("range_m", "velocity_mps", "var_range_m2", "var_velocity_m2ps2", "nis")
PLAIN_KEYS = ("track_id", "status", *_FLOATS, "nis_alarm")     # CycleReport.plain's keys, in order


def step(tracks: Tracks, z, config: TrackerConfig) -> tuple[Tracks, CycleReport]:
    """One cycle: z the (range, range rate) pairs of a measured cycle, float (m, 2) or a sequence of pairs (m may be
    0), None for an unmeasured one. Returns the tracks after the cycle and its report."""
    measured = z is not None
    zs = _measurements(z) if measured else []
    rows, next_id, nan = tracks.rows, tracks.next_id, math.nan
    states = [t[1] for t in rows]
    if len(rows) * (len(zs) + 1) <= SCALAR_MAX_PAIRS:
        states, nis, taken = filter_cycle(states, zs, *config.plain)
    else:
        states, nis, taken = _filter_arrays(states, zs, config)
    # (track, NIS of this cycle or NaN, updated) after the filter: the old tracks, then one born per untaken z
    cycle = [((t[0], x, t[2], t[3], t[4] + measured, t[5] + measured, t[6] + 1, t[7]), nan, False) if d is None
             else ((t[0], x, t[2], t[3] + 1, t[4] + measured, 0, 0, t[7][1:] + (d,)), d, True)
             for t, x, d in zip(rows, states, nis)]
    if len(zs) > sum(taken):
        r0, r1 = config.plain[2]
        blank = (nan,) * config.nis_window
        cycle += [((i, (zr, zv, r0, 0.0, r1), False, 1, 1, 0, 0, blank), nan, True)
                  for i, (zr, zv) in enumerate((zz for zz, t in zip(zs, taken) if not t), start=next_id)]
    m_confirm, n_confirm, threshold = config.confirm_m, config.confirm_n, config.nis_threshold
    max_misses, max_idle = config.delete_misses, config.coast_cycles
    after, status, born, deleted = [], [], [], []
    ids, r, v, var_r, var_v, updated, nis_out = [], [], [], [], [], [], []
    alarm = None if threshold is None else []
    for t, d, up in cycle:
        tid, x, confirmed, hits, n_measured, misses, idle, window = t
        if not confirmed and hits >= m_confirm and n_measured <= n_confirm:
            confirmed = True
            t = (tid, x, True, hits, n_measured, misses, idle, window)
        if ((not confirmed and n_measured - hits > n_confirm - m_confirm)
                or (confirmed and misses >= max_misses) or idle > max_idle):
            deleted.append(tid)
            continue
        after.append(t)
        ids.append(tid)
        r.append(x[0])
        v.append(x[1])
        var_r.append(x[2])
        var_v.append(x[4])
        updated.append(up)
        nis_out.append(d)
        status.append("tentative" if not confirmed else "confirmed" if up else "coasting")
        if alarm is not None:            # a window not full holds NaN: its sum is NaN, no alarm
            alarm.append(up and sum(window) > threshold)
        if tid >= next_id:
            born.append(tid)
    lists = {"id": ids, "range_m": r, "velocity_mps": v, "var_range_m2": var_r, "var_velocity_m2ps2": var_v,
             "updated": updated, "nis": nis_out, "nis_alarm": alarm}
    return (Tracks(tuple(after), next_id + len(cycle) - len(rows), config.nis_window),
            CycleReport(lists, tuple(status), tuple(born), tuple(deleted), measured))


def steady(tracks: Tracks, cycles, config: TrackerConfig) -> tuple[Tracks, list[tuple]]:
    """The cycles `cycles` (an iterable of each cycle's measurements: a list of (range, range rate) pairs of Python
    floats, None for an unmeasured cycle), taken in order as long as each is one of a radar's usual cycles, in which
    nothing is born or deleted:

        updated    one live track, confirmed, and one measurement, which falls within its gate
        coasted    one live track, confirmed, an unmeasured cycle, after which the track is within its coast limit
        empty      no live track and an unmeasured cycle

    Returns the tracks after the cycles taken and, per cycle taken, (state, NIS, NIS alarm): the track's state
    (r, v, var r, cov, var v) after the cycle (None: no track), its NIS (None: not updated) and its NIS alarm (None
    when the alarm is off; False on a cycle that did not update it). The first cycle it leaves (or the first of
    `cycles` when the tracks are neither one confirmed track nor none) is `step`'s to take.

    Each cycle taken is the one `step` makes of it, to the bit (tests/track/test_steady.py). What it saves is step's
    generality and its report, built for every cycle: the tracker block takes its cycles this way whenever it can
    (`python3 dev.py bench pipeline --with tracker`: what the tracker costs a graph)."""
    rows, done = tracks.rows, []
    if not rows:
        for zs in cycles:
            if zs is not None:
                break
            done.append(_EMPTY)
        return tracks, done
    if len(rows) != 1 or not rows[0][2]:
        return tracks, done
    tid, x, _, hits, n_measured, misses, idle, window = rows[0]
    dt, q, r, gamma = config.plain
    threshold, max_idle = config.nis_threshold, config.coast_cycles
    not_updated = None if threshold is None else False
    for zs in cycles:
        if zs is None:
            if idle >= max_idle:         # the coast limit: step deletes the track
                break
            x, idle = predict_one(x, dt, q), idle + 1
            done.append((x, None, not_updated))
            continue
        if len(zs) != 1:
            break
        updated, d2 = track_one(x, zs[0], dt, q, r, gamma)
        if d2 is None:
            break
        x, window, hits, n_measured, misses, idle = updated, window[1:] + (d2,), hits + 1, n_measured + 1, 0, 0
        done.append((x, d2, None if threshold is None else sum(window) > threshold))
    if not done:
        return tracks, done
    row = (tid, x, True, hits, n_measured, misses, idle, window)
    return Tracks((row,), tracks.next_id, tracks.nis_window), done


_EMPTY = (None, None, None)     # steady's entry for a cycle without a track


def _measurements(z) -> list[tuple[float, float]]:
    """The measurements as (range, range rate) pairs of Python floats."""
    if isinstance(z, np.ndarray):
        return [tuple(p) for p in np.asarray(z, dtype=float).reshape(-1, 2).tolist()]
    return [(float(r), float(v)) for r, v in z]


def _filter_arrays(states: list, zs: list, config: TrackerConfig) -> tuple[list, list, list]:
    """scalar.filter_cycle's result by the array formulation (kalman.py, association.py) over all tracks at once."""
    n = len(states)
    a = np.array(states, float).reshape(n, 5)
    x = a[:, :2]
    p = np.stack([a[:, 2], a[:, 3], a[:, 3], a[:, 4]], axis=1).reshape(n, 2, 2)
    x, p = predict(x, p, config.f, config.q)
    nis: list[float | None] = [None] * n
    taken = [False] * len(zs)
    if n and zs:
        s = p + config.r
        d2, nu, log_det_s = distances(x, s, np.array(zs, float))
        rows, cols = gnn(d2, log_det_s, config.gamma)
        x[rows], p[rows] = update(x[rows], p[rows], nu[rows, cols], s[rows], config.r)
        for i, j, d in zip(rows.tolist(), cols.tolist(), d2[rows, cols].tolist()):
            nis[i], taken[j] = d, True
    out = np.stack([x[:, 0], x[:, 1], p[:, 0, 0], p[:, 0, 1], p[:, 1, 1]], axis=1)
    return [tuple(t) for t in out.tolist()], nis, taken


def run(measurements: list[np.ndarray | None], config: TrackerConfig,
        tracks: Tracks | None = None) -> tuple[Tracks, list[CycleReport]]:
    """`step` over consecutive cycles (None: an unmeasured cycle); the tracks after the last and every report."""
    tracks = Tracks.empty(config) if tracks is None else tracks
    reports = []
    for z in measurements:
        tracks, report = step(tracks, z, config)
        reports.append(report)
    return tracks, reports
