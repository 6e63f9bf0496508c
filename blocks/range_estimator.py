"""Range estimator: target range and radial velocity of every clean cycle (Algorithm 1, step 6).

Integrates the ACTIVE chirps only (the frame's "rho" array from the gate); velocity from the phase
progression over the randomly missing active chirps. Methods: METHODS of carav_stream/estimate/estimators, one
file each there (its docstring the method's mathematics). A frame that does not carry the gate's clean verdict is
refused (counted, and reported as a record with refused = true): target processing never runs without a verdict.

Detection: "strongest" reports the n_targets strongest maxima of every cycle; "ca_cfar" | "os_cfar" reports the
radar's target list (carav_stream/firmware/target_list.py): CFAR on the range-Doppler map of the active chirps at the
design false-alarm rate `pfa` per cell, every detection refined by `method` (ml, music, root_music: jointly; the
FFT methods keep the cells), up to max_targets, a variable number per cycle.

Range migration: with max_speed_mps > 0 every target (strongest maxima or CFAR list) is refined along its range
walk within the cycle instead (carav_stream/estimate/migration.py): the velocity alias within +-max_speed_mps
whose walk integrates most power is kept, so velocities are unaliased and ranges are those at the cycle's first
chirp; a CFAR list then also leaves out what a stronger target's walk explains. For scenes whose targets cross
range cells within a cycle (awr1642: 3.6 cells at 83 m/s); `method` is then not used.

Antenna arrays: range and velocity come from one virtual element, receiver 0 and the chirps of each TDM loop's
first slot (carav_stream/estimate/virtual_element.py): one transmitter's repetitions, a loop apart. Each target's
azimuth then comes from its cell refined over the whole virtual array, TDM-compensated, by maximum likelihood
(carav_stream/estimate/target_azimuth.py), with its Cramer-Rao standard deviation at the cell's measured SNR.

Ports   in  frames      clean_frame: ADC frames (int16 codes or float32 | complex64 samples) of the clean
                        cycles, (cycles, [n_rx,] n_chirps, n_samples[, 2]), + array rho
        out estimates   header method, detection, per_cycle range_m, velocity_mps (lists, one value per target;
                        "strongest": n_targets values, None where no target was found; CFAR: the listed
                        targets only, and snr_db, amplitude beside them), range_time_s (the instant since the
                        cycle's start the ranges refer to: the active chirps' mean start plus twice the fast-time
                        centre, or that alone with max_speed_mps; estimate/virtual_element.py) beside
                        the frame's own per-cycle fields;
                        with an antenna array also azimuth_deg and azimuth_std_deg, one value per target
Graph   ranging = { type = "range_estimator", method = "root_music" }
        ranging = { type = "range_estimator", detection = "ca_cfar", pfa = 1e-6 }
"""
import math

import numpy as np

from carav_stream.estimate.estimators import METHODS, estimate
from carav_stream.estimate.target_azimuth import target_azimuths
from carav_stream.estimate.virtual_element import element_geometry, range_instant_s, reference_element
from carav_stream.firmware.target_list import KINDS, target_list
from carav_stream.radar.adc import adc_step, from_codes
from carav_stream.radar.scene import aliased_targets, velocity_warning
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Out, Param, n_cycles, pick


def _plain(values: np.ndarray) -> list:
    return [[None if math.isnan(x) else float(x) for x in row] for row in values]


class RangeEstimator(Block):
    inputs = (In("frames", kind="clean_frame", dtypes=("int16", "float32", "complex64")),)
    outputs = (Out("estimates", kind="estimates", dtypes=("none",)),)
    params = (Param("method", str, "ml", "estimator", choices=METHODS),
              Param("n_targets", int, 1, "targets per cycle (detection strongest)", low=1),
              Param("detection", str, "strongest", "which targets exist: the n_targets strongest, or a CFAR list",
                    choices=("strongest", *KINDS)),
              Param("pfa", float, 1e-6, "CFAR design false-alarm rate per range-Doppler cell", low=0.0, high=1.0,
                    strict=True),
              Param("max_targets", int, 8, "longest CFAR list per cycle", low=1, high=64),
              Param("sigma_n", float, 0.0, "noise RMS per sample for the CFAR map; 0 = from the scene", low=0.0),
              Param("max_speed_mps", float, 0.0, "largest range rate to compensate range migration for; 0 = none",
                    unit="m/s", low=0.0),
              SCENE)

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)
        self.geometry = element_geometry(self.scene_obj)

    def param_warnings(self) -> list[str]:
        """A target whose Doppler aliases beyond what max_speed_mps unaliases: its velocity estimates are the alias."""
        scene = self.scene_obj
        return [f"{velocity_warning(scene, i)}, and the range estimator reports that alias unless its max_speed_mps "
                f"(now {self.max_speed_mps:g} m/s) reaches {abs(scene.range_rate_mps(scene.targets[i])):.3g} m/s"
                for i in aliased_targets(scene, self.max_speed_mps)]

    def start(self) -> None:
        self.refused = 0

    def process(self, frames: Frame) -> Frame:
        rho = frames.arrays.get("rho")
        n = n_cycles(frames)
        if frames.header.get("verdict") != "clean" or rho is None or frames.payload is None:
            self.refused += n
            return frames.derive(None, refused=True, reason="no clean verdict")
        x, lsb, sc = frames.payload, None, self.scene_obj
        shape = x.shape[:-1] if x.dtype == np.int16 and sc.iq else x.shape      # (cycles, [n_rx,] chirps, samples)
        if len(shape) != len(sc.frame_shape(n)) or shape[0] != n or rho.shape != (n, shape[-2]) or (
                sc.n_rx > 1 and shape[1] != sc.n_rx):
            raise ValueError(f"frame seq {frames.seq}: {n} cycles, frames {x.shape} and rho {rho.shape} disagree")
        full, rho_full = x, np.asarray(rho, dtype=bool)
        x, rho = reference_element(full, rho_full, sc)
        instant = range_instant_s(rho, self.geometry, migration=self.max_speed_mps > 0).tolist()
        if x.dtype == np.int16 and self.detection == "strongest":   # the estimator reads the active chirps' codes
            lsb = adc_step(sc)
        else:
            x = from_codes(sc, x)
        if self.detection == "strongest":
            est = estimate(x, rho, self.geometry, method=self.method, n_targets=self.n_targets,
                           max_speed_mps=self.max_speed_mps, lsb=lsb)
            fields = {"range_m": _plain(est.range_m), "velocity_mps": _plain(est.velocity_mps),
                      "range_time_s": instant}
            fields.update(self._azimuths(full, rho_full, est.range_m, est.velocity_mps))
            return frames.derive(None, method=self.method, detection=self.detection,
                                 per_cycle=pick(frames, range(n), **fields))
        tl = target_list(x, rho, self.geometry, self.sigma_n or self.scene_obj.sigma_n, detection=self.detection,
                         pfa=self.pfa, method=self.method, max_targets=self.max_targets,
                         max_speed_mps=self.max_speed_mps)
        found = [slice(0, int(k)) for k in tl.n_found]
        columns = {"range_m": tl.range_m, "velocity_mps": tl.velocity_mps, "snr_db": tl.snr_db,
                   "amplitude": tl.amplitude}
        if sc.has_array:
            columns["azimuth_deg"], columns["azimuth_std_deg"] = target_azimuths(
                from_codes(sc, full), rho_full, sc, tl.range_m, tl.velocity_mps)
        lists = {name: [_plain(values[i:i + 1, s])[0] for i, s in enumerate(found)] for name, values in columns.items()}
        return frames.derive(None, method=self.method, detection=self.detection, pfa=self.pfa,
                             per_cycle=pick(frames, range(n), range_time_s=instant, **lists))

    def _azimuths(self, frames: np.ndarray, rho: np.ndarray, range_m: np.ndarray, velocity_mps: np.ndarray) -> dict:
        """per_cycle azimuth_deg and azimuth_std_deg of the targets of an array scene; none for one antenna."""
        sc = self.scene_obj
        if not sc.has_array:
            return {}
        azimuth, std = target_azimuths(from_codes(sc, frames), rho, sc, range_m, velocity_mps)
        return {"azimuth_deg": _plain(azimuth), "azimuth_std_deg": _plain(std)}

    def summary(self) -> dict:
        return {"refused": self.refused}
