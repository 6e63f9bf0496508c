"""Chirp source: a new activation sequence every cycle and the chirps it transmits (Algorithm 1, steps 1-2).

    rho(k) in {0, 1},  sum_k rho(k) = N_r / 2,  fresh every cycle; chirp k is transmitted iff rho(k) = 1

Ports   out tx    bool (n_chirps,)   the transmitted chirps: what goes on the air, to the channel
        out rho   bool (n_chirps,)   the activation sequence: a private edge to the detector alone
Params  scene (str, "table1"): preset name or scene file
        seed (int, -1): simulation seed; -1 draws the sequence from the OS's secure generator
        activation (str, "auto"): secure | seeded | lfsr (auto: secure without a seed, seeded with one)
Graph   source = { type = "chirp_source" }
"""
from carav_stream.block import Block, Out, Param
from carav_stream.radar.streams import NO_SEED, scene_of, seed_streams
from carav_stream.frames import Frame


class ChirpSource(Block):
    outputs = (Out("tx", kind="tx", dtypes=("bool",), doc="transmitted chirps of the cycle"),
               Out("rho", kind="rho", dtypes=("bool",), doc="activation sequence (private: detector only)"))
    params = (Param("scene", str, "table1", "preset name or scene file"),
              Param("seed", int, NO_SEED, "simulation seed; -1 = secure activation sequence"),
              Param("activation", str, "auto", "activation source", choices=("auto", "secure", "seeded", "lfsr")))

    def check_params(self) -> None:
        self.n_chirps = scene_of(self.scene).n_chirps
        seed_streams(self.seed, self.activation)

    def start(self) -> None:
        self.streams = seed_streams(self.seed, self.activation)

    def generate(self, seq: int) -> dict[str, Frame]:
        rho = self.streams.activation.next(1, self.n_chirps)[0]
        return {"tx": Frame.of(rho), "rho": Frame.of(rho.copy())}
