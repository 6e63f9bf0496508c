"""root_music: as music, the beat from the roots of the root-MUSIC polynomial nearest the start instead of a
pseudo-spectrum's peak (model order doubled for real I-only samples: each tone and its image).
"""
from carav_stream.estimate.estimators._method import Method
from carav_stream.estimate.estimators._subspace import refine_music


class RootMusic(Method):
    order = 4
    range_words = ('same covariance with L = min(N/4, 32), formed, its eigenvectors, the root of the root-MUSIC '
                   'polynomial (2L-2 degree, companion matrices eigenvalues, vectorised) nearest the start')
    velocity_words = 'as `ml`'

    def refine(self, x, chirps, f, nu, *, n_newton: int, music_length: int | None, iq: bool, onset=None):
        return refine_music(x, chirps, f, nu, root=True, n_newton=n_newton, music_length=music_length, iq=iq,
                            onset=onset)
