"""Attacker: an attack signal model added to the received signal; the node `carav swap` replaces.

    R_k[m] <- R_k[m] + a_k[m]     a from the chosen model; the model never sees the activation sequence

Models: none, random (i.i.d. Gaussian, paper V.D), smart (one sequence repeated over every chirp, V.E),
secondary_antenna (a moving transmitter, V.G; needs fidelity = "waveform"), ghost (chirp-synchronised
spoofer planting a false target), ramp (power rising over cycles), lfsr_predictor (learns an LFSR
activation source from past cycles' emission, heard on the `air` input one cycle late). Each model's
parameters (rarms = sigma_a / sigma_n, start_cycle, ...) are documented in carav_stream/radar/attackers.py;
a parameter the chosen model does not take is refused by name. The chirp-reactive repeater (`reactive`)
needs the current chirp's emission, which this node never receives: it runs in the library and sweeps only.

Ports   in  rx    float32 | complex64 (n_chirps, n_samples)   signal at the ADC input
        in  air   bool (n_chirps,)                            previous cycle's emission (optional)
        out rx    same as rx                                  with the attack added; header attack_active
Graph   attacker = { type = "attacker", model = "smart", rarms = 3.0, start_cycle = 200 }
"""
import numpy as np

from carav_stream.block import Block, BlockError, In, Out, Param
from carav_stream.radar.streams import NO_SEED, scene_of, seed_streams
from carav_stream.frames import Frame
from carav_stream.radar.attackers import KINDS, Attacker, make_attacker

PIPELINE_MODELS = tuple(k for k in KINDS if k != "reactive")


def _model_params() -> tuple[Param, ...]:
    """Every parameter any model takes, typed from the model's own declaration; None = the model's default."""
    found: dict[str, tuple[type, list[str]]] = {}
    for kind, cls in KINDS.items():
        for name, (_, check) in {**Attacker.COMMON, **cls.PARAMS}.items():
            typ = int if check.startswith("int") else str if check.startswith("choice") else float
            found.setdefault(name, (typ, []))[1].append(kind)
    return tuple(Param(name, typ, None, f"model parameter ({', '.join(kinds)})") for name, (typ, kinds) in sorted(found.items()))


class AttackerBlock(Block):
    inputs = (In("rx", kind="rx", dtypes=("float32", "complex64")),
              In("air", kind="air", dtypes=("bool",), required=False))
    outputs = (Out("rx", kind="rx", dtypes=("float32", "complex64")),)
    params = (Param("model", str, "none", "attack model", choices=PIPELINE_MODELS),
              Param("scene", str, "table1", "preset name or scene file"),
              Param("seed", int, NO_SEED, "simulation seed; -1 = OS entropy"),
              Param("fidelity", str, "beat", "must match the channel's", choices=("beat", "waveform")),
              *_model_params())

    def check_params(self) -> None:
        self.model_params = {p.name: getattr(self, p.name) for p in _model_params() if getattr(self, p.name) is not None}
        self.scene_obj = scene_of(self.scene)
        self.attack = make_attacker(self.model, self.scene_obj, **self.model_params)
        if self.attack.needs_waveform and self.fidelity != "waveform":
            raise BlockError(f"model {self.model!r} transmits its own waveform: set fidelity = \"waveform\" "
                             "(graph-wide, so that the channel renders the same fidelity)")

    def start(self) -> None:
        self.rng = seed_streams(self.seed).attack

    def process(self, rx: Frame, air: Frame | None = None) -> Frame:
        if self.attack.listens:
            if air is None:
                raise ValueError(f"model {self.model!r} listens to past emissions: connect channel.air -> attacker.air")
            if air.header.get("air_cycle", -1) >= 0:   # cycle c-1's emission, heard before attacking cycle c
                self.attack.listen(np.asarray(air.payload, dtype=bool))
        a, active = self.attack.emit(1, rx.cycle, self.rng, None, fidelity=self.fidelity)
        out = rx.payload if a is None else rx.payload + a[0]
        return rx.derive(out, attack_active=bool(active[0]), attack_model=self.model)
