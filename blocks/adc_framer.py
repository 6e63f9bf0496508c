"""ADC framer: the receiver's sum of echo and attack, quantisation to integer codes, clipping, and framing.

    codes[c, k, m] = clip(round((R_k[m] + a_k[m]) / lsb), -2^(b-1), 2^(b-1) - 1)     (I and Q separately)

With several receivers every one is quantised alike (a receiver axis after the cycles); clipped and nonfinite count
a cycle's samples over all its receivers.

What leaves is what a real ADC delivers: int16 codes (the scene's lsb turns them into sqrt(W) with
carav_stream.radar.synth.from_codes), a quarter of the bytes of complex64 samples; an ideal ADC
(adc_bits = 0) delivers the samples themselves. The beat signal reaches this node already dechirped (mixing
and low-pass filtering happen in the channel at waveform fidelity); a strong attacker saturates the ADC and
the clipped-sample count of every cycle is recorded. With the attacker node down, a cycle is framed as it was
received, without attack, and marked attack_lost.

A reactive repeater (attack header gate_by_on_air) sends its reply to every chirp; only the replies to chirps
actually on the air reach the receiver: a = gate_by_emission(replies, rx's on_air) (carav_stream/radar/
attackers/_base.py), and attack_active says whether it answered a chirp. Without the rx frame's on_air (bool (cycles,
n_chirps)) such an attack cannot be rendered: the node fails, naming the frame, like any attack that does not fit.

Ports   in  rx       float32 | complex64 (cycles, [n_rx,] n_chirps, n_samples)   signal at the ADC input
                     (+ "on_air")
        in  attack   attacker's signal for the same cycles (optional; (cycles, [n_rx | 1,] 1, n_samples) = every
                     chirp; gate_by_on_air: (1 | cycles, [n_rx | 1,] n_chirps, n_samples) replies [+ "tail"])
        out frames   int16 (cycles, [n_rx,] n_chirps, n_samples[, 2 for I/Q]), or float32 | complex64 samples for
                     an ideal ADC; per_cycle clipped, nonfinite (NaN/Inf input samples, coded 0: the detector
                     judges such a cycle invalid) (and attack_active), header attack_model
Graph   adc = { type = "adc_framer" }
"""
import numpy as np

from carav_stream.radar.adc import adc_codes, adc_step
from carav_stream.radar.attackers import gate_by_emission
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Out, n_cycles, per_cycle


class AdcFramer(Block):
    inputs = (In("rx", kind="rx", dtypes=("float32", "complex64")),
              In("attack", kind="attack", dtypes=("float32", "complex64", "none"), required=False))
    outputs = (Out("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64")),)
    params = (SCENE,)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)

    def process(self, rx: Frame, attack: Frame | None = None) -> Frame:
        x, a, per, extra = rx.payload, None, {}, {}
        if attack is not None:
            a, per["attack_active"] = self.attack_of(rx, attack)
            extra["attack_model"] = attack.header.get("attack_model", "unknown")
        out = None if adc_step(self.scene_obj) is None else self.output_buffer(   # in its shared-memory slot
            "frames", x.shape + (2,) if self.scene_obj.iq else x.shape, np.int16)
        codes, clipped, nonfinite = adc_codes(self.scene_obj, x, out, add=a)   # codes of x + a
        per["clipped"] = clipped.tolist()
        per["nonfinite"] = nonfinite.tolist()   # NaN/Inf samples at the input: the detector judges the cycle invalid
        return rx.derive(codes, per_cycle=per, **extra)

    @staticmethod
    def attack_of(rx: Frame, attack: Frame) -> tuple[np.ndarray | None, list]:
        """The attack signal for rx's cycles (None: silent throughout) and its per-cycle attack_active."""
        x, a, n = rx.payload, attack.payload, rx.payload.shape[0]
        gated = attack.header.get("gate_by_on_air", False)
        tail = attack.arrays.get("tail") if gated is True else None
        # a reactive repeater's replies are the same for every cycle (1 row) and differ from chirp to chirp
        rows, chirps = ((1, n), (x.shape[-2],)) if gated is True else ((n,), (1, x.shape[-2]))
        receivers = (1, x.shape[1]) if x.ndim == 4 else ()     # one receiver axis of 1: the same at every receiver
        if type(gated) is not bool or n_cycles(attack) != n or a is not None and (
                a.dtype != x.dtype or a.ndim != x.ndim or a.shape[0] not in rows or a.shape[-2] not in chirps
                or a.shape[-1] != x.shape[-1] or a.ndim == 4 and a.shape[1] not in receivers) or tail is not None and (
                    a is None or tail.shape != a.shape or tail.dtype != a.dtype):
            shape = "no payload" if a is None else f"{a.dtype} {a.shape}"
            shape += "" if tail is None else f", tail {tail.dtype} {tail.shape}"
            raise ValueError(f"attack frame seq {attack.seq} ({n_cycles(attack)} cycles, {shape}, gate_by_on_air "
                             f"{gated!r}) does not fit the received {x.dtype} {x.shape}")
        per = per_cycle(attack)
        if gated is False:
            return a, per.get("attack_active", [False] * n)
        on, on_air, problems = per.get("attack_active"), rx.arrays.get("on_air"), []
        if on_air is None or on_air.dtype != np.bool_ or on_air.shape != (n, x.shape[-2]):
            problems.append("no on_air in rx" if on_air is None else f"rx's on_air is {on_air.dtype} {on_air.shape}")
        if on is None or not all(type(v) is bool for v in on):
            problems.append(f"attack_active is {on!r}, not one bool per cycle")
        elif a is None and any(on):
            problems.append(f"the attack is switched on ({on}) but sends no replies")
        if problems:
            raise ValueError(f"frame seq {rx.seq} (cycles {rx.cycle}..{rx.cycle + n - 1}): a reactive attack is gated "
                             f"by the channel's on-air emission, bool {(n, x.shape[-2])}; " + "; ".join(problems))
        if a is None:
            return None, on
        a, active = gate_by_emission(a, tail, on_air, np.array(on, dtype=bool))
        return a, active.tolist()

    def unpaired(self, port: str, frame: Frame) -> Frame | None:
        if port == "attack":
            return None   # an attack for cycles whose signal was lost upstream: counted by the runtime
        out = self.process(frame)   # attacker down: the cycles as received, without attack
        return out.with_header(attack_lost=True)
