"""Benign mutual interference from another car's FMCW radar, and what the detectors make of it (`carav experiment
interference`; its command line in carav_stream/cli/experiment/interference.py).

Scene: table1 (the car at 43 m, +2.2 dB per sample), no attacker. The interferer is an oncoming car's radar at
--range (driving at 100 km/h towards the victim), transmitting its own chirps, not synchronised with the victim: slope
--slopes x the victim's (same sweep duration, so its bandwidth scales with the slope), a chirp period of
--period-ratio x its sweep (idle time between chirps), a start offset drawn once per run. It is received one way
(`secondary_antenna` attacker model with its own waveform, `waveform` fidelity). Its power is given as the
equivalent RARMS of its signal while in the victim's IF band (SecondaryAntennaAttacker.equivalent_rarms): with a
different slope it crosses the band briefly in each chirp, so its RMS over a chirp is far lower.

Per cell (slope, power): the share of cycles with an alarm from C(1.5), from C(eta) at the scene's PF = 1e-6
threshold (carav_stream/firmware/design.py), from the single-chirp and the integrated spectral silent-chirp
tests (PF = 1e-6 each). None of these cycles holds an attack: every alarm is a false alarm from the driver's
point of view. Beside it, the `random` attacker at the same RARMS, which the detectors are meant to catch.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from carav_stream.core.units import KMH
from carav_stream.detect import opt_in
from carav_stream.detect.detector import PAPER_ETA, detect
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["simulate"]


def _interferer(scene, slope_ratio: float, rarms: float, range_m: float, period_ratio: float, offset_s: float):
    geometry = dict(range_m=range_m, velocity_mps=-100.0 * KMH,       # oncoming at 100 km/h
                    slope_hz_per_s=slope_ratio * scene.slope_hz_per_s, t_sweep_s=scene.t_sweep_s,
                    t_chirp_s=period_ratio * scene.t_sweep_s, t_offset_s=offset_s)
    probe = make_attacker("secondary_antenna", scene, tx_power_w=1e-3, **geometry)
    p_w = 1e-3 * (rarms / probe.equivalent_rarms()) ** 2
    return make_attacker("secondary_antenna", scene, tx_power_w=p_w, **geometry)


def _alarms(frames, rho, scene, eta_design) -> dict:
    q = detect(frames, rho, scene.sigma_n).q
    return {"c_1_5": int(np.sum(q >= PAPER_ETA)), "c_design": int(np.sum(q >= eta_design)),
            "spectral": int(opt_in.spectral_silent_test(frames, rho, scene.sigma_n, pf=1e-6).alarm.sum()),
            "integrated": int(opt_in.integrated_silent_test(frames, rho, scene.sigma_n, pf=1e-6).alarm.sum()),
            "median_q": float(np.median(q))}


def simulate(trials: int, rarms: Sequence[float], slopes: Sequence[float], range_m: float, period_ratio: float,
             seed: int, progress: Callable[[int, int], None] | None = None) -> dict:
    """Alarms of every detector on `trials` cycles per cell: {"cells": one per (RARMS, slope ratio) of the
    interferer, "random": one per RARMS of the random attacker, and the settings (scene, eta_design, t_offset_s)}."""
    scene = load_scene("table1")
    eta_design = rms_threshold(scene_law(scene), 1e-6)
    root = np.random.SeedSequence(seed)
    n = trials
    out = {"scene": scene.name, "trials": n, "seed": seed, "eta_design": eta_design, "range_m": range_m,
           "period_ratio": period_ratio, "cells": [], "random": []}
    rng = np.random.default_rng(root.spawn(1)[0])
    offset = float(rng.uniform(0, period_ratio * scene.t_sweep_s))
    out["t_offset_s"] = offset
    total, done = len(rarms) * (1 + len(slopes)) * n, 0
    for r in rarms:
        rng = np.random.default_rng([seed, int(r * 1000), 0])
        rho = balanced_rows(rng, n, scene.n_chirps)
        att = make_attacker("random", scene, rarms=r)
        cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng)
        out["random"].append({"rarms": r, **_alarms(cyc.frames, rho, scene, eta_design)})
        done += n
        if progress:
            progress(done, total)
        for k in slopes:
            rng = np.random.default_rng([seed, int(r * 1000), int(k * 1000)])
            rho = balanced_rows(rng, n, scene.n_chirps)
            att = _interferer(scene, k, r, range_m, period_ratio, offset)
            cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng, fidelity="waveform")
            out["cells"].append({"slope_ratio": k, "rarms": r, **_alarms(cyc.frames, rho, scene, eta_design)})
            done += n
            if progress:
                progress(done, total)
    return out
