"""The one virtual element range and velocity are estimated from in a scene with an antenna array.

    x_ref[c, l, m] = x[c, 0, l n_slots, m],    rho_ref[c, l] = rho[c, l n_slots]     (receiver 0, slot 0 of loop l)

Receiver 0 and the chirps of each TDM loop's first slot: one transmitter and one receiver, so every chirp it reads
carries the same far-field phase, and its chirps are a transmitter's repetitions, one loop (t_loop = n_slots
t_chirp) apart: the slow-time spacing of its Doppler (``element_geometry``), whose unambiguous velocity is the
scene's. Reading the other slots as chirps of the same sequence would put every transmitter's own phase into the
Doppler progression. The activation is constant within a loop (radar/activation.py), so rho_ref is the loops'
activation, as balanced as rho. For a single antenna (one receiver, one slot) both are the frames and rho as given.

The instant a cycle's ranges refer to (``range_instant_s``): the chain moves a target by its range rate v during the
cycle, so an estimate is the range at some instant of it. Within a chirp starting at T the echo's delay is
tau(t') = tau_0 + alpha (T + t'), alpha = 2 v / c, and the dechirped phase 2 pi (fc tau + S t' tau - S tau^2 / 2)
has the frequency S tau(t') + alpha (fc + S t' - S tau) = S (tau_0 + alpha (T + 2 t')) + alpha fc - S alpha tau.
A beat read over the window (its samples' centre t_c = t_adc + (N_s - 1) / (2 fs)) with the coupling alpha fc
removed is therefore the range at T + 2 t_c (the last term is v tau, micrometres). Summing the active chirps (a
range FFT, a range-Doppler map, the estimators' joint fits) averages T over them to first order in the walk: the
instant is the active chirps' mean start plus 2 t_c. Migration compensation (estimate/migration.py) fits the walk
and reports the beat of the cycle's first chirp: 2 t_c alone.

The scene is read by duck typing (n_rx, n_slots, t_loop_s and what Geometry.from_scene reads): the estimators'
floor does not import the radar's.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from carav_stream.estimate.geometry import Geometry


def element_geometry(scene: object) -> Geometry:
    """The waveform as the reference element sees it: the scene's, with a chirp interval of one TDM loop."""
    geometry = Geometry.from_scene(scene)
    n_slots = getattr(scene, "n_slots", 1)
    return geometry if n_slots == 1 else replace(geometry, t_chirp_s=float(scene.t_loop_s))


def reference_element(frames: np.ndarray, rho: np.ndarray, scene: object) -> tuple[np.ndarray, np.ndarray]:
    """(frames, rho) of receiver 0 and each loop's first slot (module docstring).

    frames: (n_cycles, [n_rx,] n_chirps, ...) with a receiver axis when the scene has several receivers, any
    dtype; rho bool (n_cycles, n_chirps). Returns frames (n_cycles, n_loops, ...) and rho (n_cycles, n_loops); the
    arrays as given for a single antenna, else C-contiguous copies.
    """
    n_rx, n_slots = getattr(scene, "n_rx", 1), getattr(scene, "n_slots", 1)
    if n_rx == 1 and n_slots == 1:
        return frames, rho
    if n_rx > 1:
        frames = frames[:, 0]
    return np.ascontiguousarray(frames[:, ::n_slots]), np.ascontiguousarray(rho[:, ::n_slots])


def range_instant_s(rho: np.ndarray, geometry: Geometry, migration: bool = False) -> np.ndarray:
    """Seconds from each cycle's start to the instant its range estimates refer to, float64 (n_cycles,).

    rho bool (n_cycles, n_chirps) of the reference element, geometry its ``element_geometry`` (chirps t_chirp_s
    apart); migration: the estimates are migration-compensated (module docstring). A cycle without an active
    chirp gets the first chirp's instant, as with migration.
    """
    rho = np.asarray(rho, dtype=bool)
    in_chirp = 2.0 * (geometry.t_adc_start_s + (geometry.n_samples - 1) / (2.0 * geometry.fs_hz))
    if migration:
        return np.full(rho.shape[0], in_chirp)
    active = rho.sum(axis=1)
    return in_chirp + (rho @ np.arange(rho.shape[1], dtype=float)) / np.maximum(active, 1) * geometry.t_chirp_s
