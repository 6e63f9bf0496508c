"""music: the interpolated start (_grid.start), then the beat from MUSIC on the Doppler-compensated coherent sum over
the active chirps read from the echo's onset on (forward-backward smoothed covariance of subvectors a quarter of the
window long, its signal subspace by subspace iteration, Newton steps on the signal-subspace form of the
pseudo-spectrum: _subspace); the Doppler by Newton steps on the non-uniform slow-time periodogram at that beat, the
other targets and the images of real samples cancelled (_relax).
"""
from carav_stream.estimate.estimators._method import Method
from carav_stream.estimate.estimators._subspace import refine_music


class Music(Method):
    order = 3
    range_words = ("same coherent sum from the echo's onset on, forward-backward smoothed covariance of subvectors a"
                   ' quarter of the window long (L = N/4), its signal subspace by subspace iteration from the '
                   "targets' steering vectors (FFT correlations: the L x L covariance is never formed), Newton steps"
                   " on ||E_s^H a(f)||^2 (the pseudo-spectrum's peak)")
    velocity_words = 'as `ml`'

    def refine(self, x, chirps, f, nu, *, n_newton: int, music_length: int | None, iq: bool, onset=None):
        return refine_music(x, chirps, f, nu, root=False, n_newton=n_newton, music_length=music_length, iq=iq,
                            onset=onset)
