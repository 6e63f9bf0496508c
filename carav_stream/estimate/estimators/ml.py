"""ml: maximum likelihood, the maximiser of the 2-D periodogram

    |sum_{m active} sum_{n >= r} x[m, n] exp(-j 2 pi (f n + nu m))|^2        r the first sample read (_onset)

from the interpolated start (_grid.start at 2 x Doppler padding: a start, not the answer), by safeguarded Newton
steps. One target: joint steps in (f, nu), each one pass over the samples read (per-chirp DTFT moments, then sums
over the active chirp times; estimate/joint.py from each cycle's r on), the image of real samples removed in closed
form; a cut cycle whose last beat step was large takes more (_refine_one). Several
targets: alternating steps, Doppler-compensated coherent integration over the active chirps for the beat f and the
non-uniform slow-time periodogram (sparse chirp times) for nu, the others and the images removed by RELAX-style
cancellation (_relax).
"""
import numpy as np

from carav_stream.estimate import joint, spectral
from carav_stream.estimate.estimators import _onset, _relax
from carav_stream.estimate.estimators._method import Method

STEP_BINS = 0.005    # a beat step [bins of the cut window] past which the next one is taken too
EXTRA_STEPS = 2
CUT_FRACTION = 0.04  # ... where the window is cut by more than this fraction


class Ml(Method):
    order = 5
    range_words = ("start: Candan across the three range bins at the start's Doppler cell; one target: one joint "
                   "Newton step in (beat, Doppler) on the 2-D periodogram of the samples from the echo's onset on "
                   '(more for a cycle whose step was large); several: alternating steps on the periodogram of the '
                   'Doppler-compensated coherent sum over the active chirps')
    velocity_words = ("start: parabolic vertex on a 2x padded FFT of the peak's slow-time column; then the joint step, "
                      'or (several targets) Newton on the non-uniform slow-time periodogram of the per-chirp DTFT at '
                      'the refined beat')
    start_pad = 2

    def refine(self, x, chirps, f, nu, *, n_newton: int, music_length: int | None, iq: bool,
               onset: _onset.Onsets | None = None):
        if f.shape[1] == 1:
            return _refine_one(x, chirps, f, nu, n_newton, iq, None if onset is None else onset.read[:, 0])

        def beat(y, f_now, k, read):
            return spectral.newton_refine(y * _onset.gates(read, y.shape[-1]), f_now[:, k], n_iter=n_newton)

        return _relax.refine(x, chirps, f, nu, beat, n_newton, iq, onset)


def _refine_one(x, chirps, f, nu, n_newton: int, iq: bool, read):
    """One target: joint Newton steps on the 2-D periodogram of the samples read for it, from read (C,) on (None:
    all; joint.py, every cycle in the one product whatever its read start).

    Where more than CUT_FRACTION of the window is cut, a cycle whose last beat step exceeded STEP_BINS takes up to
    EXTRA_STEPS more after the n_newton steps: the start interpolates the whole window's spectrum, where a tone cut
    20 % of the way in is up to 0.11 bin off (40 % in, 0.25; 2.5 %, the table1 car's, 0.0024), and a step leaves
    about 4 step^2 [bins] behind (0.01 bin: 0.4 mm on table1, 1.5 times its bound 20 dB above its SNR). Below that
    cut the start's error is the noise's, and a step's residue far below it. Each cycle's steps depend on its own
    samples alone."""
    if read is not None and not read.any():
        read = None                                   # the echoes fill the window: the plain sums
    fr, nur, amp = f[:, 0].copy(), nu[:, 0].copy(), np.empty(f.shape[0])
    active = np.arange(f.shape[0])
    for i in range(n_newton + (EXTRA_STEPS if read is not None else 0)):
        before, every = fr[active], active.size == f.shape[0]
        fr[active], nur[active], amp[active] = joint.refine_tone(
            x if every else x[active], chirps.index[active], chirps.mask[active], chirps.n_chirps, before,
            nur[active], iq=iq, n_iter=1, read=None if read is None else read[active])
        if read is not None and i + 1 >= n_newton:      # the steps asked for are taken: cut cycles still far go on
            n_read = x.shape[-1] - read[active]
            far = (np.abs(fr[active] - before) * n_read > STEP_BINS) & (read[active] > CUT_FRACTION * x.shape[-1])
            active = active[far]
            if not active.size:
                break
    return fr[:, None], nur[:, None], amp[:, None]
