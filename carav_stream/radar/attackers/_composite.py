"""Several attackers on the air at once (a scene's ``[[attackers]]``): the sum of their signals."""
import numpy as np

from carav_stream.radar.attackers._base import Attacker, Observation
from carav_stream.radar.attackers._registry import make_attacker
from carav_stream.radar.scene import Scene


class CompositeAttacker(Attacker):
    """Several attackers on the air at once: a = sum of theirs, each as the receivers get it from its own azimuth.
    Runs them cycle by cycle, in list order, so that the draws from the shared rng_attack do not depend on the batch
    size."""

    kind = "composite"

    def __init__(self, scene: Scene, parts: list[Attacker]):
        self.scene, self.parts = scene, list(parts)
        self.needs_waveform = any(p.needs_waveform for p in parts)
        self.uses_live_emission = any(p.uses_live_emission for p in parts)
        self._listens = any(p._listens for p in parts)
        self.dtype = np.complex64 if scene.iq else np.float32

    def peak_amplitude(self):
        return sum(p.peak_amplitude() for p in self.parts)

    def emit(self, n_cycles, cycle0, rng_attack, observation=None, *, fidelity="beat"):
        a = np.zeros(self.scene.frame_shape(n_cycles), self.dtype)
        active = np.zeros(n_cycles, dtype=bool)
        for i in range(n_cycles):
            obs = None if observation is None else Observation(observation.emission[i: i + 1], cycle0 + i)
            for p in self.parts:
                a_p, on = p.emit(1, cycle0 + i, rng_attack, obs, fidelity=fidelity)
                if a_p is not None:
                    a[i] += a_p[0]          # a receiver axis of 1 (every receiver at phase 0) broadcasts
                active[i] |= bool(on[0])
        return a, active


def scene_attacker(scene: Scene) -> Attacker | None:
    """The scene's attackers as one object (a CompositeAttacker when there are several), or None; each at its
    AttackerSpec's azimuth."""
    parts = [make_attacker(spec.kind, scene, azimuth_deg=spec.azimuth_deg, **spec.kwargs())
             for spec in scene.attackers]
    if not parts:
        return None
    return parts[0] if len(parts) == 1 else CompositeAttacker(scene, parts)
