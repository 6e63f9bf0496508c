"""Small helpers shared by the experiments: rates with Clopper-Pearson intervals, scenes, sources, a preset's target,
what a reproduction is asked for (Reproduction), and the tally of cycles done that an engine's progress hears."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from carav_stream.detect.stats import clopper_pearson
from carav_stream.estimate.geometry import Geometry
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.scene_loader import load_scene

__all__ = ["Reproduction", "Tally", "rate", "radar_scene", "radar_source", "log", "load_preset"]


class Tally:
    """Cycles done out of `total`: tally(k) adds k and tells progress(done, total), if there is one. The engines'
    inner loops (and the Monte Carlo's, montecarlo.engine.simulate_q) take such a tally as their per-block tick."""

    def __init__(self, total: int, progress: Callable[[int, int], None] | None = None) -> None:
        self.total, self.progress, self.done = int(total), progress, 0

    def __call__(self, k: int) -> None:
        self.done += int(k)
        if self.progress is not None:
            self.progress(min(self.done, self.total), self.total)


@dataclass(frozen=True)
class Reproduction:
    """What `carav reproduce` asks of reproduction.render and the tables beyond the paper: cycles per curve and per
    beyond-paper cell, the seed, whether to stop after the paper's claims, the folder the markdown links the figures
    as (relative to the document), and two callbacks: `log(line)` hears a line per finished table row, and
    `progress(label)` gives the callable that hears (done, total) cycles of the sweep it names (None: not heard)."""
    trials: int
    beyond_trials: int
    seed: int
    skip_beyond: bool = False
    figure_link: str = "figures"
    log: Callable[[str], None] | None = None
    progress: Callable[[str], Callable[[int, int], None] | None] | None = None


def rate(k: int, n: int) -> str:
    lo, hi = clopper_pearson(k, n)
    return f"{k}/{n} [{float(lo):.3g}, {float(hi):.3g}]"


def radar_scene(name: str, **over):
    return load_scene(name, {"snr_db": 0.0, **over})


def radar_source(scene, **kw):
    return RadarSource(scene, **kw)


def log(run: Reproduction, msg: str) -> None:
    """Tell run.log (if any) how far a reproduction has come."""
    if run.log is not None:
        run.log(msg)


def load_preset(name: str) -> tuple[Geometry, int, float, float]:
    """(geometry, n_chirps, target range [m], target range rate [m/s]) of a radar preset."""
    sc = load_scene(name)
    t = sc.targets[0]
    return Geometry.from_scene(sc), int(sc.n_chirps), float(t.range_m), float(sc.range_rate_mps(t))
