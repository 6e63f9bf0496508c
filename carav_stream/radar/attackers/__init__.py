"""Attack signal models a_k[m] (paper Sections IV, V.D-V.G, plus physical spoofers): one model per file.

``make_attacker(kind, scene, **params)`` builds one; ``KINDS`` maps every model's kind to its class; a scene's
attackers together are ``scene_attacker(scene)``. ``carav attackers`` lists the models, what each puts on the air
and its parameters; ``carav blocks attacker`` gives each parameter's meaning.

    _base.py        Attacker (the plain models), LiveChirpAttacker (the ones that answer the victim's chirps on
                    the air), Observation (what an attacker hears), AttackerError, gate_by_emission, AZIMUTH (where
                    the radar sees it: every model's signal reaches each receiver of an array at its phase)
    _registry.py    KINDS and make_attacker, built from the model files
    _replica.py     the delayed replica of the victim's chirp that ghost and reactive send
    _composite.py   several attackers at once
    <kind>.py       one model each (none.py, random.py, ghost.py, ...)

A new model is one new file here, named after its kind, defining one subclass of Attacker or LiveChirpAttacker with
a docstring (its first paragraph says what it puts on the air), its ``params`` and its ``_batch``, ``_cycle`` or
``response``; the attacker block, the graph validator, the scene loader and the documents' model table find it.
"""
from carav_stream.radar.attackers._base import (
    AZIMUTH,
    Attacker,
    AttackerError,
    LiveChirpAttacker,
    Observation,
    gate_by_emission,
    rarms_param,
)
from carav_stream.radar.attackers._composite import CompositeAttacker, scene_attacker
from carav_stream.radar.attackers._registry import KINDS, make_attacker

# every model's class under its own name too (from carav_stream.radar.attackers import GhostAttacker)
globals().update({cls.__name__: cls for cls in KINDS.values()})

__all__ = ["AZIMUTH", "Attacker", "AttackerError", "CompositeAttacker", "KINDS", "LiveChirpAttacker", "Observation",
           "gate_by_emission", "make_attacker", "rarms_param", "scene_attacker",
           *(cls.__name__ for cls in KINDS.values())]
