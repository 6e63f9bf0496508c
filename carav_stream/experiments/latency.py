"""The reactive repeater against the spill test, and the spill test's false alarms against the targets' echo power
(`carav experiment latency`; its command line in carav_stream/cli/experiment/latency.py).

A reactive repeater answers chirp k after 2 d / c + L and so cannot stop before 2 d / c + L after the radar has
stopped: its reply spills that long into slot k + 1. So does every echo (for its round trip 2 R / c), but no echo the
receiver passes lasts past the longest visible round trip tau_vis (`physics.max_visible_delay_s`: the top of the IF
band, plus the FIR's transition, over the slope). The spill test (`detect.opt_in.spill_test`) looks at the silent
slots after active ones from tau_vis plus the filter's settling on (`window_start`), where under noise alone each
range bin's power summed over those slots is Gamma(M, 1) whatever the targets: an exact threshold.

Measured:
  false alarms  attack-free cycles, the preset's car alone and with three more targets (clutter.scenes: one 20 dB
                louder at 15 m, one receding, one 20 dB weaker), every echo scaled by -10 .. +20 dB around the
                scene's own (RCS x 10^(dB/10)); table1 at beat and waveform fidelity, awr1642 at beat fidelity. Share
                of cycles with an alarm of the spill test designed for PF = 0.05 (measurable in a few hundred
                cycles; 95 % Clopper-Pearson interval) and for PF = 1e-6, beside the head/tail power ratio it
                replaces (samples 24.. over ..24 of the active chirps, threshold calibrated for PF = 0.05 on cycles
                of the 0 dB scene: what it measures is the echo's power, which starts after its round trip).
  misses        the reactive repeater at 30 m, RARMS 1, over its latency, the same fidelities: the share of
                attacked cycles missed by the spill test (PF = 1e-6), by C(1.5) and by the integrated silent-chirp
                test (PF = 1e-6), with where the reply lands: its own beat S delay and its spill's S (delay - T_c),
                each in or out of the IF band.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from carav_stream.core.units import C_MPS
from carav_stream.detect.detector import detect
from carav_stream.detect.opt_in import calibrate_threshold, integrated_silent_test, spill_test, spill_tests
from carav_stream.experiments.clutter import scenes
from carav_stream.experiments.reporting import Tally
from carav_stream.radar import physics
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.physics import max_visible_delay_s, spill_window_start
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["windows", "false_alarms", "misses", "window_start", "head_tail_ratio"]

ECHO_DB = (-10, -5, 0, 5, 10, 15, 20)
LATENCIES_US = {"table1": (0.1, 1.0, 2.0, 3.0, 3.3, 3.6, 3.9, 4.2, 5.0, 6.0, 7.0),
                "awr1642": (0.1, 0.2, 0.5, 1.0, 5.0, 10.0, 20.0)}
CASES = (("table1", "beat"), ("table1", "waveform"), ("awr1642", "beat"))
PF_MEASURED = 0.05
N_HEAD = 24


def window_start(scene) -> int:
    """First sample of the spill test's window (`physics.spill_window_start`): after the longest visible round trip,
    plus the waveform FIR's half length (16 samples) and one."""

    return spill_window_start(scene)


def head_tail_ratio(frames, rho, n_head: int) -> np.ndarray:
    """The statistic the spill test replaces: mean power of samples n_head.. over that of ..n_head, active chirps."""
    act = frames[rho].reshape(frames.shape[0], -1, frames.shape[-1])
    p = np.abs(act.astype(np.complex128)) ** 2
    return p[..., n_head:].mean(axis=(1, 2)) / p[..., :n_head].mean(axis=(1, 2))


def _scaled(scene, db: float):
    g = 10 ** (db / 10)
    return dataclasses.replace(scene, targets=tuple(dataclasses.replace(t, rcs_m2=t.rcs_m2 * g) for t in scene.targets))


def _false_alarms(preset: str, fidelity: str, n: int, seed: int, tick: Callable[[int], None] = lambda k: None
                  ) -> list[dict]:
    base = load_scene(preset)
    variants = scenes(base, np.random.default_rng(0))
    first = window_start(base)
    rng = np.random.default_rng([seed, len(preset), len(fidelity)])
    rho = balanced_rows(rng, max(n, 200), base.n_chirps)
    ref = simulate_cycles(base, rho, rng, fidelity=fidelity).frames
    thr_old = calibrate_threshold(head_tail_ratio(ref, rho, N_HEAD), PF_MEASURED)
    tick(len(rho))
    out = []
    for name in ("car", "four targets"):
        for db in ECHO_DB:
            scene = _scaled(variants[name], db)
            rho = balanced_rows(rng, n, scene.n_chirps)
            x = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
            measured, design = spill_tests(x, rho, scene.sigma_n, first, [PF_MEASURED, 1e-6])
            out.append({"preset": preset, "fidelity": fidelity, "scene": name, "echo_db": db, "trials": n,
                        "first_sample": first,
                        "spill_pf_0_05": int(measured.alarm.sum()), "spill_pf_1e_6": int(design.alarm.sum()),
                        "head_tail": int(np.sum(head_tail_ratio(x, rho, N_HEAD) >= thr_old))})
            tick(n)
    return out


def _misses(preset: str, fidelity: str, n: int, seed: int, tick: Callable[[int], None] = lambda k: None) -> list[dict]:
    scene = load_scene(preset)
    first = window_start(scene)
    rng = np.random.default_rng([seed, len(preset), len(fidelity), 1])
    out = []
    for lat_us in LATENCIES_US[preset]:
        att = make_attacker("reactive", scene, distance_m=30.0, latency_s=lat_us * 1e-6, rarms=1.0)
        rho = balanced_rows(rng, n, scene.n_chirps)
        x = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng, fidelity=fidelity).frames
        delay = att.delay_s()
        f_own, f_spill = physics.replica_beats_hz(scene, delay, 2.0 * (0.0 - scene.radar_speed_mps) / C_MPS)
        out.append({"preset": preset, "fidelity": fidelity, "latency_us": lat_us, "delay_us": delay * 1e6,
                    "trials": n, "own_in_band": physics.in_band(scene, f_own),
                    "spill_in_band": physics.in_band(scene, f_spill),
                    "spill_reaches_window": (delay - scene.t_adc_start_s) * scene.fs_hz > first,
                    "spill_missed": int(n - spill_test(x, rho, scene.sigma_n, first, pf=1e-6).alarm.sum()),
                    "c15_missed": int(n - detect(x, rho, scene.sigma_n).alarm.sum()),
                    "integrated_missed": int(n - integrated_silent_test(x, rho, scene.sigma_n, pf=1e-6).alarm.sum())})
        tick(n)
    return out


def windows() -> list[dict]:
    """Per preset: the longest visible round trip, the spill window's first sample, samples and chirp period."""
    out = []
    for preset in ("table1", "awr1642"):
        s = load_scene(preset)
        out.append({"preset": preset, "longest_round_trip_s": max_visible_delay_s(s), "first_sample": window_start(s),
                    "n_samples": s.n_samples, "t_chirp_s": s.t_chirp_s})
    return out


def false_alarms(n: int, seed: int, partial: Callable[[dict], None] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """_false_alarms of every case of CASES, n cycles per cell; partial(row) for each row as its case is done,
    progress(cycles done, cycles in all) as they are simulated (the reference cycles included)."""
    per_case = {p: max(n, 200) + 2 * len(ECHO_DB) * n for p, _ in CASES}
    return _each_case(_false_alarms, n, seed, partial, Tally(sum(per_case[p] for p, _ in CASES), progress))


def misses(n: int, seed: int, partial: Callable[[dict], None] | None = None,
           progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """_misses of every case of CASES, n attacked cycles per row; partial(row) for each row as its case is done,
    progress(cycles done, cycles in all) as they are simulated."""
    return _each_case(_misses, n, seed, partial, Tally(sum(len(LATENCIES_US[p]) * n for p, _ in CASES), progress))


def _each_case(measure, n: int, seed: int, partial, tally: Tally) -> list[dict]:
    out = []
    for preset, fidelity in CASES:
        rows = measure(preset, fidelity, n, seed, tally)
        for r in rows:
            if partial is not None:
                partial(r)
        out += rows
    return out
