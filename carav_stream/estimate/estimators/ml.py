"""ml: maximum likelihood, the maximiser of the 2-D periodogram

    |sum_{m active} sum_n x[m, n] exp(-j 2 pi (f n + nu m))|^2

from the interpolated start (_grid.start at 2 x Doppler padding: a start, not the answer), by safeguarded Newton
steps. One target: joint steps in (f, nu), each one pass over the samples (per-chirp DTFT moments, then sums over
the active chirp times; estimate/joint.py), the image of real samples removed in closed form. Several targets:
alternating steps, Doppler-compensated coherent integration over the active chirps for the beat f and the
non-uniform slow-time periodogram (sparse chirp times) for nu, the others and the images removed by RELAX-style
cancellation (_relax).
"""
from carav_stream.estimate import joint, spectral
from carav_stream.estimate.estimators import _relax
from carav_stream.estimate.estimators._method import Method


class Ml(Method):
    order = 5
    start_pad = 2

    def refine(self, x, chirps, f, nu, *, n_newton: int, music_length: int | None, iq: bool):
        if f.shape[1] == 1:
            # one target: joint Newton steps on the 2-D periodogram, one pass over the samples each (joint.py)
            f1, nu1, a1 = joint.refine_tone(x, chirps.index, chirps.mask, chirps.n_chirps, f[:, 0], nu[:, 0],
                                            iq=iq, n_iter=n_newton)
            return f1[:, None], nu1[:, None], a1[:, None]
        return _relax.refine(x, chirps, f, nu, lambda y, f0: spectral.newton_refine(y, f0, n_iter=n_newton),
                             n_newton, iq)
