"""RMS detector: the CARAV cyberattack detector of Section V.A (Algorithm 1, steps 3-5), one verdict per cycle.

    D0(k) = ||R_k||_r / sigma_n                                 on silent chirps (rho(k) = 0)
    D1(k) = | ||R_k||_r - Rbar_rho | / (Rbar_rho + sigma_n)      on active chirps, Rbar_rho = mean active RMS
    Q = max_k D(k),   C(eta) = Q / eta,   alarm  <=>  C(eta) >= 1  or a NaN/Inf sample (invalid frame)

Ports   in  frames    ADC frames of the cycles: int16 codes (the scene's lsb makes them sqrt(W)), or float32 |
                      complex64 samples; a receiver array's (cycles, n_rx, n_chirps, ...) are judged on each
                      chirp's RMS over all its receivers' samples
        in  rho       bool (cycles, n_chirps)    activation sequences (private edge)
        out verdict   bool (cycles, n_chirps) = rho, for target processing; header eta, per_cycle q, c, alarm,
                      invalid, raised_by ("D0" | "D1" | "invalid" | "no_rho" | "bad_rho"), k_max, rbar; frames
                      whose rho never comes get alarm verdicts (reason "no_rho"), never clean ones; a cycle whose
                      rho is not balanced (half its chirps active) or whose ADC reported NaN/Inf input samples
                      (per_cycle nonfinite) gets an invalid verdict; a receiver array's verdicts also carry,
                      for every cycle whatever its verdict, the attacker's azimuth from the first direction_chirps
                      silent chirps (carav_stream/estimate/attacker_direction.py): per_cycle attack_azimuth_deg
                      (NaN without an attack; |azimuth| when mirrored), attack_azimuth_std_deg (its Cramer-Rao
                      deviation) and attack_reason ("estimated" | "no_attack" | "mirrored" | "no_silent" |
                      "invalid" for a cycle with a NaN/Inf sample | "no_rho")
Graph   detector = { type = "rms_detector", eta = 1.5 }
"""
import numpy as np

from carav_stream.detect.detector import PAPER_ETA, adc_chirp_rms, detect_from_rms
from carav_stream.estimate.attacker_direction import REASON_KEYS, attacker_direction
from carav_stream.radar.adc import adc_step, from_codes
from carav_stream.radar.scene_loader import preset_names
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Out, Param, n_cycles, per_cycle


class RmsDetector(Block):
    inputs = (In("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64")),
              In("rho", kind="rho", dtypes=("bool",)))
    outputs = (Out("verdict", kind="verdict", dtypes=("bool",), private=True),)
    params = (Param("eta", float, PAPER_ETA, "threshold of C(eta) = Q / eta", low=0.0, strict=True),
              Param("sigma_n", float, 0.0, "noise RMS per sample; 0 = from the scene", low=0.0),
              Param("direction_chirps", int, 8, "silent chirps per cycle the attacker's azimuth is estimated from "
                    "(receiver arrays)", low=1),
              SCENE)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)
        self.sigma = self.sigma_n or self.scene_obj.sigma_n
        self.lsb = adc_step(self.scene_obj)

    def param_warnings(self) -> list[str]:
        """eta is not universal: its false-alarm rate per cycle depends on the scene (firmware/design.py), and a
        scene's echo can leak into the silent slots (firmware/leak.py). Imported here, where graphs are validated:
        their scipy.stats and scipy.optimize would add their import to every start of the node, which never needs
        them."""
        from carav_stream.firmware.design import scene_law, threshold_warning
        from carav_stream.firmware.leak import leak_warnings

        where = f"--preset {self.scene}" if self.scene in preset_names() else f"--scene {self.scene}"
        text = threshold_warning(scene_law(self.scene_obj), self.eta, self.sigma, who="rms_detector",
                                 design_hint=f"carav design {where}")
        leaks = leak_warnings(self.scene_obj, self.eta, sigma_det=self.sigma, who="rms_detector")
        return ([text] if text else []) + leaks

    def _receivers(self, x: np.ndarray) -> tuple[int, bool]:
        """(axes of one receiver's frames: cycles, chirps, samples[, 2 for int16 I/Q codes]; whether the scene's
        frames hold one axis more, the receivers' (n_rx of them), after the cycles')."""
        base = 4 if x.dtype == np.int16 and self.scene_obj.iq else 3
        return base, self.scene_obj.n_rx > 1

    def process(self, frames: Frame, rho: Frame) -> Frame:
        r = np.asarray(rho.payload, dtype=bool)
        x = frames.payload
        base, rx = self._receivers(x)
        if r.ndim != 2 or x.ndim != base + rx or (x.shape[0], x.shape[1 + rx]) != r.shape or (
                rx and x.shape[1] != self.scene_obj.n_rx):
            raise ValueError(f"frame seq {frames.seq}: frames {x.dtype} {x.shape} and rho {r.shape} do not describe "
                             "the same cycles and chirps")
        nonfinite = per_cycle(frames).get("nonfinite")   # the ADC's count of NaN/Inf input samples
        if nonfinite is not None and not (isinstance(nonfinite, list) and len(nonfinite) == r.shape[0]
                                          and all(type(v) is int for v in nonfinite)):
            nonfinite = [1] * r.shape[0]                  # malformed: every cycle is judged invalid (fail closed)
        rms = adc_chirp_rms(x, self.lsb, self.scene_obj.iq, nonfinite, receivers=rx)
        # a sequence without exactly half its chirps active was not made by the source: invalid, alarm
        n, balanced = r.shape[0], r.sum(axis=1) == r.shape[1] // 2
        fields = {"q": np.full(n, np.inf), "c": np.full(n, np.inf), "alarm": np.ones(n, bool),
                  "invalid": np.ones(n, bool), "k_max": np.full(n, -1), "rbar": np.full(n, np.nan)}
        raised_by = np.full(n, "bad_rho", dtype=object)
        if balanced.any():
            d = detect_from_rms(rms[balanced], r[balanced], self.sigma, self.eta)
            for key in fields:
                fields[key][balanced] = getattr(d, key)
            raised_by[balanced] = np.where(d.invalid, "invalid", np.where(d.by_d1, "D1", "D0"))
        direction = self._direction(x, r, rms) if rx else {}
        return frames.derive(r, eta=self.eta, per_cycle={**{k: v.tolist() for k, v in fields.items()},
                                                         "raised_by": raised_by.tolist(), **direction})

    def _direction(self, x: np.ndarray, r: np.ndarray, rms: np.ndarray) -> dict[str, list]:
        """The attacker's azimuth, its deviation and the reason per cycle, from the silent chirps of the cycles
        whose samples are all finite (the others: NaN, reason "invalid")."""
        n = r.shape[0]
        az, std = np.full(n, np.nan), np.full(n, np.nan)
        reason = np.full(n, "invalid", dtype=object)
        ok = np.isfinite(rms).all(axis=1)
        if ok.any():
            samples = x if ok.all() else x[ok]
            if samples.dtype == np.int16 and self.scene_obj.iq:   # I/Q codes: (.., 2) int16 pairs -> complex64
                samples = from_codes(self.scene_obj, samples)
            d = attacker_direction(samples, r[ok], self.scene_obj.rx_positions_wl, max_chirps=self.direction_chirps)
            az[ok], std[ok] = d.azimuth_deg, d.azimuth_std_deg
            reason[ok] = np.asarray(REASON_KEYS, dtype=object)[d.reason]
        return {"attack_azimuth_deg": az.tolist(), "attack_azimuth_std_deg": std.tolist(),
                "attack_reason": reason.tolist()}

    def unpaired(self, port: str, frame: Frame) -> Frame | None:
        if port == "rho":
            return None   # sequences whose frame was lost upstream: counted by the runtime as unpaired
        # frames without their activation sequences cannot be judged: explicit alarms, never clean verdicts
        n, x = n_cycles(frame), frame.payload
        rx = self._receivers(x)[1]
        shape = (x.shape[0], x.shape[2]) if rx else x.shape[:2]
        direction = {"attack_azimuth_deg": [float("nan")] * n, "attack_azimuth_std_deg": [float("nan")] * n,
                     "attack_reason": ["no_rho"] * n} if rx else {}
        return frame.derive(np.zeros(shape, dtype=bool), eta=self.eta, reason="no_rho",
                            per_cycle={"q": [float("inf")] * n, "c": [float("inf")] * n, "alarm": [True] * n,
                                       "invalid": [True] * n, "raised_by": ["no_rho"] * n, "k_max": [-1] * n,
                                       "rbar": [float("nan")] * n, **direction})
