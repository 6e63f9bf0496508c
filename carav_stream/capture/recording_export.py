"""A recording as plain arrays for another tool (`carav export REC --mat OUT.mat`): its samples as one array read a
slab at a time, its per-cycle annotations as columns, its scene and its metadata.

    adc          (cycles, n_chirps, n_samples), one row per recorded cycle, (cycles, n_rx, n_chirps, n_samples) for
                 a receiver array (the recording's interleaved channels as the frames' receiver axis): int16 codes
                 (ri16_le), float32 (rf32_le), complex64 (cf32_le); I + jQ as complex64 for ci16_le (every int16 is
                 exact in a single, and Octave has no complex integers)
    cycle_index  int64 (cycles,): the recorded cycle of every row
    activation   bool (cycles, n_chirps): rho from the private log, when the recording was opened with it
    per_cycle    the annotations' carav: fields, one column each, one row per cycle: a flag as bool (float with
                 NaN where a cycle lacks it), a number as float64 (NaN where missing), a list of numbers per cycle
                 (the estimates of several targets) as a float64 matrix padded with NaN, text as an object column
                 ("" where missing)
    scene        the scene's parameters (an array's positions and TDM schedule among them), its targets and
                 attackers, and what follows from them
    meta         the recording's global metadata; captures: its capture segments
"""
from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from carav_stream.capture.sigmf_io import NS, Recording, RecordingError, check_scene, unplain
from carav_stream.radar.scene import Scene, SceneError
from carav_stream.radar.scene_loader import load_scene

__all__ = ["AdcSlabs", "rows_between", "per_cycle_columns", "scene_fields", "recording_variables"]

ABSENT_MEANS_FALSE = ("attack_lost",)      # sigmf_sink writes it only on the cycles where it is true
DERIVED = ("slope_hz_per_s", "wavelength_m", "range_resolution_m", "max_beat_hz", "max_range_m", "max_velocity_mps",
           "cycles_per_s")
MISSING = object()


class AdcSlabs:
    """The samples of some rows of a recording as one array (rows, [n_rx,] n_chirps, n_samples) of `dtype`, read a
    slab of samples at a time from the recording's map (console/matout.py writes it so, without holding it whole)."""

    def __init__(self, samples: np.ndarray, rows: slice | np.ndarray, n_rx: int = 1):
        self.samples, self.rows = samples, rows
        self.axes = 4 if n_rx > 1 else 3                    # rows, [receivers,] chirps, samples
        self.pairs = samples.ndim == self.axes + 1          # ci16_le: I and Q as a last axis of 2
        n = len(range(*rows.indices(len(samples)))) if isinstance(rows, slice) else len(rows)
        self.shape = (n, *samples.shape[1:self.axes])
        self.dtype = np.dtype(np.complex64) if self.pairs else samples.dtype.newbyteorder("=")

    def columns(self, k0: int, k1: int) -> np.ndarray:
        part = self.samples[(self.rows, *[slice(None)] * (self.axes - 2), slice(k0, k1))]
        if not self.pairs:
            return np.asarray(part, dtype=self.dtype)
        out = np.empty(part.shape[:self.axes], dtype=np.complex64)
        out.real, out.imag = part[..., 0], part[..., 1]
        return out


def rows_between(cycles: np.ndarray, first: int | None, stop: int | None) -> slice | np.ndarray:
    """The rows whose recorded cycle c has first <= c < stop (None: no bound): a slice when they are contiguous."""
    keep = np.ones(len(cycles), dtype=bool)
    if first is not None:
        keep &= cycles >= first
    if stop is not None:
        keep &= cycles < stop
    rows = np.flatnonzero(keep)
    if not len(rows):
        return slice(0, 0)
    return slice(int(rows[0]), int(rows[-1]) + 1) if rows[-1] - rows[0] + 1 == len(rows) else rows


def _column(key: str, values: list[Any]) -> np.ndarray:
    present = [v for v in values if v is not MISSING]
    missing = len(present) < len(values)
    if present and all(isinstance(v, bool) for v in present):
        if key in ABSENT_MEANS_FALSE or not missing:
            return np.array([v is True for v in values], dtype=bool)
        return np.array([np.nan if v is MISSING else float(v) for v in values])
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return np.array([np.nan if v is MISSING else float(v) for v in values])
    if present and all(isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                   for x in v) for v in present):
        out = np.full((len(values), max(len(v) for v in present)), np.nan)
        for i, v in enumerate(values):
            if v is not MISSING:
                out[i, :len(v)] = v
        return out
    out = np.empty(len(values), dtype=object)
    if present and all(isinstance(v, str) for v in present):
        out[:] = ["" if v is MISSING else v for v in values]
    else:
        out[:] = [None if v is MISSING else v for v in values]
    return out


def per_cycle_columns(annotations: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """The carav: fields of the annotations (but the cycle index), one column each (see the module's docstring)."""
    keys = dict.fromkeys(k for a in annotations for k in a if k.startswith(f"{NS}:") and k != f"{NS}:cycle")
    return {k[len(NS) + 1:]: _column(k[len(NS) + 1:], [unplain(a.get(k, MISSING)) for a in annotations])
            for k in keys}


def scene_fields(scene: Scene) -> dict[str, Any]:
    """The scene's parameters (targets and attackers as lists of tables) and what follows from them."""
    out: dict[str, Any] = {f.name: getattr(scene, f.name) for f in dataclasses.fields(scene)
                           if f.name not in ("source", "adc_start_default", "targets", "attackers", "warnings")}
    out["targets"] = [dataclasses.asdict(t) for t in scene.targets]
    out["attackers"] = [{"kind": a.kind, **a.kwargs()} for a in scene.attackers]
    out["warnings"] = list(scene.warnings)
    out.update({name: getattr(scene, name) for name in DERIVED})
    return out


def recording_variables(rec: Recording, rows: slice | np.ndarray) -> tuple[dict[str, Any], AdcSlabs]:
    """The recording's rows as variables (name: array or JSON-like value) and its samples as slabs; RecordingError
    if its scene no longer loads or no longer describes the samples."""
    try:
        scene = load_scene(rec.scene_ref)
    except (SceneError, OSError) as exc:
        said = "; ".join(exc.problems) if isinstance(exc, SceneError) else str(exc)
        raise RecordingError(f"{rec.base}.sigmf-meta: global {NS}:scene: {said}") from None
    check_scene(rec, scene)
    index = np.arange(len(rec.cycles))[rows]
    variables: dict[str, Any] = {"cycle_index": rec.cycles[rows],
                                 "per_cycle": per_cycle_columns([rec.annotations[i] for i in index]),
                                 "scene": scene_fields(scene), "meta": rec.meta["global"],
                                 "captures": rec.meta.get("captures", [])}
    if rec.rho is not None:
        variables["activation"] = np.asarray(rec.rho[rows], dtype=bool)
    return variables, AdcSlabs(rec.samples, rows, rec.n_rx)
