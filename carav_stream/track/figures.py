"""A run's tracks scored against the truth, one cycle at a time, in constant memory per live track.

Truth: the scene's targets, target i at range R_i(c) and range rate V_i(c) in cycle c (the caller gives them per
cycle). A track is ON target i in a cycle when it lies within the truth gate of it:

    on_i  <=>  |r - R_i(c)| <= gate_range_m  and  |rdot - V_i(c)| <= gate_velocity_mps

and OFF when it is on no target. Over the cycles a track spends confirmed (status "confirmed" or "coasting"):

    confirmed track   a track that was confirmed in some cycle
    false track       a confirmed track that was off every target in some cycle while confirmed: a track that
                      never was on a target (a ghost), or one that was and left it (dragged: a pull-off)
    dragged track     a false track that was on a target in another cycle while confirmed

Per target, from the first cycle with a confirmed track on it (the target is held from then on):

    held      cycles with a track on it that this cycle's measurement updated ("confirmed")
    coasted   the other cycles with a confirmed track on it, coasting (not updated: an unmeasured cycle, a miss)
    lost      cycles with no confirmed track on it: its track deleted, dragged away, or not confirmed again yet
    deleted   confirmed tracks deleted while on it (on it in the last cycle they lived)

Targets closer together than the gates may share a track: it is on each of them.

held + coasted + lost = the cycles from the first held one on. Alarms from the attack's start (the first cycle the
attacker says it is on, attack_active): the first cycle the gate refused for the detector's alarm (reason
"attack": CARAV) and the first cycle with a track's NIS alarm, each in cycles after the start and in ms (times the
cycle time dt_s); None when there was none, or no attack.

The two gates default to NEAR_M and NEAR_MPS: about a range cell, and far beyond the estimator's range-rate error
(a track on the car is within them; a track a range cell away from every target is not).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

NEAR_M, NEAR_MPS = 1.0, 1.0


@dataclass
class _Target:
    first_held: int | None = None
    held: int = 0
    coasted: int = 0
    lost: int = 0
    deleted: int = 0
    track_ids: set[int] = field(default_factory=set)


class TrackFigures:
    """The figures of the module docstring, added cycle by cycle (`add`), read at any time (`figures`); nis_alarm:
    whether the tracker raises NIS alarms (else the first NIS alarm reads "off")."""

    def __init__(self, n_targets: int, dt_s: float, nis_alarm: bool, gate_range_m: float = NEAR_M,
                 gate_velocity_mps: float = NEAR_MPS) -> None:
        self.dt_s, self.gate, self.nis_on = dt_s, (gate_range_m, gate_velocity_mps), nis_alarm
        self.targets = [_Target() for _ in range(n_targets)]
        self.confirmed: set[int] = set()
        self.false: set[int] = set()
        self.was_on: set[int] = set()               # confirmed tracks that were on a target while confirmed
        self.on_last: dict[int, list[int]] = {}     # live confirmed track -> the targets it was on last cycle
        self.attack_start: int | None = None
        self.first_carav: int | None = None
        self.first_nis: int | None = None

    def add(self, cycle: int, ids: Sequence[int], status: Sequence[str], range_m: Sequence[float],
            velocity_mps: Sequence[float], deleted: Sequence[int], truth: tuple[Sequence[float], Sequence[float]],
            reason: str | None = None, attack_active: bool | None = None,
            nis_alarm: Sequence[bool] | None = None) -> None:
        """One cycle, in cycle order: the live tracks after it (ids, status, range_m, velocity_mps over them), the
        ids deleted in it, the truth (R(c), V(c) over targets), the gate's reason for an unmeasured cycle, whether
        the attacker was on (None: not known), the tracks' NIS alarms (None: the alarm is off). Plain Python over
        the few tracks and targets of a cycle: for so few, numpy's calls cost more than the arithmetic."""
        for i in deleted:
            for j in self.on_last.pop(int(i), ()):
                self.targets[j].deleted += 1
        targets = list(zip(_plain(truth[0]), _plain(truth[1])))
        best = [""] * len(targets)           # per target: "confirmed" if an updated track is on it, else "coasting"
        for i, s, r, v in zip(_plain(ids), status, _plain(range_m), _plain(velocity_mps)):
            if s != "tentative":
                self._on(i, s, r, v, targets, best)
        self._count(cycle, best)
        self._alarms(cycle, reason, attack_active, nis_alarm)

    def add_one(self, cycle: int, track_id: int | None, updated: bool, range_m: float, velocity_mps: float,
                targets: list[tuple[float, float]], reason: str | None, attack_active: bool | None,
                nis_alarm: list[bool] | None) -> None:
        """`add` for a cycle with one live track, confirmed (updated or coasting), or none (track_id None), and
        nothing deleted: a radar's usual cycle, without add's lists. targets: the truth as (R(c), V(c)) pairs of
        Python floats."""
        best = [""] * len(targets)
        if track_id is not None:
            self._on(track_id, "confirmed" if updated else "coasting", range_m, velocity_mps, targets, best)
        self._count(cycle, best)
        self._alarms(cycle, reason, attack_active, nis_alarm)

    def _on(self, i: int, s: str, r: float, v: float, targets: list[tuple[float, float]], best: list[str]) -> None:
        """Confirmed track i (status s) at (r, v) this cycle: the targets it is on, and their best status."""
        g_r, g_v = self.gate
        self.confirmed.add(i)
        self.on_last[i] = on = [j for j, (tr, tv) in enumerate(targets) if abs(r - tr) <= g_r and abs(v - tv) <= g_v]
        (self.was_on if on else self.false).add(i)
        for j in on:
            self.targets[j].track_ids.add(i)
            best[j] = "confirmed" if s == "confirmed" else best[j] or s

    def _count(self, cycle: int, best: list[str]) -> None:
        """Each target's held, coasted or lost cycle, from the best status of a track on it ("" for none)."""
        for t, b in zip(self.targets, best):
            if t.first_held is None and not b:
                continue
            t.first_held = cycle if t.first_held is None else t.first_held
            if b == "confirmed":
                t.held += 1
            elif b:
                t.coasted += 1
            else:
                t.lost += 1

    def _alarms(self, cycle: int, reason: str | None, attack_active: bool | None,
                nis_alarm: Sequence[bool] | None) -> None:
        if self.attack_start is None:
            if not attack_active:
                return
            self.attack_start = cycle
        if self.first_carav is None and reason == "attack":
            self.first_carav = cycle
        if self.first_nis is None and nis_alarm is not None and any(nis_alarm):
            self.first_nis = cycle

    def _after(self, cycle: int | None) -> dict | None:
        if cycle is None:
            return None
        n = cycle - self.attack_start
        return {"cycle": cycle, "cycles": n, "ms": n * self.dt_s * 1e3}

    def figures(self, truth: tuple[np.ndarray, np.ndarray]) -> dict:
        """The figures so far; `truth` (R, V over targets) names the targets (their values at the start)."""
        dragged = self.false & self.was_on
        return {
            "truth_gate": {"range_m": self.gate[0], "velocity_mps": self.gate[1]},
            "confirmed_tracks": len(self.confirmed), "false_tracks": len(self.false),
            "false_track_ids": sorted(self.false), "dragged_tracks": len(dragged),
            "targets": [{"range_m": float(r), "velocity_mps": float(v), "first_held_cycle": t.first_held,
                         "held_cycles": t.held, "coasted_cycles": t.coasted, "lost_cycles": t.lost,
                         "deleted_tracks": t.deleted, "track_ids": sorted(t.track_ids)}
                        for r, v, t in zip(truth[0], truth[1], self.targets)],
            "attack_start_cycle": self.attack_start,
            "first_alarm": None if self.attack_start is None else {
                "carav": self._after(self.first_carav),
                "nis": self._after(self.first_nis) if self.nis_on else "off"},
        }


def _plain(values: Sequence) -> Sequence:
    """Python numbers from an array (a number from an array is slow to compute with one at a time); a sequence of
    them as it is."""
    return values.tolist() if isinstance(values, np.ndarray) else values
