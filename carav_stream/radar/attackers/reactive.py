"""Reactive repeater: re-emits each chirp of the victim that reaches it, after a reaction latency.

    delay = 2 distance_m / c + latency_s,   alpha = 2 (velocity_mps - v_radar) / c,   per-sample RMS rarms sigma_n

It answers only what is on the air: silent on the victim's silent chirps, so it never learns rho, and the part of
its reply that arrives before the latency has passed is missing (the detector's spill test). Its reply to chirp
k-1 may still arrive in chirp k (the tail).
"""
import numpy as np

from carav_stream.core.params import Param
from carav_stream.core.units import C_MPS
from carav_stream.radar.attackers._base import LiveChirpAttacker, rarms_param
from carav_stream.radar.attackers._replica import ReplicaAttacker


class ReactiveAttacker(ReplicaAttacker, LiveChirpAttacker):
    """Repeater at `distance_m` (ground speed `velocity_mps`) that re-emits each victim chirp after a reaction
    latency `latency_s`: delay 2 d / c + L, silent on silent chirps, RMS `rarms` while on."""

    kind = "reactive"
    params = (Param("distance_m", float, 30.0, "distance of the repeater", unit="m", low=0.0, strict=True),
              Param("velocity_mps", float, 0.0, "ground speed of the repeater (target convention)", unit="m/s"),
              Param("latency_s", float, 1e-7, "reaction latency after a chirp reaches it", unit="s", low=0.0),
              rarms_param())

    def delay_s(self) -> float:
        return 2.0 * self.distance_m / C_MPS + self.latency_s

    def _validate(self):
        end = self.scene.t_adc_start_s + self.scene.n_samples / self.scene.fs_hz
        if self.delay_s() >= end:
            return [("latency_s", f"the reply (delay {self.delay_s() * 1e6:.3g} us) starts after the sampling "
                                  f"window ends at {end * 1e6:.3g} us")]
        return []

    def response(self, fidelity: str) -> tuple[np.ndarray, np.ndarray | None]:
        """What it answers in a cycle in which it is on, whatever the victim transmits (rho-independent):
        ``main`` (n_chirps, n_samples), its reply to chirp k heard in chirp k, and ``tail``, its reply to chirp
        k-1 still arriving in chirp k (None at beat fidelity when that spill beats outside the IF band); scene dtype,
        read-only, the same for every cycle. ``gate_by_emission`` keeps the replies to chirps on air."""
        alpha = 2.0 * (self.velocity_mps - self.scene.radar_speed_mps) / C_MPS
        return self._replica(self.delay_s(), alpha, self.delay_s(), fidelity)
