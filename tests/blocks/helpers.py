"""What the block tests share: frames as a block receives them, and the radar front end in-process."""
from __future__ import annotations

import numpy as np

from carav_blocks.adc_framer import AdcFramer
from carav_blocks.attacker import AttackerBlock
from carav_blocks.channel import Channel
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime import Frame
from carav_stream.testing.harness import wire

SCENE = "table1"
N_S = load_scene(SCENE).n_samples      # samples per chirp of the scene
RHO = np.zeros(64, bool)
RHO[::2] = True


def adc_frame(seq: int, value: float = 1e-4, cycles: int = 1) -> Frame:
    return wire(Frame.of(np.full((cycles, 64, N_S), value, np.float32), cycles=cycles), seq)


def front_end(fidelity: str, seed: int = 4, scene: str = SCENE, **attack):
    """channel -> attacker -> adc in-process, every frame through the codec: a function of (rho, cycle0, seq)."""
    channel = Channel(scene=scene, seed=seed, fidelity=fidelity)
    attacker = AttackerBlock(scene=scene, seed=seed, fidelity=fidelity, **attack)
    adc = AdcFramer(scene=scene)
    channel.start()
    attacker.start()

    def run(rho, cycle0, seq):
        out = channel.process(wire(Frame.of(rho, cycle=cycle0, cycles=rho.shape[0]), seq))
        rx, air = wire(out["rx"], seq), wire(out["air"], seq)
        attack = wire(attacker.process(air), seq)
        return rx, air, attack, adc.process(rx, attack)
    return run
