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
not updated this cycle). The tracks live in a `Tracks` value (arrays over tracks, sorted by id); `step` returns
the next one and what the cycle did, without changing its inputs.

Written in numpy rather than on Stone Soup (the field's tracking framework): Stone Soup keeps every track, state,
detection and hypothesis as a Python object and predicts, hypothesises and updates track by track, so its cost per
cycle grows with the tracks at Python's pace, where a cycle here is a few array operations over all tracks at once
(measured with the same model, gate and GNN association: slower per cycle for one track, and by a factor that grows
with the number of tracks). The radar gives a cycle every fraction of a millisecond (Table I), so per-cycle cost
decides; the filter itself is a few lines of textbook equations, which its tests check against closed forms.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2

from carav_stream.track.association import distances, gate_threshold, gnn
from carav_stream.track.kalman import cv_model, measurement_noise, predict, update

STATUSES = ("tentative", "confirmed", "coasting")


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


@dataclass(frozen=True)
class Tracks:
    """The live tracks, sorted by id: arrays over tracks (n,)."""

    id: np.ndarray          # int64 (n,)
    x: np.ndarray           # float64 (n, 2): range [m], range rate [m/s]
    p: np.ndarray           # float64 (n, 2, 2): its covariance
    confirmed: np.ndarray   # bool (n,)
    hits: np.ndarray        # int64 (n,): measured cycles with an update, since birth (the birth counts)
    measured: np.ndarray    # int64 (n,): measured cycles since birth (the birth counts)
    misses: np.ndarray      # int64 (n,): consecutive measured cycles without an update
    idle: np.ndarray        # int64 (n,): consecutive cycles without an update, measured or not
    nis: np.ndarray         # float64 (n, nis_window): the last NIS values, newest last, NaN until there
    next_id: int = 0

    @classmethod
    def empty(cls, config: TrackerConfig) -> Tracks:
        i = np.zeros(0, np.int64)
        return cls(i, np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros(0, bool), i, i, i, i,
                   np.zeros((0, config.nis_window)))

    def __len__(self) -> int:
        return int(self.id.size)

    def keep(self, rows: np.ndarray) -> Tracks:
        """The tracks at `rows` (indices or a bool mask), next_id unchanged."""
        return self.changed(**{k: getattr(self, k)[rows] for k in _ARRAYS})

    def changed(self, **fields) -> Tracks:
        """A copy with these fields replaced: dataclasses.replace without its checks, which cost more than the
        rest of a cycle's bookkeeping (the fields are this class's own, given by this module)."""
        out = object.__new__(Tracks)
        out.__dict__.update(self.__dict__, **fields)
        return out


_ARRAYS = ("id", "x", "p", "confirmed", "hits", "measured", "misses", "idle", "nis")


@dataclass(frozen=True)
class CycleReport:
    """What one cycle did: the live tracks after it (arrays over them, in the order of `Tracks`), and the ids
    that were born or deleted in it."""

    id: np.ndarray          # int64 (n,)
    range_m: np.ndarray     # float64 (n,)
    velocity_mps: np.ndarray
    var_range_m2: np.ndarray
    var_velocity_m2ps2: np.ndarray
    status: tuple[str, ...]
    updated: np.ndarray     # bool (n,): a measurement of this cycle updated the track
    nis: np.ndarray         # float64 (n,): this cycle's NIS of an updated track, else NaN
    nis_alarm: np.ndarray | None   # bool (n,), None when the alarm is off
    born: tuple[int, ...]
    deleted: tuple[int, ...]
    measured: bool

    def plain(self) -> dict[str, list | None]:
        """The live tracks' fields as plain lists, one value per track (NaN as None), for a header or a JSON line."""
        def floats(values: np.ndarray) -> list:
            return [None if np.isnan(v) else float(v) for v in values]
        return {"track_id": [int(i) for i in self.id], "status": list(self.status), "range_m": floats(self.range_m),
                "velocity_mps": floats(self.velocity_mps), "var_range_m2": floats(self.var_range_m2),
                "var_velocity_m2ps2": floats(self.var_velocity_m2ps2), "nis": floats(self.nis),
                "nis_alarm": None if self.nis_alarm is None else [bool(a) for a in self.nis_alarm]}


def step(tracks: Tracks, z: np.ndarray | None, config: TrackerConfig) -> tuple[Tracks, CycleReport]:
    """One cycle: z float (m, 2) of (range, range rate) for a measured cycle (m may be 0), None for an unmeasured
    one. Returns the tracks after the cycle and its report."""
    x, p = predict(tracks.x, tracks.p, config.f, config.q)
    n = len(tracks)
    measured = z is not None
    z = np.zeros((0, 2)) if z is None else np.asarray(z, dtype=float).reshape(-1, 2)
    nis_now = np.full(n, np.nan)
    updated = np.zeros(n, bool)
    taken = np.zeros(z.shape[0], bool)
    if measured and n and z.shape[0]:
        s = p + config.r
        d2, nu, log_det_s = distances(x, s, z)
        rows, cols = gnn(d2, log_det_s, config.gamma)
        x[rows], p[rows] = update(x[rows], p[rows], nu[rows, cols], s[rows], config.r)
        nis_now[rows], updated[rows], taken[cols] = d2[rows, cols], True, True
    hits = tracks.hits + updated
    misses = np.where(updated, 0, tracks.misses + measured)
    window = tracks.nis
    if updated.any():
        window = window.copy()
        window[updated] = np.concatenate([window[updated, 1:], nis_now[updated, None]], axis=1)
    after = tracks.changed(x=x, p=p, hits=hits, measured=tracks.measured + measured, misses=misses,
                           idle=np.where(updated, 0, tracks.idle + 1), nis=window)
    after = _born(after, z[~taken], config)
    n_all = len(after)
    updated = np.concatenate([updated, np.ones(n_all - n, bool)])
    nis_now = np.concatenate([nis_now, np.full(n_all - n, np.nan)])
    confirmed = after.confirmed | ((after.hits >= config.confirm_m) & (after.measured <= config.confirm_n))
    hopeless = ~confirmed & (after.measured - after.hits > config.confirm_n - config.confirm_m)
    gone = hopeless | (confirmed & (after.misses >= config.delete_misses)) | (after.idle > config.coast_cycles)
    after = after.changed(confirmed=confirmed)
    deleted = tuple(int(i) for i in after.id[gone])
    if gone.any():
        live = ~gone
        after, updated, nis_now = after.keep(live), updated[live], nis_now[live]
    born = tuple(int(i) for i in after.id[after.id >= tracks.next_id])
    return after, _report(after, updated, nis_now, born, deleted, measured, config)


def _born(tracks: Tracks, z: np.ndarray, config: TrackerConfig) -> Tracks:
    """Tentative tracks at the measurements no track took: x = z, P = R (both components are measured)."""
    m = z.shape[0]
    if not m:
        return tracks
    ones = np.ones(m, np.int64)
    new = {"id": tracks.next_id + np.arange(m, dtype=np.int64), "x": z, "p": np.broadcast_to(config.r, (m, 2, 2)),
           "confirmed": np.zeros(m, bool), "hits": ones, "measured": ones, "misses": 0 * ones, "idle": 0 * ones,
           "nis": np.full((m, config.nis_window), np.nan)}
    return tracks.changed(next_id=tracks.next_id + m,
                          **{k: np.concatenate([getattr(tracks, k), new[k]]) for k in _ARRAYS})


def _report(tracks: Tracks, updated: np.ndarray, nis_now: np.ndarray, born: tuple[int, ...],
            deleted: tuple[int, ...], measured: bool, config: TrackerConfig) -> CycleReport:
    status = tuple("tentative" if not c else "confirmed" if u else "coasting"
                   for c, u in zip(tracks.confirmed, updated))
    alarm = None
    if config.nis_threshold is not None:
        alarm = updated & (np.sum(tracks.nis, axis=1) > config.nis_threshold)   # NaN (window not full): False
    return CycleReport(tracks.id.copy(), tracks.x[:, 0].copy(), tracks.x[:, 1].copy(), tracks.p[:, 0, 0].copy(),
                       tracks.p[:, 1, 1].copy(), status, updated, nis_now, alarm, born, deleted, measured)


def run(measurements: list[np.ndarray | None], config: TrackerConfig,
        tracks: Tracks | None = None) -> tuple[Tracks, list[CycleReport]]:
    """`step` over consecutive cycles (None: an unmeasured cycle); the tracks after the last and every report."""
    tracks = Tracks.empty(config) if tracks is None else tracks
    reports = []
    for z in measurements:
        tracks, report = step(tracks, z, config)
        reports.append(report)
    return tracks, reports
