"""A DCA1000 capture writer for the tests, written from TI's description of the xWR16xx raw-capture layout (the
DCA1000EVM raw ADC capture application note, SWRA581, and its reading script), sample by sample, independently
of the vectorised reader in carav_stream/capture/dca1000.py:

  chirp after chirp; within a chirp, receiver after receiver; within a receiver, its samples in order.
  Real data: one int16 word per sample. Complex data over the two LVDS lanes: lane 1 carries sample n, lane 2
  sample n + 1, and each pair is sent as I(n), I(n+1), Q(n), Q(n+1).
  A 12- or 14-bit ADC's codes are stored in its own bits, without sign extension.
"""
from __future__ import annotations

import struct

import numpy as np


def capture_bytes(samples: np.ndarray, complex_data: bool, adc_bits: int = 16) -> bytes:
    """samples: codes (chirps, n_rx, n_samples) for real data, (chirps, n_rx, n_samples, 2) I, Q for complex."""
    words: list[int] = []
    for chirp in samples:
        stream = [s for receiver in chirp for s in receiver]       # receiver after receiver
        if not complex_data:
            words += [int(v) for v in stream]
        else:
            for n in range(0, len(stream), 2):
                first, second = stream[n], stream[n + 1]
                words += [int(first[0]), int(second[0]), int(first[1]), int(second[1])]
    if adc_bits < 16:
        words = [w & (2 ** adc_bits - 1) for w in words]           # the code's own bits, no sign extension
    return struct.pack(f"<{len(words)}h", *words)
