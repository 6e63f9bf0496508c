"""An attacker that learns the activation source from the air: it fits an LFSR to what it heard and jams the chirps
it predicts active.

After each cycle it hears that cycle's on-air emission (one bit per Manchester pair: chirp 2i on or off), keeps the
last ``max_history_bits`` bits and, when its prediction missed, fits the shortest LFSR to them (Berlekamp-Massey).
In the next cycle it puts Gaussian noise at rarms sigma_n on the chirps the LFSR predicts active, nothing elsewhere.
Against an LFSR source it locks on after 2 L bits; against the secure source it stays at chance.
"""
import numpy as np

from carav_stream.core.params import Param
from carav_stream.radar.activation import berlekamp_massey, lfsr_continue
from carav_stream.radar.attackers._base import Attacker, rarms_param


class LfsrPredictorAttacker(Attacker):
    """Listens to past cycles' emission, fits the shortest LFSR (Berlekamp-Massey over the Manchester bits, the
    last `max_history_bits`) and puts Gaussian noise at `rarms` on the chirps it predicts active only."""

    kind = "lfsr_predictor"
    params = (rarms_param(), Param("max_history_bits", int, 1024, "emission bits it keeps to fit the LFSR", unit="bits",
                              low=1))
    _listens = True

    def __init__(self, scene, **params):
        super().__init__(scene, **params)
        self.history: list[int] = []
        self.model: tuple[int, tuple[int, ...]] = (0, ())
        self.prediction: np.ndarray | None = None     # predicted rho of the next cycle
        self.n_chirps_predicted = 0
        self.n_chirps_correct = 0

    def peak_amplitude(self):
        return 3.0 * self.rarms * self.scene.sigma_n

    def predict(self) -> np.ndarray:
        """Predicted activation row of the next cycle from the LFSR model (Manchester pairs)."""
        length, taps = self.model
        n_bits = self.scene.n_chirps // 2
        if taps and len(self.history) >= max(taps):
            bits = lfsr_continue(self.history[-max(taps):], taps, n_bits)
        else:
            bits = np.zeros(n_bits, dtype=bool)
        rho = np.empty(self.scene.n_chirps, dtype=bool)
        rho[0::2], rho[1::2] = bits, ~bits
        return rho

    def _cycle(self, a_c, cycle, rng, live, fidelity):
        self.prediction = self.predict()
        n_on = int(self.prediction.sum())
        a_c[self.prediction] = self._gauss(rng, (n_on, a_c.shape[1]), self.rarms * self.scene.sigma_n)
        return n_on > 0

    def _listen(self, emission_row):
        predicted = self.prediction if self.prediction is not None else self.predict()
        self.n_chirps_predicted += emission_row.size
        self.n_chirps_correct += int(np.count_nonzero(predicted == emission_row))
        self.prediction = None
        self.history.extend(int(b) for b in emission_row[0::2])
        del self.history[: max(0, len(self.history) - self.max_history_bits)]
        if not np.array_equal(predicted, emission_row):
            self.model = berlekamp_massey(self.history)


