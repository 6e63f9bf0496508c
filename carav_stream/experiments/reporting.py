"""Small helpers shared by the experiments: rates with Clopper-Pearson intervals, scenes, sources, a preset's target."""
from __future__ import annotations

import sys

from carav_stream.detect.stats import clopper_pearson
from carav_stream.estimate.geometry import Geometry
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.scene_loader import load_scene

__all__ = ["rate", "radar_scene", "radar_source", "log", "load_preset"]


def rate(k: int, n: int) -> str:
    lo, hi = clopper_pearson(k, n)
    return f"{k}/{n} [{float(lo):.3g}, {float(hi):.3g}]"


def radar_scene(name: str, **over):
    return load_scene(name, {"snr_db": 0.0, **over})


def radar_source(scene, **kw):
    return RadarSource(scene, **kw)


def log(args, msg):
    if not args.quiet:
        print(msg, file=sys.stderr, flush=True)


def load_preset(name: str) -> tuple[Geometry, int, float, float]:
    """(geometry, n_chirps, target range [m], target range rate [m/s]) of a radar preset."""
    sc = load_scene(name)
    t = sc.targets[0]
    return Geometry.from_scene(sc), int(sc.n_chirps), float(t.range_m), float(sc.range_rate_mps(t))
