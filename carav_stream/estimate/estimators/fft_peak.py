"""fft_peak: the strongest cell of the range-Doppler map, at its bin centres.

    f = k0 / nr,   nu = l0 / md        (l0, k0) the cell of the largest |RD|

Its error is the grid's, about bin / sqrt(12) whatever the SNR. Targets listed elsewhere (refine_at) keep their
cells.
"""
import numpy as np

from carav_stream.estimate.estimators import _grid
from carav_stream.estimate.estimators._method import Method


class FftPeak(Method):
    order = 0
    range_words = 'grid cell'
    velocity_words = 'grid cell'
    start_pad = None

    def locate(self, spec, chirps, l0, k0, n_samp: int, nr: int, md: int):
        return k0 / nr, l0 / md, np.abs(_grid.cells(spec, chirps, l0, k0, md))
