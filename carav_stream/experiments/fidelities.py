"""The engine of `carav experiment fidelities` (its command: carav_stream/cli/experiment/fidelities.py): where the beat
and the waveform fidelity agree, at the range edge and for loud echoes, in the detector's units (--units detector)
or in the estimator's (--units estimator).

Each preset's car (sampled as the preset samples, I only) moved to fractions of its maximum range, attack-free, as
two echoes:
  car    as strong as at its own range (its RCS scaled by R^4: a stress case, for a real car there is 20 to 40 dB
         weaker; the clutter experiment's car at the range edge)
  loud   20 dB above that per sample
The fidelities differ by design where a beat lies in the IF filter's transition band, +-0.05 fs around fs / 2 (the
waveform fidelity's FIR passes part of it, the beat fidelity's ideal filter all or none): the car's own beat from
0.9 of the maximum range on (`carav scenes` names those ranges).

Detector: the car at its own range rate (awr1642's closes at 83 m/s: its range walks 3.6 cells over a cycle, and
with it its beat through the FIR's gain). For one balanced activation pattern, each fidelity's noise-free echoes (its
own slot and its spill into the next) give every slot's expected statistic, D0 = ||R_k|| / sigma_n on a silent slot
and D1 = |r_k - Rbar| / (Rbar + sigma_n) on an active one (r_k = ||R_k||, ||R_k||^2 = sigma_n^2 + E_k / N_s, E_k the
echo energy in the slot, Rbar the mean over the active slots). Printed: the largest difference between the
fidelities over the silent slots and over the active ones, each in units of that slot's standard deviation under
the noise, sd r_k = sqrt(4 sigma_n^2 E_k / N_s + 2 sigma_n^4) / (2 sqrt(N_s) r_k) for real samples, over sigma_n
(D0) or Rbar + sigma_n (D1): a difference of a few tenths moves an alarm no more than one noise draw does.

Estimator: the car's range rate inside the unambiguous interval (table1's own -1.1 m/s; awr1642's car closing at
7 km/h, for at 300 km/h its range comes from the walk's compensation, estimate/migration.py, whose own errors would
hide the fidelities'). --trials cycles at each fidelity with the same activation and noise draws (the difference is
the fidelities' alone), `ml`'s range of the car against the range its beat measures (Geometry.range_seen): the RMSE
at each fidelity, and the RMS of the per-cycle difference between the fidelities' estimates, each over the
Cramer-Rao bound of the samples that hold the echo.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from carav_stream.estimate import Geometry, estimate
from carav_stream.estimate.crlb import fmcw_crlb
from carav_stream.experiments.reporting import Tally
from carav_stream.radar import physics
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["rows", "slot_differences", "range_errors", "FRACTIONS"]

PRESETS = ("table1", "awr1642")
ESTIMATOR_RATE_KMH = {"awr1642": -7.0}     # the car's range rate for the estimator, where its own aliases
FRACTIONS = (0.5, 0.8, 0.9, 0.95, 0.97, 0.99)
ECHOES = {"car": 0.0, "loud": 20.0}        # dB above the car's echo at its own range, per sample
FIDELITIES = ("beat", "waveform")


def moved(base, fraction: float, louder_db: float):
    """The preset's scene with its car at fraction x its maximum range, its echo as strong per sample as at its own
    range plus louder_db."""
    car = base.targets[0]
    r = fraction * Geometry.from_scene(base).max_range_m
    rcs = car.rcs_m2 * (r / car.range_m) ** 4 * 10 ** (louder_db / 10)
    return dataclasses.replace(base, targets=(dataclasses.replace(car, range_m=r, rcs_m2=rcs),))


def _slot_stats(scene, fidelity: str, rho: np.ndarray):
    """(D, sd of D under the noise, active) per slot 1.. of one cycle: the expected statistics of noise-free echoes."""
    t = physics.echo_templates(scene, fidelity)
    x = rho[:, None] * t.main_sum.astype(np.complex128)
    if t.tail_sum is not None:
        x[1:] += rho[:-1, None] * t.tail_sum[1:].astype(np.complex128)
    e = np.sum(np.abs(x) ** 2, axis=1)[1:]                 # slot 0's predecessor belongs to another cycle
    n, s2 = scene.n_samples, scene.sigma_n ** 2
    r = np.sqrt(s2 + e / n)
    var_r2 = (4.0 * s2 * e / n + 2.0 * s2 * s2) / n if not scene.iq else (2.0 * s2 * e / n + s2 * s2) / n
    sd_r = np.sqrt(var_r2) / (2.0 * r)
    active = rho[1:]
    rbar = r[active].mean()
    scale = np.where(active, rbar + scene.sigma_n, scene.sigma_n)
    return np.where(active, np.abs(r - rbar), r) / scale, sd_r / scale, active


def slot_differences(scene, rho: np.ndarray) -> tuple[float, float]:
    """Largest |beat - waveform| of D0 over the silent slots and of D1 over the active ones, each over its sd."""
    (d_b, sd, active), (d_w, _, _) = (_slot_stats(scene, f, rho) for f in FIDELITIES)
    z = np.abs(d_b - d_w) / sd
    return float(z[~active].max(initial=0.0)), float(z[active].max(initial=0.0))


def range_errors(scene, n: int, seed: int) -> tuple[float, float, float]:
    """ml's range RMSE at each fidelity and the RMS of their per-cycle difference, over the bound (same draws)."""
    g = Geometry.from_scene(scene)
    car = scene.targets[0]
    rho = balanced_rows(np.random.default_rng([seed, 0]), n, scene.n_chirps)
    seen = g.range_seen([car.range_m], [scene.range_rate_mps(car)], rho)[:, 0]
    est = {f: estimate(simulate_cycles(scene, rho, np.random.default_rng([seed, 1]), fidelity=f).frames, rho, g,
                       method="ml").range_m[:, 0] for f in FIDELITIES}
    bound = np.sqrt(np.mean(fmcw_crlb(g, scene.snr_db(), rho, range_m=car.range_m)["range_m"] ** 2))
    rms = [float(np.sqrt(np.mean((est[f] - seen) ** 2)) / bound) for f in FIDELITIES]
    return rms[0], rms[1], float(np.sqrt(np.mean((est["beat"] - est["waveform"]) ** 2)) / bound)


def rows(units: str, trials: int, seed: int, row: Callable[[dict], None],
         progress: Callable[[int, int], None] | None = None) -> None:
    """Every (preset, echo, fraction of the maximum range) case, handed to `row` as it is computed: the car's range,
    SNR and range rate, and with units "detector" the largest D0 and D1 differences over their sd, with "estimator"
    ml's RMSE at each fidelity and of their difference over the bound (`trials` cycles each); progress(cases done,
    cases in all) as well."""
    tally = Tally(len(PRESETS) * len(ECHOES) * len(FRACTIONS), progress)
    for preset in PRESETS:
        base = load_scene(preset)
        if units == "estimator" and preset in ESTIMATOR_RATE_KMH:
            base = load_scene(preset, {"targets[0].velocity_kmh": base.radar_speed_mps * 3.6
                                       + ESTIMATOR_RATE_KMH[preset]})
        rho = balanced_rows(np.random.default_rng(seed), 1, base.n_chirps)[0]
        for echo, louder_db in ECHOES.items():
            for fraction in FRACTIONS:
                scene = moved(base, fraction, louder_db)
                car = scene.targets[0]
                out = {"preset": preset, "echo": echo, "fraction": fraction, "range_m": car.range_m,
                       "snr_db": scene.snr_db(), "range_rate_mps": scene.range_rate_mps(car)}
                if units == "detector":
                    out["d0"], out["d1"] = slot_differences(scene, rho)
                else:
                    out["beat"], out["waveform"], out["difference"] = range_errors(scene, trials, seed)
                tally(1)
                row(out)
