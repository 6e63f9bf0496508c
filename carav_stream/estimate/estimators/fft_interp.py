"""fft_interp: the interpolated start of the strongest cell taken as the answer (_grid.start, 8 x padding):

    nu  parabolic vertex of |RD| along the peak's range bin on an 8 x zero-padded Doppler FFT
    f   Candan's bias-corrected three-bin interpolation in range at that Doppler

It sits a roughly constant factor above the Cramer-Rao bound in range, less in velocity.
"""
from carav_stream.estimate.estimators._method import Method


class FftInterp(Method):
    order = 2
    range_words = "Candan's bias-corrected 3-bin estimator on the FFT row"
    velocity_words = "8x padded FFT of the peak's slow-time column, parabolic"
