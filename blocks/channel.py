"""Channel: target echoes of the transmitted chirps, propagation and receiver noise of the scene.

    R_k[m] = n_k[m] + rho(k) x_k[m]        (the attacker adds a_k[m] downstream)

Ports   in  tx    bool (n_chirps,)                               transmitted chirps of the cycle
        out rx    float32 | complex64 (n_chirps, n_samples)      signal at the ADC input (no attack yet)
        out air   bool (n_chirps,)                               the PREVIOUS cycle's on-air emission (header
                                                                 air_cycle): all an attacker may have heard
                                                                 before the current cycle; zeros at cycle 0
Params  scene (str, "table1"), seed (int, -1), fidelity (str, "beat": closed-form beat samples;
        "waveform": complex chirps, true delays and Doppler, mixing and filtering)
Graph   channel = { type = "channel" }
"""
import numpy as np

from carav_stream.block import Block, In, Out, Param
from carav_stream.radar.streams import NO_SEED, scene_of, seed_streams
from carav_stream.frames import Frame
from carav_stream.radar.physics import echo_templates
from carav_stream.radar.synth import channel, transmit


class Channel(Block):
    inputs = (In("tx", kind="tx", dtypes=("bool",)),)
    outputs = (Out("rx", kind="rx", dtypes=("float32", "complex64"), doc="ADC input, echoes + noise"),
               Out("air", kind="air", dtypes=("bool",), doc="previous cycle's emission"))
    params = (Param("scene", str, "table1", "preset name or scene file"),
              Param("seed", int, NO_SEED, "simulation seed; -1 = OS entropy"),
              Param("fidelity", str, "beat", "beat or waveform", choices=("beat", "waveform")))

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)

    def start(self) -> None:
        self.rng = seed_streams(self.seed).noise
        echo_templates(self.scene_obj, self.fidelity)   # built once (cached) before the first cycle
        self.heard = np.zeros(self.scene_obj.n_chirps, dtype=bool)

    def process(self, tx: Frame) -> dict[str, Frame]:
        rho = np.asarray(tx.payload, dtype=bool)
        if rho.shape != (self.scene_obj.n_chirps,):
            raise ValueError(f"tx frame seq {tx.seq}: expected {self.scene_obj.n_chirps} chirps, got shape {rho.shape}")
        cycle = tx.cycle
        rx = channel(self.scene_obj, transmit(self.scene_obj, rho[None], cycle, self.fidelity), self.rng, cycle)[0]
        air = tx.derive(self.heard, air_cycle=cycle - 1)
        self.heard = rho.copy()
        return {"rx": tx.derive(rx, fidelity=self.fidelity), "air": air}
