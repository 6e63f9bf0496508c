"""RMS detector: the CARAV cyberattack detector of Section V.A (Algorithm 1, steps 3-5), one verdict per cycle.

    D0(k) = ||R_k||_r / sigma_n                                 on silent chirps (rho(k) = 0)
    D1(k) = | ||R_k||_r - Rbar_rho | / (Rbar_rho + sigma_n)      on active chirps, Rbar_rho = mean active RMS
    Q = max_k D(k),   C(eta) = Q / eta,   alarm  <=>  C(eta) >= 1  or a NaN/Inf sample (invalid frame)

Ports   in  frames    float32 | complex64 (n_chirps, n_samples)   ADC frame of one cycle
        in  rho       bool (n_chirps,)                            activation sequence (private edge)
        out verdict   bool (n_chirps,) = rho, for target processing; header q, c, eta, alarm, invalid,
                      raised_by ("D0" | "D1" | "invalid" | "no_rho"), k_max, rbar; a frame whose rho never
                      comes gets an alarm verdict (reason "no_rho"), never a clean one
Params  eta (float, 1.5): threshold; sigma_n (float, 0 = the scene's noise RMS)
Graph   detector = { type = "rms_detector", eta = 1.5 }
"""
import numpy as np

from carav_stream.block import Block, In, Out, Param
from carav_stream.radar.streams import scene_of
from carav_stream.detect.detector import detect
from carav_stream.frames import Frame


class RmsDetector(Block):
    inputs = (In("frames", kind="adc_frame", dtypes=("float32", "complex64")),
              In("rho", kind="rho", dtypes=("bool",)))
    outputs = (Out("verdict", kind="verdict", dtypes=("bool",)),)
    params = (Param("eta", float, 1.5, "threshold of C(eta) = Q / eta", low=0.0, strict=True),
              Param("sigma_n", float, 0.0, "noise RMS per sample; 0 = from the scene", low=0.0),
              Param("scene", str, "table1", "preset name or scene file"))

    def check_params(self) -> None:
        self.sigma = self.sigma_n or scene_of(self.scene).sigma_n

    def process(self, frames: Frame, rho: Frame) -> Frame:
        r = np.asarray(rho.payload, dtype=bool)
        d = detect(frames.payload[None], r[None], self.sigma, self.eta)
        invalid = bool(d.invalid[0])
        raised_by = "invalid" if invalid else ("D1" if d.by_d1[0] else "D0")
        return frames.derive(r, q=float(d.q[0]), c=float(d.c[0]), eta=self.eta, alarm=bool(d.alarm[0]),
                             invalid=invalid, raised_by=raised_by, k_max=int(d.k_max[0]), rbar=float(d.rbar[0]))

    def unpaired(self, port: str, frame: Frame) -> Frame | None:
        if port == "rho":
            return None   # a sequence whose frame was lost upstream: counted by the runtime as unpaired
        # a frame without its activation sequence cannot be judged: an explicit alarm, never a clean verdict
        return frame.derive(np.zeros(frame.payload.shape[0], dtype=bool), q=float("inf"), c=float("inf"),
                            eta=self.eta, alarm=True, invalid=True, raised_by="no_rho", reason="no_rho",
                            k_max=-1, rbar=float("nan"))
