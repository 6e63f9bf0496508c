"""Toy detector: rms_detector's own verdicts up to frame seq `at_seq`, where it raises (a crashed detector).

Graph   detector = { type = "crashing_detector", at_seq = 3 }
"""
from carav_blocks.rms_detector import RmsDetector
from carav_stream.runtime.block import Param
from carav_stream.runtime.frames import Frame


class CrashingDetector(RmsDetector):
    params = (*RmsDetector.params, Param("at_seq", int, 3, "frame seq at which to raise", low=0))

    def process(self, frames: Frame, rho: Frame) -> Frame:
        if frames.seq >= self.at_seq:
            raise RuntimeError(f"deliberate detector crash at seq {frames.seq}")
        return super().process(frames, rho)
