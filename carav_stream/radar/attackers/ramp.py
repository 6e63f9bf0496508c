"""A ramp attack: a random or smart attack whose power rises over cycles, then stays.

    rarms(c) = rarms_start + (rarms_end - rarms_start) clip((c - start_cycle) / n_ramp_cycles, 0, 1)
    a_k[m] = rarms(c) sigma_n z,   z unit Gaussian, i.i.d. over k and m (random) or over m only (smart)
"""
import numpy as np

from carav_stream.core.params import Param
from carav_stream.radar.attackers._base import Attacker


class RampAttacker(Attacker):
    """Random (or `pattern` = smart) samples whose RARMS rises linearly from `rarms_start` to `rarms_end` over
    `n_ramp_cycles` cycles, then stays."""

    kind = "ramp"
    params = (Param("rarms_start", float, 0.5, "RARMS when it switches on", low=0.0),
              Param("rarms_end", float, 5.0, "RARMS it rises to, then keeps", low=0.0),
              Param("n_ramp_cycles", int, 1000, "cycles the rise takes", unit="cycles", low=1),
              Param("pattern", str, "random", "random: i.i.d. samples; smart: one sequence per cycle",
                    choices=("random", "smart")))

    def rarms_at(self, cycle: int) -> float:
        frac = min(max((cycle - self.start_cycle) / self.n_ramp_cycles, 0.0), 1.0)
        return self.rarms_start + (self.rarms_end - self.rarms_start) * frac

    def peak_amplitude(self):
        return 3.0 * max(self.rarms_start, self.rarms_end) * self.scene.sigma_n

    def _batch(self, a, on, cycle0, rng, fidelity):
        idx = np.flatnonzero(on)
        if idx.size:
            shape = (idx.size,) + (a.shape[1:] if self.pattern == "random" else (a.shape[2],))
            z = self._gauss(rng, shape, 1.0)
            scale = np.array([self.rarms_at(cycle0 + i) for i in idx], dtype=np.float32) * self.scene.sigma_n
            z *= scale.reshape((-1,) + (1,) * (z.ndim - 1)).astype(np.float32)
            a[idx] = z if self.pattern == "random" else z[:, None, :]
        return True
