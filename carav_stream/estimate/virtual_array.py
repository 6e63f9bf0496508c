"""A TDM-MIMO receiver array as the angle kernels see it: receive and transmit positions and the TDM schedule, the
virtual array they make, and its steering vectors.

Positions are along the array axis in wavelengths. Slot j of a TDM loop is fired by transmitter schedule[j]; chirp k
of a cycle is slot k % n_slots of loop k // n_slots. Virtual channel v = j n_rx + r (slot-major) is slot j heard on
receiver r, at position

    x_v = tx_positions_wl[schedule[j]] + rx_positions_wl[r]

A far-field target at azimuth theta (positive towards increasing position) puts the phase exp(+j 2 pi x sin(theta))
on an element at x relative to x = 0 (two-way: the virtual position; an attacker's signal, one-way, sees the
receive positions only). Duplicate virtual positions are allowed (two slots whose transmitters sit as far apart as
two receivers); the FFT over the array needs the positions to be a filled uniform line at half a wavelength.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.core.arrays import virtual_positions

__all__ = ["VirtualArray", "tdm_max_velocity_mps"]

_TOL_WL = 1e-9     # positions closer than this [wavelengths] are the same position


@dataclass(frozen=True)
class VirtualArray:
    """rx_positions_wl  receive positions [wavelengths]
    tx_positions_wl     transmit positions [wavelengths]
    tdm_schedule        one TDM loop: slot j fired by transmitter tdm_schedule[j]
    """

    rx_positions_wl: tuple[float, ...] = (0.0,)
    tx_positions_wl: tuple[float, ...] = (0.0,)
    tdm_schedule: tuple[int, ...] = (0,)

    def __post_init__(self) -> None:
        for name in ("rx_positions_wl", "tx_positions_wl"):
            value = tuple(float(p) for p in getattr(self, name))
            if not value or not all(np.isfinite(value)):
                raise ValueError(f"VirtualArray.{name}: must be one or more finite positions, got {value!r}")
            object.__setattr__(self, name, value)
        schedule = tuple(int(j) for j in self.tdm_schedule)
        if not schedule or not all(0 <= j < len(self.tx_positions_wl) for j in schedule):
            raise ValueError(f"VirtualArray.tdm_schedule: must name transmitters 0..{len(self.tx_positions_wl) - 1}, "
                             f"got {self.tdm_schedule!r}")
        object.__setattr__(self, "tdm_schedule", schedule)

    @classmethod
    def from_scene(cls, scene: object) -> VirtualArray:
        """The array of any object with rx_positions_wl, tx_positions_wl and tdm_schedule (duck typing); an object
        without them is the one-antenna radar, (0.0,), (0.0,), (0,)."""
        return cls(tuple(getattr(scene, "rx_positions_wl", (0.0,))), tuple(getattr(scene, "tx_positions_wl", (0.0,))),
                   tuple(getattr(scene, "tdm_schedule", (0,))))

    @property
    def n_rx(self) -> int:
        return len(self.rx_positions_wl)

    @property
    def n_slots(self) -> int:
        return len(self.tdm_schedule)

    @property
    def n_virtual(self) -> int:
        return self.n_slots * self.n_rx

    @property
    def positions_wl(self) -> np.ndarray:
        """Virtual positions x_v [wavelengths], float64 (n_virtual,), slot-major."""
        return virtual_positions(self.tx_positions_wl, self.rx_positions_wl, self.tdm_schedule)

    @property
    def slot_of_channel(self) -> np.ndarray:
        """Slot j of each virtual channel, int64 (n_virtual,)."""
        return np.repeat(np.arange(self.n_slots), self.n_rx)

    def uniform_spacing_wl(self) -> float | None:
        """d if the distinct virtual positions are a filled uniform line x_0 + d i (d > 0), else None; a single
        position has none."""
        x = distinct(self.positions_wl)
        if x.size < 2:
            return None
        step = np.diff(x)
        return float(step.mean()) if np.all(np.abs(step - step.mean()) < 1e-6) else None

    def is_filled_half_wave(self) -> bool:
        """The virtual positions are distinct and a filled uniform line at half a wavelength (an FFT over them,
        in order of position, is the beamscan on the sin(theta) grid)."""
        x = self.positions_wl
        spacing = self.uniform_spacing_wl()
        return spacing is not None and distinct(x).size == x.size and abs(spacing - 0.5) < 1e-6

    def steering(self, sin_theta) -> np.ndarray:
        """exp(+j 2 pi x_v sin(theta)), complex128 (..., n_virtual) for sin_theta (...)."""
        return steering(self.positions_wl, sin_theta)

    def rx_steering(self, sin_theta) -> np.ndarray:
        """One-way steering over the receivers, complex128 (..., n_rx)."""
        return steering(np.asarray(self.rx_positions_wl), sin_theta)


def steering(positions_wl, sin_theta) -> np.ndarray:
    """exp(+j 2 pi x sin(theta)) for positions x (P,) [wavelengths], complex128 (..., P) for sin_theta (...)."""
    phase = 2.0 * np.pi * np.asarray(sin_theta, dtype=float)[..., None] * np.asarray(positions_wl, dtype=float)
    return np.cos(phase) + 1j * np.sin(phase)


def distinct(positions_wl) -> np.ndarray:
    """The distinct positions in increasing order (positions closer than 1e-9 wavelength are one)."""
    x = np.sort(np.asarray(positions_wl, dtype=float))
    return x[np.concatenate(([True], np.diff(x) > _TOL_WL))] if x.size else x


def tdm_max_velocity_mps(wavelength_m: float, t_chirp_s: float, n_slots: int) -> float:
    """Unambiguous radial velocity with TDM, lambda / (4 T_c n_slots) [m/s]: a virtual channel is sampled once a
    loop of n_slots chirps."""
    return wavelength_m / (4.0 * t_chirp_s * n_slots)
