"""Closed-form TDM-MIMO frames for the angle tests, written from the equations alone (nothing of the kernels under
test is imported).

Receiver r, chirp k (slot j = k % S, fired by transmitter schedule[j]), sample n:

    x[c, r, k, n] = rho[c, k] sum_t a_t exp(j (2 pi f_t n + 2 pi nu_t k + 2 pi (tx[schedule[j]] + rx[r]) s_t + phi_ct))
                    + attack[c, k, n] exp(j 2 pi rx[r] s_att)  +  w[c, r, k, n]

f [cycles/sample], nu [cycles/chirp], s = sin(azimuth); the real part for I-only samples, where the per-sample SNR of
target 0 is a_0^2 / (2 sigma^2) (I/Q: a_0^2 / sigma^2), w white, independent per receiver.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

AWR1642 = {"rx": (0.0, 0.5, 1.0, 1.5), "tx": (0.0, 2.0), "schedule": (0, 1)}


@dataclass(frozen=True)
class Tone:
    f: float            # beat [cycles/sample]
    nu: float           # Doppler progression [cycles/chirp]
    azimuth_deg: float
    amplitude: float = 1.0


def frames(rng, n_cycles: int, tones, *, n_chirps: int = 128, n_samples: int = 256, snr_db: float | None = None,
           iq: bool, layout=AWR1642, rho=None, attack=None, attack_deg: float = 0.0):
    """(C, R, M, N) complex64 (iq) or float32. attack: complex (C, M, N) baseband added on every chirp with the
    one-way phase over the receivers (its real part on I-only receivers), or None."""
    rx, tx, schedule = (np.asarray(layout[k], dtype=float if k != "schedule" else int) for k in ("rx", "tx",
                                                                                                "schedule"))
    k = np.arange(n_chirps)
    pos = tx[schedule[k % schedule.size]][None, :] + rx[:, None]                   # (R, M) [wavelengths]
    n = np.arange(n_samples)
    x = np.zeros((n_cycles, rx.size, n_chirps, n_samples), dtype=np.complex64) if not tones else None
    for t in tones:
        s = np.sin(np.radians(t.azimuth_deg))
        phi = rng.uniform(0.0, 2.0 * np.pi, n_cycles)
        slow = t.amplitude * np.exp(1j * (phi[:, None, None] + 2 * np.pi * (t.nu * k[None, None, :] + pos[None] * s)))
        if rho is not None:
            slow *= np.asarray(rho)[:, None, :]
        tone = np.multiply.outer(slow.astype(np.complex64), np.exp(2j * np.pi * t.f * n).astype(np.complex64))
        x = tone if x is None else np.add(x, tone, out=x)
    if attack is not None:
        x += (attack[:, None] * np.exp(2j * np.pi * rx * np.sin(np.radians(attack_deg)))[None, :, None, None]
              ).astype(np.complex64)
    if not iq:
        x = np.ascontiguousarray(x.real)
    if snr_db is not None:
        sigma = noise_sigma(snr_db, tones[0].amplitude, iq=iq)
        w = rng.standard_normal(x.shape[:-1] + (x.shape[-1] * (2 if iq else 1),), dtype=np.float32)
        w *= np.float32(sigma / np.sqrt(2) if iq else sigma)
        x += w.view(np.complex64) if iq else w
    return x


def noise_sigma(snr_db: float, amplitude: float = 1.0, *, iq: bool) -> float:
    """The noise RMS per sample of `frames` at that SNR."""
    snr = 10 ** (snr_db / 10)
    return amplitude / np.sqrt(snr) if iq else amplitude / np.sqrt(2 * snr)


def virtual_positions(layout=AWR1642) -> np.ndarray:
    """Slot-major virtual positions [wavelengths], from the layout's definition."""
    return np.array([layout["tx"][t] + r for t in layout["schedule"] for r in layout["rx"]])
