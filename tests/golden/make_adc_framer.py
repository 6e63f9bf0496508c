"""Golden vectors for blocks/adc_framer.py, written from the ADC's description (12 bits, full scale F):

    lsb = F / 2^(b-1),   code = clip(round((R + a) / lsb), -2^(b-1), 2^(b-1) - 1)   rounding: to nearest, ties to even
    I/Q: I and Q are quantised separately (last axis of 2: I, Q); a sample is clipped when I or Q hits a rail
    clipped[c] = how many samples of cycle c hit a rail;  a compact attack (cycles, 1, n_samples) is added to
    every chirp of its cycle

The reference works in float64 on the float32 | complex64 inputs (exact quotients). Scenes: adc_small_i.toml and
adc_small_iq.toml (table1's ADC on 4 chirps x 256 samples, to keep the file small); only their constants are
read from carav_stream. Run `python tests/golden/make_adc_framer.py` to rewrite tests/golden/adc_framer.npz.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import golden_io  # noqa: E402

from carav_stream.radar.scene_loader import load_scene  # noqa: E402  scene constants only

GENERATOR = "make_adc_framer.py"
# The block computes x * float32(1/lsb) in float32: an exact quotient within ~1e-5 LSB of a tie (n + 1/2) may
# round the other way. Such codes may differ by 1, no more, and only a few per vector (~1e-6 of Gaussian samples).
CODE_TOLERANCE = {"atol": 1, "max_mismatch": 4}


def adc(x: np.ndarray, bits: int, full_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(int16 codes, clipped count per cycle) of float (I) or complex (I/Q) samples, cycles on axis 0."""
    lsb = full_scale / 2 ** (bits - 1)
    lo, hi = -2 ** (bits - 1), 2 ** (bits - 1) - 1
    parts = np.stack([x.real, x.imag], axis=-1) if np.iscomplexobj(x) else x
    q = np.round(parts.astype(np.float64) / lsb)      # numpy rounds ties to even
    over = (q < lo) | (q > hi)
    if np.iscomplexobj(x):
        over = over.any(axis=-1)
    return np.clip(q, lo, hi).astype(np.int16), over.reshape(len(x), -1).sum(axis=1).astype(np.int64)


def edge_samples(lsb: float, n: int) -> np.ndarray:
    """Samples a quarter LSB either side of codes and rails, far from any tie, and far beyond full scale."""
    codes = np.array([0, 1, -1, 100, -100, 2046, 2047, -2047, -2048, 2048, -2049, 5000, -5000])
    offsets = np.array([-0.25, 0.25, 0.0])
    x = (codes[:, None] + offsets).ravel() * lsb
    return np.resize(np.concatenate([x, [1e3 * lsb * 2048, -1e3 * lsb * 2048]]), n)


def vector(name_scene: str, seed: int, n_cycles: int, attack_rarms: float | None, edges: bool) -> dict:
    scene = load_scene(str(golden_io.HERE / name_scene))
    lsb = scene.adc_full_scale / 2 ** (scene.adc_bits - 1)
    rng = np.random.default_rng(seed)
    shape = (n_cycles, scene.n_chirps, scene.n_samples)
    dtype = np.complex64 if scene.iq else np.float32
    sigma = scene.sigma_n / np.sqrt(2) if scene.iq else scene.sigma_n   # per branch
    rx = rng.normal(0, sigma, shape)
    if scene.iq:
        rx = rx + 1j * rng.normal(0, sigma, shape)
    if edges:   # cycle 0, chirp 1: every edge case (I, and Q reversed)
        e = edge_samples(lsb, scene.n_samples)
        rx[0, 1] = e + 1j * e[::-1] if scene.iq else e
    rx = rx.astype(dtype)
    inputs, headers, outputs, what = {"rx": rx}, {}, {}, []
    total = rx.astype(np.complex128 if scene.iq else np.float64)
    if attack_rarms is not None:   # one sequence for every chirp of a cycle; cycle 0 silent (zeros)
        a = rng.normal(0, attack_rarms * sigma, (n_cycles, 1, scene.n_samples))
        if scene.iq:
            a = a + 1j * rng.normal(0, attack_rarms * sigma, a.shape)
        a[0] = 0
        a = a.astype(dtype)
        active = [False] + [True] * (n_cycles - 1)
        inputs["attack"] = a
        headers["attack"] = {"attack_model": "smart", "per_cycle": {"attack_active": active}}
        total = total + a
        outputs["attack_active"] = np.array(active)
        what.append(f"compact smart attack rarms {attack_rarms:g} on cycles 1..{n_cycles - 1}")
    codes, clipped = adc(total, scene.adc_bits, scene.adc_full_scale)
    outputs |= {"codes": codes, "clipped": clipped}
    if edges:
        what.append("cycle 0 chirp 1: codes +-0.25 LSB, rails, far beyond full scale")
    kind = "complex64 I/Q" if scene.iq else "float32 I-only"
    description = (f"{n_cycles} cycles x {scene.n_chirps} chirps x {scene.n_samples} {kind} samples, "
                   f"{scene.adc_bits}-bit ADC, lsb {lsb:.4g}, noise {scene.sigma_n / lsb:.1f} LSB RMS"
                   + "".join(f"; {w}" for w in what) + f"; clipped {clipped.tolist()}")
    return {"args": {"scene": name_scene}, "description": description, "generator": GENERATOR,
            "tolerance": {"codes": CODE_TOLERANCE}, "inputs": inputs, "headers": headers, "outputs": outputs}


CASES = {   # name: scene file, seed, cycles, attack rarms (None = no attack port), edge samples
    "i_only": ("adc_small_i.toml", 21, 3, None, True),
    "i_only_attack": ("adc_small_i.toml", 22, 3, 30.0, False),
    "iq": ("adc_small_iq.toml", 23, 3, None, True),
    "iq_attack": ("adc_small_iq.toml", 24, 4, 40.0, False),
}


def build() -> dict[str, dict]:
    return {name: vector(*case) for name, case in CASES.items()}


if __name__ == "__main__":
    golden_io.save(golden_io.HERE / "adc_framer.npz", build())
