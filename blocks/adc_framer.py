"""ADC framer: quantisation to the scene's bits and full scale, clipping, and framing of each cycle.

    frame[k, m] = clip(round(R_k[m] / lsb), -2^(b-1), 2^(b-1) - 1) * lsb    (I and Q separately)

The beat signal reaches this node already dechirped (mixing and low-pass filtering happen in the channel
at waveform fidelity); a strong attacker saturates the ADC and the clipped-sample count is recorded.

Ports   in  rx       float32 | complex64 (n_chirps, n_samples)   signal at the ADC input
        out frames   same dtype and shape                        ADC frame of one cycle; header clipped
Graph   adc = { type = "adc_framer" }
"""
from carav_stream.block import Block, In, Out, Param
from carav_stream.radar.streams import scene_of
from carav_stream.frames import Frame
from carav_stream.radar.synth import adc


class AdcFramer(Block):
    inputs = (In("rx", kind="rx", dtypes=("float32", "complex64")),)
    outputs = (Out("frames", kind="adc_frame", dtypes=("float32", "complex64")),)
    params = (Param("scene", str, "table1", "preset name or scene file (ADC bits, full scale)"),)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)

    def process(self, rx: Frame) -> Frame:
        frames, clipped = adc(self.scene_obj, rx.payload[None])
        return rx.derive(frames[0], clipped=int(clipped[0]))
