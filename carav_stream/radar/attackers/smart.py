"""Smart attack (paper Section V.E): one Gaussian sequence per cycle, repeated in every chirp of that cycle.

    a_k[m] = s[m],   s[m] ~ N(0, sigma_a^2) i.i.d. over m, drawn afresh each cycle,   sigma_a = rarms sigma_n

Every chirp carries the same samples, so a node sends them once per cycle (``same_every_chirp``).
"""
from carav_stream.radar.attackers.random import RandomAttacker


class SmartAttacker(RandomAttacker):
    """One Gaussian sequence of n_samples per cycle, repeated in every chirp, at per-sample RMS `rarms` sigma_n
    (paper V.E)."""

    kind = "smart"
    same_every_chirp = True

    def _batch(self, a, on, cycle0, rng, fidelity):
        if on.any():
            seq = self._gauss(rng, (int(on.sum()), a.shape[2]), self.rarms * self.scene.sigma_n)
            a[on] = seq[:, None, :]
        return True
