"""The azimuth of targets already ranged: each target's cell refined over the whole virtual array.

Range and velocity come from one virtual element (virtual_element.py); the azimuth needs every receiver and every TDM
slot. From a target's estimated range R and radial velocity v its cell on the array's frames is

    f0  = (2 S_r R / c + 2 v / lambda) / fs            beat [cycles/sample] (Geometry.beat_from_range)
    nu0 = wrap(2 v T_c / lambda (1 + S_r t_adc / fc))   chirp-to-chirp progression [cycles/chirp] at the scene's
                                                        chirp interval, wrapped into [-1/(2S), 1/(2S)) (S slots)

and angle_refine.refine_cells refines it (beat, Doppler, TDM compensation, ML azimuth over the virtual positions);
the azimuth is theta = asin(s) [degrees], positive towards increasing array position, and its bound's standard
deviation angle_crlb.azimuth_crlb at the snapshots' measured SNR_eff (per cycle and target, so it says how well
that cycle's azimuth is known, not what the scene promises). A velocity that aliased in the reference element aliases
to the same wrapped nu0 (its loop interval is S chirps), so the cell is the same.

The scene is read by duck typing (VirtualArray.from_scene, Geometry.from_scene): this floor does not import the
radar's.
"""
from __future__ import annotations

import numpy as np

from carav_stream.estimate.angle_crlb import azimuth_crlb
from carav_stream.estimate.angle_refine import refine_cells
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.virtual_array import VirtualArray

__all__ = ["target_cells", "target_azimuths"]


def target_cells(geometry: Geometry, n_slots: int, range_m, velocity_mps) -> tuple[np.ndarray, np.ndarray]:
    """(f0, nu0) float64 of range_m, velocity_mps's shape: the cells of targets at those ranges and velocities
    (module docstring), NaN where either is NaN; geometry at the scene's own chirp interval."""
    r, v = np.asarray(range_m, dtype=float), np.asarray(velocity_mps, dtype=float)
    f0 = geometry.beat_from_range(r, v) / geometry.fs_hz
    nu = geometry.slow_freq_from_velocity(v)
    wrap = 1.0 / n_slots
    nu0 = nu - wrap * np.floor(nu / wrap + 0.5)
    ok = np.isfinite(f0) & np.isfinite(nu0)
    return np.where(ok, f0, np.nan), np.where(ok, nu0, np.nan)


def target_azimuths(frames, rho, scene: object, range_m, velocity_mps, *, n_iter: int = 2):
    """(azimuth_deg, azimuth_std_deg) float64 (C, K) of the targets at range_m, velocity_mps (C, K) (NaN: none) in
    frames (C, R, M, N) float32 | complex64 of the scene's array, rho bool (C, M); NaN where there is no target
    or the cycle has no active loop."""
    array = VirtualArray.from_scene(scene)
    f0, nu0 = target_cells(Geometry.from_scene(scene), array.n_slots, range_m, velocity_mps)
    cells = refine_cells(frames, array, f0, nu0, rho, n_iter=n_iter)
    azimuth = np.degrees(np.arcsin(cells.sin_theta))
    return azimuth, azimuth_crlb(cells.snr_eff, array.positions_wl, azimuth)["deg"]
