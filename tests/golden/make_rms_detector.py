"""Golden vectors for blocks/rms_detector.py, from the paper's Section V.A written out in plain numpy.

Inputs are the int16 ADC codes of the table1 scene (Table I: 64 chirps of N_s samples, 12-bit ADC) built here
from the model R_k[m] = n_k[m] + rho(k) x_k[m] + a_k[m] (Section IV): white Gaussian noise of RMS sigma_n, a
closed-form beat tone for the car, and the attack. The reference then computes, per cycle,

    ||R_k||_r = lsb * sqrt(mean_m code^2)            (lsb = full scale / 2^(bits-1): codes -> sqrt(W))
    D0(k) = ||R_k||_r / sigma_n,   Rbar = (1 / (N_r/2)) sum_{rho(k)=1} ||R_k||_r
    D1(k) = | ||R_k||_r - Rbar | / (Rbar + sigma_n),   D(k) = D1(k) if rho(k) else D0(k)
    Q = max_k D(k),   C(eta) = Q / eta,   alarm <=> C(eta) >= 1

Only the scene's constants come from carav_stream (its preset file); nothing from carav_stream.detect or blocks/.
Run `python tests/golden/make_rms_detector.py` to rewrite tests/golden/rms_detector.npz.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import golden_io  # noqa: E402

from carav_stream.radar.scene_loader import load_scene  # noqa: E402  scene constants only

GENERATOR = "make_rms_detector.py"
C_MPS = 299_792_458.0
SCENE = load_scene("table1")
LSB = SCENE.adc_full_scale / 2 ** (SCENE.adc_bits - 1)
CODE_MAX = 2 ** (SCENE.adc_bits - 1) - 1


def balanced_rho(rng: np.random.Generator, n_cycles: int) -> np.ndarray:
    """Activation rows with exactly n_chirps / 2 active chirps (Algorithm 1, step 1)."""
    n = SCENE.n_chirps
    return np.array([rng.permutation(n) < n // 2 for _ in range(n_cycles)])


def echo(n_cycles: int) -> np.ndarray:
    """The car's beat tone x_k[m] (I only): amplitude sqrt(2 P) for echo power P, Doppler phase per chirp."""
    target = SCENE.targets[0]
    slope = SCENE.bandwidth_hz / SCENE.t_sweep_s
    wavelength = C_MPS / SCENE.fc_hz
    v = target.velocity_mps - SCENE.radar_speed_mps            # range rate: the car is slower, closing
    f_beat = 2 * slope * target.range_m / C_MPS + 2 * v / wavelength
    m = np.arange(SCENE.n_samples) / SCENE.fs_hz
    k = np.arange(SCENE.n_chirps)[:, None]
    amplitude = np.sqrt(2 * SCENE.echo_power_w(target))
    x = amplitude * np.cos(2 * np.pi * f_beat * m + 4 * np.pi * v * k * SCENE.t_chirp_s / wavelength + 0.3)
    return np.broadcast_to(x, (n_cycles, SCENE.n_chirps, SCENE.n_samples))


def adc(r: np.ndarray) -> np.ndarray:
    """Quantise sqrt(W) samples to the 12-bit codes: round to nearest, clip to the rails."""
    return np.clip(np.round(r / LSB), -CODE_MAX - 1, CODE_MAX).astype(np.int16)


def received(seed: int, attacks: list[tuple[str, float]]) -> tuple[np.ndarray, np.ndarray]:
    """(codes int16 (cycles, 64, N_s), rho bool (cycles, 64)), one cycle per (attack model, rarms)."""
    rng = np.random.default_rng(seed)
    n_cycles, n, n_s = len(attacks), SCENE.n_chirps, SCENE.n_samples
    rho = balanced_rho(rng, n_cycles)
    r = rng.normal(0.0, SCENE.sigma_n, (n_cycles, n, n_s)) + rho[:, :, None] * echo(n_cycles)
    for c, (attack, rarms) in enumerate(attacks):
        sigma_a = rarms * SCENE.sigma_n
        if attack == "random":      # Section V.D: a_k[m] i.i.d. N(0, sigma_a)
            r[c] += rng.normal(0.0, sigma_a, (n, n_s))
        elif attack == "smart":     # Section V.E: the same Gaussian sequence repeated in every chirp
            r[c] += rng.normal(0.0, sigma_a, n_s)
        elif attack == "burst":     # a burst on the first 4 ACTIVE chirps only: the cycle is raised by D1
            burst = np.flatnonzero(rho[c])[:4]
            r[c, burst] += rng.normal(0.0, sigma_a, (4, n_s))
        else:
            assert attack == "none", attack
    return adc(r), rho


def detector(codes: np.ndarray, rho: np.ndarray, sigma_n: float, eta: float) -> dict[str, np.ndarray]:
    """Section V.A per cycle, from the codes."""
    rms = LSB * np.sqrt(np.mean(codes.astype(np.float64) ** 2, axis=-1))       # (cycles, chirps)
    n_r = rms.shape[1]
    rbar = np.sum(rms * rho, axis=1) / (n_r / 2)
    d0 = rms / sigma_n
    d1 = np.abs(rms - rbar[:, None]) / (rbar[:, None] + sigma_n)
    d = np.where(rho, d1, d0)
    k_max = np.argmax(d, axis=1)
    rows = np.arange(len(d))
    q = d[rows, k_max]
    return {"q": q, "c": q / eta, "alarm": q / eta >= 1, "invalid": np.zeros(len(q), bool),
            "raised_by": np.where(rho[rows, k_max], "D1", "D0"), "k_max": k_max, "rbar": rbar}


CASES = [   # name, seed, [(attack, rarms) per cycle], eta, sigma_n (0 = the scene's)
    ("no_attack", 11, [("none", 0.0)] * 2, 1.5, 0.0),
    ("attacks", 12, [("random", 3.0), ("smart", 3.0), ("burst", 8.0)], 1.5, 0.0),
    ("eta2_clipped", 13, [("smart", 1.4), ("random", 60.0)], 2.0, 1.2e-4),
]


def build() -> dict[str, dict]:
    vectors = {}
    for name, seed, attacks, eta, sigma_n in CASES:
        codes, rho = received(seed, attacks)
        rails = np.count_nonzero((codes == CODE_MAX) | (codes == -CODE_MAX - 1), axis=(1, 2))
        sigma = sigma_n or SCENE.sigma_n
        what = ", ".join(("no attack" if a == "none" else f"{a} rarms {r:g}") + (f" ({k} codes at a rail)" if k else "")
                         for (a, r), k in zip(attacks, rails))
        description = (f"table1, {len(attacks)} cycles of {SCENE.n_chirps} chirps x {SCENE.n_samples} int16 codes: "
                       f"{what}; eta {eta:g}, "
                       f"sigma_n {'of the scene' if not sigma_n else f'{sigma_n:g}'}")
        args = {"eta": eta, "scene": "table1"} | ({"sigma_n": sigma_n} if sigma_n else {})
        vectors[name] = {
            "args": args, "description": description, "generator": GENERATOR,
            "tolerance": {"q": {"rtol": 1e-12}, "c": {"rtol": 1e-12}, "rbar": {"rtol": 1e-12}},
            "inputs": {"frames": codes, "rho": rho},
            "outputs": {"verdict": rho, **detector(codes, rho, sigma, eta)}}
    return vectors


if __name__ == "__main__":
    golden_io.save(golden_io.HERE / "rms_detector.npz", build())
