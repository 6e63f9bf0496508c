"""MATLAB's published FMCWExample result beside our replica of its chain and beside `ml` and `root_music`, over a
Monte Carlo of closed-form table1 frames (docs/ESTIMATION.md; `carav experiment matlab-table1`, its command line in
carav_stream/cli/experiment/matlab_table1.py).

Frames: complex (I/Q) table1 beat signals of the car (43 m, closing at 1.111 m/s) from `estimate.tones.synth_beat`
at the radar equation's +2.2 dB per sample, all 64 chirps, range migration included. Chains: our replica of
MATLAB's (`estimate.matlab_reference`: decimate, pulsint, 2x2 rootmusic on the sum and on one fast-time sample
across sweeps), `ml` and `root_music` of this package. Measured: mean, standard deviation and 0.5 % .. 99.5 % of
each quantity, MATLAB's published values as z-scores within the replica's spread, and how much such a test can
tell: the interval of published values it would have accepted (|z| < 3), set beside the truth.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.estimate import estimate
from carav_stream.estimate.matlab_reference import (
    MATLAB_TABLE1_CLOSING_SPEED_MPS,
    MATLAB_TABLE1_RANGE_M,
    TABLE1_TRUE_CLOSING_SPEED_MPS,
    TABLE1_TRUE_RANGE_M,
    fmcw_example_estimate,
    fmcw_example_geometry,
)
from carav_stream.estimate.tones import synth_beat

__all__ = ["simulate", "figures", "SNR_DB"]

SNR_DB = 2.2          # the radar equation's per-sample SNR of the car (docs/SCENES.md)
CHUNK = 50            # cycles per simulated block (memory: 50 x 64 x 1100 complex64 = 28 MB)


def simulate(cycles: int, seed: int, progress: Callable[[int, int], None] | None = None) -> dict[str, np.ndarray]:
    """Per-cycle estimates of every chain: {quantity: (cycles,) float64}; progress(cycles done, cycles) as each
    block is estimated."""
    g = fmcw_example_geometry()
    rng = np.random.default_rng(seed)
    out: dict[str, list[np.ndarray]] = {}
    for start in range(0, cycles, CHUNK):
        n = min(CHUNK, cycles - start)
        rho = np.ones((n, 64), bool)
        x = synth_beat(g, rho, [TABLE1_TRUE_RANGE_M], [-TABLE1_TRUE_CLOSING_SPEED_MPS], snr_sample_db=SNR_DB,
                       rng=rng, migrate=True)
        ref = fmcw_example_estimate(x, g)
        ml = estimate(x, rho, g, method="ml")
        rm = estimate(x, rho, g, method="root_music")
        for key, v in (("replica_range_m", ref["range_m"]), ("replica_closing_speed_mps", ref["closing_speed_mps"]),
                       ("ml_beat_range_m", ml.beat_hz[:, 0] * g.range_per_hz_m),
                       ("ml_range_m", ml.range_m[:, 0]), ("ml_velocity_mps", ml.velocity_mps[:, 0]),
                       ("root_music_beat_range_m", rm.beat_hz[:, 0] * g.range_per_hz_m)):
            out.setdefault(key, []).append(np.asarray(v, float).ravel())
        if progress is not None:
            progress(start + n, cycles)
    return {k: np.concatenate(v) for k, v in out.items()}


def figures(runs: dict[str, np.ndarray]) -> dict:
    stats = {k: {"mean": float(v.mean()), "std": float(v.std(ddof=1)),
                 "q005": float(np.quantile(v, 0.005)), "q995": float(np.quantile(v, 0.995))}
             for k, v in runs.items()}
    tests = {}
    for name, key, published, truth in (
            ("range", "replica_range_m", MATLAB_TABLE1_RANGE_M, TABLE1_TRUE_RANGE_M),
            ("closing_speed", "replica_closing_speed_mps", MATLAB_TABLE1_CLOSING_SPEED_MPS,
             TABLE1_TRUE_CLOSING_SPEED_MPS)):
        s = stats[key]
        tests[name] = {"published": published, "truth": truth, "z": (published - s["mean"]) / s["std"],
                       "accepted": [s["mean"] - 3 * s["std"], s["mean"] + 3 * s["std"]]}
    return {"stats": stats, "matlab": tests}
