"""Run summary: detection and ranging figures of a run, live on the console and in `carav run --json`.

Counts every cycle once, from the gate's alarms and the estimator's records (each frame carries one or more
cycles, per_cycle lists): cycles, alarms (by reason and by the detector that raised them), attacked cycles
(per-cycle attack_active, set by the attacker), detected attacks, false alarms (the detector's own alarms,
C(eta) >= 1, on cycles with no attack), missed attacks, fail-closed refusals apart (cycles stopped without a
verdict of the detector: invalid frames, no activation sequence, no verdict, a crashed detector; they are neither
detections nor false alarms, and the rates are over the cycles the detector judged), the radar's own cycle
duration and rate (the scene's t_cycle and 1 / t_cycle: `carav run` reports cycles x t_cycle as the radar time
simulated and its ratio to the wall time as the real-time factor), and the range and velocity errors of the
estimates against the scene's first target (n, mean, rmse, abs_max = the largest |error|, also under its older
key max), split into attacked and clean cycles. The target moves during a cycle: the range error is taken against
its range at the instant the cycle's estimate refers to (the estimator's range_time_s: the scene's range plus its
range rate times that instant; records without it are scored at the cycle's start). The velocity error is the
estimate minus the true range rate, unfolded: a target faster than the unambiguous +-lambda / (4 T_c) (AWR1642's
Table II car) is seen at its alias, so its error is tens of m/s, and `velocity_ambiguous` says so; the error modulo the
unambiguous interval (how well the alias was measured) is reported beside it. With an antenna array the azimuth
error of the first target (estimate minus the scene's target azimuth, degrees) beside them, and the RMS of the
Cramer-Rao standard deviations the estimator reported with it: one target of one scene, no other.

With a CFAR target list (range_estimator detection = "ca_cfar" | "os_cfar") every cycle's list is scored against
all of the scene's targets (carav_stream.firmware.target_list.associate: nearest pairs within 1.5 range cells plus
half the cycle's range migration and 1.5 Doppler bins, velocities modulo the ambiguity): the probability of
detection per true target and the false targets per cycle, on cycles without an attack and, apart, on attacked
cycles the detector missed (where a ghost shows up as a false target).

On a receiver array the detector's attacker columns (per_cycle attack_azimuth_deg, attack_azimuth_std_deg,
attack_reason; the gate carries them on both of its outputs) are tallied under attacker_direction: the cycles by
reason, attacked and clean apart; over the attacked cycles with an azimuth (estimated or mirrored) its median, half
its interquartile range (quantiles of a 0.01 degree histogram: constant memory) and its RMS deviation; and where the
estimates carry per-target azimuths (per_cycle azimuth_deg, azimuth_std_deg beside them if any) every detection of a
cycle with an attacker's azimuth is compared with it (carav_stream/estimate/attacker_direction.matches_attacker:
within 3 sqrt(std_det^2 + std_att^2) + azimuth_floor_deg) and the flagged ones counted: a target in the attacker's
direction may be its ghost, even where CARAV passed the cycle.

The figures are those of this process: a restarted run_summary starts them afresh, and then says which cycles
they cover (`figures_cover`: the first and last cycle counted, the restarts, and a sentence `carav run` prints).

Ports   in  estimates   range_estimator records          (merged in arrival order with alarms)
        in  alarms      gate alarm records
Graph   summary = { type = "run_summary" }
"""
import math
import sys
import time

import numpy as np

from carav_stream.estimate.attacker_direction import MIRRORED, AttackerDirection, matches_attacker
from carav_stream.estimate.geometry import Geometry
from carav_stream.firmware.target_list import KINDS, associate, gates
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Param, cycle_indices, n_cycles, per_cycle


class ErrorStats:
    """Count, mean, RMS and largest magnitude of a stream of errors, in constant memory (a run may be endless)."""

    def __init__(self) -> None:
        self.n, self.total, self.squares, self.largest = 0, 0.0, 0.0, 0.0

    def add(self, e: float) -> None:
        self.n += 1
        self.total += e
        self.squares += e * e
        self.largest = max(self.largest, abs(e))

    def merged(self, other: "ErrorStats") -> "ErrorStats":
        out = ErrorStats()
        out.n, out.total = self.n + other.n, self.total + other.total
        out.squares, out.largest = self.squares + other.squares, max(self.largest, other.largest)
        return out

    def figures(self) -> dict:
        if not self.n:
            return {"n": 0, "mean": None, "rmse": None, "max": None, "abs_max": None}
        # abs_max names the largest |error|; max is the same figure under its older key (kept for readers of it)
        return {"n": self.n, "mean": self.total / self.n, "rmse": math.sqrt(self.squares / self.n),
                "max": self.largest, "abs_max": self.largest}


class DirectionTally:
    """The attacker's azimuth per cycle and the detections in its direction (module docstring), constant memory."""

    STEP = 0.01   # degrees per histogram bin

    def __init__(self, floor_deg: float) -> None:
        self.floor_deg = floor_deg
        self.reasons: dict[str, dict[str, int]] = {"attacked": {}, "clean": {}}
        self.hist = np.zeros(int(round(180 / self.STEP)) + 1, dtype=np.int64)
        self.azimuth = ErrorStats()      # the attacked cycles' azimuths (their mean and RMS about it)
        self.flags = {"attacked": [0, 0, 0], "clean": [0, 0, 0]}   # detections compared, flagged, cycles flagged

    def add(self, per: dict, n: int, attacked: list) -> None:
        reasons, az = per.get("attack_reason"), per.get("attack_azimuth_deg")
        if reasons is None or az is None:
            return
        std = per.get("attack_azimuth_std_deg") or [float("nan")] * n
        for i in range(n):
            kind = "attacked" if attacked[i] else "clean"
            tally = self.reasons[kind]
            tally[str(reasons[i])] = tally.get(str(reasons[i]), 0) + 1
            if attacked[i] and isinstance(az[i], float | int) and math.isfinite(az[i]):
                self.azimuth.add(float(az[i]))
                self.hist[int(round((min(max(az[i], -90.0), 90.0) + 90.0) / self.STEP))] += 1
        if per.get("azimuth_deg") is not None:
            self._flag(per, n, attacked, az, std, reasons)

    def _flag(self, per: dict, n: int, attacked: list, az: list, std: list, reasons: list) -> None:
        """Every detection of a cycle (per_cycle azimuth_deg: a list per cycle) against its cycle's attacker."""
        def table(rows: list) -> np.ndarray:
            rows = [list(r) if isinstance(r, list | tuple) else [] for r in rows]
            out = np.full((n, max((len(r) for r in rows), default=0)), np.nan)
            for i, r in enumerate(rows):
                out[i, :len(r)] = [np.nan if v is None else float(v) for v in r]
            return out

        def column(values: list) -> np.ndarray:
            return np.array([float(v) if isinstance(v, float | int) else np.nan for v in values])
        det = table(per["azimuth_deg"])
        det_std = np.nan_to_num(table(per.get("azimuth_std_deg") or [[]] * n), nan=0.0)[:, :det.shape[1]]
        det_std = np.pad(det_std, ((0, 0), (0, det.shape[1] - det_std.shape[1])))
        att = AttackerDirection(column(az), column(std), np.full(n, np.nan), np.full(n, np.nan),
                                np.zeros(n, np.int64), np.array([MIRRORED if r == "mirrored" else 0 for r in reasons]))
        hit = matches_attacker(det, det_std, att, floor_deg=self.floor_deg)
        compared = np.isfinite(det) & np.isfinite(att.azimuth_deg)[:, None]
        for i in range(n):
            f = self.flags["attacked" if attacked[i] else "clean"]
            f[0] += int(compared[i].sum())
            f[1] += int(hit[i].sum())
            f[2] += int(hit[i].any())

    def _quantile(self, q: float) -> float:
        cum = np.cumsum(self.hist)
        return round(float(np.searchsorted(cum, q * cum[-1]) * self.STEP - 90.0), 2)

    def figures(self) -> dict | None:
        if not any(self.reasons.values()):
            return None
        n = self.azimuth.n
        stats = self.azimuth.figures()
        out = {"cycles_by_reason": self.reasons, "attacked_cycles_with_azimuth": n,
               "median_azimuth_deg": self._quantile(0.5) if n else None,
               "azimuth_spread_deg": (self._quantile(0.75) - self._quantile(0.25)) / 2 if n else None,
               "azimuth_rms_deviation_deg": (math.sqrt(max(stats["rmse"] ** 2 - stats["mean"] ** 2, 0.0))
                                             if n else None)}
        if any(f[0] for f in self.flags.values()):
            out["flagged_detections"] = {k: {"compared": f[0], "flagged": f[1], "cycles_flagged": f[2]}
                                         for k, f in self.flags.items()}
            out["floor_deg"] = self.floor_deg
        return out


class RunSummary(Block):
    inputs = (In("estimates", kind="estimates"), In("alarms", kind="alarm", required=False))
    merge_inputs = True
    params = (SCENE,
              Param("every_s", float, 0.0, "console line period; 0 = none", low=0.0),
              Param("azimuth_floor_deg", float, 2.0, "added to 3 sigma when a detection's azimuth is compared with "
                    "the attacker's", unit="deg", low=0.0))

    def check_params(self) -> None:
        scene = scene_of(self.scene)
        target = scene.targets[0] if scene.targets else None
        self.true_range_m = target.range_m if target else None
        self.true_velocity_mps = scene.range_rate_mps(target) if target else None
        self.true_azimuth_deg = target.azimuth_deg if target and scene.has_array else None
        geometry = Geometry.from_scene(scene)
        self.radar_rate, self.radar_cycle_s = scene.cycles_per_s, scene.t_cycle_s
        self.v_max = geometry.max_velocity_mps
        self.truth = ([t.range_m for t in scene.targets], [scene.range_rate_mps(t) for t in scene.targets])
        fastest = max((abs(v) for v in self.truth[1]), default=0.0)
        self.gates = gates(geometry, scene.n_chirps, fastest)

    def start(self) -> None:
        self.cycles = self.attacked = self.detected = self.false_alarms = self.refused = self.unreadable = 0
        self.refused_attacked = 0                  # fail-closed refusals of attacked cycles (no detector verdict)
        self.reasons: dict[str, int] = {}
        self.raised_by: dict[str, int] = {}
        self.range_err = {"attacked": ErrorStats(), "clean": ErrorStats()}
        self.velocity_err = ErrorStats()           # estimate - true range rate, as measured
        self.velocity_err_folded = ErrorStats()    # the same error modulo the unambiguous interval
        self.azimuth_err = ErrorStats()            # first target's azimuth estimate - the scene's, degrees
        self.azimuth_bound = ErrorStats()          # the Cramer-Rao std reported with it (its rmse: their RMS)
        self.next_print = time.monotonic() + self.every_s
        self.listing: dict[str, dict] = {}         # CFAR lists scored against the truth, by attacked / clean
        self.detection: str | None = None
        self.first_cycle: int | None = None       # the lowest and highest cycle index counted
        self.last_cycle: int | None = None
        self.direction = DirectionTally(self.azimuth_floor_deg)

    def process(self, estimates: Frame | None, alarms: Frame | None = None) -> None:
        frame = estimates if estimates is not None else alarms
        n = n_cycles(frame)
        try:
            per = per_cycle(frame)
        except ValueError:   # not readable cycle by cycle: counted, never guessed
            per = {}
            self.unreadable += n
        attacked = per.get("attack_active") or [False] * n
        self.cycles += n
        self._covered(frame)
        self.attacked += sum(bool(a) for a in attacked)
        if not frame.header.get("refused"):
            self.direction.add(per, n, attacked)
        if alarms is not None:
            for i in range(n):
                reason = (per.get("reason") or ["attack"] * n)[i]
                self.reasons[reason] = self.reasons.get(reason, 0) + 1
                by = (per.get("raised_by") or [None] * n)[i]
                if by is not None:
                    self.raised_by[by] = self.raised_by.get(by, 0) + 1
                if reason == "attack":             # the detector's own verdict: C(eta) >= 1
                    self.detected += bool(attacked[i])
                    self.false_alarms += not attacked[i]
                else:                              # refused without a verdict (fail closed): counted apart
                    self.refused_attacked += bool(attacked[i])
        elif frame.header.get("refused"):
            self.refused += n
        elif self.true_range_m is not None:
            ranges, velocities = per.get("range_m") or [None] * n, per.get("velocity_mps") or [None] * n
            if frame.header.get("detection") in KINDS:
                self.detection = frame.header["detection"]
                for i in range(n):
                    self._score(ranges[i] or [], velocities[i] or [], "attacked_missed" if attacked[i] else "clean")
            instants = per.get("range_time_s") or [0.0] * n
            for i in range(n):
                if ranges[i] and ranges[i][0] is not None:
                    truth = self.true_range_m + self.true_velocity_mps * (instants[i] or 0.0)
                    self.range_err["attacked" if attacked[i] else "clean"].add(ranges[i][0] - truth)
                if velocities[i] and velocities[i][0] is not None:
                    err = velocities[i][0] - self.true_velocity_mps
                    self.velocity_err.add(err)
                    self.velocity_err_folded.add((err + self.v_max) % (2 * self.v_max) - self.v_max)
            if self.true_azimuth_deg is not None:
                self._azimuths(per, n)
        if self.every_s and time.monotonic() >= self.next_print:
            self.next_print = time.monotonic() + self.every_s
            r = self.run_figures()
            rmse = r["range_error_m"]["rmse"]
            print(f"[summary] {r['cycles']} cycles judged: attacked {r['attacked_cycles']}, detected "
                  f"{r['detected']}, false alarms {r['false_alarms']}, refused without a verdict "
                  f"{r['refused']['cycles']}; range RMSE {'n/a' if rmse is None else f'{rmse * 1e3:.3g} mm'}",
                  file=sys.stderr, flush=True)

    def _azimuths(self, per: dict, n: int) -> None:
        azimuths, stds = per.get("azimuth_deg") or [None] * n, per.get("azimuth_std_deg") or [None] * n
        for i in range(n):
            if azimuths[i] and azimuths[i][0] is not None:
                self.azimuth_err.add(azimuths[i][0] - self.true_azimuth_deg)
                if stds[i] and stds[i][0] is not None:
                    self.azimuth_bound.add(stds[i][0])

    def _covered(self, frame: Frame) -> None:
        try:
            index = [c for c in cycle_indices(frame) if type(c) is int]
        except (TypeError, ValueError):   # an unreadable frame's cycles are counted as unreadable, not placed
            index = []
        if index:
            lo, hi = min(index), max(index)
            self.first_cycle = lo if self.first_cycle is None else min(self.first_cycle, lo)
            self.last_cycle = hi if self.last_cycle is None else max(self.last_cycle, hi)

    def coverage(self) -> dict | None:
        """None for the run_summary a run started with; after a restart, which cycles these figures cover."""
        restarts = self.instance[0]
        if not restarts:
            return None
        span = "no cycle" if self.first_cycle is None else f"cycles {self.first_cycle}-{self.last_cycle}"
        return {"first_cycle": self.first_cycle, "last_cycle": self.last_cycle, "cycles": self.cycles,
                "restarts": restarts,
                "text": f"figures cover {span} only ({self.cycles} cycles counted): run_summary restarted "
                        f"{restarts} time{'s' if restarts != 1 else ''}"}

    def _score(self, ranges: list, velocities: list, kind: str) -> None:
        pairs = [(r, v) for r, v in zip(ranges, velocities) if r is not None and v is not None]
        found, false = associate([r for r, _ in pairs], [v for _, v in pairs], *self.truth, *self.gates, self.v_max)
        tally = self.listing.setdefault(kind, {"cycles": 0, "detected": [0] * len(found), "false_targets": 0})
        tally["cycles"] += 1
        tally["detected"] = [d + int(f) for d, f in zip(tally["detected"], found)]
        tally["false_targets"] += false

    def target_list_figures(self) -> dict | None:
        if self.detection is None:
            return None
        out = {"detection": self.detection, "gates": {"range_m": self.gates[0], "velocity_mps": self.gates[1]}}
        for kind, t in self.listing.items():
            out[kind] = {"cycles": t["cycles"], "false_targets": t["false_targets"],
                         "false_targets_per_cycle": t["false_targets"] / t["cycles"],
                         "targets": [{"range_m": r, "velocity_mps": v, "detected_cycles": d,
                                      "probability_of_detection": d / t["cycles"]}
                                     for r, v, d in zip(*self.truth, t["detected"])]}
        return out

    def azimuth_error_figures(self) -> dict | None:
        """The first target's azimuth error and the RMS of its reported bound; None without an array."""
        if self.true_azimuth_deg is None:
            return None
        return {**self.azimuth_err.figures(), "true_azimuth_deg": self.true_azimuth_deg,
                "bound_rms_deg": self.azimuth_bound.figures()["rmse"], "covers": "the scene's first target only"}

    def run_figures(self) -> dict:
        alarms = sum(self.reasons.values())
        refusals = {k: v for k, v in self.reasons.items() if k != "attack"}
        judged_attacked = self.attacked - self.refused_attacked
        judged_clean = self.cycles - self.attacked - (sum(refusals.values()) - self.refused_attacked)
        all_range = self.range_err["attacked"].merged(self.range_err["clean"])
        return {
            "cycles_judged": self.cycles, "cycles": self.cycles, "alarms": alarms, "alarm_reasons": self.reasons,
            "raised_by": self.raised_by, "attacked_cycles": self.attacked, "detected": self.detected,
            "missed": judged_attacked - self.detected, "false_alarms": self.false_alarms,
            # rates over the cycles the detector judged: a refusal is neither a detection nor a false alarm
            "detection_rate": self.detected / judged_attacked if judged_attacked else None,
            "false_alarm_rate": self.false_alarms / judged_clean if judged_clean else None,
            "refused": {"cycles": sum(refusals.values()), "by_reason": refusals,
                        "attacked_cycles": self.refused_attacked},
            "radar_cycles_per_s": self.radar_rate, "radar_cycle_duration_s": self.radar_cycle_s,
            "refused_by_estimator": self.refused, "unreadable_cycles": self.unreadable,
            "range_error_m": all_range.figures(),
            "range_error_attacked_missed_m": self.range_err["attacked"].figures(),
            "velocity_error_mps": self.velocity_err.figures(),
            # the Doppler FFT measures velocity modulo 2 v_max: a target beyond +-v_max is reported folded, and
            # its error above is the folded estimate's (tens of m/s); this one says how well the folded value fits
            "velocity_ambiguous": self.true_velocity_mps is not None and abs(self.true_velocity_mps) >= self.v_max,
            "unambiguous_velocity_mps": self.v_max,
            "velocity_error_modulo_ambiguity_mps": self.velocity_err_folded.figures(),
            "azimuth_error_deg": self.azimuth_error_figures(),
            "target_list": self.target_list_figures(),
            "attacker_direction": self.direction.figures(),
            "figures_cover": self.coverage(),
        }

    def summary(self) -> dict:
        figures = self.run_figures()
        figures.pop("cycles")   # the runtime's own count of cycles stays authoritative
        return {"run": figures}
