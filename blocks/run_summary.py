"""Run summary: detection and ranging figures of a run, live on the console and in `carav run --json`.

Counts every cycle once, from the gate's alarms and the estimator's records: cycles, alarms (by reason and by
the detector that raised them), attacked cycles (header attack_active, set by the attacker), detected
attacks, false alarms (alarms on cycles with no attack), missed attacks, and the range and velocity errors
of the estimates against the scene's first target (mean, rmse, max), split into attacked and clean cycles.

Ports   in  estimates   range_estimator records          (merged in arrival order with alarms)
        in  alarms      gate alarm records
Params  scene (str, "table1"): truth for the errors; every_s (float, 0): print a line every so many seconds
Graph   summary = { type = "run_summary" }
"""
import math
import sys
import time

import numpy as np

from carav_stream.block import Block, In, Param
from carav_stream.radar.streams import scene_of
from carav_stream.frames import Frame


def _stats(errors: list[float]) -> dict:
    if not errors:
        return {"n": 0, "mean": None, "rmse": None, "max": None}
    e = np.asarray(errors)
    return {"n": int(e.size), "mean": float(e.mean()), "rmse": float(math.sqrt(np.mean(e ** 2))),
            "max": float(np.max(np.abs(e)))}


class RunSummary(Block):
    inputs = (In("estimates", kind="estimates"), In("alarms", kind="alarm", required=False))
    merge_inputs = True
    params = (Param("scene", str, "table1", "preset name or scene file (truth)"),
              Param("every_s", float, 0.0, "console line period; 0 = none", low=0.0))

    def check_params(self) -> None:
        scene = scene_of(self.scene)
        target = scene.targets[0] if scene.targets else None
        self.true_range_m = target.range_m if target else None
        self.true_velocity_mps = scene.range_rate_mps(target) if target else None

    def start(self) -> None:
        self.cycles = self.attacked = self.detected = self.false_alarms = self.refused = 0
        self.reasons: dict[str, int] = {}
        self.raised_by: dict[str, int] = {}
        self.range_err = {"attacked": [], "clean": []}
        self.velocity_err: list[float] = []
        self.next_print = time.monotonic() + self.every_s

    def process(self, estimates: Frame | None, alarms: Frame | None = None) -> None:
        frame = estimates if estimates is not None else alarms
        h = frame.header
        attacked = bool(h.get("attack_active", False))
        self.cycles += 1
        self.attacked += attacked
        if alarms is not None:
            reason = h.get("reason", "attack")
            self.reasons[reason] = self.reasons.get(reason, 0) + 1
            if "raised_by" in h:
                self.raised_by[h["raised_by"]] = self.raised_by.get(h["raised_by"], 0) + 1
            self.detected += attacked
            self.false_alarms += not attacked
        elif h.get("refused"):
            self.refused += 1
        elif self.true_range_m is not None and h.get("range_m") and h["range_m"][0] is not None:
            self.range_err["attacked" if attacked else "clean"].append(h["range_m"][0] - self.true_range_m)
            if h.get("velocity_mps") and h["velocity_mps"][0] is not None:
                self.velocity_err.append(h["velocity_mps"][0] - self.true_velocity_mps)
        if self.every_s and time.monotonic() >= self.next_print:
            self.next_print = time.monotonic() + self.every_s
            r = self.run_figures()
            print(f"[summary] {r['cycles']} cycles  alarms {r['alarms']}  attacked {r['attacked_cycles']}  "
                  f"detected {r['detected']}  false alarms {r['false_alarms']}  range rmse "
                  f"{r['range_error_m']['rmse']}", file=sys.stderr, flush=True)

    def run_figures(self) -> dict:
        alarms = sum(self.reasons.values())
        all_range = self.range_err["attacked"] + self.range_err["clean"]
        return {
            "cycles_judged": self.cycles, "cycles": self.cycles, "alarms": alarms, "alarm_reasons": self.reasons,
            "raised_by": self.raised_by, "attacked_cycles": self.attacked, "detected": self.detected,
            "missed": self.attacked - self.detected, "false_alarms": self.false_alarms,
            "detection_rate": self.detected / self.attacked if self.attacked else None,
            "false_alarm_rate": self.false_alarms / (self.cycles - self.attacked) if self.cycles > self.attacked else None,
            "refused_by_estimator": self.refused,
            "range_error_m": _stats(all_range),
            "range_error_attacked_missed_m": _stats(self.range_err["attacked"]),
            "velocity_error_mps": _stats(self.velocity_err),
        }

    def summary(self) -> dict:
        figures = self.run_figures()
        figures.pop("cycles")   # the runtime's own count of cycles stays authoritative
        return {"run": figures}
