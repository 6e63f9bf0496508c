"""Channel: target echoes of the transmitted chirps, propagation and receiver noise of the scene.

    R_k[m] = n_k[m] + rho(k) x_k[m]        (the attacker's a_k[m] is added at the receiver, adc_framer)

With several receivers (radar/arrays.py) each gets every echo at the far-field phase of its antenna and of the
transmitter that fired the chirp, and noise of its own: rx gets a receiver axis, (cycles, n_rx, n_chirps, n_samples).

Ports   in  tx    bool (cycles, n_chirps)                               transmitted chirps of the cycles
        out rx    float32 | complex64 (cycles, [n_rx,] n_chirps,        signal at the ADC input, no attack;
                  n_samples) + array "on_air" bool (cycles, n_chirps)   the same cycles' emission, which
                                                                        gates a reactive repeater's replies
        out air   bool (cycles, n_chirps)                               row i: the on-air emission of the cycle
                                                                        BEFORE cycle i (header air_cycle = the
                                                                        first row's): all an attacker may have
                                                                        heard before attacking; zeros before 0
Graph   channel = { type = "channel" }
"""
import numpy as np

from carav_stream.radar.arrays import receiver_echoes
from carav_stream.radar.streams import FIDELITY, SCENE, SEED, scene_of, seed_streams
from carav_stream.radar.synth import channel, transmit
from carav_stream.runtime import Block, Frame, In, Out


class Channel(Block):
    inputs = (In("tx", kind="tx", dtypes=("bool",)),)
    outputs = (Out("rx", kind="rx", dtypes=("float32", "complex64"), doc="ADC input, echoes + noise"),
               Out("air", kind="air", dtypes=("bool",), doc="each cycle's previous cycle's emission",
                   private=True))
    params = (SCENE, SEED, FIDELITY)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)

    def start(self) -> None:
        self.rng = seed_streams(self.seed, instance=self.instance).noise
        receiver_echoes(self.scene_obj, self.fidelity)   # built once (cached) before the first cycle
        self.heard = np.zeros(self.scene_obj.n_chirps, dtype=bool)

    def process(self, tx: Frame) -> dict[str, Frame]:
        rho = np.asarray(tx.payload, dtype=bool)
        if rho.ndim != 2 or rho.shape[1] != self.scene_obj.n_chirps:
            raise ValueError(f"tx frame seq {tx.seq}: expected (cycles, {self.scene_obj.n_chirps}) chirps, "
                             f"got shape {rho.shape}")
        cycle = tx.cycle
        sc = self.scene_obj
        out = self.output_buffer("rx", sc.frame_shape(rho.shape[0]),   # in its shared-memory slot
                                 np.complex64 if sc.iq else np.float32)
        rx = channel(sc, transmit(sc, rho, cycle, self.fidelity), self.rng, cycle, out=out)
        air = np.concatenate([self.heard[None], rho[:-1]])
        self.heard = rho[-1].copy()
        return {"rx": tx.derive(rx, arrays={"on_air": rho}, fidelity=self.fidelity),
                "air": tx.derive(air, air_cycle=cycle - 1)}
