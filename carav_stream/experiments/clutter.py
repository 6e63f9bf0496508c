"""Several targets and clutter, no attacker: false alarms of every detector and what the radar's target list makes
of the scene (`carav experiment clutter`; its command line in carav_stream/cli/experiment/clutter.py).

Scenes, each the preset with its own car plus:
  car                 nothing (the baseline)
  four targets        a truck 20 dB louder at 15 m closing, a receding car, a slow pedestrian-sized target
  road clutter        40 stationary scatterers (guard-rail posts, road returns: ground speed 0, so they close at the
                      radar's own speed), ranges uniform over 3 m .. 0.9 x the maximum range, RCS exponential with
                      mean 0.5 m2, a new draw per run (--seed)
  at the range edge   the car moved to 0.97 x the maximum range, its echo as strong as at its own range (its RCS
                      scaled by R^4): its beat near the band edge, a target leaving the range
  beyond the range    the same at 1.1 x the maximum range (outside the band: folded or filtered, by fidelity)
Presets and fidelities: table1 at beat and waveform fidelity, awr1642 at beat fidelity (its closing car with range
migration compensated, max_speed_mps 100). Per scene, over --trials attack-free cycles: the share of cycles with an
alarm from C(1.5), from C(eta) at the scene's PF = 1e-6 threshold (montecarlo/design.py), from the opt-in
spectral, integrated and coherent silent-chirp tests (each at PF = 1e-6), and the OS-CFAR target list (pfa 1e-6 per
cell): the preset car's probability of detection (where it is in range), its range RMSE, and the listed targets
per cycle that match no scene target (association gates of target_list.gates). Every alarm is a false alarm.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from carav_stream.detect import opt_in
from carav_stream.detect.detector import PAPER_ETA, detect
from carav_stream.estimate.geometry import Geometry
from carav_stream.experiments.reporting import Tally
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.firmware.target_list import associate, gates, target_list
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene import Target
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["clutter", "scenes", "CASES"]

CASES = (("table1", "beat", 0.0), ("table1", "waveform", 0.0), ("awr1642", "beat", 100.0))
"""(preset, fidelity, max_speed_mps of the target list's range-walk compensation)"""


def scenes(base, rng) -> dict:
    """The scene variants of `base` (see the module docstring), by name."""

    car = base.targets[0]
    r_max = Geometry.from_scene(base).max_range_m
    ours = base.radar_speed_mps      # ground speed of a target moving with the radar (range rate 0)
    loud = 100 * (15.0 / car.range_m) ** 4                           # 20 dB louder than the car at 15 m (R^-4)
    others = (Target(range_m=15.0, velocity_mps=ours - 8.0, rcs_m2=loud * car.rcs_m2),         # closing 8 m/s
              Target(range_m=min(0.6 * r_max, car.range_m + 25.0), velocity_mps=ours + 6.0, rcs_m2=car.rcs_m2),
              Target(range_m=min(0.3 * r_max, 9.0), velocity_mps=ours - 1.0, rcs_m2=car.rcs_m2 / 100))

    def moved(range_m):              # the car elsewhere, its RCS scaled by (R / R_car)^4 to keep its echo power
        return dataclasses.replace(car, range_m=range_m, rcs_m2=car.rcs_m2 * (range_m / car.range_m) ** 4)
    posts = tuple(Target(range_m=float(r), velocity_mps=0.0, rcs_m2=float(s))                  # standing still
                  for r, s in zip(rng.uniform(3.0, 0.9 * r_max, 40), rng.exponential(0.5, 40)))
    return {"car": base,
            "four targets": dataclasses.replace(base, targets=(car, *others)),
            "road clutter": dataclasses.replace(base, targets=(car, *posts)),
            "at the range edge": dataclasses.replace(base, targets=(moved(0.97 * r_max),)),
            "beyond the range": dataclasses.replace(base, targets=(moved(1.1 * r_max),))}


def _measure(scene, fidelity: str, n: int, rng, eta_design: float, max_speed: float) -> dict:
    rho = balanced_rows(rng, n, scene.n_chirps)
    x = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
    q = detect(x, rho, scene.sigma_n).q
    g = Geometry.from_scene(scene)
    tl = target_list(x, rho, g, scene.sigma_n, detection="os_cfar", max_speed_mps=max_speed)
    truth_r = [t.range_m for t in scene.targets]
    truth_v = [scene.range_rate_mps(t) for t in scene.targets]
    car = scene.targets[0]
    in_range = car.range_m < g.max_range_m
    fastest = max(abs(v) for v in truth_v)
    r_gate, v_gate = gates(g, scene.n_chirps, fastest)
    hits, false, err = 0, 0, []
    for c in range(n):
        k = int(tl.n_found[c])
        r, v = tl.range_m[c, :k], tl.velocity_mps[c, :k]
        found, f = associate(r, v, truth_r, truth_v, r_gate, v_gate, g.max_velocity_mps)
        hits += int(found[0])
        false += f
        near = np.abs(r - car.range_m) <= r_gate
        if in_range and near.any():
            err.append(float(r[near][np.argmin(np.abs(r[near] - car.range_m))] - car.range_m))
    return {"c_1_5": float(np.mean(q >= PAPER_ETA)), "c_design": float(np.mean(q >= eta_design)),
            "spectral": float(opt_in.spectral_silent_test(x, rho, scene.sigma_n, pf=1e-6).alarm.mean()),
            "integrated": float(opt_in.integrated_silent_test(x, rho, scene.sigma_n, pf=1e-6).alarm.mean()),
            "coherent": float(opt_in.coherent_silent_test(x, rho, scene.sigma_n, pf=1e-6).alarm.mean()),
            "car_pd": hits / n if in_range else None,
            "car_range_rmse_m": float(np.sqrt(np.mean(np.square(err)))) if err else None,
            "false_targets_per_cycle": false / n}


def clutter(n: int, seed: int, partial: Callable[[dict], None] | None = None,
            progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """One row per case of CASES and scene variant: {"preset", "fidelity", "scene", and _measure's figures over n
    attack-free cycles}; partial(row) as each is done, progress(cycles done, cycles in all) as well."""
    cases = []
    for preset, fidelity, max_speed in CASES:      # each case its own generator: drawing the variants first is the same
        base = load_scene(preset)
        rng = np.random.default_rng([seed, len(preset), len(fidelity)])
        cases.append((preset, fidelity, max_speed, rms_threshold(scene_law(base), 1e-6), rng, scenes(base, rng)))
    tally = Tally(n * sum(len(c[-1]) for c in cases), progress)
    rows = []
    for preset, fidelity, max_speed, eta_design, rng, variants in cases:
        for name, scene in variants.items():
            row = {"preset": preset, "fidelity": fidelity, "scene": name,
                   **_measure(scene, fidelity, n, rng, eta_design, max_speed)}
            tally(n)
            if partial is not None:
                partial(row)
            rows.append(row)
    return rows
