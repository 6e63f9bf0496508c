"""Random attack (paper Section V.D): white Gaussian noise on every chirp of every cycle it is on.

    a_k[m] ~ N(0, sigma_a^2) i.i.d. over k and m,   sigma_a = rarms sigma_n   (complex circular for I/Q)
"""
from carav_stream.radar.attackers._base import Attacker, rarms_param


class RandomAttacker(Attacker):
    """I.i.d. Gaussian samples at per-sample RMS `rarms` sigma_n (paper V.D)."""

    kind = "random"
    params = (rarms_param(),)

    def peak_amplitude(self):
        return 3.0 * self.rarms * self.scene.sigma_n

    def _batch(self, a, on, cycle0, rng, fidelity):
        if on.any():
            a[on] = self._gauss(rng, (int(on.sum()),) + a.shape[1:], self.rarms * self.scene.sigma_n)
        return True
