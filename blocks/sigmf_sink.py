"""SigMF recorder: the ADC's output of every cycle as a SigMF recording, the activation sequences in a private log.

    BASE.sigmf-data   the ADC's codes, cycle after cycle (ri16_le | ci16_le; rf32_le | cf32_le for an ideal ADC);
                      a receiver array's as SigMF's channels, core:num_channels = n_rx, interleaved sample by
                      sample: each cycle (n_chirps, n_samples, n_rx) in C order
    BASE.sigmf-meta   sample rate, carrier, the scene's chirp structure (with an array its geometry: carav:n_rx,
                      rx_positions_wl, tx_positions_wl, tdm_schedule), the graph and its seed, the software
                      version; one annotation per cycle: attack on or off and its model, clipped and non-finite
                      counts, the detector's verdict and Q (an array's also: the attacker's azimuth, its
                      deviation and reason), the gate's decision, the estimates (an array's also: the targets'
                      azimuths and deviations), and with a tracker the tracks after the cycle (track_id,
                      track_status, track_range_m, track_velocity_mps, track_var_range_m2,
                      track_var_velocity_m2ps2, and track_nis_alarm when the alarm is on: one value per live track)
    BASE.activation   the activation sequence of every cycle: firmware state, mode 0600, never in the two above

The samples are written as they arrive; the metadata and the log when the stream ends (format: carav_stream/
capture/sigmf_io.py), from what the recorder holds in memory. A recorder is therefore never restarted: a graph
that gives it a restart policy other than "never" is refused when it is validated (the run fails instead, and
its recording has no metadata, which `carav replay` refuses). `carav record GRAPH --out DIR` adds this block to
a graph and wires it, with restart "never"; `carav replay DIR` runs the recording through detection and ranging
again.

Ports   in  frames     ADC frames (cycles, [n_rx,] n_chirps, n_samples[, 2]): int16 codes, or float32 | complex64
                       samples of an ideal ADC
        in  rho        the activation sequences (the private edge the detector reads)
        in  verdict    the detector's verdicts (optional)           (inputs merged in arrival order,
        in  estimates  the range estimator's records (optional)      matched by cycle index)
        in  alarms     the gate's refusals (optional)
        in  tracks     the tracker's tracks (optional)
Graph   recorder = { type = "sigmf_sink", path = "rec/recording" }
"""
import hashlib
import json
import shutil
from pathlib import Path

import numpy as np

from carav_stream.capture.activation_log import log_path, write_log
from carav_stream.capture.sigmf_io import NS, datatype_of, file_layout, plain, write_meta
from carav_stream.radar.scene_loader import preset_names
from carav_stream.radar.streams import NO_SEED, SCENE, SEED, scene_of
from carav_stream.runtime import Block, Frame, In, Param, cycle_indices, per_cycle, writing

VERDICT_FIELDS = ("alarm", "invalid", "q", "c", "raised_by",   # k_max and rbar stay out: they speak of rho
                  "attack_azimuth_deg", "attack_azimuth_std_deg", "attack_reason")   # a receiver array's only
ADC_FIELDS = ("attack_active", "clipped", "nonfinite")
ESTIMATE_FIELDS = ("range_m", "velocity_mps", "azimuth_deg", "azimuth_std_deg")   # the azimuths: an array's
# the tracker's per-cycle fields -> the annotation's (track_ in front: the estimates have range_m and velocity_mps)
TRACK_FIELDS = {"track_id": "track_id", "status": "track_status", "range_m": "track_range_m",
                "velocity_mps": "track_velocity_mps", "var_range_m2": "track_var_range_m2",
                "var_velocity_m2ps2": "track_var_velocity_m2ps2", "nis_alarm": "track_nis_alarm"}


class SigmfSink(Block):
    inputs = (In("frames", kind="adc_frame", dtypes=("int16", "float32", "complex64")),
              In("rho", kind="rho", dtypes=("bool",)),
              In("verdict", kind="verdict", required=False),
              In("estimates", kind="estimates", required=False),
              In("alarms", kind="alarm", required=False),
              In("tracks", kind="tracks", required=False))
    merge_inputs = True
    not_restartable = ("it writes the recording's metadata and activation log at the end from what it holds in "
                       "memory: a restarted recorder would write a recording without the cycles before the restart")
    params = (Param("path", str, doc="base name of the recording (BASE.sigmf-meta, BASE.sigmf-data)", output=True),
              SCENE, SEED,
              Param("batch", int, 16, "cycles per frame of the recorded graph (metadata)", low=1),
              Param("graph", str, "", "the recorded graph, as JSON (metadata)"))

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)
        if self.graph:
            try:
                json.loads(self.graph)
            except ValueError as exc:
                raise ValueError(f"graph: not JSON: {exc}") from None

    def start(self) -> None:
        self.base = Path(self.path)
        self.data = open(f"{self.base}.sigmf-data", "wb")
        self.hash = hashlib.sha512()
        self.datatype: str | None = None
        self.order: list[int] = []             # recorded cycles, in the order their samples were written
        self.cycle: dict[int, dict] = {}       # cycle -> its annotation fields
        self.rho: dict[int, bytes] = {}        # cycle -> packed activation sequence
        self.bytes = 0

    def _fields(self, cycle: int) -> dict:
        return self.cycle.setdefault(cycle, {})

    def process(self, frames: Frame | None, rho: Frame | None = None, verdict: Frame | None = None,
                estimates: Frame | None = None, alarms: Frame | None = None, tracks: Frame | None = None) -> None:
        if frames is not None:
            self._samples(frames)
        elif tracks is not None:
            per = per_cycle(tracks)
            for i, c in enumerate(cycle_indices(tracks)):
                self._fields(c).update({name: per[k][i] for k, name in TRACK_FIELDS.items()
                                        if per.get(k) is not None and per[k][i] is not None})
        elif rho is not None:
            r = np.asarray(rho.payload, dtype=bool)
            if r.ndim != 2 or r.shape[1] != self.scene_obj.n_chirps or r.shape[0] != len(cycle_indices(rho)):
                raise ValueError(f"rho frame seq {rho.seq}: {r.shape} is not one sequence of "
                                 f"{self.scene_obj.n_chirps} chirps per cycle")
            for c, row in zip(cycle_indices(rho), r):
                self.rho[c] = np.packbits(row).tobytes()
        else:
            frame, names = ((verdict, VERDICT_FIELDS) if verdict is not None else (estimates, ESTIMATE_FIELDS)
                            if estimates is not None else (alarms, ("reason",)))
            per, index = per_cycle(frame), cycle_indices(frame)
            gate = None                        # the gate's decision: clean (it reached ranging) or its reason
            if estimates is not None and not frame.header.get("refused"):
                gate = ["clean"] * len(index)
            elif alarms is not None:
                gate = per.get("reason") or ["refused"] * len(index)
            for i, c in enumerate(index):
                fields = self._fields(c)
                fields.update({k: per[k][i] for k in names if k in per})
                if gate is not None:
                    fields["gate"] = gate[i]

    def _samples(self, frames: Frame) -> None:
        x = frames.payload
        datatype = datatype_of(x, self.scene_obj.iq)
        shape = (*self.scene_obj.frame_shape(1)[1:], *((2,) if datatype == "ci16_le" else ()))
        if self.datatype not in (None, datatype) or x.shape[1:] != shape:
            raise ValueError(f"frame seq {frames.seq}: {x.dtype} {x.shape} does not continue the recording of "
                             f"{self.datatype or datatype} cycles of shape {shape}")
        self.datatype = datatype
        raw = file_layout(x, self.scene_obj.n_rx)
        with writing(self.data.name):
            self.data.write(raw.data)
        self.hash.update(raw.data)             # hashed as written: no second pass over the file at the end
        self.bytes += raw.nbytes
        per = per_cycle(frames)
        for i, c in enumerate(cycle_indices(frames)):
            self.order.append(c)
            fields = self._fields(c)
            fields.update({k: per[k][i] for k in ADC_FIELDS if k in per})
            fields["attack_model"] = frames.header.get("attack_model")
            if frames.header.get("attack_lost"):
                fields["attack_lost"] = True

    def finish(self) -> None:
        with writing(self.data.name):
            self.data.close()
        scene, per_cycle_samples = self.scene_obj, self.scene_obj.n_chirps * self.scene_obj.n_samples
        annotations = []
        for i, c in enumerate(self.order):
            fields = self.cycle.get(c, {})
            annotations.append({"core:sample_start": i * per_cycle_samples, "core:sample_count": per_cycle_samples,
                                "core:label": f"cycle {c}", f"{NS}:cycle": c,
                                **{f"{NS}:{k}": plain(v) for k, v in fields.items()}})
        known = [c for c in self.order if c in self.rho]
        rho = np.array([np.unpackbits(np.frombuffer(self.rho[c], np.uint8))[:scene.n_chirps] for c in known],
                       dtype=bool).reshape(len(known), scene.n_chirps)
        with writing(str(log_path(self.base))):
            write_log(log_path(self.base), known, rho)
        self.without_rho = len(self.order) - len(known)
        preset = self.scene in preset_names()
        extra = {"cycles": len(self.order), "batch": self.batch, "activation_log": log_path(self.base).name,
                 "activation_log_checksum": "sha256",
                 "scene": scene.name if preset else Path(self.scene).name,
                 "graph": json.loads(self.graph) if self.graph else {}}
        if self.seed != NO_SEED:
            extra["seed"] = self.seed
        if not preset:                         # a scene file travels with the recording
            copy = Path(f"{self.base}.scene.toml")
            with writing(str(copy)):
                shutil.copyfile(self.scene, copy)
            extra["scene_file"] = copy.name
        with writing(f"{self.base}.sigmf-meta"):
            write_meta(self.base, self.datatype or datatype_of(np.zeros(0, np.int16), scene.iq), scene, annotations,
                       extra, sha512=self.hash.hexdigest())

    def summary(self) -> dict:
        n = len(self.order)
        return {"run": {"recording": {"meta": f"{self.base}.sigmf-meta", "cycles": n, "bytes": self.bytes,
                                      "bytes_per_cycle": self.bytes // n if n else None,
                                      "cycles_without_activation": getattr(self, "without_rho", 0)}}}
