"""DCA1000 player: raw ADC captures of a TI radar (DCA1000 .bin) into the detector and estimator.

Reads the .bin layouts TI documents (2 LVDS lanes for xWR16xx/18xx/68xx, 4 for xWR12xx/14xx; real or complex;
two's complement or offset binary; 12, 14 or 16 bits: carav_stream/capture/dca1000.py), cuts it into cycles of
the scene's n_chirps chirps, keeps receiver `rx` (a scene with one receiver) or the scene's receivers (`receivers`:
all the capture's by default, with a receiver axis, for a scene whose rx_positions_wl name several; a capture whose
receivers contradict the scene is refused), and sends each cycle as this project's ADC frames, with the
activation sequence of every cycle from a log the capture's firmware wrote (carav_stream/capture/activation_log.py)
or the fixed pattern of a TI profile's chirps (`carav scenes --from-ti-cfg` prints it; a fixed pattern is not the
secret per-cycle sequence the detector needs against an attacker who learns it), so that rms_detector, gate and
range_estimator run on a real radar's samples when its firmware silenced chirps. Exactly one of `activation`
(the log) and `pattern` is given; with a TDM scene every loop of its n_slots chirps is active or silent as a whole.

The scene file describes the capture's chirp configuration: n_chirps (chirps per cycle), n_samples, fs_hz,
slope (bandwidth_hz / t_sweep_s), t_chirp_s, iq (true: complex capture), adc_bits (12, 14 or 16) and
adc_full_scale (the volts, or sqrt(W), of one full-scale code; the detector's sigma_n is in the same unit).
A capture that ends within a cycle (truncated) is warned about when the graph is validated; its whole cycles are
all sent, and then the node fails with an error naming the file and the bytes left over. A layout that does not
seem to fit the capture (codes of the other encoding, unequal lanes, receivers or chirps) is warned about with
the likely fix (carav_stream/capture/inspect.py, on the first cycles).

Ports   out frames   int16 (cycles, n_chirps, n_samples[, 2]): receiver rx's codes; (cycles, receivers, n_chirps,
                     n_samples[, 2]) for a scene with several receivers
        out rho      bool (cycles, n_chirps): the activation sequences (private edge to the detector)
Graph   source = { type = "dca1000_source", path = "adc_data.bin", activation = "adc_data.activation" }
"""
from pathlib import Path

import numpy as np

from carav_stream.capture.activation_log import capture_activation
from carav_stream.capture.dca1000 import (
    CAPTURE_PARAMS,
    capture_layout,
    capture_receivers,
    check_loops,
    complete_cycles,
    read_cycles,
)
from carav_stream.capture.inspect import layout_warnings
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, BlockError, Frame, Out, Param


class Dca1000Source(Block):
    outputs = (Out("frames", kind="adc_frame", dtypes=("int16",), doc="ADC codes per cycle: rx's, or the scene's "
                                                                       "receivers'"),
               Out("rho", kind="rho", dtypes=("bool",), doc="activation sequences (private)", private=True))
    params = (Param("path", str, doc="DCA1000 .bin capture", file=True),
              *CAPTURE_PARAMS,
              SCENE,
              Param("batch", int, 16, "cycles per frame", low=1, high=4096))

    def check_params(self) -> None:
        scene = scene_of(self.scene)
        self.layout = capture_layout(scene, self.n_rx, self.lanes, self.encoding)
        self.chosen = capture_receivers(scene, self.n_rx, self.rx, self.receivers)
        if not Path(self.path).is_file():
            raise ValueError(f"path: {self.path}: capture file not found")
        self.cycles, self.left = complete_cycles(self.path, self.layout)
        fixed, self.log_cycles, self.rho = capture_activation(self.activation, self.pattern, scene.n_chirps)
        self.n_slots = scene.n_slots
        check_loops(fixed[None] if fixed is not None else self.rho, self.n_slots,
                    "pattern" if fixed is not None else f"activation: {self.activation}")
        if fixed is not None:
            self.log_cycles, self.rho = np.arange(self.cycles), np.tile(fixed, (self.cycles, 1))
            return
        if len(self.log_cycles) < self.cycles:
            raise ValueError(f"activation: {self.activation}: {len(self.log_cycles)} cycles, shorter than the "
                             f"capture's {self.cycles} whole cycles ({self.path})")
        bad = np.flatnonzero(self.log_cycles[:self.cycles] != np.arange(self.cycles))
        if bad.size:
            raise ValueError(f"activation: {self.activation}: row {bad[0]} is cycle {self.log_cycles[bad[0]]}; a "
                             "capture's log lists cycles 0, 1, 2, ... in capture order")

    def param_warnings(self) -> list[str]:
        first = min(self.cycles, 8)
        words = np.fromfile(self.path, dtype="<i2", count=first * self.layout.bytes_per_cycle // 2)
        codes = read_cycles(self.path, self.layout, 0, first, None)
        doubts = layout_warnings(self.path, Path(self.path).stat().st_size, words, self.layout, codes,
                                 self.rho[:first], self.n_slots)
        return ([self._truncated()] if self.left else []) + [w for w in doubts if "whole number of cycles" not in w]

    def _truncated(self) -> str:
        return (f"{self.path} is truncated: {self.left} bytes after its {self.cycles} whole cycles are not a cycle "
                f"({self.layout.bytes_per_cycle} bytes: {self.layout.n_chirps} chirps x {self.n_rx} receivers x "
                f"{self.layout.n_samples} {'complex' if self.layout.complex else 'real'} int16 samples)")

    def generate(self, seq: int) -> dict[str, Frame] | None:
        first = seq * self.batch
        n = min(self.batch, self.cycle_budget or self.batch, self.cycles - first)
        if n <= 0:
            if self.left:
                raise BlockError(self._truncated() + f"; cycles 0..{self.cycles - 1} were sent")
            return None
        codes = read_cycles(self.path, self.layout, first, n, self.chosen)
        header = {"cycle": first, "cycles": n}
        return {"frames": Frame.of(codes, **header), "rho": Frame.of(self.rho[first:first + n].copy(), **header)}

    def summary(self) -> dict:
        return {"run": {"capture": {"file": str(self.path), "whole_cycles": self.cycles,
                                    "bytes_left_over": self.left}}}
