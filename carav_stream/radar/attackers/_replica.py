"""A delayed replica of the victim's chirp at a per-sample RMS: what the ghost, the pull-off and the reactive repeater
send."""
import math

import numpy as np

from carav_stream.radar import physics
from carav_stream.radar.attackers._base import Attacker


class ReplicaAttacker(Attacker):
    """Shared by ghost, pull_off and reactive: a delayed replica of the victim's chirp at per-sample RMS rarms."""

    analytic_rendering = True

    def _replica(self, tau0_s, alpha, gate_from_s, fidelity):
        """(main, tail) of the replica delayed tau0_s + alpha t, computed once for each delay a model sends (the
        last one kept: a model whose delay moves from cycle to cycle, such as pull_off, recomputes it); complex64,
        the analytic signal, when ``analytic`` asks."""
        key = (fidelity, tau0_s, alpha, gate_from_s)
        if getattr(self, "_cache_key", None) != key:
            amp = self.rarms * self.scene.sigma_n * (1.0 if self.scene.iq else math.sqrt(2.0))
            if fidelity == "beat":
                main, tail = physics.beat_replica(self.scene, tau0_s, alpha, amp, gate_from_s, self.analytic)
            else:
                main, tail = physics.waveform_replica(self.scene, tau0_s, alpha, amp, analytic=self.analytic)
            dtype = np.complex64 if self.analytic else self.dtype
            tail = None if tail is None else tail.astype(dtype)
            main = main.astype(dtype)
            for x in (main, tail):
                if x is not None:
                    x.setflags(write=False)   # shared by every cycle (and sent by a node without a copy)
            self._cache = (main, tail)
            self._cache_key = key
        return self._cache

    def peak_amplitude(self):
        return self.rarms * self.scene.sigma_n * (1.0 if self.scene.iq else math.sqrt(2.0))


