"""What an attack does to the car's picture of the road, by defence (`carav experiment tracks`; its command line in
carav_stream/cli/experiment/tracks.py).

Table I's radar behind the car at its own speed (table1_following: the car keeps its range from cycle to cycle, as a
tracker's constant-velocity model has it), the radar chain in one process (run_algorithm1, the strongest target of
every cycle by ML) with an attacker switched on at cycle START and left on, and the tracker of
graphs/table1_tracks.toml on the estimates. One simulation per attacker model and RARMS, four defences on it:

    none    every cycle's estimate reaches the tracker; no NIS alarm
    CARAV   the cycles the RMS detector refuses (C(eta) >= 1 at the paper's eta, or an invalid frame) are unmeasured:
            the tracks coast through them
    NIS     every cycle measured, the tracker's windowed NIS alarm on: it raises an alarm, it refuses nothing, so
            the tracks are those of `none`
    both    CARAV's refusals and the NIS alarm

Figures of each, over the cycles from the attack's start on:

    false tracks/min  confirmed tracks that were ever more than NEAR_M or NEAR_MPS from the car (the gates of
                      track/figures.py, the run summary's), per minute of radar time (the run's cycles times the
                      scene's cycle time)
    car lost          share of the cycles without a confirmed track (coasting included) within NEAR_M and NEAR_MPS
                      of the car
    lead error        RMS range and range-rate error, against the car, of the lead track: the nearest confirmed
                      track, the one an adaptive cruise control follows; over the cycles that have one
    first alarm       cycles from the attack's start to the first alarm: CARAV's first refusal, the NIS alarm's first
                      firing, the earlier of the two for both; None: none in the run
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.detect.detector import PAPER_ETA
from carav_stream.experiments.reporting import Tally
from carav_stream.firmware.algorithm1 import run_algorithm1
from carav_stream.radar.scene_loader import load_scene
from carav_stream.track import NEAR_M, NEAR_MPS, CycleReport, TrackerConfig, run

__all__ = ["tracks_experiment", "cell", "MODELS", "DEFENCES", "TRACKER", "START", "SCENE"]

SCENE = "table1_following"
START = 200                  # the attacker's first cycle: the car's track is confirmed and settled by then
NO_ALARM_ETA = 1e9           # the chain's detector as good as off; CARAV's refusals come from its Q at PAPER_ETA
# the tracker of graphs/table1_tracks.toml (tests/experiments/test_tracks.py keeps the two the same)
TRACKER = {"sigma_accel_mps2": 8.0, "sigma_range_m": 0.0025, "sigma_velocity_mps": 0.01, "gate_probability": 0.9999,
           "confirm_m": 3, "confirm_n": 5, "delete_misses": 3, "coast_cycles": 1066, "nis_pfa": 1e-3,
           "nis_window": 16}
# each model as the graphs and documents use it; every one rides the scene's car or plants its own target
MODELS = {"pull_off": {"capture_cycles": 100, "pull_mps": 10.0, "pull_accel_mps2": 40.0},
          "ghost": {"range_m": 30.0, "velocity_mps": 100 / 3.6},
          "smart": {}}
DEFENCES = ("none", "CARAV", "NIS", "both")


def _config(nis: bool, dt_s: float) -> TrackerConfig:
    return TrackerConfig(dt_s=dt_s, **{**TRACKER, "nis_pfa": TRACKER["nis_pfa"] if nis else 0.0})


def _figures(reports: list[CycleReport], car: tuple[float, float], refused: np.ndarray | None, nis: bool,
             t_cycle_s: float) -> dict:
    """The defence's figures (module docstring) from the tracker's reports of every cycle."""
    after = reports[START:]
    false_ids, lost, errors = set(), 0, []
    for rep in after:
        confirmed = np.array([s != "tentative" for s in rep.status], bool)
        dr, dv = rep.range_m - car[0], rep.velocity_mps - car[1]
        near = (np.abs(dr) <= NEAR_M) & (np.abs(dv) <= NEAR_MPS)
        false_ids |= {int(i) for i in rep.id[confirmed & ~near]}
        lost += not np.any(confirmed & near)
        if confirmed.any():
            lead = np.flatnonzero(confirmed)[np.argmin(rep.range_m[confirmed])]
            errors.append((dr[lead], dv[lead]))
    alarms = []
    if refused is not None and refused[START:].any():
        alarms.append(int(np.argmax(refused[START:])))
    if nis:
        alarms += [k for k, rep in enumerate(after) if rep.nis_alarm is not None and rep.nis_alarm.any()][:1]
    e = np.array(errors).reshape(-1, 2)
    minutes = len(reports) * t_cycle_s / 60.0
    return {"false_tracks": len(false_ids), "false_tracks_per_min": len(false_ids) / minutes,
            "car_lost": lost / len(after), "lead_cycles": len(errors),
            "lead_range_rmse_m": float(np.sqrt(np.mean(e[:, 0] ** 2))) if errors else None,
            "lead_velocity_rmse_mps": float(np.sqrt(np.mean(e[:, 1] ** 2))) if errors else None,
            "first_alarm_cycles": min(alarms) if alarms else None}


def cell(model: str, rarms: float, n_cycles: int, seed: int) -> dict:
    """Every defence's figures against `model` at `rarms`, on one simulation of n_cycles (the attack from START)."""
    if n_cycles <= START:
        raise ValueError(f"n_cycles: the attack starts at cycle {START}, so a run needs more cycles, got {n_cycles}")
    scene = load_scene(SCENE)
    car = (scene.targets[0].range_m, scene.range_rate_mps(scene.targets[0]))
    r = run_algorithm1(scene, n_cycles, seed=seed, attack=model, eta=NO_ALARM_ETA,
                       attack_params={"rarms": rarms, "start_cycle": START, **MODELS[model]})
    refused = (r.q >= PAPER_ETA) | r.invalid
    estimate = [np.array([[r.range_m[k, 0], r.velocity_mps[k, 0]]]) for k in range(n_cycles)]
    estimate = [z if np.isfinite(z).all() else np.zeros((0, 2)) for z in estimate]
    out = {"model": model, "rarms": rarms, "cycles": n_cycles, "start_cycle": START,
           "attacked_cycles": int(r.attack_active.sum()), "refused_cycles": int(refused[START:].sum()),
           "false_refusals": int(refused[:START].sum()), "defences": {}}
    for defence in DEFENCES:
        carav, nis = defence in ("CARAV", "both"), defence in ("NIS", "both")
        z = [None if carav and refused[k] else estimate[k] for k in range(n_cycles)]
        reports = run(z, _config(nis, scene.t_cycle_s))[1]
        out["defences"][defence] = _figures(reports, car, refused if carav else None, nis, scene.t_cycle_s)
    return out


def tracks_experiment(models: list[str], rarms: list[float], n_cycles: int, seed: int,
                      partial: Callable[[dict], None] | None = None,
                      progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """cell() of every model and RARMS, in that order; partial(cell) as each is done, progress(done, total) in
    cells."""
    rows = []
    tally = Tally(len(models) * len(rarms), progress)
    for i, model in enumerate(models):
        for j, level in enumerate(rarms):
            c = cell(model, level, n_cycles, seed + 1000 * i + j)
            if partial is not None:
                partial(c)
            rows.append(c)
            tally(1)
    return rows
