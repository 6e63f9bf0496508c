"""The beat stage of the subspace methods (music, root_music): (root-)MUSIC on the Doppler-compensated coherent sum
over the active chirps, forward-backward smoothed covariance of subvector length L; the Doppler stage is ml's
(_relax). Model order K for I/Q samples, 2K for real (I-only) ones (each tone and its image)."""
from __future__ import annotations

import numpy as np

from carav_stream.estimate import spectral
from carav_stream.estimate.estimators import _relax
from carav_stream.estimate.estimators._common import Chirps

N_GRID = 129    # points of the pseudo-spectrum's grid over +-1 FFT bin around the start


def music_beat(y, f_init, n_model: int, length: int, root: bool, n_bins: int):
    """Beat [cycles/sample] nearest f_init from (root-)MUSIC on y (C, N)."""
    cov = spectral.fb_covariance(y, length)
    _, sig = spectral.subspaces(cov, n_model)
    if root:
        cand, _ = spectral.root_music_roots(sig, n_model)
        d = (cand - f_init[:, None] + 0.5) % 1.0 - 0.5
        pick = np.argmin(np.abs(d), axis=1)
        return f_init + np.take_along_axis(d, pick[:, None], axis=1)[:, 0]
    # spectral MUSIC on a fine grid of +-1 FFT bin around the interpolated peak, then a parabolic vertex
    offs = np.linspace(-1.0, 1.0, N_GRID) / n_bins
    grid = f_init[:, None] + offs  # (C, G)
    a = np.exp(2j * np.pi * grid[:, :, None] * np.arange(length))  # (C, G, L)
    proj = np.abs(np.matmul(a, sig.conj())) ** 2  # (C, G, K)  |e^H a|^2 = |a^T e*|^2
    pseudo = 1.0 / np.maximum(length - proj.sum(axis=-1), length * 1e-15)
    k = np.clip(np.argmax(pseudo, axis=1), 1, N_GRID - 2)
    lp = np.log(np.take_along_axis(pseudo, np.stack([k - 1, k, k + 1], axis=1), axis=1))
    delta = spectral.parabolic_delta(lp[:, 0], lp[:, 1], lp[:, 2])
    return f_init + (offs[k] + delta * (offs[1] - offs[0]))


def refine_music(x, chirps: Chirps, f, nu, *, root: bool, n_newton: int, music_length: int | None, iq: bool):
    """(f, nu, amp), each (C, K), refined from (f, nu): beat by (root-)MUSIC with subvector length music_length
    (default min(N // 4, 32)), Doppler by Newton steps, the other targets and the images cancelled."""
    n_samp = x.shape[-1]
    length = music_length or int(min(n_samp // 4, 32))
    n_model = (1 if iq else 2) * f.shape[1]
    return _relax.refine(x, chirps, f, nu, lambda y, f0: music_beat(y, f0, n_model, length, root, n_samp),
                         n_newton, iq)
