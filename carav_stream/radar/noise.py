"""Fast float32 Gaussian samples from a numpy Generator's raw bit stream (Box-Muller).

Why by hand: ``Generator.standard_normal(dtype=np.float32)`` is a ziggurat with a branch per sample, which does
not vectorise; Box-Muller on the generator's raw 64-bit words is vector math throughout, and costs a small multiple
of that vector math alone. The same steps compiled in one loop with numba are slower, on AVX-512 and AVX2 code
alike (the C library's log, cos and sin one value at a time). Measured: docs/bench/synth.md (the noise stage
against its bound), docs/bench/compiled.md (against numba).

A row of n samples takes h = ceil(n / 2) consecutive 64-bit words, read as 2h 32-bit integers (little
endian: word j gives integers 2j and 2j + 1). Pair j (j < h) takes u = integer j, as u1 = (u + 1/2) 2^-32
in (0, 1], and v = integer h + j, signed, as the angle theta = 2 pi v 2^-32 in [-pi, pi):

    r = sqrt(-2 ln u1),   sample j = r cos(theta),   sample h + j = r sin(theta)

with numpy's float32 ln, cos and sin, which are vectorised on AVX2 and AVX-512 alike (numpy's float32 tan,
which could replace the cosine and the sine with one call, runs one element at a time without AVX-512).
u1 >= 2^-33 bounds |z| at 6.8 (P(|N(0,1)| > 6.8) = 1e-11). Each row is filled from its own consecutive block of
words, so drawing n rows at once gives exactly the rows that n one-row calls give, however the rows are chunked.

Work is done a few rows at a time (about ``CHUNK_WORDS`` words, so the raw words, the radii and the
output of a chunk stay in the core's L2 cache) in a reused scratch buffer per thread: no temporary the
size of the whole batch is allocated (fresh multi-megabyte temporaries cost more in page faults than
the arithmetic). The angles, cosines and sines are computed in the output rows themselves, half rows (2-D
views with gaps) though they are: computing them in contiguous scratch and writing the rows with the two
last products is faster into an output array in cache but slower in the graph's case, output frames not in
cache (a shared-memory slot), whose rows are then first touched at the very end.
"""
from __future__ import annotations

import numpy as np

from carav_stream.core.allocator import scratch

CHUNK_WORDS = 1 << 15                        # 256 KiB of raw words per chunk (at least one row)
_U32 = np.float32(2.0 ** -32)
_HALF_U32 = np.float32(2.0 ** -33)
_ANGLE = np.float32(2.0 * np.pi * 2.0 ** -32)


def words(rng: np.random.Generator, n: int) -> np.ndarray:
    """The generator's next n 64-bit words, uint64: ``rng.bit_generator.random_raw(n)`` for numpy's 64-bit bit
    generators (PCG64, PCG64DXSM, SFC64, Philox). MT19937 is a 32-bit generator, whose raw values are 32-bit:
    its words come from ``Generator.integers`` over the whole uint64 range (two draws each).
    ``Generator.integers`` gives the 64-bit generators' raw words too, but it made the graph's channel slower
    (the two alternated by `python3 dev.py bench compare`)."""
    bits = rng.bit_generator
    if isinstance(bits, np.random.MT19937):
        return rng.integers(0, 1 << 64, n, dtype=np.uint64)
    return bits.random_raw(n)


def standard_normal_rows(rng: np.random.Generator, n_rows: int, n_per_row: int, scale: float = 1.0, *,
                         out: np.ndarray | None = None) -> np.ndarray:
    """i.i.d. N(0, scale^2) float32 (n_rows, n_per_row), consuming ceil(n_per_row / 2) words per row.

    ``out``: a C-contiguous float32 array of n_rows * n_per_row elements to fill (returned reshaped to
    (n_rows, n_per_row)); a new array if None.
    """
    h = (n_per_row + 1) // 2
    if out is None:
        out = np.empty((n_rows, n_per_row), np.float32)
    elif out.dtype != np.float32 or out.size != n_rows * n_per_row or not out.flags.c_contiguous:
        raise ValueError(f"out: expected a C-contiguous float32 array of {n_rows} x {n_per_row} elements")
    out = out.reshape(n_rows, n_per_row)
    if n_rows == 0 or n_per_row == 0:
        return out
    folded = 1e-15 < scale < 1e15                # scale^2 stays a normal float32
    k = np.float32(-2.0 * (scale * scale if folded else 1.0))   # r^2 = k ln u1, the scale riding on it
    even = 2 * h == n_per_row
    m_max = max(1, CHUNK_WORDS // h)
    for a in range(0, n_rows, m_max):
        m = min(m_max, n_rows - a)
        u = words(rng, m * h).view(np.uint32).reshape(m, 2 * h)
        buf = scratch("noise", m * (h if even else 3 * h), np.float32)
        r = buf[:m * h].reshape(m, h)
        z = out[a: a + m] if even else buf[m * h:].reshape(m, 2 * h)
        c, s = z[:, :h], z[:, h:]
        np.multiply(u[:, :h], _U32, out=r, dtype=np.float32)         # u1
        r += _HALF_U32
        np.log(r, out=r)
        r *= k
        np.sqrt(r, out=r)                                            # r
        if not folded:
            r *= np.float32(scale)
        np.multiply(u[:, h:].view(np.int32), _ANGLE, out=s, dtype=np.float32)   # theta
        np.cos(s, out=c)
        np.sin(s, out=s)
        c *= r                                                       # r cos(theta)
        s *= r                                                       # r sin(theta)
        if not even:
            out[a: a + m] = z[:, :n_per_row]
    return out


def gaussian(rng: np.random.Generator, shape: tuple[int, ...], rms: float, complex_: bool, *,
             out: np.ndarray | None = None) -> np.ndarray:
    """Zero-mean Gaussian with E|z|^2 = rms^2: float32, or circular complex64 (rms^2 / 2 per part).

    The leading axis is the row axis (one block of words per row, see module docstring). ``out``: a
    C-contiguous array of that shape and dtype to fill (and return); a new array if None.
    """
    n_rows = shape[0]
    n_per_row = int(np.prod(shape[1:], dtype=np.int64)) * (2 if complex_ else 1)
    dtype = np.complex64 if complex_ else np.float32
    if out is not None and (out.dtype != dtype or out.shape != tuple(shape) or not out.flags.c_contiguous):
        raise ValueError(f"out: expected a C-contiguous {np.dtype(dtype)} array of shape {tuple(shape)}")
    flat = None if out is None else out.reshape(-1).view(np.float32)
    z = standard_normal_rows(rng, n_rows, n_per_row, rms / np.sqrt(2.0) if complex_ else rms, out=flat)
    if out is not None:
        return out
    if complex_:
        return z.view(np.complex64).reshape(shape)
    return z.reshape(shape)
