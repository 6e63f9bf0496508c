"""Joint Newton refinement of one tone's beat and Doppler on the 2-D periodogram, one pass over the samples a step.

Per cycle (A active chirps at times t_a, N samples, centred times n' = n - (N-1)/2, t' = t - (M-1)/2):

    S_pq(f, nu) = sum_a t'_a^q exp(-j 2 pi nu t'_a) Z_p[a],    Z_p[a] = sum_n x[a, n] n'^p exp(-j 2 pi f n')
    P(f, nu)    = |S_00|^2,   dS/df = -j 2 pi S_10,  d2S/df dnu = -4 pi^2 S_11,  ...

The per-chirp moments Z_0, Z_1 come from one single-precision matrix product per cycle (the samples against the 4
real columns cos, -sin times 1, n'), so a step reads the samples once; everything after it is on (C, A) arrays.
Real (I-only) samples x = a e^{+j..} + conj(a) e^{-j..} hold the target's image at (-f, -nu): its contribution
conj(a) F_p(2f) G_q(2 nu) (F_p = sum_n n'^p e^{-j 2 pi 2f n'}, G_q the same over the active chirp times) is removed
from every S_pq in closed form, a solved from S_00 = a N A + conj(a) F_0 G_0.

The step is Newton's on the 2-D Hessian where it is negative definite, otherwise per dimension as
spectral.newton_refine (a 1-D Newton step where that direction is concave, else a gradient step of a quarter of
the largest), clipped to half a bin (0.5 / N in beat, 0.5 / M in Doppler). The Hessian's beat curvature takes S_20
at its expectation for a tone at f, S_00 (N^2 - 1) / 12 (Fisher scoring in beat): the observed S_20 would need two
more columns, a third more work in the pass over the samples, for the same fixed point (grad P = 0) and, from an
interpolated start a fraction of a bin away, the same error after one step (docs/bench/estimators.md). Slow time,
where the active chirps are irregular, keeps the observed curvature (it costs nothing: (C, A) arrays).

Every product and sum is within one cycle (matmul over the stack of cycles, reductions along a cycle's own axes):
a cycle's result does not depend on the batch it came in.

An echo read from sample r_c of cycle c on (`read`: its window starts after its round trip, estimators/_onset.py)
is the same tone over N - r_c samples: the fast-time sums run from r_c on, with the time origin at their middle
(n' = n - (N - 1 + r_c) / 2), and k, the beat curvature's (N^2 - 1) / 12 and the step's clip use N - r_c; the
samples before r_c weigh zero in the one product, so cycles of any read starts go through it together.
"""
from __future__ import annotations

import functools

import numpy as np

from carav_stream.estimate import spectral

__all__ = ["fast_time_moments", "refine_tone"]


@functools.lru_cache(maxsize=16)
def _powers(n_len: int, n_orders: int, dtype=float, columns: bool = False):
    """n'^p for n' = n - (n_len - 1) / 2, p = 0..n_orders-1: read-only (n_orders, n_len) of dtype, or
    (n_len, n_orders) with columns."""
    t = np.arange(n_len) - 0.5 * (n_len - 1)
    out = np.empty((n_orders, n_len))
    out[0] = 1.0
    for p in range(1, n_orders):
        out[p] = out[p - 1] * t
    out = np.ascontiguousarray(out.T if columns else out, dtype=dtype)
    out.flags.writeable = False
    return out


def fast_time_moments(x, f, order: int = 2, read=None):
    """(Z, e): Z[c, p, a] = sum_{n >= r_c} x[c, a, n] n'^p exp(-j 2 pi f_c n') complex128 (C, order + 1, A), and the
    phasor e[c, n] = exp(-j 2 pi f_c n') complex128 (C, N), zero before r_c; n' = n - (N - 1 + r_c) / 2.

    x  float32 or complex64 (C, A, N); f float (C,) [cycles/sample]; read None (r = 0) or int (C,): each cycle's
    first sample. Single-precision products (the data's precision) from one real matrix product per cycle: complex
    samples are read as interleaved (re, im) pairs."""
    n_cycles, n_rows, n_samp = x.shape
    e = spectral.phasor(f, n_samp, origin=0.5 * (n_samp - 1))  # (C, N)
    n_centred = _powers(n_samp, 2, np.float32)[1]
    if read is not None:               # the origin at the middle of n >= r: shift it, and weigh the rest zero
        half = 0.5 * np.asarray(read, dtype=float)
        e = e * np.exp((2j * np.pi) * f * half)[:, None] * (np.arange(n_samp) >= read[:, None])
        n_centred = (n_centred - half[:, None].astype(np.float32))[:, None, :]       # (C, 1, N)
    if np.iscomplexobj(x):
        # sum (xr + j xi)(c - j s) n'^p: the xr samples weigh (c, -s), the xi samples (s, c)
        w = np.empty((n_cycles, 2, order + 1, n_samp, 2), dtype=np.float32)
        w[:, 0, 0, :, 0] = e.real
        w[:, 1, 0, :, 0] = e.imag
        for p in range(order):
            np.multiply(w[:, :, p, :, 0], n_centred, out=w[:, :, p + 1, :, 0])
        np.negative(w[:, 1, :, :, 0], out=w[:, 0, :, :, 1])
        w[:, 1, :, :, 1] = w[:, 0, :, :, 0]
        w = w.reshape(n_cycles, 2 * (order + 1), 2 * n_samp)
        x = x.view(np.float32)
    else:
        w = np.empty((n_cycles, 2, order + 1, n_samp), dtype=np.float32)
        w[:, 0, 0] = e.real   # cos
        w[:, 1, 0] = e.imag   # -sin
        for p in range(order):
            np.multiply(w[:, :, p], n_centred, out=w[:, :, p + 1])
        w = w.reshape(n_cycles, 2 * (order + 1), n_samp)
    r = np.matmul(w, np.swapaxes(x, 1, 2))  # (C, 2P, A) float32: a product per cycle, none across cycles
    z = np.empty((n_cycles, order + 1, n_rows), dtype=complex)
    z.real = r[:, :order + 1]
    z.imag = r[:, order + 1:]
    return z, e


def _sums(x, f, nu, t, tq, iq: bool, k, read=None):
    """S[c, p, q] = S_pq(f, nu) (C, 2, Q), p = 0, 1 (fast time), Q = tq.shape[1] (slow time), with the image removed
    for real samples (then S_00 = a k, a the tone's complex amplitude). t (C, A): centred chirp times; tq (C, Q, A):
    t'^q on active rows, 0 on padding rows (q = 0: the mask); k (C,): the samples read times the active chirps;
    read: None or each cycle's first sample (C,)."""
    z, e = fast_time_moments(x, f, 1, read)  # (C, 2, A)
    em = np.exp((-2j * np.pi) * (nu[:, None] * t))  # (C, A)
    wq = np.swapaxes(em[:, None, :] * tq, 1, 2)  # (C, A, Q)
    s = np.matmul(z, wq)  # (C, 2, Q): a product per cycle
    if iq:
        return s
    # the image conj(a) exp(-j 2 pi (f n' + nu t')) adds conj(a) F_p(2 f) G_q(2 nu) to S_pq; a from
    # S_00 = a k + conj(a) F_0 G_0
    if read is None:
        fm = np.matmul(np.square(e)[:, None, :], _powers(e.shape[-1], 2, complex, True))[:, 0]  # (C, 2): per cycle
    else:               # e is zero before each read start; n' from the middle of the samples read
        e2 = np.square(e)
        n_mid = np.arange(e.shape[-1]) - 0.5 * (e.shape[-1] - 1 + np.asarray(read, dtype=float))[:, None]
        fm = np.stack((e2.sum(axis=1), (e2 * n_mid).sum(axis=1)), axis=1)
    gm = np.matmul(em[:, None, :], wq)[:, 0]  # (C, Q): sum_a em^2 t'^q
    b = fm[:, 0] * gm[:, 0]
    a = (k * s[:, 0, 0] - b * np.conj(s[:, 0, 0])) / (k * k - np.abs(b) ** 2)
    return s - np.conj(a)[:, None, None] * fm[:, :, None] * gm[:, None, :]


def refine_tone(x, index, mask, n_chirps: int, f, nu, *, iq: bool, n_iter: int = 1, read=None):
    """One tone per cycle refined jointly in beat f and Doppler nu: (f, nu, amplitude) each float (C,).

    x       float32 or complex64 (C, A, N): the active chirps of each cycle (rows past its count are zero)
    index   int (C, A): chirp number of each row; mask bool (C, A): the row holds an active chirp
    f, nu   float (C,): start [cycles/sample], [cycles/chirp] (within a fraction of a bin: an interpolated peak)
    n_iter  Newton steps (each one pass over x)
    read    None, or int (C,): the first sample of each cycle's tone (module docstring)
    Amplitude: |a| of the tone a e^{j..} per sample (normalised units), from the second-order expansion of S_00
    about the last step's start (the periodogram is not evaluated again at the result)."""
    n_samp = x.shape[-1] if read is None else (x.shape[-1] - np.asarray(read)).astype(float)
    m = mask.astype(float)
    t = (index - 0.5 * (n_chirps - 1)) * m  # centred chirp times, 0 on padding rows
    tq = np.stack((m, t, t * t), axis=1)  # (C, 3, A)
    count = mask.sum(axis=1)
    k = n_samp * np.maximum(count, 1).astype(float)
    no_doppler = count < 2  # one chirp: P is flat in nu (velocity unknown); no step there
    f, nu = np.asarray(f, dtype=float), np.asarray(nu, dtype=float)
    s_end = np.full(f.shape, np.nan)
    for _ in range(n_iter):
        s = _sums(x, f, nu, t, tq, iq, k, read)
        step_f, step_v, s_end = _newton_step(s, n_samp, n_chirps, no_doppler)
        f, nu = f + step_f, nu + step_v
    return f, nu, np.abs(s_end) / k


_W = 2.0 * np.pi


def _newton_step(s, n_samp, n_chirps: int, no_doppler):
    """(step in beat, step in Doppler, S_00 at the step by its second-order expansion), each (C,): a safeguarded
    Newton step on P = |S_00|^2 from the moments s (C, 2, 3); in beat alone where no_doppler (C,) bool; n_samp the
    samples read, an int or per cycle (C,).

    With d^(p+q) S / df^p dnu^q = (-j w)^(p+q) S_pq, w = 2 pi:
        grad P = 2 w Im(conj(S) [S_10, S_01]),
        Hess P = 2 w^2 [[|S_10|^2 - Re(conj(S) S_20), Re(conj(S_10) S_01 - conj(S) S_11)],
                        [.,                            |S_01|^2 - Re(conj(S) S_02)]]
    with S_20 at its expectation S_00 (N^2 - 1) / 12 (see the module's note)."""
    c = (n_samp * n_samp - 1) / 12.0
    s00, s10, s01, s11, s02 = s[:, 0, 0], s[:, 1, 0], s[:, 0, 1], s[:, 1, 1], s[:, 0, 2]
    u = np.conj(s00)[:, None] * s.reshape(len(s00), -1)  # conj(S) S_pq, (C, 6) in the order of s[:, p, q]
    power = u[:, 0].real
    g_f, g_v = u[:, 3].imag, u[:, 1].imag  # grad P / (2 w)
    h_ff = (s10.real ** 2 + s10.imag ** 2) - c * power  # Hess P / (2 w^2)
    h_vv = (s01.real ** 2 + s01.imag ** 2) - u[:, 2].real
    h_fv = (np.conj(s10) * s01).real - u[:, 4].real
    det = h_ff * h_vv - h_fv * h_fv
    joint = (h_ff < 0) & (det > 0) & ~no_doppler  # negative definite: the 2-D Newton step
    max_f, max_v = 0.5 / n_samp, 0.5 / n_chirps
    num_f, num_v = h_fv * g_v - h_vv * g_f, h_fv * g_f - h_ff * g_v
    if joint.all():  # the usual case; the same arithmetic per cycle as below
        step_f, step_v = num_f / (det * _W), num_v / (det * _W)
    else:
        safe = np.where(joint, det, 1.0) * _W
        # elsewhere per dimension: Newton where that direction is concave, else a gradient step of a quarter of the
        # largest
        step_f = np.where(joint, num_f / safe, np.where(
            h_ff < 0, -g_f / (_W * np.where(h_ff < 0, h_ff, -1.0)), np.sign(g_f) * (0.25 * max_f)))
        step_v = np.where(joint, num_v / safe, np.where(
            h_vv < 0, -g_v / (_W * np.where(h_vv < 0, h_vv, -1.0)), np.sign(g_v) * (0.25 * max_v)))
        step_v[no_doppler] = 0.0
    step_f = np.minimum(np.maximum(step_f, -max_f), max_f)  # ufuncs: np.clip's dispatch costs more on (C,)
    step_v = np.minimum(np.maximum(step_v, -max_v), max_v)
    s_end = s00 - (1j * _W) * (s10 * step_f + s01 * step_v) - (0.5 * _W * _W) * (
        (c * s00) * step_f ** 2 + 2.0 * s11 * step_f * step_v + s02 * step_v ** 2)
    return step_f, step_v, s_end
