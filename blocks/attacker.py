"""Attacker: the signal an attacker model puts on the air for each cycle; the node `carav swap` replaces.

    a_k[m] from the chosen model; the receiver (adc_framer) adds it to R_k[m]

The node hears what an attacker physically can: the victim's on-air emission, one cycle late (input `air`);
it never receives the activation sequence, nor the victim's received signal. It runs any model of
carav_stream/radar/attackers/ (listed below). A model that sends the same samples in every chirp (such as smart)
sends one row per cycle, shape (cycles, 1, n_samples), which the receiver adds to every chirp; a model that
transmits its own waveform (such as secondary_antenna) needs fidelity = "waveform". Each model's parameters
(rarms = sigma_a / sigma_n, start_cycle, ...) are listed below with their meanings and units, each with the models
that take it; a parameter the chosen model does not take is refused by name.

A model that answers live chirps (a LiveChirpAttacker, such as the reactive repeater) answers whatever is on the
air: its reply to chirp k exists only if chirp k was transmitted. The node cannot tell which chirps of a cycle are
(it hears the emission one cycle late), so it sends its reply to every chirp, the same for every cycle (shape
(1, n_chirps, n_samples), and at waveform fidelity array "tail", the reply to chirp k-1 still arriving in chirp k)
with header gate_by_on_air = true; the receiver keeps the replies to the chirps on the air
(attackers.gate_by_emission). Its per-cycle attack_active says whether the model is switched on; the receiver
reports whether it answered a chirp.

With several receivers the signal is sent as each receiver gets it from the attacker's azimuth `azimuth_deg` (one
way: the far-field phase of each receiver's antenna, radar/arrays.py), a receiver axis after the cycles: (cycles,
n_rx, n_chirps | 1, n_samples), or a receiver axis of 1 when every receiver sees it at phase 0 (broadside).

Ports   in  air      bool (cycles, n_chirps)    row i: the emission of the cycle before cycle i
        out attack   float32 | complex64 (cycles, [n_rx | 1,] n_chirps | 1, n_samples), live-chirp: (1, [n_rx | 1,]
                     n_chirps, n_samples) [+ "tail"]; no payload when the model is silent for the whole frame;
                     per_cycle attack_active, header attack_model [, gate_by_on_air]
Graph   attacker = { type = "attacker", model = "smart", rarms = 3.0, start_cycle = 200 }
"""
import textwrap

import numpy as np

from carav_stream.radar.attackers import AZIMUTH, KINDS, LiveChirpAttacker, make_attacker
from carav_stream.radar.streams import FIDELITY, SCENE, SEED, scene_of, seed_streams
from carav_stream.runtime import Block, BlockError, Frame, In, Out, Param


def _model_params() -> tuple[Param, ...]:
    """Every parameter any model takes, with its meaning and unit from the models' own declarations and each
    model's default; the block's default None leaves a parameter to the model."""
    found: dict[str, list[tuple[str, Param]]] = {}
    for kind, cls in KINDS.items():
        for p in cls.declared():
            found.setdefault(p.name, []).append((kind, p))
    out = []
    for name, uses in sorted(found.items()):
        first = uses[0][1]
        same = all((p.low, p.high, p.strict, p.choices) == (first.low, first.high, first.strict, first.choices)
                   for _, p in uses)
        defaults = "every model" if len(uses) == len(KINDS) else ", ".join(k for k, _ in uses)
        out.append(Param(name, first.type, None, f"{first.doc} ({defaults})", unit=first.unit, optional=True,
                         **({"low": first.low, "high": first.high, "strict": first.strict, "choices": first.choices}
                            if same else {})))
    return tuple(out)


def _models_doc() -> str:
    """The models of the registry, one entry each, for the docstring that `carav blocks attacker` prints."""
    lines = ["", "Models  one file each in carav_stream/radar/attackers/ (`carav attackers`: their table)"]
    for kind, cls in KINDS.items():
        lines += textwrap.wrap(cls.summary(), 112, initial_indent=f"        {kind:<18} ", subsequent_indent=" " * 27,
                               break_on_hyphens=False)
    return "\n".join(lines) + "\n"


MODEL_PARAMS = _model_params()
__doc__ += _models_doc()


class AttackerBlock(Block):
    inputs = (In("air", kind="air", dtypes=("bool",), doc="past cycles' on-air emission"),)
    outputs = (Out("attack", kind="attack", dtypes=("float32", "complex64", "none"), doc="attack signal"),)
    variant = "model"           # another model starts from its own defaults (runtime/loader.py)
    params = (Param("model", str, "none", "attack model", choices=tuple(KINDS)), SCENE, SEED, FIDELITY, AZIMUTH,
              *MODEL_PARAMS)

    def check_params(self) -> None:
        self.model_params = {p.name: getattr(self, p.name) for p in MODEL_PARAMS if getattr(self, p.name) is not None}
        self.scene_obj = scene_of(self.scene)
        self.attack = make_attacker(self.model, self.scene_obj, azimuth_deg=self.azimuth_deg, **self.model_params)
        if self.attack.needs_waveform and self.fidelity != "waveform":
            raise BlockError(f"model {self.model!r} transmits its own waveform: set fidelity = \"waveform\" "
                             "(graph-wide, so that the channel renders the same fidelity)")

    def start(self) -> None:
        self.rng = seed_streams(self.seed, instance=self.instance).attack

    def process(self, air: Frame) -> Frame:
        heard = np.asarray(air.payload, dtype=bool)
        if heard.ndim != 2 or heard.shape[1] != self.scene_obj.n_chirps:
            raise ValueError(f"air frame seq {air.seq}: expected (cycles, {self.scene_obj.n_chirps}) chirps, "
                             f"got shape {heard.shape}")
        c0, n = air.cycle, heard.shape[0]
        if isinstance(self.attack, LiveChirpAttacker):   # the receiver gates its replies by the on-air chirps
            return self.replies(c0, n)
        if self.attack.listens:   # hear cycle c-1, then attack cycle c: one cycle at a time
            a, active = None, np.zeros(n, dtype=bool)
            for i in range(n):
                if air.header.get("air_cycle", -1) + i >= 0:
                    self.attack.listen(heard[i])
                a_i, active[i: i + 1] = self.attack.emit(1, c0 + i, self.rng, None, fidelity=self.fidelity,
                                                                compact=True)
                if a_i is not None:
                    a = np.zeros((n,) + a_i.shape[1:], a_i.dtype) if a is None else a
                    a[i] = a_i[0]
        else:
            a, active = self.attack.emit(n, c0, self.rng, None, fidelity=self.fidelity, compact=True)
        return Frame.of(a, per_cycle={"attack_active": active.tolist()}, attack_model=self.model,
                        cycle=c0, cycles=n)

    def replies(self, c0: int, n: int) -> Frame:
        """A live-chirp model's reply to every chirp (rho-independent), for the receiver to gate."""
        on = self.attack.on_cycles(n, c0)
        fields = dict(per_cycle={"attack_active": on.tolist()}, attack_model=self.model, gate_by_on_air=True,
                      cycle=c0, cycles=n)
        if not on.any():
            return Frame.of(None, **fields)
        main, tail = self.attack.replies(self.fidelity)   # as the receivers get them
        out = Frame.of(main[None], **fields)
        return out if tail is None else out.derive(keep_data=True, arrays={"tail": tail[None]})
