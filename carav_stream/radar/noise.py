"""Fast float32 Gaussian samples from a numpy Generator's raw bit stream (Box-Muller).

``Generator.standard_normal(dtype=np.float32)`` costs about 11 ns per sample on the 2-core reference
machine (the ziggurat's per-sample branch); vectorised Box-Muller on the generator's raw 64-bit words
costs about 3.5 ns, which is what lets Table I run near its real-time rate (docs/bench/synth.md).

Each 64-bit word gives two 32-bit uniforms u1 in (0, 1], u2 in [0, 1): z1 = r cos(2 pi u2),
z2 = r sin(2 pi u2), r = sqrt(-2 ln u1). u1 >= 2^-33 bounds |z| at 6.8 (P(|N(0,1)| > 6.8) = 1e-11).
Each row is filled from its own consecutive block of words (cosines in the first half, sines in the
second), so drawing n rows at once gives exactly the rows that n one-row calls give.
"""
from __future__ import annotations

import numpy as np

_U32 = np.float32(2.0 ** -32)
_HALF_U32 = np.float32(2.0 ** -33)
_ANGLE = np.float32(2.0 * np.pi * 2.0 ** -32)


def standard_normal_rows(rng: np.random.Generator, n_rows: int, n_per_row: int, scale: float = 1.0) -> np.ndarray:
    """i.i.d. N(0, scale^2) float32 (n_rows, n_per_row), consuming ceil(n_per_row / 2) words per row."""
    h = (n_per_row + 1) // 2
    raw = rng.bit_generator.random_raw(n_rows * h).reshape(n_rows, h)
    u = raw.view(np.uint32)                      # (n_rows, 2h): even = u1 bits, odd = u2 bits
    out = np.empty((n_rows, 2 * h), np.float32)
    r, s = out[:, :h], out[:, h:]
    np.multiply(u[:, 0::2], _U32, out=r, dtype=np.float32)
    r += _HALF_U32
    np.log(r, out=r)
    folded = 1e-15 < scale < 1e15                # scale^2 stays a normal float32
    r *= np.float32(-2.0 * scale * scale if folded else -2.0)   # the scale rides on the radius
    np.sqrt(r, out=r)
    if not folded:
        r *= np.float32(scale)
    np.multiply(u[:, 1::2], _ANGLE, out=s, dtype=np.float32)
    c = np.cos(s)
    np.sin(s, out=s)
    s *= r
    r *= c
    return out if 2 * h == n_per_row else out[:, :n_per_row]


def gaussian(rng: np.random.Generator, shape: tuple[int, ...], rms: float, complex_: bool) -> np.ndarray:
    """Zero-mean Gaussian with E|z|^2 = rms^2: float32, or circular complex64 (rms^2 / 2 per part).

    The leading axis is the row axis (one block of words per row, see module docstring).
    """
    n_rows = shape[0]
    n_per_row = int(np.prod(shape[1:], dtype=np.int64)) * (2 if complex_ else 1)
    z = standard_normal_rows(rng, n_rows, n_per_row, rms / np.sqrt(2.0) if complex_ else rms)
    if complex_:
        return z.view(np.complex64).reshape(shape)
    return z.reshape(shape)
