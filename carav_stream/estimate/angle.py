"""The range-Doppler-angle cube of a TDM-MIMO radar's frames, and the angle spectrum over its virtual array.

Frames (C cycles, R receivers, M chirps, N samples), float32 (I-only) or complex64 (I/Q); chirp k is slot
j = k % S of loop l = k // S (S = n_slots, L = M / S loops), fired by transmitter schedule[j]
(carav_stream/estimate/virtual_array.py). A target at beat f [cycles/sample], chirp-to-chirp Doppler progression
nu [cycles/chirp] (nu = 2 v T_c / lambda, Geometry's sign: positive receding) and azimuth theta puts on receiver r

    x[r, k, n] = A exp(j 2 pi (f n + nu k + x_v sin(theta))),   k = l S + j,   v = j R + r

(the real part for I-only samples). The cube, per cycle:

    range FFT     X[r, k, b] = sum_n x[r, k, n] exp(-j 2 pi b n / N)     (rectangular: the angle's ML weights;
                                                                          I-only: bins 1 .. ceil(N/2) - 1)
    regroup       Y[v, l, b] = X[r, l S + j, b],  v = j R + r  (slot-major virtual channels, L Doppler snapshots)
    Doppler FFT   Z[v, d, b] = sum_l rho_l Y[v, l, b] exp(-j 2 pi d l / L)   (silent loops weigh nothing)
    TDM           Z[v, d, b] <- Z[v, d, b] exp(-j 2 pi nu_d j),   nu_d = wrap(d / L) / S  [cycles/chirp]

The TDM step: between slot 0 and slot j of one loop a target's Doppler phase advances by 2 pi f_D j T_c
(f_D = nu / T_c = 2 v / lambda), which would add to the angle phase of slot j's channels; at Doppler bin d it is
removed for the velocity of that bin, wrap(d / L) in [-1/2, 1/2) cycles per loop, i.e. |v| < lambda / (4 T_c S)
(an off-bin target keeps a residue of at most pi (S - 1) / (L S) rad on the last slot: the refinement removes it,
angle_refine.py). Then the angle spectrum over the V virtual channels (angle_spectrum).

Range bin b of the cube is FFT bin b (I/Q) or b + 1 (I-only), as in carav_stream.detect.rdmap and the CFAR lists.
"""
from __future__ import annotations

import numpy as np
import scipy.fft

from carav_stream.estimate.virtual_array import VirtualArray, steering

__all__ = ["check_frames", "sin_grid", "loop_doppler", "virtual_cube", "angle_spectrum", "range_doppler_angle"]


def check_frames(frames, array: VirtualArray, rho=None):
    """frames as (C, R, M, N) (a one-receiver array's (C, M, N) gains its receiver axis) and rho as bool (C, M)
    (None: every chirp active), checked against the array; ValueError/TypeError naming the culprit."""
    x = np.asarray(frames)
    if x.ndim == 3 and array.n_rx == 1:
        x = x[:, None]
    if x.ndim != 4 or x.shape[1] != array.n_rx:
        raise ValueError(f"frames: expected (n_cycles, n_rx={array.n_rx}, n_chirps, n_samples), got shape {x.shape}")
    if x.dtype.kind not in "fc":
        raise TypeError(f"frames: expected float32 (I-only) or complex64 (I/Q) samples, got {x.dtype}")
    n_cycles, _, n_chirps, _ = x.shape
    if n_chirps % array.n_slots:
        raise ValueError(f"frames: {n_chirps} chirps are not whole loops of {array.n_slots} TDM slots")
    if rho is None:
        rho = np.ones((n_cycles, n_chirps), dtype=bool)
    rho = np.asarray(rho)
    if rho.dtype != bool or rho.shape != (n_cycles, n_chirps):
        raise ValueError(f"rho: expected bool {(n_cycles, n_chirps)}, got {rho.dtype} {rho.shape}")
    return x, rho


def sin_grid(n_angle: int) -> np.ndarray:
    """The angle spectrum's grid in sin(theta): -1 + 2 k / n_angle, k = 0 .. n_angle - 1, float64."""
    return -1.0 + 2.0 * np.arange(n_angle) / n_angle


def loop_doppler(doppler_bin, n_loops: int, n_slots: int):
    """nu [cycles/chirp] of Doppler bin d of an L-point FFT over loops: wrap(d / L) / S, wrap into [-1/2, 1/2)."""
    per_loop = np.asarray(doppler_bin, dtype=float) / n_loops
    return (per_loop - np.floor(per_loop + 0.5)) / n_slots


def virtual_cube(frames, array: VirtualArray, rho=None, *, tdm: bool = True) -> np.ndarray:
    """Z complex64 (C, V, L, B): range FFT, virtual channels, Doppler FFT over loops, TDM compensation (module
    docstring). tdm False leaves the slots' Doppler phase in (it then biases the angle of a moving target)."""
    x, rho = check_frames(frames, array, rho)
    n_cycles, n_rx, n_chirps, n_samp = x.shape
    s, n_loops = array.n_slots, n_chirps // array.n_slots
    if np.iscomplexobj(x):
        spec = scipy.fft.fft(x, axis=-1)
    else:
        spec = scipy.fft.rfft(x, axis=-1)[..., 1: (n_samp + 1) // 2]
    spec = spec.astype(np.complex64, copy=False)
    spec *= rho[:, None, :, None]
    n_bins = spec.shape[-1]
    y = spec.reshape(n_cycles, n_rx, n_loops, s, n_bins).transpose(0, 3, 1, 2, 4)
    y = y.reshape(n_cycles, s * n_rx, n_loops, n_bins)
    z = scipy.fft.fft(y, axis=2, overwrite_x=True)
    if tdm and s > 1:
        nu = loop_doppler(np.arange(n_loops), n_loops, s)                        # (L,) cycles/chirp
        comp = np.exp(-2j * np.pi * nu[None, :] * array.slot_of_channel[:, None]).astype(np.complex64)
        z *= comp[None, :, :, None]
    return z


def angle_spectrum(z, array: VirtualArray, n_angle: int = 64, *, axis: int = -1) -> np.ndarray:
    """Beamscan power |sum_v z_v exp(-j 2 pi x_v s)|^2 on the grid s = sin_grid(n_angle), float64, the virtual
    channel axis `axis` of z replaced by the grid's (last).

    A filled uniform virtual array at half a wavelength is one FFT of n_angle points over the channels in order of
    position (grid step 2 / n_angle in s = the FFT's bin at half-wave spacing; n_angle even and >= V); any other array
    (gaps, duplicates, other spacings) the product with the steering matrix."""
    z = np.moveaxis(np.asarray(z), axis, -1)
    if z.shape[-1] != array.n_virtual:
        raise ValueError(f"angle_spectrum: {z.shape[-1]} channels on the axis, the array has {array.n_virtual}")
    x = array.positions_wl
    if array.is_filled_half_wave() and n_angle >= x.size and n_angle % 2 == 0:
        # sum_i z_i exp(-j pi i s) (the first position's phase drops out of the power): bin k is s = 2 k / n_angle
        # modulo 2, so the grid, from s = -1, is the FFT rolled by half its length
        b = np.roll(scipy.fft.fft(z[..., np.argsort(x)], n=n_angle, axis=-1), n_angle // 2, axis=-1)
    else:
        b = z @ steering(x, sin_grid(n_angle)).conj().T
    return b.real ** 2 + b.imag ** 2


def range_doppler_angle(frames, array: VirtualArray, rho=None, *, n_angle: int = 64, tdm: bool = True):
    """The range-Doppler-angle power cube, float64 (C, L, B, n_angle): virtual_cube then angle_spectrum over the
    virtual channels; axis 3 is sin(theta) on sin_grid(n_angle)."""
    z = virtual_cube(frames, array, rho, tdm=tdm)
    return angle_spectrum(np.moveaxis(z, 1, -1), array, n_angle)
