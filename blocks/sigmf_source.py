"""SigMF player: a recording made by `carav record` (sigmf_sink) back into a graph, with its activation log.

Replays the ADC's output cycle by cycle, as the ADC framer sent it (the same per-cycle fields: attack_active,
clipped, nonfinite; header attack_model), and the activation sequences from the private log on their own edge,
so that rms_detector, gate and range_estimator judge the recorded cycles exactly as in the live run: the same
verdicts, Q and estimates, bit for bit, when the batch is the recording's (`carav replay` sets it).

Before anything runs the recording is checked (carav_stream/capture/sigmf_io.py): metadata valid SigMF, datatype
one an ADC writes, data size equal to what the metadata describes, sha512 (verify = true), the log present and
covering every recorded cycle, and the graph's scene describing the recorded samples (chirps, samples, I/Q, ADC
bits and full scale, sample rate, receivers and array geometry). Each problem is one error naming the file and the
field. A receiver array's recording (core:num_channels = n_rx, the receivers interleaved in the data file) is
replayed with the receiver axis after the cycles, as the ADC framer sent it.

Ports   out frames   ADC frames: int16 (cycles, [n_rx,] n_chirps, n_samples[, 2]) or float32 | complex64 samples
        out rho      bool (cycles, n_chirps): the recorded activation sequences (private edge to the detector)
Graph   source = { type = "sigmf_source", path = "rec" }   (graphs/replay.toml)
"""
import time

import numpy as np

from carav_stream.capture.sigmf_io import NS, check_scene, open_recording, unplain
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, Out, Param

FIELDS = ("attack_active", "clipped", "nonfinite")


class SigmfSource(Block):
    outputs = (Out("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64"), doc="recorded ADC frames"),
               Out("rho", kind="rho", dtypes=("bool",), doc="recorded activation sequences (private)", private=True))
    params = (Param("path", str, doc="the recording (BASE, BASE.sigmf-meta or a folder)", file=True),
              Param("activation", str, "", "activation log; empty: BASE.activation", file=True),
              Param("paced", bool, False, "release cycles at the radar's cycle rate"),
              Param("verify", bool, True, "check the data's sha512 before replaying"),
              SCENE,
              Param("batch", int, 16, "cycles per frame", low=1, high=4096))

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)
        self.rec = open_recording(self.path, self.activation or None, verify_hash=self.verify)
        check_scene(self.rec, self.scene_obj)

    def start(self) -> None:
        a = self.rec.annotations
        self.per = {k: [unplain(x.get(f"{NS}:{k}")) for x in a] for k in FIELDS}
        self.model = [x.get(f"{NS}:attack_model") for x in a]
        self.t0 = time.monotonic()

    def ready_in(self, seq: int) -> float:
        return self.t0 + seq * self.batch * self.scene_obj.t_cycle_s - time.monotonic() if self.paced else 0.0

    def generate(self, seq: int) -> dict[str, Frame] | None:
        first = seq * self.batch
        n = min(self.batch, self.cycle_budget or self.batch, len(self.rec.cycles) - first)
        if n <= 0:
            return None
        rows = slice(first, first + n)
        cycles = self.rec.cycles[rows].tolist()
        per = {k: v[rows] for k, v in self.per.items() if all(x is not None for x in v[rows])}
        if cycles != list(range(cycles[0], cycles[0] + n)):
            per["cycle_index"] = cycles   # cycles the recording skipped (lost upstream live): named one by one
        header = {"cycle": cycles[0], "cycles": n, "per_cycle": per}
        models = set(self.model[rows]) - {None}
        if len(models) == 1:
            header["attack_model"] = models.pop()
        frames = Frame.of(np.array(self.rec.samples[rows], order="C"), **header)   # an array's: deinterleaved
        return {"frames": frames, "rho": Frame.of(self.rec.rho[rows].copy(), cycle=cycles[0], cycles=n,
                                                   **({"per_cycle": {"cycle_index": cycles}}
                                                      if "cycle_index" in per else {}))}

    def summary(self) -> dict:
        return {"run": {"replayed": {"meta": f"{self.rec.base}.sigmf-meta", "recorded_cycles": len(self.rec.cycles)}}}
