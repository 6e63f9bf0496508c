"""Blind zones: the share of attacked cycles each detector misses, over the attack's strength, on one scene.

Every detector judges the same simulated cycles (the radar chain at the scene's fidelity, attack-free noise and
echoes plus the attack), each at its own design for a false-alarm rate `pf` per cycle: C(eta) at the eta the closed
form gives for the scene and pf (carav_stream/firmware/design.py), the opt-in tests at their exact (or union-bound)
PF 1e-6 thresholds (carav_stream/montecarlo/detectors.py; only 1e-6 is designed for them), calibrated to the noise
the ADC delivers (sigma_n with its quantisation, as C's law counts it). The weakest attack a detector
catches is the smallest RARMS of the grid from which on its miss rate stays at or below `caught` (0.1: nine cycles
in ten caught). The opt-in tests judge range bins with an exact law: on a scene whose chirps have none (I only,
N_s <= 2) they are left out of the rows (`defined`).

A receiver array's scene (n_rx > 1) is judged on all its receivers: C(eta) on each chirp's RMS over them (eta
designed for the combined law, scene_law's n_rx), the opt-in tests on the bin powers summed over them (their exact
Gamma(n_rx M, 1) thresholds, detect/opt_in.py); activation rows are drawn per TDM loop, as the radar's source
draws them. Every row says over how many receivers (``n_rx``).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.detect.detector import detect
from carav_stream.detect.opt_in import exact_bins
from carav_stream.detect.stats import clopper_pearson
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.montecarlo.detectors import DESIGN_PF, statistic
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.synth import simulate_cycles

__all__ = ["DETECTORS", "defined", "miss_rates", "opt_in_alarms", "weakest_caught"]

DETECTORS = ("C(eta)", "spectral", "integrated", "coherent")
CHUNK = 100


def defined(scene) -> tuple[str, ...]:
    """The detectors of DETECTORS defined on the scene: C(eta) always, the opt-in tests where a chirp has a range
    bin with an exact law."""
    return DETECTORS if exact_bins(scene.n_samples, scene.iq) else DETECTORS[:1]


def opt_in_alarms(x, rho, scene, law, names) -> dict[str, np.ndarray]:
    """bool (n_cycles,) per opt-in test in `names`: its statistic at or above its PF 1e-6 threshold, judged against
    the noise the ADC delivers (law.sigma_eff); x one receiver's frames (n_cycles, n_chirps, n_samples) or a
    receiver array's (n_cycles, n_rx, n_chirps, n_samples), judged over all its receivers."""
    return {name: statistic(name, x, rho, law.sigma_eff, scene) >= 1.0 for name in names}


def miss_rates(scene, attack: str, rarms_grid, n: int, seed: int, *, fidelity: str = "auto",
               params: dict | None = None, pf: float = DESIGN_PF, tick: Callable[[int], None] | None = None
               ) -> list[dict]:
    """One row per RARMS: {"rarms", "missed": {detector: k}, "ci": {detector: [lo, hi]}, "trials", "eta", "n_rx"};
    C(eta) at the eta designed for pf, the opt-in tests at their 1e-6 designs (the detectors `defined` on the
    scene), every detector over the scene's n_rx receivers. tick(k) as each block of k cycles is judged."""
    law = scene_law(scene)
    eta = rms_threshold(law, pf)
    names = defined(scene)
    n_rx = scene.n_rx
    rows = []
    for i, r in enumerate(rarms_grid):
        rng = np.random.default_rng([seed, i])
        attacker = make_attacker(attack, scene, rarms=float(r), **(params or {}))
        missed = dict.fromkeys(names, 0)
        for done in range(0, n, CHUNK):
            rho = balanced_rows(rng, min(CHUNK, n - done), scene.n_chirps, scene.n_slots)
            x = simulate_cycles(scene, rho, rng, attacker=attacker, rng_attack=rng, fidelity=fidelity,
                                cycle0=done).frames
            missed["C(eta)"] += int(np.sum(detect(x, rho, scene.sigma_n, receivers=n_rx > 1).q < eta))
            for name, alarm in opt_in_alarms(x, rho, scene, law, names[1:]).items():
                missed[name] += int(np.sum(~alarm))
            if tick is not None:
                tick(len(rho))
        ci = {d: [float(v) for v in clopper_pearson(k, n)] for d, k in missed.items()}
        rows.append({"rarms": float(r), "missed": missed, "ci": ci, "trials": n, "eta": eta, "n_rx": n_rx})
    return rows


def weakest_caught(rows: list[dict], caught: float = 0.1) -> dict:
    """Per detector of the rows: the smallest RARMS from which on every row's miss rate is <= caught (None: not in
    the grid)."""
    out = {}
    for d in (rows[0]["missed"] if rows else DETECTORS):
        weakest = None
        for row in sorted(rows, key=lambda x: -x["rarms"]):
            if row["missed"][d] / row["trials"] > caught:
                break
            weakest = row["rarms"]
        out[d] = weakest
    return out

