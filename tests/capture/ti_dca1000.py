"""A DCA1000 capture writer for the tests, written from TI's description of the raw-capture layouts (the
DCA1000EVM user guide, the raw ADC capture application note SWRA581 and TI's reading scripts), sample by sample,
independently of the vectorised reader in carav_stream/capture/dca1000.py:

  chirp after chirp.
  2 LVDS lanes (xWR16xx): within a chirp, receiver after receiver; within a receiver, its samples in order.
      Real data: one word per sample. Complex data: lane 1 carries sample n, lane 2 sample n + 1, and each pair
      is sent as I(n), I(n+1), Q(n), Q(n+1).
  4 LVDS lanes (xWR12xx/14xx): one receiver per lane, the four lanes always present (unused lanes are zeros);
      within a chirp, sample after sample. Real data: sample n of lanes 1..4. Complex data: I(n) of lanes 1..4,
      then Q(n) of lanes 1..4.
  A 12- or 14-bit ADC's codes are stored in its own bits, without sign extension; offset binary stores the code
  plus 2^(bits-1) (its top bit inverted).
"""
from __future__ import annotations

import struct

import numpy as np


def capture_bytes(samples: np.ndarray, complex_data: bool, adc_bits: int = 16, lanes: int = 2,
                  encoding: str = "twos_complement") -> bytes:
    """samples: codes (chirps, n_rx, n_samples) for real data, (chirps, n_rx, n_samples, 2) I, Q for complex."""
    words: list[int] = []
    for chirp in samples:
        if lanes == 2:
            stream = [s for receiver in chirp for s in receiver]       # receiver after receiver
            if not complex_data:
                words += [int(v) for v in stream]
            else:
                for n in range(0, len(stream), 2):
                    first, second = stream[n], stream[n + 1]
                    words += [int(first[0]), int(second[0]), int(first[1]), int(second[1])]
        else:
            n_rx, n_samples = len(chirp), len(chirp[0])
            for n in range(n_samples):
                lane = [chirp[r][n] if r < n_rx else (np.zeros(2, np.int16) if complex_data else 0)
                        for r in range(4)]
                if not complex_data:
                    words += [int(v) for v in lane]
                else:
                    words += [int(v[0]) for v in lane] + [int(v[1]) for v in lane]
    mask = 2 ** adc_bits - 1
    if encoding == "offset_binary":
        words = [(w + 2 ** (adc_bits - 1)) & mask for w in words]      # code + 2^(b-1), in the ADC's bits
    elif adc_bits < 16:
        words = [w & mask for w in words]                              # the code's own bits, no sign extension
    return struct.pack(f"<{len(words)}H", *[w & 0xFFFF for w in words])
