"""Tracker: the car's picture of the road over time, tracks in range and range rate from every cycle's estimates.

    x_k+1 = F x_k + G a_k,   z_k = (range_m, velocity_mps) of the clean cycle k,   a refused cycle: predict only

The tracking is carav_stream/track/tracker.py's (constant-velocity Kalman filter, chi-square gate, GNN association,
M-of-N confirmation, deletion after misses or the coast limit, the opt-in windowed NIS alarm), one cycle at a time
over dt = the scene's cycle time. A cycle the gate refused is no measurement, never no target: the tracks coast
through it. The estimator's records of the clean cycles and the gate's alarm records of the refused ones come on two
streams, merged in arrival order; the tracker takes them in cycle order, a cycle waiting for every cycle before it,
from the first cycle of the frames that came before the estimator's first (the alarms' path is the shorter). A
cycle that has not come once a later one is max_hold_cycles ahead, or by the end of the stream, is unmeasured
(reason "lost"); one that comes after its turn is counted (late) and left out.

The simulator freezes geometry per cycle (each cycle starts from the scene's ranges): a scene target with a range
rate stays at its range while its Doppler says it moves, which no constant-velocity track follows (validation warns);
table1_following is Table I's radar with the car at its own speed.

The run's figures (carav_stream/track/figures.py: confirmed, false and dragged tracks against the scene's targets
within truth_gate_m and truth_gate_mps; each target's held, coasted and lost cycles and its deleted tracks; the
first CARAV and NIS alarms after the attack's start) go to the run summary under "tracks", with the counts.

Ports   in  estimates   range_estimator records (per_cycle range_m, velocity_mps: one value per target)
        in  alarms      gate alarm records (per_cycle cycle_index, reason)                      optional
        out tracks      header only, per_cycle: cycle_index, measured, reason (None, the gate's reason or "lost"),
                        attack_active, born and deleted (track ids), and one value per live track in track_id,
                        status ("tentative" | "confirmed" | "coasting"), range_m, velocity_mps, var_range_m2,
                        var_velocity_m2ps2 (the covariance's diagonal), nis (None unless updated), nis_alarm (None
                        when nis_pfa = 0)
Graph   tracker = { type = "tracker", sigma_range_m = 0.0025, sigma_velocity_mps = 0.01 }
"""
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Out, Param, cycle_indices, n_cycles, per_cycle
from carav_stream.track import (
    NEAR_M,
    NEAR_MPS,
    PLAIN_KEYS,
    CycleReport,
    TrackerConfig,
    TrackFigures,
    Tracks,
    steady,
    step,
)


class Tracker(Block):
    inputs = (In("estimates", kind="estimates"), In("alarms", kind="alarm", required=False))
    outputs = (Out("tracks", kind="tracks", dtypes=("none",)),)
    merge_inputs = True
    params = (SCENE,
              Param("sigma_range_m", float, doc="the estimator's range error RMS (run_summary's range_error_m rmse "
                    "on a clean run)", unit="m", low=0.0, strict=True),
              Param("sigma_velocity_mps", float, doc="the estimator's range-rate error RMS", unit="m/s", low=0.0,
                    strict=True),
              Param("sigma_accel_mps2", float, 8.0, "acceleration RMS a target may have (a car's hardest braking)",
                    unit="m/s^2", low=0.0),
              Param("gate_probability", float, 0.9999, "probability that a target's measurement falls in its gate",
                    low=0.0, high=1.0, strict=True),
              Param("confirm_m", int, 3, "hits that confirm a tentative track ...", low=1),
              Param("confirm_n", int, 5, "... among its first confirm_n measured cycles", low=1),
              Param("delete_misses", int, 3, "consecutive misses (measured cycles without it) that delete a track",
                    low=1),
              Param("coast_cycles", int, 64, "cycles a track coasts without an update before it is deleted",
                    unit="cycles", low=0),
              Param("nis_pfa", float, 0.0, "NIS alarm's design false-alarm rate per update; 0 = no NIS alarm",
                    low=0.0, high=1.0),
              Param("nis_window", int, 1, "updates the NIS alarm sums", low=1),
              Param("max_hold_cycles", int, 1024, "how far a later cycle may run ahead of a missing one",
                    unit="cycles", low=1),
              Param("truth_gate_m", float, NEAR_M, "a track this near a scene target's range (and truth_gate_mps "
                    "its range rate) is on it, in the run's figures", unit="m", low=0.0, strict=True),
              Param("truth_gate_mps", float, NEAR_MPS, "... and this near its range rate", unit="m/s", low=0.0,
                    strict=True))

    def check_params(self) -> None:
        scene = scene_of(self.scene)
        self.config = TrackerConfig(
            dt_s=scene.t_cycle_s, sigma_accel_mps2=self.sigma_accel_mps2, sigma_range_m=self.sigma_range_m,
            sigma_velocity_mps=self.sigma_velocity_mps, gate_probability=self.gate_probability,
            confirm_m=self.confirm_m, confirm_n=self.confirm_n, delete_misses=self.delete_misses,
            coast_cycles=self.coast_cycles, nis_pfa=self.nis_pfa, nis_window=self.nis_window)
        self.truth = ([float(t.range_m) for t in scene.targets],
                      [float(scene.range_rate_mps(t)) for t in scene.targets])

    def param_warnings(self) -> list[str]:
        scene = scene_of(self.scene)
        return [f"scene {scene.name}: target {i} ({t.range_m:g} m) has a range rate of "
                f"{scene.range_rate_mps(t):+.4g} m/s, but every cycle starts from the scene's ranges: its range "
                f"never moves while its Doppler says it does, which a constant-velocity track cannot follow (a "
                f"range bias and NIS far above the design); a target at the radar's speed keeps its range"
                for i, t in enumerate(scene.targets) if scene.range_rate_mps(t) != 0.0]

    def start(self) -> None:
        self.tracks = Tracks.empty(self.config)
        self.pending: dict[int, tuple] = {}    # cycle -> (measurements or None, reason, attack_active)
        self.next_cycle: int | None = None     # None until the estimator's first frame (or a long wait)
        self.first_cycle: int | None = None
        self.newest = -1                         # the latest cycle received
        self.columns = _columns()               # cycles tracked, not sent yet: the output's per_cycle columns
        self.last_sent, self.last_seq = -1, -1
        self.counts = {"cycles": 0, "measured": 0, "late": 0, "born": 0, "deleted": 0, "nis_alarms": 0,
                       "unsent_cycles": 0}
        self.reasons: dict[str, int] = {}
        self.figures = TrackFigures(len(self.truth[0]), self.config.dt_s, self.nis_pfa > 0, self.truth_gate_m,
                                    self.truth_gate_mps)

    def process(self, estimates: Frame | None, alarms: Frame | None = None) -> Frame | None:
        frame = estimates if estimates is not None else alarms
        self._take(frame, from_estimator=estimates is not None)
        self._advance(flush=False)
        self.last_seq = frame.seq
        if not self.columns["cycle_index"] or frame.seq <= self.last_sent:   # an output's seq must grow: wait
            return None
        self.last_sent = frame.seq
        return self._frame()

    def finish(self) -> Frame | None:
        self._advance(flush=True)
        if not self.columns["cycle_index"]:
            return None
        if self.last_seq + 1 <= self.last_sent:    # the end's seq (the last handled + 1) was sent already
            self.counts["unsent_cycles"] += len(self.columns["cycle_index"])
            return None
        return self._frame()

    def _take(self, frame: Frame, from_estimator: bool) -> None:
        if self.next_cycle is None:
            self.first_cycle = frame.cycle if self.first_cycle is None else min(self.first_cycle, frame.cycle)
            if from_estimator:                   # the longer path has spoken: the tracking starts
                self.next_cycle = self.first_cycle
        measured = from_estimator and not frame.header.get("refused")
        per, n = per_cycle(frame), n_cycles(frame)
        ranges, speeds = per.get("range_m") or [[]] * n, per.get("velocity_mps") or [[]] * n
        reasons = per.get("reason") or ["attack"] * n
        active = per.get("attack_active") or [None] * n
        for i, c in enumerate(cycle_indices(frame)):
            if c < (self.first_cycle if self.next_cycle is None else self.next_cycle) or c in self.pending:
                self.counts["late"] += 1
                continue
            self.newest = max(self.newest, c)
            if measured:
                self.pending[c] = ([(float(r), float(v)) for r, v in zip(ranges[i] or (), speeds[i] or ())
                                    if r is not None and v is not None], None, active[i])
            else:
                self.pending[c] = (None, "refused_by_estimator" if frame.header.get("refused") else reasons[i],
                                   active[i])

    def _advance(self, flush: bool) -> None:
        """Track every cycle whose turn has come, in cycle order (module docstring)."""
        if self.next_cycle is None and self.pending and (flush or self.newest - self.first_cycle
                                                          >= self.max_hold_cycles):
            self.next_cycle = self.first_cycle
        while self.pending and self.next_cycle is not None:
            c = self.next_cycle
            self.tracks, done = steady(self.tracks, self._pending_from(c), self.config)
            if done:                             # the usual cycles: one confirmed track updated or coasting, or none
                self._record_steady(c, done)
                self.next_cycle = c + len(done)
                continue
            if c in self.pending:
                z, reason, active = self.pending.pop(c)
            elif flush or self.newest - c >= self.max_hold_cycles:
                z, reason, active = None, "lost", None
            else:
                return
            self.tracks, report = step(self.tracks, z, self.config)
            self._record(c, report, reason, active)
            self.next_cycle = c + 1

    def _pending_from(self, c: int):
        """The measurements (None: unmeasured) of the cycles c, c + 1, ... that have come, up to the first that has
        not."""
        pending = self.pending
        while (entry := pending.get(c)) is not None:
            yield entry[0]
            c += 1

    def _record(self, cycle: int, r: CycleReport, reason: str | None, active) -> None:
        """Count the cycle, score it (figures) and add it to the output's columns."""
        lists, counts = r.lists, self.counts
        counts["cycles"] += 1
        counts["measured"] += r.measured
        counts["born"] += len(r.born)
        counts["deleted"] += len(r.deleted)
        counts["nis_alarms"] += sum(lists["nis_alarm"] or ())
        if reason is not None:
            self.reasons[reason] = self.reasons.get(reason, 0) + 1
        self.figures.add(cycle, lists["id"], r.status, lists["range_m"], lists["velocity_mps"], r.deleted, self.truth,
                         reason, active, lists["nis_alarm"])
        for column, value in zip(self.columns.values(), (cycle, r.measured, reason, active, list(r.born),
                                                         list(r.deleted), *r.plain().values())):
            column.append(value)

    def _record_steady(self, first: int, done: list[tuple]) -> None:
        """_record of the cycles first, first + 1, ... that tracker.steady took, each as _record has it: its one
        confirmed track updated (measured) or coasting (unmeasured), or no track (unmeasured); none born or deleted
        (the track's values are finite: no NaN to write as None)."""
        tid = self.tracks.rows[0][0] if self.tracks.rows else None
        counts, reasons, cols, add = self.counts, self.reasons, self.columns, self.figures.add_one
        targets = list(zip(*self.truth))
        no_alarms = None if self.nis_pfa == 0 else []
        counts["cycles"] += len(done)
        (c_cycle, c_measured, c_reason, c_active, c_born, c_deleted, c_id, c_status, c_r, c_v, c_var_r, c_var_v, c_nis,
         c_alarm) = cols.values()
        for cycle, (x, d2, alarm) in enumerate(done, start=first):
            _, reason, active = self.pending.pop(cycle)
            c_cycle.append(cycle)
            c_born.append([])
            c_deleted.append([])
            c_active.append(active)
            c_reason.append(reason)
            if reason is not None:
                reasons[reason] = reasons.get(reason, 0) + 1
            if x is None:                    # no track, no measurement
                add(cycle, None, False, 0.0, 0.0, targets, reason, active, no_alarms)
                c_measured.append(False)
                for column in (c_id, c_status, c_r, c_v, c_var_r, c_var_v, c_nis):
                    column.append([])
                c_alarm.append(None if no_alarms is None else [])
                continue
            r, v, var_r, _, var_v = x
            alarms = None if alarm is None else [alarm]
            updated = d2 is not None
            status = "confirmed" if updated else "coasting"
            counts["measured"] += updated
            counts["nis_alarms"] += alarm is True
            add(cycle, tid, updated, r, v, targets, reason, active, alarms)
            c_measured.append(updated)
            c_id.append([tid])
            c_status.append([status])
            c_r.append([r])
            c_v.append([v])
            c_var_r.append([var_r])
            c_var_v.append([var_v])
            c_nis.append([d2])
            c_alarm.append(alarms)

    def _frame(self) -> Frame:
        columns, self.columns = self.columns, _columns()
        return Frame.of(None, cycle=columns["cycle_index"][0], cycles=len(columns["cycle_index"]), per_cycle=columns,
                        dt_s=self.config.dt_s)

    def summary(self) -> dict:
        counts = {**self.counts, "unmeasured_by_reason": self.reasons, "live_tracks": len(self.tracks),
                  "live_confirmed_tracks": int(self.tracks.confirmed.sum())}
        # the run's track figures (carav_stream/track/figures.py) go to the run summary's "tracks"
        return {**counts, "run": {"tracks": {**counts, "dt_s": self.config.dt_s, "nis_alarm": self.nis_pfa > 0,
                                  **self.figures.figures(self.truth)}}}


def _columns() -> dict[str, list]:
    """The output's per_cycle columns, empty, in the order of the module docstring (the tracks' as CycleReport.plain
    gives them)."""
    return {key: [] for key in ("cycle_index", "measured", "reason", "attack_active", "born", "deleted", *PLAIN_KEYS)}
