"""Small helpers shared by `reproduce` and `beyond`: rates with Clopper-Pearson intervals, scenes, sources."""
from __future__ import annotations

import sys

from carav_stream.detect.stats import clopper_pearson
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.scene_loader import load_scene

__all__ = ["rate", "radar_scene", "radar_source", "log"]


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
