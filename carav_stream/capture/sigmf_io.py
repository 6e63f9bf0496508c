"""SigMF recordings of what the ADC delivered: metadata out of a run, and a recording checked before it is replayed.

A recording is three files with one base name (SigMF 1.2, written and validated with the `sigmf` package):
    BASE.sigmf-data     the ADC's output of every recorded cycle, cycle after cycle, chirp after chirp:
                        ri16_le (real codes), ci16_le (I/Q codes), or rf32_le / cf32_le for an ideal ADC
    BASE.sigmf-meta     global: sample rate, datatype, sha512, recorder, the scene's chirp structure
                        (carav:n_chirps, carav:n_samples, ...), the graph with its seed (carav:graph, carav:seed);
                        one capture (core:frequency = the carrier); one annotation per cycle: its index, whether
                        an attack was on and its model, clipped and non-finite sample counts, the detector's
                        verdict and Q, the gate's decision, the estimates, a tracker's tracks (track_id,
                        track_status, track_range_m, ...: one value per live track)
    BASE.activation     the private activation log (activation_log.py, mode 0600); never in the two above.
                        The detector's k_max (the chirp that decided) is left out of the annotations too: with
                        raised_by it would tell whether that chirp was silent, one bit of the sequence per cycle.

A receiver array (a scene with n_rx > 1, frames (cycles, n_rx, n_chirps, n_samples)) is one recording of n_rx
channels, as SigMF lays several channels out in one dataset: global core:num_channels = n_rx and the channels
interleaved sample by sample, so that the data file is (cycles, n_chirps, n_samples, n_rx[, 2]) in C order, what
the sigmf package's reader returns as (samples, n_rx) (a SigMF "sample" spans every channel: the annotations'
core:sample_start and core:sample_count count n_chirps x n_samples per cycle, as for one receiver). The scene's
array geometry goes into the global metadata too (carav:n_rx, carav:rx_positions_wl, carav:tx_positions_wl,
carav:tdm_schedule; written for a scene with an array only, so a one-antenna recording's metadata is as it
was), and a replay's scene must have the same. `open_recording` gives the samples back in the frames' layout,
the receiver axis after the cycles. One receiver: core:num_channels = 1, no geometry fields.

A scene that is not a preset is copied beside the recording (BASE.scene.toml), so a recording travels whole.
Non-finite floats (Q of an invalid cycle is infinite) are written as the strings "inf", "-inf", "nan": JSON has
no such numbers. Every float is written with Python's shortest round-trip repr, so Q reads back bit for bit.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream import __version__
from carav_stream.capture.activation_log import ActivationLogError, log_path, read_log
from carav_stream.radar.scene import Scene

NS = "carav"
EXTENSION = {"name": NS, "version": "1.0.0", "optional": True}
DATATYPES = {"ri16_le": ("<i2", False), "ci16_le": ("<i2", True), "rf32_le": ("<f4", False),
             "cf32_le": ("<c8", False)}   # datatype -> (element dtype, I and Q as a last axis of 2 int16)
SCENE_FIELDS = ("n_chirps", "n_samples", "iq", "adc_bits", "adc_full_scale", "fc_hz", "bandwidth_hz", "t_sweep_s",
                "t_chirp_s", "t_cycle_s", "t_adc_start_s")
CHECKED_FIELDS = ("n_chirps", "n_samples", "iq", "adc_bits", "adc_full_scale")   # what a replay's scene must match
# the array geometry, written for a scene with an array (absent: one antenna, transmitter and slot at 0)
ARRAY_FIELDS = {"rx_positions_wl": (0.0,), "tx_positions_wl": (0.0,), "tdm_schedule": (0,)}


class RecordingError(ValueError):
    """A recording that cannot be replayed; the text names the file and the field."""


def datatype_of(frames: np.ndarray, iq: bool) -> str:
    """The SigMF datatype of an ADC frame payload (cycles, [n_rx,] n_chirps, n_samples[, 2])."""
    if frames.dtype == np.int16:
        return "ci16_le" if iq else "ri16_le"
    if frames.dtype == np.float32:
        return "rf32_le"
    if frames.dtype == np.complex64:
        return "cf32_le"
    raise ValueError(f"ADC frames of dtype {frames.dtype} have no SigMF datatype here (int16, float32, complex64)")


def plain(value: Any) -> Any:
    """A JSON-safe copy: non-finite floats as strings, numpy scalars as Python ones, lists element-wise."""
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def unplain(value: Any) -> Any:
    """The inverse of `plain` for floats written as strings."""
    if isinstance(value, list):
        return [unplain(v) for v in value]
    if value in ("inf", "-inf", "nan"):
        return float(value)
    return value


def scene_globals(scene: Scene) -> dict[str, Any]:
    """The scene's chirp structure, and for a scene with an array its geometry, as carav: global fields."""
    out = {f"{NS}:{k}": getattr(scene, k) for k in SCENE_FIELDS}
    if scene.has_array:
        out[f"{NS}:n_rx"] = scene.n_rx
        out.update({f"{NS}:{k}": list(getattr(scene, k)) for k in ARRAY_FIELDS})
    return out


def file_layout(frames: np.ndarray, n_rx: int) -> np.ndarray:
    """ADC frames (cycles, [n_rx,] n_chirps, n_samples[, 2]) as the data file holds them: little-endian, C order,
    the receivers interleaved innermost (cycles, n_chirps, n_samples, n_rx[, 2]) for n_rx > 1."""
    x = frames.astype(frames.dtype.newbyteorder("<"), copy=False)
    return np.ascontiguousarray(np.moveaxis(x, 1, 3) if n_rx > 1 else x)


def write_meta(base: Path, datatype: str, scene: Scene, annotations: list[dict[str, Any]],
               extra: dict[str, Any], sha512: str | None = None) -> Path:
    """Write and validate BASE.sigmf-meta for the data file BASE.sigmf-data: its sha512 as given (computed while the
    data was written), else by the sigmf package reading the file."""
    import sigmf
    from sigmf.sigmffile import SigMFFile

    glob = {"core:datatype": datatype, "core:sample_rate": scene.fs_hz, "core:version": sigmf.__specification__,
            "core:num_channels": scene.n_rx, "core:recorder": f"carav-stream {__version__}",
            "core:extensions": [EXTENSION],
            "core:description": f"ADC output of a carav-stream radar graph, scene {scene.name}",
            **scene_globals(scene), **{f"{NS}:{k}": plain(v) for k, v in extra.items()}}
    meta = {"global": glob, "captures": [{"core:sample_start": 0, "core:frequency": scene.fc_hz}],
            "annotations": annotations}
    if sha512 is not None:
        glob["core:sha512"] = sha512
    data_file = Path(str(base) + ".sigmf-data")
    # sigmf maps the data file to check its size: an empty one (a recorder that received no frame) cannot be mapped
    rec = SigMFFile(metadata=meta, data_file=str(data_file) if data_file.stat().st_size else None,
                    skip_checksum=sha512 is not None)
    rec.tofile(str(base), overwrite=True)                                    # validates against the schema
    return Path(str(base) + ".sigmf-meta")


def base_of(path: str | Path) -> Path:
    """The base name of a recording given as BASE, BASE.sigmf-meta, BASE.sigmf-data, or a folder holding one."""
    path = Path(path)
    if path.is_dir():
        metas = sorted(path.glob("*.sigmf-meta"))
        if len(metas) != 1:
            raise RecordingError(f"{path}: a folder with {'no' if not metas else len(metas)} SigMF recordings "
                                 "(.sigmf-meta); name the one to read")
        path = metas[0]
    if path.suffix in (".sigmf-meta", ".sigmf-data"):
        path = path.with_suffix("")
    return path


@dataclass
class Recording:
    """A recording, checked: its samples as a read-only map in the frames' layout (cycles, [n_rx,] n_chirps,
    n_samples[, 2]; the receiver axis a view of the file's interleaved channels), one annotation per recorded
    cycle, the global metadata, and (with the log) the activation sequence of every cycle."""

    base: Path
    meta: dict[str, Any]
    samples: np.ndarray
    cycles: np.ndarray                       # recorded cycle index of every row of `samples`
    annotations: list[dict[str, Any]]
    n_rx: int = 1                            # receivers (core:num_channels)
    rho: np.ndarray | None = None            # bool (cycles, n_chirps), from the private log
    scene_file: Path | None = None           # the copied scene, when the recording's scene is not a preset
    problems: list[str] = field(default_factory=list)

    def global_field(self, key: str, default: Any = None) -> Any:
        return self.meta["global"].get(f"{NS}:{key}", default)

    @property
    def scene_ref(self) -> str:
        """What a graph's `scene` must say to replay this recording: the preset name or the copied file."""
        return str(self.scene_file) if self.scene_file else self.global_field("scene")


def _field(meta_path: Path, glob: dict, key: str, kind: type, optional: bool = False) -> Any:
    value = glob.get(key)
    if optional and key not in glob:
        return None
    if type(value) is not kind:   # exactly: a bool is no count, an int no flag
        name = {dict: "table", list: "list"}.get(kind, kind.__name__)
        raise RecordingError(f"{meta_path}: global {key}: expected {name}, got {value!r:.60}")
    return value


def _carav_globals(meta_path: Path, glob: dict) -> None:
    """The carav: global fields a replay reads, each of its type (RecordingError naming the field otherwise)."""
    _field(meta_path, glob, f"{NS}:scene", str)
    for key, kind in (("scene_file", str), ("batch", int), ("seed", int), ("cycles", int), ("graph", dict)):
        _field(meta_path, glob, f"{NS}:{key}", kind, optional=True)
    nodes = glob.get(f"{NS}:graph", {}).get("nodes", {})
    if type(nodes) is not dict or not all(type(n) is dict for n in nodes.values()):
        raise RecordingError(f"{meta_path}: global {NS}:graph: nodes: expected a table of tables (node: its "
                             f"parameters), got {nodes!r:.60}")


def _receivers(meta_path: Path, glob: dict) -> int:
    """The receivers of a recording: core:num_channels (1 when absent), which carav:n_rx must repeat when given;
    the array geometry's fields, when given, lists of numbers (the transmitters' schedule of integers)."""
    n_rx = glob.get("core:num_channels", 1)
    recorded = _field(meta_path, glob, f"{NS}:n_rx", int, optional=True)
    if recorded is not None and recorded != n_rx:
        raise RecordingError(f"{meta_path}: global {NS}:n_rx = {recorded}, but core:num_channels = {n_rx}: the "
                             "receivers and the data's channels must be the same")
    for key, default in ARRAY_FIELDS.items():
        value = _field(meta_path, glob, f"{NS}:{key}", list, optional=True)
        kinds = (int,) if isinstance(default[0], int) else (int, float)
        if value is not None and (not value or not all(type(v) in kinds for v in value)):
            raise RecordingError(f"{meta_path}: global {NS}:{key}: expected a list of "
                                 f"{'integers' if kinds == (int,) else 'numbers'}, got {value!r:.60}")
    return n_rx


def _check_layout(meta_path: Path, meta: Any) -> None:
    """SigMF's top level: a table whose global is a table and whose captures and annotations are lists (what the
    sigmf library assumes before its schema check runs)."""
    if type(meta) is not dict:
        raise RecordingError(f"{meta_path}: not valid SigMF: metadata: expected a table, got {type(meta).__name__}")
    for key, kind in (("global", dict), ("captures", list), ("annotations", list)):
        if key in meta and type(meta[key]) is not kind:
            raise RecordingError(f"{meta_path}: not valid SigMF: {key}: expected a "
                                 f"{'table' if kind is dict else 'list'}, got {type(meta[key]).__name__}")


def _read_meta(meta_path: Path) -> tuple[dict[str, Any], Any]:
    """The metadata of a recording as JSON and as a sigmf.SigMFFile, validated against SigMF's schema."""
    import sigmf
    from jsonschema.exceptions import ValidationError
    from sigmf.error import SigMFError

    try:
        meta = json.loads(meta_path.read_text())
        _check_layout(meta_path, meta)
        rec = sigmf.SigMFFile(metadata=meta)
        rec.validate()
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise RecordingError(f"{meta_path}: not a valid SigMF metadata file: {str(exc).splitlines()[0]}") from None
    except ValidationError as exc:   # the schema's verdict, located: global/core:sample_rate, annotations/3/...
        where = "/".join(str(p) for p in exc.absolute_path) or "metadata"
        raise RecordingError(f"{meta_path}: not valid SigMF: {where}: {exc.message}") from None
    except SigMFError as exc:
        raise RecordingError(f"{meta_path}: {exc}") from None
    return meta, rec


def _cycles(meta_path: Path, data_path: Path, annotations: list, datatype: str, n_chirps: int,
            n_samples: int, n_rx: int = 1) -> np.ndarray:
    """The recorded cycle index of every row, once the data file's size fits the annotations and every annotation
    covers its own cycle's samples (a sample: every receiver's)."""
    dtype, pair = DATATYPES[datatype]
    per_cycle = n_chirps * n_samples
    cycle_bytes = per_cycle * n_rx * np.dtype(dtype).itemsize * (2 if pair else 1)
    size = data_path.stat().st_size
    if size != len(annotations) * cycle_bytes:
        receivers = f" x {n_rx} receivers" if n_rx > 1 else ""
        raise RecordingError(f"{data_path}: {size} bytes, but the metadata ({meta_path.name}: annotations) describes "
                             f"{len(annotations)} cycles of {cycle_bytes} bytes ({n_chirps} chirps x {n_samples} "
                             f"samples{receivers}, {datatype}) = {len(annotations) * cycle_bytes} bytes")
    cycles = []
    for i, a in enumerate(annotations):
        start, count, cycle = a.get("core:sample_start"), a.get("core:sample_count"), a.get(f"{NS}:cycle")
        if start != i * per_cycle or count != per_cycle or not isinstance(cycle, int):
            raise RecordingError(f"{meta_path}: annotations[{i}]: expected core:sample_start {i * per_cycle}, "
                                 f"core:sample_count {per_cycle} and an integer {NS}:cycle, got {start}, {count}, "
                                 f"{cycle!r}")
        cycles.append(cycle)
    return np.array(cycles, dtype=np.int64)


def _verify_hash(rec: Any, data_path: Path) -> None:
    from sigmf.error import SigMFError

    if data_path.stat().st_size == 0:      # a recording of no cycle: sigmf cannot map an empty file
        if rec.get_global_field("core:sha512") != hashlib.sha512(b"").hexdigest():
            raise RecordingError(f"{data_path}: empty, but global core:sha512 is not the hash of no data")
        return
    try:
        rec.set_data_file(str(data_path))   # recomputes the sha512 and compares it with core:sha512
    except SigMFError as exc:
        raise RecordingError(f"{data_path}: {exc} (global core:sha512)") from None


def _activation(log: Path, cycles: np.ndarray, n_chirps: int, meta_path: Path, checksum: bool) -> np.ndarray:
    """rho of every recorded cycle from the private log, which must list the recording's cycles, row by row (and
    carry its checksum when the recording says it was written with one)."""
    try:
        log_cycles, rho = read_log(log, n_chirps, require_checksum=checksum)
    except ActivationLogError as exc:
        raise RecordingError(str(exc)) from None
    if len(log_cycles) < len(cycles):
        raise RecordingError(f"{log}: {len(log_cycles)} cycles, shorter than the recording's {len(cycles)} "
                             f"({meta_path.name}: annotations)")
    if not np.array_equal(log_cycles[:len(cycles)], cycles) or len(log_cycles) > len(cycles):
        where = next((i for i in range(min(len(cycles), len(log_cycles)))
                      if log_cycles[i] != cycles[i]), min(len(cycles), len(log_cycles)))
        raise RecordingError(f"{log}: cycle {log_cycles[where] if where < len(log_cycles) else 'none'} at "
                             f"row {where}, but the recording's row {where} is cycle "
                             f"{cycles[where] if where < len(cycles) else 'none'}: the log belongs to "
                             "another recording")
    return rho


def open_recording(path: str | Path, activation: str | Path | None = None, *, with_log: bool = True,
                   verify_hash: bool = True, require_hash: bool | None = None) -> Recording:
    """Read and check a recording (and its activation log): RecordingError naming the file and field.
    verify_hash  compare the data with core:sha512; require_hash  refuse a recording without core:sha512 (default:
    as verify_hash; a caller that leaves the comparison to the player still refuses a recording it cannot check)."""
    base = base_of(path)
    meta_path, data_path = Path(f"{base}.sigmf-meta"), Path(f"{base}.sigmf-data")
    for p in (meta_path, data_path):
        if not p.is_file():
            raise RecordingError(f"{p}: not found (a recording is BASE.sigmf-meta beside BASE.sigmf-data)")
    meta, rec = _read_meta(meta_path)
    glob = meta["global"]
    datatype = glob.get("core:datatype")
    if datatype not in DATATYPES:
        raise RecordingError(f"{meta_path}: global core:datatype: {datatype!r} is not what an ADC of this project "
                             f"writes ({', '.join(DATATYPES)})")
    if (verify_hash if require_hash is None else require_hash) and "core:sha512" not in glob:
        raise RecordingError(f"{meta_path}: global core:sha512: missing, so the samples cannot be checked "
                             "(verify = false on the player replays them unchecked)")
    _carav_globals(meta_path, glob)
    n_chirps = _field(meta_path, glob, f"{NS}:n_chirps", int)
    n_samples = _field(meta_path, glob, f"{NS}:n_samples", int)
    iq = _field(meta_path, glob, f"{NS}:iq", bool)
    dtype, pair = DATATYPES[datatype]
    if datatype.startswith("c") != iq:
        raise RecordingError(f"{meta_path}: global core:datatype {datatype} does not fit carav:iq = {iq}")
    n_rx = _receivers(meta_path, glob)
    annotations = meta.get("annotations", [])
    cycles = _cycles(meta_path, data_path, annotations, datatype, n_chirps, n_samples, n_rx)
    if verify_hash:
        _verify_hash(rec, data_path)
    shape = (n_chirps, n_samples, *((n_rx,) if n_rx > 1 else ()), *((2,) if pair else ()))
    samples = np.memmap(data_path, dtype=dtype, mode="r", shape=(len(annotations), *shape)) if annotations else \
        np.zeros((0, *shape), dtype=dtype)
    if n_rx > 1:                           # the file's interleaved channels as the frames' receiver axis (a view)
        samples = np.moveaxis(samples, 3, 1)
    out = Recording(base, meta, samples, cycles, annotations, n_rx)
    scene_file = glob.get(f"{NS}:scene_file")
    if scene_file:
        out.scene_file = base.parent / scene_file
        if not out.scene_file.is_file():
            raise RecordingError(f"{meta_path}: global {NS}:scene_file: {out.scene_file} not found")
    if with_log:
        checksum = glob.get(f"{NS}:activation_log_checksum") == "sha256"
        out.rho = _activation(Path(activation) if activation else log_path(base), out.cycles, n_chirps, meta_path,
                              checksum)
    return out


def check_scene(rec: Recording, scene: Scene) -> None:
    """A replay's scene must describe the recorded samples (their chirp structure, ADC, receivers and the array
    geometry): RecordingError naming the field otherwise."""
    for key in CHECKED_FIELDS:
        recorded, own = rec.global_field(key), getattr(scene, key)
        if recorded != own and not (isinstance(own, float) and isinstance(recorded, (int, float))
                                    and math.isclose(recorded, own, rel_tol=1e-12)):
            raise RecordingError(f"{rec.base}.sigmf-meta: global {NS}:{key} = {recorded!r}, but scene {scene.name} "
                                 f"has {key} = {own!r}")
    if rec.n_rx != scene.n_rx:
        raise RecordingError(f"{rec.base}.sigmf-meta: global core:num_channels = {rec.n_rx} receivers, but scene "
                             f"{scene.name} has n_rx = {scene.n_rx}")
    for key, default in ARRAY_FIELDS.items():
        recorded, own = tuple(rec.global_field(key, default)), getattr(scene, key)
        if recorded != own:
            raise RecordingError(f"{rec.base}.sigmf-meta: global {NS}:{key} = {list(recorded)}"
                                 f"{'' if rec.global_field(key) is not None else ' (absent: one antenna)'}, but "
                                 f"scene {scene.name} has {key} = {list(own)}")
    rate = rec.meta["global"]["core:sample_rate"]
    if not math.isclose(rate, scene.fs_hz, rel_tol=1e-12):
        raise RecordingError(f"{rec.base}.sigmf-meta: global core:sample_rate = {rate}, but scene {scene.name} "
                             f"samples at {scene.fs_hz}")
