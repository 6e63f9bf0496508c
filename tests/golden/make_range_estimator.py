"""Golden vectors for blocks/range_estimator.py: planted point targets written in closed form (Section II).

One target per cycle at range R [m] with radial velocity v [m/s] (positive receding), I-only beat signal:

    f_b = 2 S R / c + 2 v / lambda                   (S = bandwidth / sweep time, lambda = c / f_c)
    x_k[m] = A cos(2 pi f_b m / fs + 4 pi v k T_c / lambda + phi0)   on active chirps, 0 on silent ones
    R_k[m] = rho(k) x_k[m] + n_k[m],   quantised by the scene's 12-bit ADC into int16 codes

The golden outputs are the planted R and v. fft_peak must land within +-1 range bin, c fs / (2 S N), and
+-1 Doppler bin of the active chirps; ml within the tolerance stored with its vector. Scene ranging_small.toml
(table1's waveform, 16 chirps x 256 samples); only its constants are read from carav_stream.
Run `python tests/golden/make_range_estimator.py` to rewrite tests/golden/range_estimator.npz.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import golden_io  # noqa: E402

from carav_stream.radar.scene_loader import load_scene  # noqa: E402  scene constants only

GENERATOR = "make_range_estimator.py"
C_MPS = 299_792_458.0
SCENE_FILE = "ranging_small.toml"
SCENE = load_scene(str(golden_io.HERE / SCENE_FILE))
LSB = SCENE.adc_full_scale / 2 ** (SCENE.adc_bits - 1)
SLOPE = SCENE.bandwidth_hz / SCENE.t_sweep_s
WAVELENGTH = C_MPS / SCENE.fc_hz
RANGE_BIN_M = C_MPS * SCENE.fs_hz / (2 * SLOPE * SCENE.n_samples)
DOPPLER_BIN_MPS = WAVELENGTH / (2 * SCENE.n_chirps * SCENE.t_chirp_s)
TARGETS = [(43.0, -1.11), (31.0, 12.0), (120.4, -30.0)]   # (range_m, velocity_mps) per cycle


def cycles(seed: int, amplitude_lsb: float, noise_lsb: float) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n_c, n_k, n_s = len(TARGETS), SCENE.n_chirps, SCENE.n_samples
    rho = np.array([rng.permutation(n_k) < n_k // 2 for _ in range(n_c)])
    t = np.arange(n_s) / SCENE.fs_hz
    k = np.arange(n_k)[:, None]
    x = np.empty((n_c, n_k, n_s))
    for c, (r, v) in enumerate(TARGETS):
        f_beat = 2 * SLOPE * r / C_MPS + 2 * v / WAVELENGTH
        phase = 4 * np.pi * v * k * SCENE.t_chirp_s / WAVELENGTH + rng.uniform(0, 2 * np.pi)
        x[c] = amplitude_lsb * LSB * np.cos(2 * np.pi * f_beat * t + phase)
    x = rho[:, :, None] * x + rng.normal(0, noise_lsb * LSB, x.shape)
    return np.clip(np.round(x / LSB), -2048, 2047).astype(np.int16), rho


CASES = {   # name: method, seed, amplitude and noise RMS in LSB, tolerance on range_m and velocity_mps
    "fft_peak": ("fft_peak", 31, 300.0, 40.0, {"range_m": {"atol": RANGE_BIN_M},
                                                "velocity_mps": {"atol": DOPPLER_BIN_MPS}}),
    "ml": ("ml", 32, 300.0, 40.0, {"range_m": {"atol": 0.05}, "velocity_mps": {"atol": 0.1}}),
}


def build() -> dict[str, dict]:
    vectors = {}
    for name, (method, seed, amplitude, noise, tolerance) in CASES.items():
        codes, rho = cycles(seed, amplitude, noise)
        where = ", ".join(f"{r:g} m at {v:g} m/s" for r, v in TARGETS)
        description = (f"{method}: {len(TARGETS)} cycles of {SCENE.n_chirps} chirps x {SCENE.n_samples} int16 "
                       f"codes, one target each ({where}), amplitude {amplitude:g} LSB, noise {noise:g} LSB RMS; "
                       f"range bin {RANGE_BIN_M:.3f} m, Doppler bin {DOPPLER_BIN_MPS:.2f} m/s")
        vectors[name] = {
            "args": {"method": method, "scene": SCENE_FILE}, "description": description, "generator": GENERATOR,
            "tolerance": tolerance, "inputs": {"frames": codes, "frames@rho": rho},
            "headers": {"frames": {"verdict": "clean"}},
            "outputs": {"range_m": np.array([[r] for r, _ in TARGETS]),
                        "velocity_mps": np.array([[v] for _, v in TARGETS])}}
    return vectors


if __name__ == "__main__":
    golden_io.save(golden_io.HERE / "range_estimator.npz", build())
