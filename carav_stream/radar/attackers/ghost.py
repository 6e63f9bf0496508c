"""Ghost: a chirp-synchronised spoofer planting a false target. It knows the victim's timing and slope, not rho.

In every chirp period it sends a replica of the victim's chirp, delayed and Doppler-shifted as an echo of a target
at range_m moving at velocity_mps (ground speed, target convention):

    tau0 = 2 range_m / c,   alpha = 2 (velocity_mps - v_radar) / c,   per-sample RMS rarms sigma_n

It transmits in every chirp period, silent chirps of the victim included, which is what gives it away.
"""
from carav_stream.core.params import Param
from carav_stream.core.units import C_MPS
from carav_stream.radar.attackers._base import rarms_param
from carav_stream.radar.attackers._replica import ReplicaAttacker


class GhostAttacker(ReplicaAttacker):
    """Chirp-synchronised spoofer (knows the victim's timing and slope, not rho): in every chirp period a replica
    of the victim's chirp delayed and Doppler-shifted to look like a target at `range_m` with ground speed
    `velocity_mps` (target convention), per-sample RMS `rarms`."""

    kind = "ghost"
    params = (Param("range_m", float, 30.0, "range of the false target it plants", unit="m", low=0.0, strict=True),
              Param("velocity_mps", float, 0.0, "ground speed of the false target (target convention)", unit="m/s"),
              rarms_param())

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        tau0 = 2.0 * self.range_m / C_MPS
        alpha = 2.0 * (self.velocity_mps - self.scene.radar_speed_mps) / C_MPS
        main, tail = self._replica(tau0, alpha, None, fidelity)
        a_c += main
        if tail is not None:         # it transmits in every chirp period, so every tail is there
            a_c += tail
        return True


