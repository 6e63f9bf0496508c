"""The frames the estimators benchmark scores (bench/estimators.py), each with its truth and its Cramer-Rao bound.

tones  closed-form beat signals (carav_stream.estimate.tones.synth_beat) over the whole window, the range walking over
       the cycle as an echo's does: one target per cycle at the preset's range +-0.5 resolution cell, its velocity
       within +-v_max / 4 of the preset target's (aliased) range rate. The bound counts every sample.
chain  the radar chain (carav_stream.radar.synth.simulate_cycles, at a fidelity): the preset's scene, its car moved to
       CHAIN_SCENES ranges spread evenly over one resolution cell around its own and given range rates within
       +-v_max / 4 of its (aliased) own, CHAIN_SCENES blocks of cycles; one noise level, set by the scene's snr_db
       at its own range (the SNR follows the range within the cell: +-0.4 dB on awr1642), the ADC's quantisation
       included. The echo is there from its round trip on; the bound counts the samples that hold it, at each
       scene's SNR (fmcw_crlb with the range).

Truth: the range the beat measures of the walking target, at the active chirps' mean time (tones.centroid_ranges,
Geometry.range_seen), and its range rate (folded into the unambiguous interval when scored). Both draw balanced
random silencing (half the chirps active) unless every chirp is asked for.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.estimate.crlb import fmcw_crlb
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.tones import centroid_ranges, synth_beat
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

CHAIN_SCENES = 8


@dataclass(frozen=True)
class Frames:
    """Cycles to score: x (C, M, N) samples, rho (C, M), per-cycle truth (C, 1) and bound (C,), noise RMS sigma_n."""

    geometry: Geometry
    x: np.ndarray
    rho: np.ndarray
    range_m: np.ndarray
    velocity_mps: np.ndarray
    range_bound_m: np.ndarray
    velocity_bound_mps: np.ndarray
    sigma_n: float
    snr_sample_db: float


def _rates(rng, geometry: Geometry, rate_mps: float, n: int) -> np.ndarray:
    """n range rates within +-v_max / 4 of rate_mps folded into the unambiguous interval, kept within 0.9 v_max."""
    vmax = geometry.max_velocity_mps
    v0 = (rate_mps + vmax) % (2 * vmax) - vmax
    return np.clip(v0 + rng.uniform(-0.25, 0.25, n) * vmax, -0.9 * vmax, 0.9 * vmax)


def tones(geometry: Geometry, n_chirps: int, range_m: float, rate_mps: float, snr_db: float, *, n_cycles: int,
          rng: np.random.Generator, all_chirps: bool = False) -> Frames:
    """Closed-form frames at snr_db after coherent integration over n_chirps / 2 chirps (the per-sample SNR is the
    same with all_chirps)."""
    snr_sample_db = snr_db - 10 * np.log10(n_chirps // 2)
    rho = np.ones((n_cycles, n_chirps), bool) if all_chirps else balanced_rows(rng, n_cycles, n_chirps)
    r0 = min(range_m, 0.8 * geometry.max_range_m)
    ranges = r0 + rng.uniform(-0.5, 0.5, (n_cycles, 1)) * geometry.range_resolution_m
    vels = _rates(rng, geometry, rate_mps, n_cycles)[:, None]
    x = synth_beat(geometry, rho, ranges, vels, snr_sample_db=snr_sample_db, rng=rng, migrate=True)
    bound = fmcw_crlb(geometry, snr_sample_db, rho)
    sigma_n = 10 ** (-snr_sample_db / 20) / (1.0 if geometry.iq else np.sqrt(2.0))     # synth_beat's noise RMS
    return Frames(geometry, x, rho, centroid_ranges(geometry, rho, ranges, vels), vels, bound["range_m"],
                  bound["velocity_mps"], sigma_n, snr_sample_db)


def chain(preset: str, fidelity: str, snr_db: float, *, n_cycles: int, rng: np.random.Generator) -> Frames:
    """Radar-chain frames of the preset's car at snr_db after coherent integration over half its chirps."""
    base = load_scene(preset)
    car = base.targets[0]
    geometry = Geometry.from_scene(base)
    snr_sample_db = snr_db - 10 * np.log10(base.n_chirps // 2)
    r0 = min(car.range_m, 0.8 * geometry.max_range_m)
    offsets = (np.arange(CHAIN_SCENES) + 0.5) / CHAIN_SCENES - 0.5
    rates = _rates(rng, geometry, base.range_rate_mps(car), CHAIN_SCENES)
    sizes = np.diff(np.linspace(0, n_cycles, CHAIN_SCENES + 1).astype(int))
    sigma_n = load_scene(preset, {"targets[0].range_m": r0, "snr_db": snr_sample_db}).sigma_n
    parts = []
    for offset, rate, n in zip(offsets, rates, sizes):
        r = r0 + offset * geometry.range_resolution_m        # one noise level: the SNR follows the range (+-0.2 dB)
        scene = load_scene(preset, {"targets[0].range_m": r, "sigma_n": sigma_n,
                                    "targets[0].velocity_kmh": (base.radar_speed_mps + rate) * 3.6})
        rho = balanced_rows(rng, n, scene.n_chirps)
        x = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
        rate_now = scene.range_rate_mps(scene.targets[0])
        parts.append((x, rho, geometry.range_seen([r], [rate_now], rho), np.full((n, 1), rate_now),
                      fmcw_crlb(geometry, scene.snr_db(), rho, range_m=r)))
    x, rho, ranges, vels = (np.concatenate([p[i] for p in parts]) for i in range(4))
    return Frames(geometry, x, rho, ranges, vels, np.concatenate([p[4]["range_m"] for p in parts]),
                  np.concatenate([p[4]["velocity_mps"] for p in parts]), float(sigma_n), snr_sample_db)
