"""Super-resolution of several targets in one range-Doppler cell: MUSIC over a uniform virtual array, with
forward-backward spatial smoothing.

Snapshots. The kernels take any snapshots z (..., S, V) of the virtual channels; the radar's are the cells'
(angle_refine.Cells.snapshots: S = 1, the Doppler and TDM phases removed, summed over the loops and the samples, so
the snapshot holds the whole cycle's SNR). More snapshots of the same cell do not help with targets in one cell: two
targets at the same range and velocity have the same range and Doppler responses, so every neighbouring cell and
every loop holds them in the same ratio. Their sum is the same vector up to a scalar in every snapshot: the sources
are coherent and the covariance sum z z^H has rank one whatever the number of snapshots, so MUSIC sees one source
(between the two) and no subspace for the other.

Remedy: spatial smoothing over a uniform line of P positions x_0 + d i (duplicate positions averaged first: they
carry the same steering). The subarrays y[i : i + L] (i = 0 .. P - L) see the sources with phases advanced by
exp(j 2 pi d i s_k), different per source, and the backward ones (J conj(.)) with the phases conjugated:

    R = 1 / (2 (P - L + 1)) sum_i (y_i y_i^H + J conj(y_i y_i^H) J)             (spectral.fb_covariance)

has rank min(K, 2 (P - L + 1)) for K sources; the default L = P - K + 1 gives K forward subarrays (rank K without
the backward ones too) and leaves L - K >= 1 noise dimensions (P >= 2K). The price is aperture: L < P elements.
Angles by root-MUSIC (spectral.root_music_roots on the L x L covariance's K-dimensional signal subspace: the
roots of a(1/z)^T E_n E_n^H a(z) nearest the unit circle, z = exp(j 2 pi d s)), sorted; the pseudo-spectrum
1 / (L - ||E_s^H a(s)||^2) on the angle spectrum's grid (angle.sin_grid).
"""
from __future__ import annotations

import numpy as np

from carav_stream.estimate import spectral
from carav_stream.estimate.angle import sin_grid
from carav_stream.estimate.virtual_array import VirtualArray, distinct, steering

__all__ = ["uniform_snapshots", "smoothed_covariance", "music_azimuths", "music_spectrum"]


def uniform_snapshots(z, array: VirtualArray):
    """(y (..., S, P), d): the snapshots z (..., S, V) on the P distinct virtual positions in increasing order
    (duplicates averaged) and their spacing d [wavelengths]; ValueError unless they are a filled uniform line."""
    d = array.uniform_spacing_wl()
    if d is None:
        raise ValueError(f"MUSIC with spatial smoothing needs a filled uniform virtual array; positions "
                         f"{np.round(array.positions_wl, 6).tolist()} are not")
    x = array.positions_wl
    grid = distinct(x)
    which = np.argmin(np.abs(x[:, None] - grid[None, :]), axis=1)                 # (V,) -> distinct position
    onehot = (which[:, None] == np.arange(grid.size)[None, :]).astype(float)
    return np.asarray(z) @ (onehot / onehot.sum(axis=0)), d


def smoothed_covariance(y, length: int, *, forward_backward: bool = True):
    """R (..., L, L) averaged over the snapshots y (..., S, P): subarrays of `length` (spatial smoothing), with the
    backward ones too unless forward_backward is False (module docstring)."""
    if forward_backward:
        return spectral.fb_covariance(y, length).mean(axis=-3)
    h = np.lib.stride_tricks.sliding_window_view(y, length, axis=-1)              # (..., S, P - L + 1, L)
    return np.einsum("...swi,...swj->...ij", h, h.conj()) / (h.shape[-2] * h.shape[-3])


def _subspace(z, array: VirtualArray, n_sources: int, length: int | None, forward_backward: bool):
    y, d = uniform_snapshots(z, array)
    n_pos = y.shape[-1]
    length = n_pos - n_sources + 1 if length is None else int(length)
    if not n_sources + 1 <= length <= n_pos:
        raise ValueError(f"MUSIC: subarray length must be in {n_sources + 1}..{n_pos} for {n_sources} sources on "
                         f"{n_pos} positions, got {length}")
    _, sig = spectral.subspaces(smoothed_covariance(y, length, forward_backward=forward_backward), n_sources)
    return sig, d


def music_azimuths(z, array: VirtualArray, n_sources: int, *, length: int | None = None,
                   forward_backward: bool = True) -> np.ndarray:
    """Root-MUSIC azimuths [degrees] (..., n_sources), ascending, of the snapshots z (..., S, V) (S = 1: a cell's
    snapshot); length the subarray length L (default P - n_sources + 1)."""
    sig, d = _subspace(z, array, n_sources, length, forward_backward)
    f, _ = spectral.root_music_roots(sig, n_sources)                               # cycles per element
    return np.sort(np.degrees(np.arcsin(np.clip(f / d, -1.0, 1.0))), axis=-1)


def music_spectrum(z, array: VirtualArray, n_sources: int, n_angle: int = 256, *, length: int | None = None,
                   forward_backward: bool = True) -> np.ndarray:
    """MUSIC pseudo-spectrum 1 / (L - ||E_s^H a(s)||^2), float64 (..., n_angle), on s = angle.sin_grid(n_angle)."""
    sig, d = _subspace(z, array, n_sources, length, forward_backward)
    a = steering(d * np.arange(sig.shape[-2]), sin_grid(n_angle))                 # (n_angle, L)
    proj = np.abs(np.swapaxes(sig.conj(), -1, -2) @ a.T) ** 2                       # (..., K, n_angle)
    den = sig.shape[-2] - proj.sum(axis=-2)
    return 1.0 / np.maximum(den, sig.shape[-2] * 1e-15)
