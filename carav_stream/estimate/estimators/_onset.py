"""Where each target's echo starts in the window: the echo model of the refining methods (ml, music, root_music).

A chirp's echo is in the window from its round trip on (Geometry.echo_onset: sample n0 = ceil((tau - t_adc) fs),
tau = 2 R / c); the samples before n0 hold none of it. A target found at beat f [cycles/sample] and Doppler nu
[cycles/chirp] has its round trip at tau = 2 R / c, R its range with the Doppler part of the beat taken out (a fifth
of a sample on table1 at 50 m/s), and the refining methods model its echo as a tone (and, for real samples, its
image) from that onset on, the others' likewise from theirs:

    x[m, n] = sum_k [n >= n0_k] (a_k e^{j 2 pi (f_k n + nu_k m)} + conj(a_k) e^{-j ..} for real samples) + noise

Why the samples from the onset on rather than the whole window with a gate in each closed form: in white noise a
sample without the echo carries no information on its frequency, so the estimate loses nothing, and from its onset
on the echo is again a whole tone, for which the closed forms of the image (joint.py, _relax), the Fisher scoring of
joint.py and the signal subspace of MUSIC (one vector a tone, two with its image) hold as they are. Modelled over the
whole window instead, the image of real samples is cancelled where there is none: the residual is a tone at -f over
the first n0 samples whose phase there, not the noise, sets the error (tens of times the bound for the table1 car at
high SNR; tests/estimate/test_chain_accuracy.py holds the methods near it).

A target is read from MARGIN_SAMPLES past its onset (`read`; its echo is modelled, and cancelled from the others'
samples, from the onset itself: `echo`). The receiver's anti-alias (IF) filter smears the echo's onset over its
impulse response (the waveform fidelity's FIR: +-16 samples, most of its step within 8), so the first samples hold a
partial echo that a tone does not fit (ml with I/Q samples on the table1 car 20 dB above its SNR: a bias of 0.6
times the bound read from the onset itself, none from 8 samples on), and an error of the start's beat (a fraction
of a bin: a fraction of a sample of round trip) must not put a sample without the echo into the model. The bound's
standard deviation grows as (N - n0)^-3/2: 8 of table1's 1052 samples left out make it 1.2 % larger. Reading starts
at half the window at the latest (an echo that arrives later is read from there; the scene warns of such a target:
most of its samples hold nothing), which keeps every method's sums, and MUSIC's subvectors of a quarter of the
window, on at least half of it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.estimate.geometry import Geometry

MARGIN_SAMPLES = 8


@dataclass(frozen=True)
class Onsets:
    """Where the targets' echoes start, each int64 (C, K) [samples]:

    echo  the first sample at or after the round trip, within [0, N]: where a target's echo is modelled (cancelled)
    read  MARGIN_SAMPLES later, within [0, N // 2]: the first sample read to estimate the target
    """

    echo: np.ndarray
    read: np.ndarray

    @classmethod
    def none(cls, shape) -> Onsets:
        """Echoes that fill the window: every sample holds and reads them."""
        zero = np.zeros(shape, dtype=np.int64)
        return cls(zero, zero)


def onsets(f, nu, geometry: Geometry) -> Onsets:
    """The Onsets of targets at beats f [cycles/sample] and chirp-to-chirp phase progressions nu [cycles/chirp],
    each (C, K): round trips from their ranges, the Doppler part of the beat taken out."""
    # 2 R / c = (f_b - 2 v / lambda) / S, and 2 v / lambda = nu / (T_c doppler_scale) (Geometry's conversions)
    doppler_hz = ((np.asarray(nu, dtype=float) + 0.5) % 1.0 - 0.5) / (geometry.t_chirp_s * geometry.doppler_scale)
    beat_hz = (np.asarray(f, dtype=float) % 1.0) * geometry.fs_hz
    late = ((beat_hz - doppler_hz) / geometry.slope_hz_per_s - geometry.t_adc_start_s) * geometry.fs_hz
    n_samp = geometry.n_samples
    return Onsets(echo=np.clip(np.ceil(late), 0, n_samp).astype(np.int64),
                  read=np.clip(np.ceil(late + MARGIN_SAMPLES), 0, n_samp // 2).astype(np.int64))


def gates(onset, n_samp: int):
    """float64 (..., N): 1 from each onset (...) on, 0 before it."""
    return (np.arange(n_samp) >= np.asarray(onset)[..., None]).astype(float)
