"""The one virtual element range and velocity are estimated from in a scene with an antenna array.

    x_ref[c, l, m] = x[c, 0, l n_slots, m],    rho_ref[c, l] = rho[c, l n_slots]     (receiver 0, slot 0 of loop l)

Receiver 0 and the chirps of each TDM loop's first slot: one transmitter and one receiver, so every chirp it reads
carries the same far-field phase, and its chirps are a transmitter's repetitions, one loop (t_loop = n_slots
t_chirp) apart: the slow-time spacing of its Doppler (``element_geometry``), whose unambiguous velocity is the
scene's. Reading the other slots as chirps of the same sequence would put every transmitter's own phase into the
Doppler progression. The activation is constant within a loop (radar/activation.py), so rho_ref is the loops'
activation, as balanced as rho. For a single antenna (one receiver, one slot) both are the frames and rho as given.

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
