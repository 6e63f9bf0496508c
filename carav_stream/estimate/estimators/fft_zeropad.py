"""fft_zeropad: a zero-padded grid (estimate's `zeropad` x in range, 4 x in Doppler) and the parabolic vertex of
|RD| through the strongest cell and its neighbours, in range and in Doppler apart:

    f = (k0 + delta(|RD[l0, k0-1]|, |RD[l0, k0]|, |RD[l0, k0+1]|)) / nr,   nu likewise along l, over md
    delta(a, b, c) = (a - c) / (2 (a - 2 b + c)), clipped to [-1/2, 1/2]

The parabola on a magnitude is biased on a padded grid at high SNR. Targets listed elsewhere (refine_at) get the
interpolated start of fft_interp.
"""
import numpy as np

from carav_stream.estimate import spectral
from carav_stream.estimate.estimators import _grid
from carav_stream.estimate.estimators._method import Method

DOPPLER_PAD = 4


class FftZeropad(Method):
    order = 1
    range_words = '8x zero-padded range FFT, parabolic vertex of the magnitude'
    velocity_words = '4x padded Doppler, parabolic'

    def padding(self, zeropad: int) -> tuple[int, int]:
        return zeropad, DOPPLER_PAD

    def locate(self, spec, chirps, l0, k0, n_samp: int, nr: int, md: int):
        nb = spec.shape[-1]
        k3 = np.concatenate([np.clip(k0 - 1, 0, nb - 1), k0, np.clip(k0 + 1, 0, nb - 1), k0, k0], axis=1)
        l3 = np.concatenate([l0, l0, l0, l0 - 1, l0 + 1], axis=1)
        mag = np.abs(_grid.cells(spec, chirps, l3, k3, md))
        f = k0 / nr + spectral.parabolic_delta(mag[:, 0:1], mag[:, 1:2], mag[:, 2:3]) / nr
        nu = l0 / md + spectral.parabolic_delta(mag[:, 3:4], mag[:, 1:2], mag[:, 4:5]) / md
        return f, nu, mag[:, 1:2]
