"""Range estimator: target range and radial velocity of every clean cycle (Algorithm 1, step 6).

Integrates the ACTIVE chirps only (the frame's "rho" array from the gate); velocity from the phase
progression over the randomly missing active chirps. Methods: fft_peak, fft_zeropad, fft_interp, music,
root_music, ml (see carav_stream/estimate). A frame that does not carry the gate's clean verdict is refused
(counted, and reported as a record with refused = true): target processing never runs without a verdict.

Ports   in  frames      clean_frame: ADC frames (int16 codes or float32 | complex64 samples) of the clean
                        cycles + array rho
        out estimates   header method, per_cycle range_m, velocity_mps (lists, one value per target; None
                        where no target was found) beside the frame's own per-cycle fields
Graph   ranging = { type = "range_estimator", method = "root_music" }
"""
import math

import numpy as np

from carav_stream.estimate.estimators import METHODS, estimate
from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.adc import from_codes
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Out, Param, n_cycles, pick


def _plain(values: np.ndarray) -> list:
    return [[None if math.isnan(x) else float(x) for x in row] for row in values]


class RangeEstimator(Block):
    inputs = (In("frames", kind="clean_frame", dtypes=("int16", "float32", "complex64")),)
    outputs = (Out("estimates", kind="estimates", dtypes=("none",)),)
    params = (Param("method", str, "ml", "estimator", choices=METHODS),
              Param("n_targets", int, 1, "targets per cycle", low=1),
              SCENE)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)
        self.geometry = Geometry.from_scene(self.scene_obj)

    def start(self) -> None:
        self.refused = 0

    def process(self, frames: Frame) -> Frame:
        rho = frames.arrays.get("rho")
        n = n_cycles(frames)
        if frames.header.get("verdict") != "clean" or rho is None or frames.payload is None:
            self.refused += n
            return frames.derive(None, refused=True, reason="no clean verdict")
        x = from_codes(self.scene_obj, frames.payload)
        if x.ndim != 3 or rho.shape != x.shape[:2] or x.shape[0] != n:
            raise ValueError(f"frame seq {frames.seq}: {n} cycles, frames {x.shape} and rho {rho.shape} disagree")
        est = estimate(x, np.asarray(rho, dtype=bool), self.geometry, method=self.method, n_targets=self.n_targets)
        return frames.derive(None, method=self.method, per_cycle=pick(
            frames, range(n), range_m=_plain(est.range_m), velocity_mps=_plain(est.velocity_mps)))

    def summary(self) -> dict:
        return {"refused": self.refused}
