"""Algorithm 1 in one process: the same stage functions the pipeline blocks wrap, batched over cycles.

    rho      = activation rows (secure, or seeded for simulation)          chirp_source
    rx       = echoes + receiver noise                                       channel
    rx      += attack signal a_k                                            attacker
    frames   = quantised, clipped ADC codes (and the samples they stand for)  adc_framer
    verdict  = D0, D1, Q, C(eta) per cycle, from the codes' exact RMS        rms_detector
    clean    = cycles with C(eta) < 1 and valid samples                      gate
    ranges   = estimates on the clean cycles only, active chirps only        range_estimator

Random streams come from carav_stream.radar.streams, like the blocks', so a pipeline and `run_algorithm1` give the
same numbers bit for bit. With an antenna array, as in the graph: the activation is drawn per TDM loop, a chirp's RMS
is taken over all its receivers' samples, and ranging reads one virtual element (estimate/virtual_element.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.detect.detector import PAPER_ETA, adc_chirp_rms, detect_from_rms
from carav_stream.estimate.estimators import estimate
from carav_stream.estimate.virtual_element import element_geometry, reference_element
from carav_stream.radar.adc import adc_step
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.scene import Scene
from carav_stream.radar.streams import seed_streams
from carav_stream.radar.synth import simulate_cycles


@dataclass
class Algorithm1Result:
    """Per-cycle results of `run_algorithm1`, arrays over cycles."""

    rho: np.ndarray            # bool (n, n_chirps)
    q: np.ndarray              # float64 (n,)
    alarm: np.ndarray          # bool (n,)
    invalid: np.ndarray        # bool (n,)
    attack_active: np.ndarray  # bool (n,)
    clipped: np.ndarray        # int64 (n,)
    range_m: np.ndarray        # float64 (n, n_targets), NaN on alarmed cycles (never estimated)
    velocity_mps: np.ndarray   # float64 (n, n_targets)


def run_algorithm1(scene: Scene, n_cycles: int, *, seed: int | None = None, attack: str = "none",
                   attack_params: dict | None = None, eta: float = PAPER_ETA, method: str = "ml",
                   fidelity: str = "beat", sigma_n: float | None = None, n_targets: int = 1,
                   batch: int = 64) -> Algorithm1Result:
    """Run Algorithm 1 for n_cycles in this process; estimates only the cycles the detector passes."""
    streams = seed_streams(seed)
    attacker = make_attacker(attack, scene, **(attack_params or {})) if attack != "none" else None
    geometry = element_geometry(scene)
    sigma = scene.sigma_n if sigma_n is None else sigma_n
    lsb = adc_step(scene)   # the ADC's step: detector and estimator read its codes, as the graph's nodes do
    out = {k: [] for k in ("rho", "q", "alarm", "invalid", "attack_active", "clipped", "range_m", "velocity_mps")}
    for c0 in range(0, n_cycles, batch):
        n = min(batch, n_cycles - c0)
        rho = streams.activation.next(n, scene.n_chirps, scene.n_slots)
        cyc = simulate_cycles(scene, rho, streams.noise, attacker=attacker, rng_attack=streams.attack,
                              fidelity=fidelity, cycle0=c0)
        det = detect_from_rms(_chirp_rms(scene, cyc, lsb), rho, sigma, eta)
        rng = np.full((n, n_targets), np.nan)
        vel = np.full((n, n_targets), np.nan)
        clean = ~det.alarm
        if clean.any():
            x, r = reference_element((cyc.frames if lsb is None else cyc.codes)[clean], rho[clean], scene)
            est = estimate(x, r, geometry, method=method, n_targets=n_targets, lsb=lsb)
            rng[clean], vel[clean] = est.range_m, est.velocity_mps
        for key, value in (("rho", rho), ("q", det.q), ("alarm", det.alarm), ("invalid", det.invalid),
                           ("attack_active", cyc.attack_active), ("clipped", cyc.clipped), ("range_m", rng),
                           ("velocity_mps", vel)):
            out[key].append(value)
    return Algorithm1Result(**{k: np.concatenate(v) for k, v in out.items()})


def _chirp_rms(scene: Scene, cyc, lsb: float | None) -> np.ndarray:
    """Every chirp's RMS (n_cycles, n_chirps) from the ADC's output, over all its receivers' samples for an array
    (the rms_detector node's combined RMS)."""
    return adc_chirp_rms(cyc.codes, lsb, scene.iq, cyc.nonfinite, receivers=scene.n_rx > 1)
