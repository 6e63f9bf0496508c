"""What the live view shows, gathered from the frames its taps receive: no plotting, no sockets, thread-safe.

The live_view block's process thread adds frames (`ViewState.add`); the page's update callback, on the web
server's thread, takes what is new since its last look (`since`) and the latest range-Doppler map. Points per
cycle: Q with the detector's decision (clean, D0, D1, an opt-in detector, or a fail-closed refusal with its
reason), whether the attacker was on, and the estimates (every listed target); per cycle of a tracker's output, its
confirmed tracks (coasting included: the car's picture of the road). Only the most recent `history`
cycles are kept; a page that looks less often than that loses the oldest points from its plot, never from the
run (the run summary counts everything).

Why a plot paused: the range, velocity and range-Doppler plots draw clean cycles only, so they stand still while the
gate refuses every cycle (an attack it detects, or a fail-closed refusal). `paused()` gives the latest clean cycle
received and the refused cycles received after it, by class: exact whatever order the taps deliver them in, unless a
clean cycle reaches the view more than REFUSED_KEPT refused cycles late (then those older ones stay counted).

Display accounting: a clean frame the view received but did not draw a map of (a newer one came before the page
looked) is counted in `frames_not_drawn`; frames the tap edge skipped while the view was busy are counted by the
runtime (`skipped_by_taps`). Neither is lost.
"""
from __future__ import annotations

import collections
import math
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

from carav_stream.detect.rdmap import rd_power
from carav_stream.estimate.geometry import Geometry
from carav_stream.runtime.cycles import cycle_indices, per_cycle
from carav_stream.runtime.frames import Frame

CATEGORIES = ("clean", "D0", "D1", "opt-in", "refused")   # how a cycle's Q point is drawn
REFUSED_KEPT = 1 << 16      # refused cycles after the latest clean one kept by index; older ones only counted


def category(reason: str | None, raised_by: str | None) -> str:
    """A cycle's class on the Q plot: clean (passed), the detector that raised the alarm (D0, D1, any other
    name is an opt-in detector), or refused without a verdict of the detector (fail closed)."""
    if reason is None:
        return "clean"
    if reason != "attack":
        return "refused"
    return raised_by if raised_by in ("D0", "D1") else "opt-in"


def attacker_text(cycle: int, reason: object, azimuth: object, std: object) -> str:
    """A line on the attacker's direction the detector estimated for a cycle (a receiver array's verdict)."""
    if reason in ("estimated", "mirrored") and isinstance(azimuth, float | int) and math.isfinite(azimuth):
        spread = f" +- {std:.2g}" if isinstance(std, float | int) and math.isfinite(std) else ""
        sign = " (|azimuth|: its sign is not observable on I-only receivers)" if reason == "mirrored" else ""
        return f"attacker's azimuth, cycle {cycle}: {azimuth:.1f}{spread} deg{sign}"
    return f"attacker's azimuth, cycle {cycle}: none ({str(reason).replace('_', ' ')})"


@dataclass(frozen=True)
class CyclePoint:
    cycle: int
    q: float | None            # None: no Q (a refusal without a verdict)
    category: str
    detail: str                # the detector or the refusal's reason; "" for clean
    attacked: bool


@dataclass(frozen=True)
class EstimatePoint:
    cycle: int
    range_m: tuple[float, ...]
    velocity_mps: tuple[float, ...]


@dataclass(frozen=True)
class TrackPoint:
    """A cycle's confirmed tracks (status "confirmed" or "coasting"), one value per track."""
    cycle: int
    track_id: tuple[int, ...]
    range_m: tuple[float, ...]
    velocity_mps: tuple[float, ...]
    coasting: tuple[bool, ...]


def confirmed_tracks(per: dict[str, Any], cycles: list[int]) -> list[TrackPoint]:
    """The confirmed tracks of every cycle of a tracker's frame (per-cycle track_id, status, range_m,
    velocity_mps: one value per live track); a cycle without any gives an empty point."""
    n = len(cycles)
    ids, status = per.get("track_id") or [[]] * n, per.get("status") or [[]] * n
    ranges, velocities = per.get("range_m") or [[]] * n, per.get("velocity_mps") or [[]] * n
    out = []
    for i, c in enumerate(cycles):
        kept = [(int(t), float(r), float(v), s == "coasting")
                for t, s, r, v in zip(ids[i] or [], status[i] or [], ranges[i] or [], velocities[i] or [])
                if s in ("confirmed", "coasting") and _finite(r) is not None and _finite(v) is not None]
        out.append(TrackPoint(c, *(tuple(x) for x in zip(*kept))) if kept else TrackPoint(c, (), (), (), ()))
    return out


def rd_map_db(x: np.ndarray, rho: np.ndarray, geometry: Geometry, sigma_n: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The range-Doppler map of one cycle in dB over the noise (0 dB = the mean of a noise cell), Doppler centred:
    (map (n_chirps, n_range_bins) float32, range of each bin [m], velocity of each Doppler row [m/s]).

    x (n_chirps, n_samples) samples of one cycle, rho (n_chirps,) its activation; the map is detect.rdmap.rd_power's
    (active chirps only). Range bin j is beat frequency j fs / N (I/Q) or (j + 1) fs / N (I-only, DC dropped), read
    as a range without Doppler (a target moving at v shows 2 v / lambda x range_per_hz further: the map is what the
    receiver sees, before range-Doppler coupling is removed); Doppler row k is the chirp-to-chirp progression
    k / n_chirps cycles, centred on 0."""
    power = rd_power(x[None], rho[None], sigma_n, single=True)[0]
    n_chirps, n_samples = x.shape
    first = 0 if geometry.iq else 1
    ranges = geometry.range_from_beat((np.arange(power.shape[1]) + first) * geometry.fs_hz / n_samples)
    nu = np.fft.fftshift(np.fft.fftfreq(n_chirps))
    db = 10.0 * np.log10(np.maximum(np.fft.fftshift(power, axes=0), 1e-6))
    return db.astype(np.float32), ranges, geometry.velocity_from_slow_freq(nu)


class ViewState:
    """The view's data, shared between the block (writer) and the page sessions (readers)."""

    def __init__(self, history: int = 2000) -> None:
        self.lock = threading.Lock()
        self.points: collections.deque[tuple[int, CyclePoint]] = collections.deque(maxlen=history)
        self.estimates: collections.deque[tuple[int, EstimatePoint]] = collections.deque(maxlen=history)
        self.tracks: collections.deque[tuple[int, TrackPoint]] = collections.deque(maxlen=history)
        self.n_points = self.n_estimates = self.n_tracks = 0   # running numbers: a reader asks for what came after
        self.latest: tuple[int, np.ndarray, np.ndarray] | None = None   # (cycle, samples, rho) of the last clean one
        self.latest_version = 0                       # clean frames received (a new map is due when it changes)
        self.drawn_version = 0
        self.frames_in: collections.Counter[str] = collections.Counter()
        self.unreadable = 0                           # frames whose per-cycle fields could not be read
        self.frames_not_drawn = 0
        self.maps_drawn = 0
        self.eta: float | None = None
        self.attacker: tuple[int, str] | None = None  # (cycle, text) of the latest cycle with the attacker's azimuth
        self.last_cycle = -1
        self.status: dict[str, Any] | None = None     # the supervisor's last status (set by the page's poller)
        self.status_error: str | None = None
        self.swap_log: list[str] = []                 # the page's swaps and their answers, newest last
        self.ports: list[dict[str, Any]] | None = None   # the run's output ports (admin `ports`), once known
        self.last_clean = -1                          # the latest clean cycle received (estimated or mapped)
        self.refused_after: collections.deque[tuple[int, str]] = collections.deque()   # (cycle, class) after it
        self.refused_by: collections.Counter[str] = collections.Counter()   # their classes, folded ones included
        self.folded_max = -1                          # the highest refused cycle only counted (beyond REFUSED_KEPT)
        self.folded: collections.Counter[str] = collections.Counter()

    def add(self, port: str, frame: Frame) -> None:
        """Take one frame from tap `port` (alarms, estimates, clean or tracks). Cheap: the map is drawn by a
        reader."""
        with self.lock:
            self.frames_in[port] += 1
            try:
                per, cycles = per_cycle(frame), cycle_indices(frame)
            except ValueError:
                self.unreadable += 1
                return
            if isinstance(frame.header.get("eta"), int | float):
                self.eta = float(frame.header["eta"])
            self.last_cycle = max([self.last_cycle, *cycles])
            n = len(cycles)
            attacked = [bool(a) for a in per.get("attack_active") or [False] * n]
            reasons_az = per.get("attack_reason")
            if reasons_az and port in ("alarms", "estimates") and (self.attacker is None
                                                                   or cycles[-1] > self.attacker[0]):
                az, std = per.get("attack_azimuth_deg") or [None] * n, per.get("attack_azimuth_std_deg") or [None] * n
                self.attacker = (cycles[-1], attacker_text(cycles[-1], reasons_az[-1], az[-1], std[-1]))
            if port == "alarms":
                reasons = per.get("reason") or ["attack"] * n
                by = per.get("raised_by") or [None] * n
                q = per.get("q") or [None] * n
                for i, c in enumerate(cycles):
                    cat = category(reasons[i], by[i])
                    detail = (by[i] or "") if cat != "refused" else str(reasons[i])
                    self._point(CyclePoint(c, _finite(q[i]), cat, detail, attacked[i]))
            elif port == "estimates" and not frame.header.get("refused"):
                q = per.get("q") or [None] * n
                ranges, velocities = per.get("range_m") or [[]] * n, per.get("velocity_mps") or [[]] * n
                for i, c in enumerate(cycles):
                    self._point(CyclePoint(c, _finite(q[i]), "clean", "", attacked[i]))
                    self.n_estimates += 1
                    self.estimates.append((self.n_estimates, EstimatePoint(
                        c, _numbers(ranges[i]), _numbers(velocities[i]))))
            elif port == "tracks":
                for t in confirmed_tracks(per, cycles):
                    self.n_tracks += 1
                    self.tracks.append((self.n_tracks, t))
            elif port == "clean" and frame.payload is not None and "rho" in frame.arrays and n:
                if self.latest_version > self.drawn_version:
                    self.frames_not_drawn += 1        # the one before it was never drawn
                self.latest = (cycles[-1], frame.payload[-1], frame.arrays["rho"][-1])
                self.latest_version += 1
                self._clean(max(cycles))

    def _point(self, p: CyclePoint) -> None:
        self.n_points += 1
        self.points.append((self.n_points, p))
        if p.category == "clean":
            self._clean(p.cycle)
        elif p.cycle > self.last_clean:
            self.refused_after.append((p.cycle, p.category))
            self.refused_by[p.category] += 1
            if len(self.refused_after) > REFUSED_KEPT:
                cycle, cat = self.refused_after.popleft()
                self.folded[cat] += 1
                self.folded_max = max(self.folded_max, cycle)

    def _clean(self, cycle: int) -> None:
        """A clean cycle received: the refused cycles before it no longer explain a pause."""
        if cycle <= self.last_clean:
            return
        self.last_clean = cycle
        if self.folded_max <= cycle:
            self.refused_by.subtract(self.folded)
            self.folded.clear()
            self.folded_max = -1
        if self.refused_after:
            kept: collections.deque[tuple[int, str]] = collections.deque()
            for c, cat in self.refused_after:
                if c > cycle:
                    kept.append((c, cat))
                else:
                    self.refused_by[cat] -= 1
            self.refused_after = kept

    def paused(self) -> tuple[int, dict[str, int]]:
        """(the latest clean cycle received, -1 before any; the refused cycles received after it, by class)."""
        with self.lock:
            return self.last_clean, {cat: n for cat, n in self.refused_by.items() if n > 0}

    def since(self, points_after: int, estimates_after: int) -> tuple[list[CyclePoint], int, list[EstimatePoint], int]:
        """The points and estimates added after the given running numbers, and the numbers to ask with next."""
        with self.lock:
            pts = [p for k, p in self.points if k > points_after]
            est = [e for k, e in self.estimates if k > estimates_after]
            return pts, self.n_points, est, self.n_estimates

    def tracks_since(self, after: int) -> tuple[list[TrackPoint], int]:
        """The cycles of confirmed tracks added after running number `after`, and the number to ask with next."""
        with self.lock:
            return [t for k, t in self.tracks if k > after], self.n_tracks

    def recent(self, n: int) -> list[CyclePoint]:
        """The last n cycle points received."""
        with self.lock:
            return [p for _, p in list(self.points)[-n:]]

    def latest_clean(self, newer_than: int) -> tuple[int, int, np.ndarray, np.ndarray] | None:
        """(version, cycle, samples, rho) of the last clean cycle if it is newer than version `newer_than` (what the
        asking page drew last), else None. Each page asks for itself; `drawn(version)` counts a map drawn."""
        with self.lock:
            if self.latest is None or self.latest_version <= newer_than:
                return None
            return (self.latest_version, *self.latest)

    def drawn(self, version: int) -> None:
        with self.lock:
            self.maps_drawn += 1
            self.drawn_version = max(self.drawn_version, version)

    def counts(self) -> dict[str, Any]:
        with self.lock:
            return {"frames_in": dict(self.frames_in), "unreadable": self.unreadable, "maps_drawn": self.maps_drawn,
                    "frames_not_drawn": self.frames_not_drawn, "last_cycle": self.last_cycle}


def _finite(x: Any) -> float | None:
    return float(x) if isinstance(x, int | float) and math.isfinite(x) else None


def _numbers(values: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in values or () if isinstance(v, int | float) and math.isfinite(v))
