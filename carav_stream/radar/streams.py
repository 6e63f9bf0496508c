"""What every radar block of a run shares: the scene, the seed and its random streams, the fidelity.

The three are graph-wide parameters (declared here once, `SCENE`, `SEED`, `FIDELITY`): a graph sets each once,
the loader checks it once, and every radar block uses the same value.

With a seed, SeedSequence(seed) spawns three independent streams (activation, noise, attack), each drawn in
cycle order by the block that owns it, so a pipeline and `carav_stream.firmware.algorithm1.run_algorithm1` give the same
numbers bit for bit. Without a seed (NO_SEED) the activation sequence comes from the OS's secure generator.
The noise stream's bit generator is numpy's SFC64 (the others numpy's default, PCG64): the receiver noise takes
one 64-bit word for every two samples (carav_stream.radar.noise), and SFC64 makes a word faster than PCG64 does.

A block restarted after a crash, or swapped in mid-run, is another `instance` (Block.instance): its streams
come from SeedSequence(seed, spawn_key=instance), still reproducible but independent of the first instance's,
which it would otherwise replay from the start (noise, attacks or activation sequences seen before).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from carav_stream.core.params import REQUIRED, Param
from carav_stream.radar.activation import ActivationSource
from carav_stream.radar.scene import Scene
from carav_stream.radar.scene_loader import load_scene

NO_SEED = -1


@lru_cache(maxsize=16)
def scene_of(name_or_path: str) -> Scene:
    """A preset or scene file, loaded once per process (scenes are immutable)."""
    return load_scene(name_or_path)


SCENE = Param("scene", str, REQUIRED, "preset name or scene file", file=True, graph_wide=True, validate=scene_of)
SEED = Param("seed", int, NO_SEED, "simulation seed; -1: the activation sequence from the OS's secure generator",
             low=NO_SEED, graph_wide=True)
FIDELITY = Param("fidelity", str, "beat", "beat: closed-form dechirped samples; waveform: chirps mixed and "
                 "filtered on a finer grid", choices=("beat", "waveform"), graph_wide=True)


@dataclass
class Streams:
    activation: ActivationSource
    noise: np.random.Generator
    attack: np.random.Generator


def _noise_generator(seed: np.random.SeedSequence | None) -> np.random.Generator:
    return np.random.Generator(np.random.SFC64(seed))


def seed_streams(seed: int | None, activation: str = "auto", instance: tuple[int, int] = (0, 0)) -> Streams:
    """The three random streams of a run. seed None/-1: secure activation, OS-seeded noise and attack.
    `instance` other than (0, 0): the streams of a restarted or swapped-in block (module docstring)."""
    if seed is None or seed == NO_SEED:
        if activation not in ("auto", "secure"):
            raise ValueError(f"activation {activation!r} needs a seed (simulation only)")
        return Streams(ActivationSource("secure"), _noise_generator(None), np.random.default_rng())
    root = np.random.SeedSequence(seed, spawn_key=tuple(instance) if any(instance) else ())
    s_act, s_noise, s_attack = root.spawn(3)
    kind = "seeded" if activation == "auto" else activation
    act_seed = int(s_act.generate_state(1, np.uint32)[0]) | 1   # odd: never the LFSR's all-zero state
    return Streams(ActivationSource(kind, seed=act_seed), _noise_generator(s_noise),
                   np.random.default_rng(s_attack))
