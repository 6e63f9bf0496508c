"""The radar chain's azimuth against its Cramer-Rao bound (`carav experiment angles`; its command line in
carav_stream/cli/experiment/angles.py).

One target, one scene: the awr1642_mimo preset (2 TX x 4 RX TDM, an 8-element virtual array at half a wavelength)
with its car at 20 m turned to each azimuth asked, attack-free, frames from the radar chain's simulation
(carav_stream.radar.synth.simulate_cycles, after the ADC) at beat and at waveform fidelity, I-only (the preset's)
and I/Q. Per cycle, what the range_estimator block does on an array: range and velocity by `ml` from the reference
element (estimate/virtual_element.py), then the azimuth from the target's cell refined over the whole virtual array,
TDM-compensated (estimate/target_azimuth.py). Measured: the azimuth's RMSE and mean error against the scene's
azimuth, and the RMS of the bounds reported per cycle (at each cycle's measured SNR).

The bound it is compared with comes from the scene, not from the data: angle_crlb.azimuth_crlb at
SNR_eff = angle_crlb.effective_snr(the scene's per-sample SNR of the car, n_samples, n_loops / 2 active loops, iq)
(balanced activation: half the loops active), over the scene's virtual positions.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.estimate.angle_crlb import azimuth_crlb, effective_snr
from carav_stream.estimate.estimators import estimate
from carav_stream.estimate.target_azimuth import target_azimuths
from carav_stream.estimate.virtual_array import VirtualArray
from carav_stream.estimate.virtual_element import element_geometry, reference_element
from carav_stream.experiments.reporting import Tally
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["angles", "azimuth_errors", "scene_bound_deg", "PRESET", "AZIMUTHS", "FIDELITIES", "CHUNK"]

PRESET = "awr1642_mimo"
AZIMUTHS = (0.0, 20.0, 45.0)
FIDELITIES = ("beat", "waveform")
CHUNK = 50            # cycles simulated at a time (a cycle of the preset is 4 receivers x 128 chirps x 256 samples)


def scene_bound_deg(scene) -> float:
    """The Cramer-Rao std of the scene's first target's azimuth [degrees], from the scene: its per-sample SNR, its
    samples, half its loops active (module docstring)."""
    snr_eff = effective_snr(scene.snr_db(0), scene.n_samples, scene.n_loops // 2, iq=scene.iq)
    positions = VirtualArray.from_scene(scene).positions_wl
    return float(azimuth_crlb(snr_eff, positions, scene.targets[0].azimuth_deg)["deg"])


def azimuth_errors(scene, n_cycles: int, rng: np.random.Generator, fidelity: str,
                   tally: Callable[[int], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(error [degrees], reported bound std [degrees]), float64 (n_cycles,): the first target's azimuth estimate
    (the range_estimator's way, module docstring) minus the scene's, over n_cycles attack-free cycles."""
    err, std = [], []
    truth = scene.targets[0].azimuth_deg
    geometry = element_geometry(scene)
    for start in range(0, n_cycles, CHUNK):
        n = min(CHUNK, n_cycles - start)
        rho = balanced_rows(rng, n, scene.n_chirps, scene.n_slots)
        frames = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
        x, r = reference_element(frames, rho, scene)
        est = estimate(x, r, geometry, method="ml")
        azimuth, bound = target_azimuths(frames, rho, scene, est.range_m, est.velocity_mps)
        err.append(azimuth[:, 0] - truth)
        std.append(bound[:, 0])
        if tally is not None:
            tally(n)
    return np.concatenate(err), np.concatenate(std)


def angles(cycles: int, seed: int, azimuths=AZIMUTHS, fidelities=FIDELITIES, iqs=(False, True),
           progress: Callable[[int, int], None] | None = None) -> dict:
    """{"scene": what was simulated, "cycles", "seed", "rows": one per (fidelity, iq, azimuth): fidelity, iq,
    azimuth_deg, n (cycles with an estimate), rmse_deg, mean_deg, bound_deg (the scene's, scene_bound_deg), ratio
    (rmse over bound) and reported_bound_rms_deg}; job j of the grid draws from SeedSequence(seed).spawn(...)[j];
    progress(cycles done, in all)."""
    jobs = [(f, bool(iq), float(a)) for f in fidelities for iq in iqs for a in azimuths]
    tally = Tally(len(jobs) * cycles, progress)
    base = load_scene(PRESET)
    rows = []
    for (fidelity, iq, azimuth), child in zip(jobs, np.random.SeedSequence(seed).spawn(len(jobs))):
        scene = load_scene(PRESET, {"targets[0].azimuth_deg": azimuth, "iq": iq})
        err, std = azimuth_errors(scene, cycles, np.random.default_rng(child), fidelity, tally)
        ok = np.isfinite(err)
        rmse, bound = float(np.sqrt(np.mean(err[ok] ** 2))), scene_bound_deg(scene)
        rows.append({"fidelity": fidelity, "iq": iq, "azimuth_deg": azimuth, "n": int(ok.sum()), "rmse_deg": rmse,
                     "mean_deg": float(np.mean(err[ok])), "bound_deg": bound, "ratio": rmse / bound,
                     "reported_bound_rms_deg": float(np.sqrt(np.mean(std[ok] ** 2)))})
    return {"scene": {"preset": PRESET, "range_m": base.targets[0].range_m, "snr_db": base.snr_db(0),
                      "n_rx": base.n_rx, "n_virtual": len(base.virtual_positions_wl), "n_samples": base.n_samples,
                      "n_loops": base.n_loops},
            "cycles": cycles, "seed": seed, "rows": rows}
