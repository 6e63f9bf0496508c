"""music: the interpolated start (_grid.start), then the beat from the MUSIC pseudo-spectrum of the
Doppler-compensated coherent sum over the active chirps (forward-backward smoothed covariance, subvector length
L), on a fine grid of +-1 FFT bin around the start, parabolic vertex; the Doppler by Newton steps on the
non-uniform slow-time periodogram at that beat, the other targets and the images of real samples cancelled
(_subspace, _relax).
"""
from carav_stream.estimate.estimators._method import Method
from carav_stream.estimate.estimators._subspace import refine_music


class Music(Method):
    order = 3

    def refine(self, x, chirps, f, nu, *, n_newton: int, music_length: int | None, iq: bool, onset=None):
        return refine_music(x, chirps, f, nu, root=False, n_newton=n_newton, music_length=music_length, iq=iq,
                            onset=onset)
