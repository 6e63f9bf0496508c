"""ml: maximum likelihood, the maximiser of the 2-D periodogram

    |sum_{m active} sum_{n >= r} x[m, n] exp(-j 2 pi (f n + nu m))|^2        r the first sample read (_onset)

from the interpolated start (_grid.start at 2 x Doppler padding: a start, not the answer), by safeguarded Newton
steps. One target: joint steps in (f, nu), each one pass over the samples read (per-chirp DTFT moments, then sums
over the active chirp times; estimate/joint.py on the window cut at r, cycles of equal r together), the image of
real samples removed in closed form; a cycle whose last beat step was large takes more (_refine_one). Several
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
    all) (joint.py), the cycles of each read start together on their window cut there (the beat f is the same on
    the cut window, its phase origin moved).

    After n_newton steps, a cycle whose last beat step exceeded STEP_BINS takes up to EXTRA_STEPS more: its start was
    that far off (a late echo's: the start interpolates the whole window's spectrum, where a tone cut 20 % of the way
    in is up to 0.11 bin off, 40 % in 0.25), and a step leaves about 4 step^2 [bins] behind (0.01 bin: 0.4 mm on
    table1, 1.5 times its bound 20 dB above its SNR). Each cycle's steps depend on its own samples alone."""
    n0 = np.zeros(f.shape[0], dtype=np.int64) if read is None else read
    out = np.empty((3, f.shape[0]))
    alike = not n0.size or (n0 == n0[0]).all()                    # the usual batch: one target, one onset
    for start in n0[:1] if alike else np.unique(n0):
        rows = np.arange(n0.size) if alike else np.flatnonzero(n0 == start)
        part = x if rows.size == x.shape[0] else x[rows]
        part = np.ascontiguousarray(part[..., start:]) if start else part
        index, mask = chirps.index[rows], chirps.mask[rows]
        fr, nur = f[rows, 0], nu[rows, 0]
        active = np.arange(rows.size)
        for i in range(n_newton + EXTRA_STEPS):
            before = fr[active]
            fr[active], nur[active], amp = joint.refine_tone(part[active] if active.size < rows.size else part,
                                                             index[active], mask[active], chirps.n_chirps,
                                                             fr[active], nur[active], iq=iq, n_iter=1)
            out[2, rows[active]] = amp
            if i + 1 >= n_newton:       # the steps asked for are taken: only cycles still far go on
                active = active[np.abs(fr[active] - before) * part.shape[-1] > STEP_BINS]
                if not active.size:
                    break
        out[0, rows], out[1, rows] = fr, nur
    return out[0][:, None], out[1][:, None], out[2][:, None]
