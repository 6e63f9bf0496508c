"""Detectors a sweep can score: the paper's C(eta) and the opt-in ones, each as one statistic per cycle.

`carav`        Q of the RMS detector (an alarm is Q >= eta); the Monte Carlo's own fast paths apply.
`spectral`     the single-chirp spectral silent-chirp test (carav_stream/detect/opt_in.py)
`integrated`   the same bins summed over the silent chirps (opt_in.integrated_silent_test)
`coherent`     the silent chirps' own range-Doppler map (opt_in.coherent_silent_test; union-bound threshold)
`spill`        energy still arriving in the silent slots after active ones, after the longest visible round trip
               (opt_in.spill_test, against reactive repeaters; needs the scene for its window)

The opt-in statistics are divided by their threshold for PF = 1e-6 per cycle (white Gaussian noise; exact, or a
union bound for `coherent`), so a sweep's eta grid reads the same for every detector: an alarm is
statistic >= eta, and eta = 1 is the 1e-6 design. A receiver array's frames (n_cycles, n_rx, n_chirps, n_samples)
are judged on the bin powers summed over its receivers (opt_in's ``receivers=True``).
"""
from __future__ import annotations

import numpy as np

from carav_stream.detect import opt_in
from carav_stream.radar.physics import spill_window_start

__all__ = ["DETECTORS", "OPT_IN", "statistic"]

DESIGN_PF = 1e-6


def _receivers(frames) -> bool:
    """Whether a batch of frames has a receiver axis (n_cycles, n_rx, n_chirps, n_samples)."""
    return np.ndim(frames) == 4


def _spectral(frames, rho, sigma_n):
    res = opt_in.spectral_silent_test(frames, rho, sigma_n, pf=DESIGN_PF, receivers=_receivers(frames))
    return res.stat / res.threshold


def _integrated(frames, rho, sigma_n):
    res = opt_in.integrated_silent_test(frames, rho, sigma_n, pf=DESIGN_PF, receivers=_receivers(frames))
    return res.stat / res.threshold


def _coherent(frames, rho, sigma_n):
    res = opt_in.coherent_silent_test(frames, rho, sigma_n, pf=DESIGN_PF, receivers=_receivers(frames))
    return res.stat / res.threshold


def _spill(frames, rho, sigma_n, scene):
    if scene is None:
        raise ValueError("detector 'spill' needs the scene (its window starts after the longest visible round trip)")
    first, n_s = spill_window_start(scene), np.shape(frames)[-1]
    if first > n_s - 4:
        raise ValueError(f"the spill test's window starts at sample {first} (after the longest round trip the "
                         f"receiver passes, and the IF filter's settling), and N_s = {n_s} leaves fewer than the 4 "
                         f"samples it needs: it takes N_s >= {first + 4}")
    return opt_in.spill_test(frames, rho, sigma_n, first, pf=DESIGN_PF, receivers=_receivers(frames)).stat


OPT_IN = {"spectral": _spectral, "integrated": _integrated, "coherent": _coherent, "spill": _spill}
DETECTORS = ("carav", *OPT_IN)


def statistic(detector: str, frames, rho, sigma_n: float, scene=None) -> np.ndarray:
    """float64 (n_cycles,) statistic of an opt-in detector, in units of its PF = 1e-6 threshold; frames
    (n_cycles, n_chirps, n_samples), or a receiver array's (n_cycles, n_rx, n_chirps, n_samples) (``scene``: the
    frames' scene, which `spill` needs)."""
    if detector not in OPT_IN:
        raise ValueError(f"detector: unknown {detector!r}, expected one of {', '.join(DETECTORS)}")
    if detector == "spill":
        return np.asarray(_spill(frames, rho, sigma_n, scene), dtype=np.float64)
    return np.asarray(OPT_IN[detector](frames, rho, sigma_n), dtype=np.float64)
