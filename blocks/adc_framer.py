"""ADC framer: the receiver's sum of echo and attack, quantisation to integer codes, clipping, and framing.

    codes[c, k, m] = clip(round((R_k[m] + a_k[m]) / lsb), -2^(b-1), 2^(b-1) - 1)     (I and Q separately)

What leaves is what a real ADC delivers: int16 codes (the scene's lsb turns them into sqrt(W) with
carav_stream.radar.synth.from_codes), a quarter of the bytes of complex64 samples; an ideal ADC
(adc_bits = 0) delivers the samples themselves. The beat signal reaches this node already dechirped (mixing
and low-pass filtering happen in the channel at waveform fidelity); a strong attacker saturates the ADC and
the clipped-sample count of every cycle is recorded. With the attacker node down, a cycle is framed as it was
received, without attack, and marked attack_lost.

Ports   in  rx       float32 | complex64 (cycles, n_chirps, n_samples)   signal at the ADC input
        in  attack   attacker's signal for the same cycles (optional; (cycles, 1, n_samples) = every chirp)
        out frames   int16 (cycles, n_chirps, n_samples[, 2 for I/Q]), or float32 | complex64 samples for an
                     ideal ADC; per_cycle clipped (and attack_active), header attack_model
Graph   adc = { type = "adc_framer" }
"""
from carav_stream.block import Block, In, Out, Param
from carav_stream.cycles import n_cycles, per_cycle
from carav_stream.radar.streams import scene_of
from carav_stream.frames import Frame
from carav_stream.radar.synth import adc_codes


class AdcFramer(Block):
    inputs = (In("rx", kind="rx", dtypes=("float32", "complex64")),
              In("attack", kind="attack", dtypes=("float32", "complex64", "none"), required=False))
    outputs = (Out("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64")),)
    params = (Param("scene", str, "table1", "preset name or scene file (ADC bits, full scale)"),)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)

    def process(self, rx: Frame, attack: Frame | None = None) -> Frame:
        x, per, extra = rx.payload, {}, {}
        if attack is not None:
            a = attack.payload
            if n_cycles(attack) != x.shape[0] or a is not None and (
                    a.dtype != x.dtype or a.ndim != 3 or a.shape[::2] != x.shape[::2] or a.shape[1] not in (1, x.shape[1])):
                shape = "no payload" if a is None else f"{a.dtype} {a.shape}"
                raise ValueError(f"attack frame seq {attack.seq} ({n_cycles(attack)} cycles, {shape}) does not fit "
                                 f"the received {x.dtype} {x.shape}")
            if a is not None:
                x = x + a
            per["attack_active"] = per_cycle(attack).get("attack_active", [False] * x.shape[0])
            extra["attack_model"] = attack.header.get("attack_model", "unknown")
        codes, clipped = adc_codes(self.scene_obj, x)
        per["clipped"] = clipped.tolist()
        return rx.derive(codes, per_cycle=per, **extra)

    def unpaired(self, port: str, frame: Frame) -> Frame | None:
        if port == "attack":
            return None   # an attack for cycles whose signal was lost upstream: counted by the runtime
        out = self.process(frame)   # attacker down: the cycles as received, without attack
        return out.with_header(attack_lost=True)
