"""A secondary antenna (paper Section V.G): a physical FMCW transmitter of its own, received one way.

A transmitter at range_m moving at velocity_mps (ground speed, target convention) sweeps with its own slope,
duration and period from fc + f_offset_hz, starting t_offset_s against the victim's chirps; the victim receives it
one way through its antenna and receive chain and dechirps it with its own reference:

    A = sqrt(P_a G_a G_rx lambda^2 / (4 pi R)^2)       (one-way free space, dechirped amplitude)

Its mixer product is rendered on the waveform grid, filtered and decimated like the echoes, so it needs the
waveform fidelity. ``equivalent_rarms`` maps its power to the paper's RARMS.
"""
import math

import numpy as np

from carav_stream.core.params import Param
from carav_stream.core.units import C_MPS, KMH
from carav_stream.radar import physics
from carav_stream.radar.attackers._base import Attacker


class SecondaryAntennaAttacker(Attacker):
    """A physical FMCW transmitter at `range_m` moving at `velocity_mps` with its own sweep (default: the victim's),
    received one way through the victim's antenna and receive chain (paper V.G); needs the waveform fidelity."""

    kind = "secondary_antenna"
    needs_waveform = True
    analytic_rendering = True
    params = (Param("range_m", float, 30.0, "range of the transmitter", unit="m", low=0.0, strict=True),
              Param("velocity_mps", float, 50.0 * KMH, "ground speed of the transmitter (target convention)",
                    unit="m/s"),
              Param("tx_power_w", float, 1e-3, "transmit power", unit="W", low=0.0),
              Param("tx_gain_db", float, 0.0, "transmit antenna gain", unit="dB"),
              Param("slope_hz_per_s", float, None, "its sweep slope (none: the victim's)", unit="Hz/s", low=0.0,
                    strict=True, optional=True),
              Param("t_sweep_s", float, None, "its sweep duration (none: the victim's)", unit="s", low=0.0,
                    strict=True, optional=True),
              Param("t_chirp_s", float, None, "its chirp period (none: the longer of the victim's and its sweep)",
                    unit="s", low=0.0, strict=True, optional=True),
              Param("t_offset_s", float, 0.0, "start of its chirps against the victim's", unit="s"),
              Param("f_offset_hz", float, 0.0, "start frequency of its sweeps above fc", unit="Hz"))

    def __init__(self, scene, **params):
        super().__init__(scene, **params)
        self.slope_hz_per_s = self.slope_hz_per_s or scene.slope_hz_per_s
        self.t_sweep_s = self.t_sweep_s or scene.t_sweep_s
        self.t_chirp_s = self.t_chirp_s or max(scene.t_chirp_s, self.t_sweep_s)
        self._cache: dict = {}
        self._grid_terms: tuple[np.ndarray, np.ndarray] | None = None

    def _validate(self):
        out = []
        t_sweep = self.t_sweep_s or self.scene.t_sweep_s
        t_chirp = self.t_chirp_s or max(self.scene.t_chirp_s, t_sweep)
        if t_chirp < t_sweep:
            out.append(("t_chirp_s", f"must be >= its t_sweep_s {t_sweep:.6g} s, got {t_chirp:.6g}"))
        return out

    def amplitude(self) -> float:
        """Dechirped amplitude: sqrt(Pa Ga Grx lambda^2 / (4 pi R)^2), one-way free space."""
        s = self.scene
        with np.errstate(over="ignore"):
            p_w = (np.float64(self.tx_power_w) * 10 ** (np.float64(self.tx_gain_db) / 10)
                   * 10 ** (s.rx_gain_db / 10) * s.wavelength_m ** 2 / (4 * np.pi * np.float64(self.range_m)) ** 2)
        return float(np.sqrt(p_w))

    def peak_amplitude(self):
        return self.amplitude()

    def equivalent_rarms(self) -> float:
        """sigma_a / sigma_n of its contribution while in band (A for I/Q, A / sqrt 2 for I-only):
        maps transmit power to the paper's RARMS (low / medium / high power cases of V.G)."""
        a = self.amplitude() if self.scene.iq else self.amplitude() / math.sqrt(2.0)
        return a / self.scene.sigma_n

    def physics_warnings(self):
        s = self.scene
        # worst mixer-product frequency on the waveform grid: slope mismatch over a sweep, plus offset
        f_mix = abs(self.slope_hz_per_s - s.slope_hz_per_s) * s.t_sweep_s + abs(self.f_offset_hz)
        nyq = s.waveform_oversample * s.fs_hz / 2
        if f_mix > nyq:
            return [f"its mixer product sweeps up to {f_mix / 1e6:.4g} MHz, beyond the waveform grid's "
                    f"+-{nyq / 1e6:.4g} MHz (waveform_oversample = {s.waveform_oversample}): the parts beyond "
                    f"alias into the IF band; raise waveform_oversample to about {math.ceil(2 * f_mix / s.fs_hz)}"]
        return []

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        if fidelity != "waveform":
            raise ValueError("attacker 'secondary_antenna' transmits its own waveform: use fidelity 'waveform'")
        s = self.scene
        phase0 = (cycle * s.t_cycle_s - self.t_offset_s) % self.t_chirp_s
        key = round(phase0 * 1e15)
        if key not in self._cache:
            if len(self._cache) > 8:
                self._cache.clear()
            self._cache[key] = physics.filter_decimate(s, self.mixed(phase0)).astype(a_c.dtype)
        a_c += self._cache[key]
        return self.tx_power_w > 0

    def mixed(self, phase0_s: float) -> np.ndarray:
        """The victim's mixer output on the waveform grid, float64 | complex128 (n_chirps, n_grid), in a cycle that
        starts phase0_s seconds into one of its chirp periods (t since the cycle start, R, v: its range and speed):

            tau = (R + (v - v_radar) t) / c,    u = (t - tau + phase0_s) mod t_chirp,    gate = u < t_sweep
            y = A gate exp(j (theta_ref(t) + 2 pi fc tau - (2 pi f_offset u + pi slope u u)))    (Re for I-only)

        (complex for I-only too when ``analytic`` asks: the analytic signal an array turns, attackers/_base.py).

        t - tau and theta_ref + 2 pi fc tau are the same in every cycle and are kept from the first; the rest runs a
        few chirps at a time (its temporaries stay in cache), the modulo by physics.wrap_s and the exponential only
        under the gate (physics.tone). The values are those of these expressions evaluated on the whole grid with
        numpy in the order written (off the gate a zero whose sign may differ, which the IF filter's sums never
        show), for less work (its cost: docs/bench/synth.md).
        """
        s = self.scene
        if self._grid_terms is None:
            g = physics.waveform_grid(s)
            tau = (self.range_m + (self.velocity_mps - s.radar_speed_mps) * g.t_cycle_s) / C_MPS
            self._grid_terms = (g.t_cycle_s - tau, g.ref_phase + 2 * np.pi * s.fc_hz * tau)
        lead, carrier = self._grid_terms
        y = np.empty(lead.shape, np.complex128 if s.iq or self.analytic else np.float64)
        amp = self.amplitude()
        c_offset, c_slope = 2 * np.pi * self.f_offset_hz, np.pi * self.slope_hz_per_s
        rows = max(1, 32768 // lead.shape[1])
        for a in range(0, lead.shape[0], rows):
            u = physics.wrap_s(lead[a: a + rows] + phase0_s, self.t_chirp_s)
            gate = u < self.t_sweep_s
            phase = c_slope * u
            phase *= u
            if self.f_offset_hz != 0:            # else 0 u + x = x (u >= 0; where u is NaN, so is x)
                phase += c_offset * u
            np.subtract(carrier[a: a + rows], phase, out=phase)
            physics.tone(s, phase, amp, gate, out=y[a: a + rows], analytic=self.analytic)
        return y


