"""The far field across antenna arrays: the phase a path from azimuth theta takes at each element, and the signals
every receiver gets.

    psi(x, theta) = 2 pi x sin(theta)        x: the element's position in wavelengths (scene.py, "Arrays")

An echo goes out from the transmitter that fires its chirp slot and comes back to every receiver: in slot k its
dechirped samples on receiver r carry exp(j psi(tx[tdm_schedule[k mod n_slots]] + rx[r], theta_target)), and its
spill from chirp k-1 into slot k the phase of the transmitter that fired chirp k-1. An attacker's signal travels
one way: exp(j psi(rx[r], theta_attacker)) on receiver r, whatever the slot.

The phase multiplies complex (I/Q) samples. An I-only receiver digitises the real part of the analytic signal z
turned by it, Re{z e^(j psi)}: for a beat A cos(phi), A cos(phi + psi), the real beat's phase shifted by psi. The
analytic signal of a waveform rendered from its physics is that rendering in complex (physics.py, ``analytic``);
of real samples drawn as such (a Gaussian attack) it is the discrete analytic signal along fast time, a + j H{a}
(:func:`hilbert`; scipy.signal.hilbert's: every positive DFT bin doubled, the negative ones zeroed), so that every
positive-frequency DFT bin of a receiver's samples is the reference's turned by exactly psi.

An echo's templates at the receivers are built once per scene and fidelity (:func:`receiver_echoes`, cached like
physics.echo_templates); a single antenna at position 0 keeps physics.echo_templates' own arrays.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from carav_stream.radar import physics
from carav_stream.radar.scene import Scene


def far_field_phase(positions_wl, azimuth_deg: float) -> np.ndarray:
    """psi = 2 pi x sin(theta) of elements at ``positions_wl`` (wavelengths): float64, positions' shape."""
    return 2.0 * np.pi * np.asarray(positions_wl, dtype=np.float64) * np.sin(np.radians(azimuth_deg))


def echo_phases(scene: Scene, azimuth_deg: float) -> np.ndarray:
    """Two-way phases of a path from ``azimuth_deg``: float64 (n_slots, n_rx), slot j of a TDM loop (its transmitter,
    tdm_schedule[j]) to receiver r: psi(tx + rx) over the virtual array."""
    return far_field_phase(scene.virtual_positions_wl.reshape(scene.n_slots, scene.n_rx), azimuth_deg)


def receiver_phases(scene: Scene, azimuth_deg: float) -> np.ndarray:
    """One-way phases of a signal from ``azimuth_deg`` at each receiver: float64 (n_rx,)."""
    return far_field_phase(scene.rx_positions_wl, azimuth_deg)


def hilbert(a: np.ndarray) -> np.ndarray:
    """The discrete Hilbert transform of real samples along their last axis, H{a} = irfft(-j rfft(a)) with the DC and
    Nyquist bins zeroed, a's dtype: the imaginary part of scipy.signal.hilbert(a). scipy.fft, imported here for
    start-up time (only an array's steering of real samples needs it), transforms float32 as float32."""
    import scipy.fft
    n = a.shape[-1]
    spectrum = scipy.fft.rfft(a, axis=-1)
    spectrum *= -1j
    spectrum[..., 0] = 0
    if n % 2 == 0:
        spectrum[..., -1] = 0
    return scipy.fft.irfft(spectrum, n=n, axis=-1).astype(a.dtype, copy=False)


def steer(z: np.ndarray, psi: np.ndarray, iq: bool) -> np.ndarray:
    """z e^(j psi) (I/Q), or its real part (I-only), psi broadcasting against z; z's precision (complex64 ->
    complex64 | float32). The real part is formed as Re z cos psi - Im z sin psi, without the complex product."""
    psi = np.asarray(psi, dtype=np.float64)
    real = np.float32 if z.dtype == np.complex64 else np.float64
    if iq:
        return z * np.exp(1j * psi).astype(z.dtype)
    out = z.real * np.cos(psi).astype(real)
    out -= z.imag * np.sin(psi).astype(real)
    return out


def attack_at_receivers(scene: Scene, a: np.ndarray, azimuth_deg: float) -> np.ndarray:
    """An attack signal a (n_cycles, rows, n_samples) as each receiver gets it from ``azimuth_deg`` (one way).

    a is the signal at position 0: of the scene's dtype, or complex64 for an I-only scene when it is already the
    analytic signal (rendered so by the model). Returns the scene's dtype: (n_cycles, n_rx, rows, n_samples) for
    several receivers ((n_cycles, 1, rows, n_samples) when every receiver sees it at phase 0, which broadcasts),
    (n_cycles, rows, n_samples) for one. :func:`steer`'s products a cycle at a time into the output (its samples
    stay in cache); for I-only, every receiver's Re z cos psi - Im z sin psi of a cycle as one matrix product
    [cos psi, -sin psi] (n_rx, 2) x [Re z; Im z] (2, samples), which costs less than the products one by one.
    """
    psi = receiver_phases(scene, azimuth_deg)
    dtype = np.complex64 if scene.iq else np.float32
    if not psi.any():
        a = a if a.dtype == dtype else a.real.astype(dtype)
        return a if scene.n_rx == 1 else a[:, None]
    n, n_rx, per = a.shape[0], scene.n_rx, math.prod(a.shape[1:])
    out = np.empty((n, n_rx) + a.shape[1:], dtype)
    if scene.iq:
        turn = np.exp(1j * psi).astype(np.complex64)
        for i in range(n):
            for r in range(n_rx):
                np.multiply(a[i], turn[r], out=out[i, r])
        return out if n_rx > 1 else out[:, 0]
    weights = np.stack([np.cos(psi), -np.sin(psi)], axis=1).astype(np.float32)       # (n_rx, 2)
    if np.iscomplexobj(a):          # the rendered analytic signal: (Re, Im) interleaved, read as (2, samples)
        parts = a.reshape(n, per).view(np.float32).reshape(n, per, 2).transpose(0, 2, 1)
    else:                           # real samples and their Hilbert transform
        parts = np.empty((n, 2, per), np.float32)
        parts[:, 0] = a.reshape(n, per)
        parts[:, 1] = hilbert(a).reshape(n, per)
    for i in range(n):
        np.matmul(weights, parts[i], out=out[i].reshape(n_rx, per))
    return out if n_rx > 1 else out[:, 0]


def needs_steering(scene: Scene) -> bool:
    """Whether any target's echo reaches any element of the scene's (virtual) array at a phase other than 0."""
    return any(echo_phases(scene, t.azimuth_deg).any() for t in scene.targets)


@lru_cache(maxsize=16)
def receiver_echoes(scene: Scene, fidelity: str) -> physics.EchoTemplates:
    """The targets' echoes of a fully active cycle at every receiver, as physics.echo_templates gives them at
    position 0: main[t], tail[t], main_sum, tail_sum complex64 | float32 (n_rx, n_chirps, n_samples), or
    (n_chirps, n_samples) for one receiver. main[t][r, k] is target t's echo of chirp k turned by the phase of slot
    k's transmitter and receiver r, tail[t][r, k] its spill from chirp k-1 turned by chirp k-1's. For one receiver
    and every phase 0 (the single-antenna radar) these are physics.echo_templates' own arrays."""
    if scene.n_rx == 1 and not needs_steering(scene):
        return physics.echo_templates(scene, fidelity)
    dtype = np.complex64 if scene.iq else np.float32
    shape = (scene.n_rx, scene.n_chirps, scene.n_samples)
    slot = np.arange(scene.n_chirps) % scene.n_slots
    replica = physics.beat_replica if fidelity == "beat" else physics.waveform_replica
    mains, tails = [], []
    for t in scene.targets:
        psi = echo_phases(scene, t.azimuth_deg)                         # (n_slots, n_rx)
        tau0, alpha = physics.target_delay(scene, t)
        z_main, z_tail = replica(scene, tau0, alpha, physics.echo_amplitude(scene, t), analytic=True)
        mains.append(steer(z_main[None], psi[slot].T[:, :, None], scene.iq).astype(dtype))
        # the spill into slot k left with chirp k-1 (the previous cycle's last slot is the loop's last)
        tails.append(None if z_tail is None else
                     steer(z_tail[None], psi[(slot - 1) % scene.n_slots].T[:, :, None], scene.iq).astype(dtype))
    if scene.n_rx == 1:
        mains = [m[0] for m in mains]
        tails = [None if tl is None else tl[0] for tl in tails]
        shape = shape[1:]
    return physics.assemble_templates(mains, tails, shape, dtype, fidelity)
