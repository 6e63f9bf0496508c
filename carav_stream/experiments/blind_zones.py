"""What each detector misses of the weak attacks, per scene (`carav experiment blind-zones`; its command line in
carav_stream/cli/experiment/blind_zones.py).

Three scenes: table1 (64 x 1080 samples at 150 MHz), awr1642 (128 x 256 at 10 MHz) and table1 cut to short chirps
(48 x 300). Three weak attacks: the ghost (a replica of the victim's chirp planting a false target at 25 m, in every
chirp period), the paper's `random` (i.i.d. Gaussian) and `smart` (the same sequence on every chirp). For each
RARMS of the grid, --trials attacked cycles (seeded, the radar chain at beat fidelity) judged by every detector at
its design for PF 1e-6 per cycle: C(eta) at the scene's designed eta, the spectral, integrated and coherent
silent-chirp tests at theirs (carav_stream/firmware/blind_zone.py). Measured: the share of cycles each detector
misses, and the weakest RARMS of the grid from which on it misses at most one cycle in ten.
"""
from __future__ import annotations

from collections.abc import Callable

from carav_stream.experiments.reporting import Tally
from carav_stream.firmware.blind_zone import miss_rates, weakest_caught
from carav_stream.radar.scene import Scene
from carav_stream.radar.scene_loader import load_scene

__all__ = ["blind_zones", "SCENES", "ATTACKS", "RARMS"]

SCENES = {"table1": ("table1", None), "awr1642": ("awr1642", None),
          "short chirps": ("table1", {"n_chirps": 48, "n_samples": 300})}
ATTACKS = {"ghost": {"range_m": 25.0}, "random": {}, "smart": {}}
RARMS = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0)


def blind_zones(n: int, seed: int, partial: Callable[[Scene, list[dict]], None] | None = None,
                progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Per scene of SCENES and attack of ATTACKS: {"scene" (its label), "attack", "rows" (firmware.blind_zone's
    miss_rates over RARMS, n attacked cycles each), "weakest_caught"}; partial(scene, its entries) as each scene is
    done, progress(cycles done, cycles in all) as they are judged."""
    tally = Tally(len(SCENES) * len(ATTACKS) * len(RARMS) * n, progress)
    out = []
    for label, (preset, over) in SCENES.items():
        scene = load_scene(preset, over)
        entries = []
        for attack, params in ATTACKS.items():
            rows = miss_rates(scene, attack, RARMS, n, seed, fidelity="beat", params=params, tick=tally)
            entries.append({"scene": label, "attack": attack, "rows": rows, "weakest_caught": weakest_caught(rows)})
        if partial is not None:
            partial(scene, entries)
        out += entries
    return out
