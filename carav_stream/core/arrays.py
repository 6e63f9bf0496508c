"""The virtual array of a TDM-MIMO radar, one formula for the scenes (radar/) and the angle kernels (estimate/).

Slot j of a TDM loop is fired by transmitter schedule[j]; slot j heard on receiver r is the virtual element at

    x_{j n_rx + r} = tx_positions_wl[schedule[j]] + rx_positions_wl[r]      (wavelengths, slot-major)
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def virtual_positions(tx_positions_wl: Sequence[float], rx_positions_wl: Sequence[float],
                      schedule: Sequence[int]) -> np.ndarray:
    """float64 (len(schedule) * len(rx_positions_wl),): the virtual elements' positions, slot-major."""
    tx = np.asarray(tx_positions_wl, dtype=np.float64)[list(schedule)]
    return (tx[:, None] + np.asarray(rx_positions_wl, dtype=np.float64)[None, :]).ravel()
