"""Range estimator: target range and radial velocity of every clean cycle (Algorithm 1, step 6).

Integrates the ACTIVE chirps only (the frame's "rho" array from the gate); velocity from the phase
progression over the randomly missing active chirps. Methods: fft_peak, fft_zeropad, fft_interp, music,
root_music, ml (see carav_stream/estimate). A frame that does not carry the gate's clean verdict is refused
(counted, and reported as a record with refused = true): target processing never runs without a verdict.

Ports   in  frames      clean_frame: float32 | complex64 (n_chirps, n_samples) + array rho
        out estimates   header range_m, velocity_mps (lists, one per target), method
Graph   ranging = { type = "range_estimator", method = "root_music" }
"""
import math

import numpy as np

from carav_stream.block import Block, In, Out, Param
from carav_stream.radar.streams import scene_of
from carav_stream.estimate.estimators import METHODS, estimate
from carav_stream.estimate.geometry import Geometry
from carav_stream.frames import Frame


class RangeEstimator(Block):
    inputs = (In("frames", kind="clean_frame", dtypes=("float32", "complex64")),)
    outputs = (Out("estimates", kind="estimates", dtypes=("none",)),)
    params = (Param("method", str, "ml", "estimator", choices=METHODS),
              Param("n_targets", int, 1, "targets per cycle", low=1),
              Param("scene", str, "table1", "preset name or scene file"))

    def check_params(self) -> None:
        self.geometry = Geometry.from_scene(scene_of(self.scene))

    def start(self) -> None:
        self.refused = 0

    def process(self, frames: Frame) -> Frame:
        rho = frames.arrays.get("rho")
        if frames.header.get("verdict") != "clean" or rho is None:
            self.refused += 1
            return frames.derive(None, refused=True, reason="no clean verdict")
        est = estimate(frames.payload[None], np.asarray(rho, dtype=bool)[None], self.geometry,
                       method=self.method, n_targets=self.n_targets)
        clean = lambda xs: [None if math.isnan(x) else float(x) for x in xs]
        return frames.derive(None, range_m=clean(est.range_m[0]), velocity_mps=clean(est.velocity_mps[0]),
                             method=self.method)

    def summary(self) -> dict:
        return {"refused": self.refused}
