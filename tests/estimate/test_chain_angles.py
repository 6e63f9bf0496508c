"""Azimuth on the radar chain's frames (carav_stream.radar.synth.simulate_cycles, after the ADC), as the
range_estimator block reads it on an array: range and velocity by `ml` from the reference element, then the target's
cell refined over the whole virtual array, TDM-compensated (estimate/target_azimuth.py).

The awr1642_mimo car (20 m, 2 TX x 4 RX TDM) turned to 0, 20 and 45 degrees, at the scene's SNR, 300 attack-free
cycles each: the azimuth's RMSE within 0.8 and 1.2 times the Cramer-Rao bound at beat fidelity, and at 20 degrees at
waveform fidelity and with I/Q samples. The bound's SNR_eff comes from the scene, not from the data:
angle_crlb.effective_snr(scene.snr_db(0) per sample, n_samples, n_loops / 2 active loops, iq), over the scene's
virtual positions. Two cars at the same range and velocity 15 degrees apart: their common cell's snapshot resolves
into both by MUSIC with forward-backward smoothing (angle_music.music_azimuths).
"""
from dataclasses import replace

import numpy as np
import pytest

from carav_stream.estimate import estimate
from carav_stream.estimate.angle_crlb import azimuth_crlb, effective_snr
from carav_stream.estimate.angle_music import music_azimuths
from carav_stream.estimate.angle_refine import refine_cells
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.target_azimuth import target_azimuths, target_cells
from carav_stream.estimate.virtual_array import VirtualArray
from carav_stream.estimate.virtual_element import element_geometry, reference_element
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

PRESET = "awr1642_mimo"
N_CYCLES, CHUNK = 300, 50


def chain(scene, n: int, rng, fidelity: str):
    """(frames, rho, range/velocity estimates) of n attack-free cycles of the scene."""
    rho = balanced_rows(rng, n, scene.n_chirps, scene.n_slots)
    frames = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
    x, r = reference_element(frames, rho, scene)
    return frames, rho, estimate(x, r, element_geometry(scene), method="ml")


def rmse_over_bound(azimuth_deg: float, fidelity: str, iq: bool, seed: int) -> float:
    scene = load_scene(PRESET, {"targets[0].azimuth_deg": azimuth_deg, "iq": iq})
    rng = np.random.default_rng(seed)
    err = []
    for _ in range(N_CYCLES // CHUNK):
        frames, rho, est = chain(scene, CHUNK, rng, fidelity)
        azimuth, _ = target_azimuths(frames, rho, scene, est.range_m, est.velocity_mps)
        err.append(azimuth[:, 0] - azimuth_deg)
    err = np.concatenate(err)
    assert np.isfinite(err).all()
    snr_eff = effective_snr(scene.snr_db(0), scene.n_samples, scene.n_loops // 2, iq=iq)
    bound = azimuth_crlb(snr_eff, VirtualArray.from_scene(scene).positions_wl, azimuth_deg)["deg"]
    return float(np.sqrt(np.mean(err ** 2)) / bound)


@pytest.mark.slow
@pytest.mark.parametrize("azimuth_deg, fidelity, iq", [(0.0, "beat", False), (20.0, "beat", False),
                                                       (45.0, "beat", False), (20.0, "waveform", False),
                                                       (20.0, "beat", True)])
def test_the_chains_azimuth_sits_at_its_bound(azimuth_deg, fidelity, iq):
    ratio = rmse_over_bound(azimuth_deg, fidelity, iq, seed=int(azimuth_deg) + 7 * iq + (fidelity == "waveform"))
    assert 0.8 <= ratio <= 1.2, f"azimuth RMSE {ratio:.2f} x the bound"


@pytest.mark.slow
def test_two_cars_at_one_range_and_velocity_15_degrees_apart_are_resolved_by_music():
    base = load_scene(PRESET)
    car = base.targets[0]
    truth = (5.0, 20.0)
    scene = replace(base, targets=tuple(replace(car, azimuth_deg=a) for a in truth))
    frames, rho, est = chain(scene, 20, np.random.default_rng(4), "beat")
    array = VirtualArray.from_scene(scene)
    f0, nu0 = target_cells(Geometry.from_scene(scene), array.n_slots, est.range_m, est.velocity_mps)
    cells = refine_cells(frames, array, f0, nu0, rho)
    pair = music_azimuths(cells.snapshots[:, 0, None, :], array, 2)
    assert pair.shape == (20, 2)
    np.testing.assert_allclose(pair, np.broadcast_to(truth, pair.shape), atol=0.3)
