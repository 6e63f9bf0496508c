"""Cycle source of the paper's model on a receiver array: the detector on each chirp's RMS over all its receivers.

    R_{k,r}[m] = n_{k,r}[m] + rho(k) x_k[m] + steer_r(a_k)[m],     r = 0..n_rx-1

n_{k,r} independent per receiver (white Gaussian, RMS sigma_n per sample, drawn in C order over (cycle, receiver,
chirp, sample)); x_k the paper model's echo (`paper_model.paper_scene`, the target at broadside: the same on every
receiver); a_k the paper model's attack (none; random: new on every chirp; smart: one sequence per cycle, on every
chirp), one transmitter's signal on every receiver with unit-modulus steering v_r = exp(j phi_r),
phi_r = 2 pi x_r sin(theta) for the receivers' positions x_r in wavelengths (default a line at half-wavelength steps
from 0) and the attacker's azimuth theta:

    I/Q     steer_r(a) = v_r a
    I-only  steer_r(a) = cos(phi_r) a - sin(phi_r) b: the real part of the steered analytic signal a + j b, with b an
            independent sequence of a's law (drawn only when some phi_r is not a multiple of pi)

Every sample is simulated (no sufficient-statistic path). Closed form for none and random (`closed_form`): the
law with nu -> n_rx nu, the attack through its steering's gains (carav_stream/detect/receivers.py).
"""
from __future__ import annotations

import numpy as np

from carav_stream.detect.detector import chirp_rms, detect_from_rms
from carav_stream.detect.receivers import receiver_count, steering_gains
from carav_stream.montecarlo import paper_model
from carav_stream.radar.activation import balanced_rows

__all__ = ["ArraySource", "ula_positions_wl"]


def ula_positions_wl(n_rx: int) -> tuple[float, ...]:
    """Receiver positions of a uniform line at half-wavelength steps from 0, in wavelengths."""
    return tuple(0.5 * r for r in range(n_rx))


class ArraySource:
    """Cycle source over a `paper_model.PaperScene` received by n_rx receivers (see the module docstring).

    n_rx                  receivers (>= 1)
    rx_positions_wl       their positions along the array axis, in wavelengths (default `ula_positions_wl`)
    attacker_azimuth_deg  the attacker's azimuth (0: broadside, the same phase on every receiver)
    """

    attacks = paper_model.ATTACKS

    def __init__(self, scene: paper_model.PaperScene, n_rx: int, *, rx_positions_wl=None,
                 attacker_azimuth_deg: float = 0.0):
        n_rx = receiver_count(n_rx)
        positions = ula_positions_wl(n_rx) if rx_positions_wl is None else tuple(map(float, rx_positions_wl))
        if len(positions) != n_rx:
            raise ValueError(f"rx_positions_wl: {len(positions)} positions for n_rx = {n_rx} receivers")
        if not np.isfinite(attacker_azimuth_deg) or abs(attacker_azimuth_deg) > 90:
            raise ValueError(f"attacker_azimuth_deg: must be within [-90, 90], got {attacker_azimuth_deg!r}")
        self.scene = scene
        self.name = scene.name
        self.n_chirps, self.n_samples, self.iq, self.sigma_n = scene.n_chirps, scene.n_samples, scene.iq, scene.sigma_n
        self.n_rx = n_rx
        self.rx_positions_wl = positions
        self.attacker_azimuth_deg = float(attacker_azimuth_deg)
        self.phases = 2 * np.pi * np.asarray(positions) * np.sin(np.radians(self.attacker_azimuth_deg))

    def energy_exact(self, attack: str) -> bool:
        return False

    def closed_form(self, attack: str) -> dict | None:
        if attack not in ("none", "random") or not paper_model.exchangeable(self.scene, "none"):
            return None
        return {"n_chirps": self.n_chirps, "dof": self.scene.dof, "snr": self.scene.echo_snr, "n_rx": self.n_rx,
                "attack_gains": None if self.n_rx == 1 else steering_gains(self.phases, self.iq)}

    def frames(self, rho: np.ndarray, rng: np.random.Generator, attack: str = "none",
               rarms: float = 0.0) -> np.ndarray:
        """Every sample of the cycles of rho (bool (n_cycles, n_chirps), balanced): float32 (I-only) or complex64
        (I/Q), shape (n_cycles, n_rx, n_chirps, n_samples). The generator's stream: the noise, then the attack
        (a, then b for I-only off broadside)."""
        paper_model.check_attack(attack, rarms)
        rho = np.asarray(rho, dtype=bool)
        n = rho.shape[0]
        dtype = np.dtype(np.complex64 if self.iq else np.float32)
        out = paper_model.gaussian(rng, (n, self.n_rx, self.n_chirps, self.n_samples), self.sigma_n, self.iq, dtype)
        np.add(out, self.scene.echo.astype(dtype)[None, None], out=out, where=rho[:, None, :, None])
        sigma_a = rarms * self.sigma_n
        if attack == "none" or sigma_a == 0:
            return out
        shape = (n, self.n_chirps if attack == "random" else 1, self.n_samples)
        a = paper_model.gaussian(rng, shape, sigma_a, self.iq, dtype)[:, None]
        if self.iq:
            out += np.exp(1j * self.phases).astype(dtype)[None, :, None, None] * a
            return out
        cos, sin = np.cos(self.phases), np.sin(self.phases)
        out += cos.astype(dtype)[None, :, None, None] * a
        if np.any(np.abs(sin) > 1e-12):
            b = paper_model.gaussian(rng, shape, sigma_a, False, dtype)[:, None]
            out -= sin.astype(dtype)[None, :, None, None] * b
        return out

    def draw(self, n_cycles, attack, rarms, rng, method):
        if method != "samples":
            raise ValueError(f"method: the {self.name} array source simulates every sample; got {method!r}")
        rho = balanced_rows(rng, n_cycles, self.n_chirps)
        return chirp_rms(self.frames(rho, rng, attack, rarms), receivers=True), rho

    def draw_q(self, n_cycles, attack, rarms, rng, method):
        rms, rho = self.draw(n_cycles, attack, rarms, rng, method)
        det = detect_from_rms(rms, rho, self.sigma_n, 1.0)
        return det.q, det.by_d1

    def describe(self) -> dict:
        return {"model": "paper", "name": self.name, "n_chirps": self.n_chirps, "n_samples": self.n_samples,
                "iq": self.iq, "sigma_n": self.sigma_n, "echo_snr_db": float(10 * np.log10(self.scene.echo_snr)),
                "n_rx": self.n_rx, "rx_positions_wl": list(self.rx_positions_wl),
                "attacker_azimuth_deg": self.attacker_azimuth_deg}
