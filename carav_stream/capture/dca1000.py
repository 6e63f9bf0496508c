"""Raw ADC captures of TI's DCA1000 capture card, as it records an AWR1642-family radar (xWR16xx, two LVDS lanes).

The layout TI documents for these devices (the DCA1000 and mmWave Studio raw-capture application note and its
reading script): the .bin file is a stream of little-endian int16, chirp after chirp in capture order; within a
chirp, receiver after receiver; within a receiver, its n_samples ADC samples.
  real data:    one int16 per sample, in sample order (the two lanes carry alternate samples)
  complex data: every two samples n, n+1 of a receiver travel as four int16: I(n), I(n+1), Q(n), Q(n+1)
                (lane 1 carries even samples, lane 2 odd ones, I before Q)
An ADC of 12 or 14 bits delivers its codes without sign extension: a code above 2^(b-1) - 1 is negative and
2^b is subtracted from it, as TI's script does.

A cycle (a radar frame in TI's words) is `n_chirps` consecutive chirps; the detector and the estimator read one
receiver's samples of every cycle, shaped like this project's ADC frames: int16 (cycles, n_chirps, n_samples) for
real data, (cycles, n_chirps, n_samples, 2) with I then Q for complex data.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

LANES = 2   # xWR16xx: two LVDS lanes


@dataclass(frozen=True)
class Layout:
    n_rx: int           # receivers enabled in the capture
    n_samples: int      # ADC samples per chirp and receiver
    n_chirps: int       # chirps per cycle (TI: per frame)
    complex: bool       # complex (I/Q) or real capture
    adc_bits: int = 16

    def __post_init__(self) -> None:
        if not 1 <= self.n_rx <= 4 or self.n_samples < 1 or self.n_chirps < 1 or self.adc_bits not in (12, 14, 16):
            raise ValueError(f"DCA1000 layout: n_rx 1..4, n_samples >= 1, n_chirps >= 1, adc_bits 12 | 14 | 16; "
                             f"got {self}")
        if self.complex and (self.n_samples * self.n_rx) % LANES:
            raise ValueError(f"DCA1000 layout: complex samples travel in pairs over {LANES} lanes: n_samples x n_rx "
                             f"must be even, got {self.n_samples} x {self.n_rx}")

    @property
    def words_per_chirp(self) -> int:
        return self.n_rx * self.n_samples * (2 if self.complex else 1)

    @property
    def bytes_per_cycle(self) -> int:
        return 2 * self.words_per_chirp * self.n_chirps


def decode(words: np.ndarray, layout: Layout) -> np.ndarray:
    """int16 words of whole cycles -> int16 (cycles, n_chirps, n_rx, n_samples[, 2]) (I, Q on the last axis)."""
    words = np.asarray(words)
    if words.dtype != np.dtype("<i2") or words.ndim != 1 or words.size % (layout.words_per_chirp * layout.n_chirps):
        raise ValueError(f"DCA1000 words: expected little-endian int16 of whole cycles "
                         f"({layout.words_per_chirp * layout.n_chirps} words each), got {words.dtype} {words.shape}")
    if layout.adc_bits < 16:   # codes of a 12- or 14-bit ADC come without their sign extended
        wide = words.astype(np.int32)
        wide[wide > 2 ** (layout.adc_bits - 1) - 1] -= 2 ** layout.adc_bits
        words = wide.astype(np.int16)
    chirps = words.size // layout.words_per_chirp
    if not layout.complex:
        out = words.reshape(chirps, layout.n_rx, layout.n_samples)
    else:   # groups of four words I(n), I(n+1), Q(n), Q(n+1) -> (sample, I|Q)
        quads = words.reshape(chirps, layout.n_rx * layout.n_samples // 2, 2, 2)   # (pair, I|Q, n|n+1)
        out = quads.transpose(0, 1, 3, 2).reshape(chirps, layout.n_rx, layout.n_samples, 2)
    return np.ascontiguousarray(out.reshape(chirps // layout.n_chirps, layout.n_chirps, *out.shape[1:]))


def complete_cycles(path: str | Path, layout: Layout) -> tuple[int, int]:
    """(whole cycles in the capture, bytes left after them: a truncated capture leaves some)."""
    size = Path(path).stat().st_size
    return size // layout.bytes_per_cycle, size % layout.bytes_per_cycle


def read_cycles(path: str | Path, layout: Layout, first: int, count: int, rx: int) -> np.ndarray:
    """Receiver `rx`'s samples of cycles [first, first + count): int16 (count, n_chirps, n_samples[, 2])."""
    words = np.fromfile(path, dtype="<i2", count=count * layout.bytes_per_cycle // 2,
                        offset=first * layout.bytes_per_cycle)
    return np.ascontiguousarray(decode(words, layout)[:, :, rx])
