"""Vectorised exact generators for the Monte Carlo of the smart attack (`paper_model.sample_q_smart`).

Each generator's law is exact and tested against scipy's (tests/montecarlo/test_paper_model_draws.py); each is
there because numpy's own draw of the same law cost more, by the measurement in its docstring.
"""
from __future__ import annotations

import math

import numpy as np

from carav_stream.core.allocator import scratch
from carav_stream.radar.noise import words as raw_words

X_MAX = 8.6     # bound on |x| in chi2_and_normal: sqrt(-2 ln 2^-53) = 8.572, plus float32 rounding


def chi2_and_normal(rng: np.random.Generator, k: int, chi2: np.ndarray, z: np.ndarray) -> None:
    """Fill chi2 with i.i.d. chi2(k) and z with i.i.d. N(0, 1), independent (C-contiguous float32, same shape).

    Two normals per element by Box-Muller, r = sqrt(-2 ln(1 - u)) with u ~ U[0, 1) float64 (53 bits, so
    |x| <= 8.57: P(|N(0, 1)| > 8.57) = 1e-17) and theta = 2 pi v, v ~ U[0, 1) float32: x = r cos(theta),
    z = r sin(theta). x makes chi2(k) = 2 Gamma(k / 2) by Marsaglia-Tsang (the method of numpy's gamma):

        Gamma(a) = b v^3,  v = 1 + c x,  b = a - 1/3,  c = 1 / sqrt(9 b),  accepted when ln u' < h(x),
        h(x) = x^2/2 + b (1 - v^3 + ln v^3) = R(cx) / (3 c^2),  R(y) = ln(1 + y) - y + y^2/2 - y^3/3.

    |R(y)| <= y^4 / (4 (1 - |y|)), so u' < 1 - K x^4, K = c^2 / (12 (1 - c x_max)), accepts without a logarithm
    (1 - K x^4 <= 1 + h <= e^h). u' is a float32 uniform, a cell of width 2^-24; the squeeze, in float32, accepts
    only when the whole cell passes (margin 2^-21 over the cell and the rounding); the few others get a float64
    uniform within their cell and the exact test in float64. A rejected value is replaced by an independent draw
    of numpy's gamma, which leaves the law exact (P(reject) = 5e-5 for k = 1079). For k < 18 (c x_max >= 1)
    numpy's gamma draws every chi2. Both come out of vector passes, cheaper than Generator.standard_gamma and
    .standard_normal in float32, which draw one element at a time.
    """
    n = chi2.size
    chi2, z = chi2.reshape(-1), z.reshape(-1)
    r = rng.random(out=scratch("r64", n, np.float64))
    np.subtract(1.0, r, out=r)
    np.log(r, out=r)
    t = scratch("t", n, np.float32)
    np.multiply(r, -2.0, out=t, casting="same_kind")
    np.sqrt(t, out=t)                                        # Box-Muller radius
    x = rng.random(dtype=np.float32, out=scratch("x", n, np.float32))
    x *= np.float32(2.0 * np.pi)
    np.sin(x, out=z)
    np.cos(x, out=x)
    x *= t
    z *= t
    a = k / 2.0
    b = a - 1.0 / 3.0
    c = 1.0 / np.sqrt(9.0 * b)
    if c * X_MAX >= 1.0:
        rng.standard_gamma(a, dtype=np.float32, out=chi2)
        chi2 *= np.float32(2.0)
        return
    u = rng.random(dtype=np.float32, out=scratch("u", n, np.float32))
    np.multiply(x, np.float32(c), out=chi2)
    chi2 += np.float32(1.0)
    np.square(chi2, out=t)
    chi2 *= t                                                # v^3
    np.square(x, out=t)
    np.square(t, out=t)
    t *= np.float32(c * c / (12.0 * (1.0 - c * X_MAX)))
    t += np.float32(2.0 ** -21)                              # K x^4 + margin
    np.subtract(np.float32(1.0), u, out=u)                   # 1 - u', exact
    hard = np.flatnonzero(u <= t)                            # not accepted by the squeeze
    chi2 *= np.float32(2.0 * b)
    if hard.size:
        xh = x[hard].astype(np.float64)
        vh = 1.0 + c * xh
        uh = (1.0 - u[hard].astype(np.float64)) + rng.random(hard.size) * 2.0 ** -24
        with np.errstate(divide="ignore", invalid="ignore"):
            ok = (vh > 0) & (np.log(uh) < 0.5 * xh * xh + b * (1.0 - vh ** 3 + 3.0 * np.log(vh)))
        bad = hard[~ok]
        if bad.size:
            chi2[bad] = 2.0 * rng.standard_gamma(a, size=bad.size, dtype=np.float32)


def popcount(words: np.ndarray) -> np.ndarray:
    """Set bits of every uint64 word (np.bitwise_count where numpy has it)."""
    if hasattr(np, "bitwise_count"):
        return np.bitwise_count(words)
    w = words - ((words >> np.uint64(1)) & np.uint64(0x5555555555555555))
    w = (w & np.uint64(0x3333333333333333)) + ((w >> np.uint64(2)) & np.uint64(0x3333333333333333))
    w = (w + (w >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (w * np.uint64(0x0101010101010101)) >> np.uint64(56)


def balanced_mask(rng: np.random.Generator, out: np.ndarray) -> np.ndarray:
    """Fill out, float32 (n_chirps, n_cycles), with uniformly random balanced activations: 1 active, 0 silent.

    An n_chirps-bit word from the raw stream (ceil(n_chirps / 64) 64-bit words), kept when exactly half its bits
    are set: uniform over the balanced patterns, as `balanced_rows`. A word is kept with probability
    C(N, N/2) / 2^N (0.099 for N = 64): about 10 raw words a cycle: with the unpacking, cheaper than
    balanced_rows' float key per chirp and selection.
    """
    n_chirps, n_cycles = out.shape
    n_words = -(-n_chirps // 64)
    p_keep = math.comb(n_chirps, n_chirps // 2) / 2.0 ** n_chirps
    kept, need = [], n_cycles
    while need > 0:
        n_rows = int(need / p_keep * 1.2) + 16
        words = raw_words(rng, n_rows * n_words).reshape(n_rows, n_words)
        if n_chirps % 64:
            words[:, -1] &= np.uint64((1 << (n_chirps % 64)) - 1)
        ones = popcount(words).sum(axis=1) if n_words > 1 else popcount(words[:, 0])
        good = words[np.flatnonzero(ones == n_chirps // 2)[:need]]
        kept.append(good)
        need -= good.shape[0]
    words = np.concatenate(kept) if len(kept) > 1 else kept[0]
    bits = np.unpackbits(words.astype("<u8", copy=False).view(np.uint8), axis=1, count=n_chirps, bitorder="little")
    np.copyto(out, bits.T)
    return out
