"""The attacker registry: built from the package's model files, one model each, named after the file; the live-chirp
base class gates any model's response by the chirps on the air."""
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import carav_stream.radar.attackers as attackers
from carav_stream.core.params import Param
from carav_stream.radar.attackers import KINDS, Attacker, LiveChirpAttacker, Observation, gate_by_emission
from carav_stream.radar.attackers._registry import model_class

PACKAGE_DIR = Path(attackers.__file__).parent


def test_every_model_file_of_the_package_is_a_kind_named_after_it():
    files = {p.stem for p in PACKAGE_DIR.glob("*.py") if not p.stem.startswith("_")}
    assert set(KINDS) == files
    assert all(Path(sys.modules[cls.__module__].__file__).stem == kind for kind, cls in KINDS.items())
    assert list(KINDS) == ["none"] + sorted(files - {"none"})        # the block's default first, then by name


def test_every_model_class_is_importable_from_the_package_under_its_name():
    for cls in KINDS.values():
        assert getattr(attackers, cls.__name__) is cls and cls.__name__ in attackers.__all__


def test_only_the_reactive_repeater_answers_live_chirps_among_the_built_in_models():
    live = {kind for kind, cls in KINDS.items() if issubclass(cls, LiveChirpAttacker)}
    assert live == {"reactive"}
    assert all(cls.uses_live_emission == (kind in live) for kind, cls in KINDS.items())


def _module(name: str, **classes) -> ModuleType:
    module = ModuleType(f"carav_stream.radar.attackers.{name}")
    for attr, (base, body) in classes.items():
        setattr(module, attr, type(attr, (base,), {"__module__": module.__name__, **body}))
    return module


def _reply(self, fidelity):
    return np.ones((self.scene.n_chirps, self.scene.n_samples), self.dtype), None


@pytest.mark.parametrize("classes, culprit", [
    ({}, "defines 0 Attacker subclasses"),
    ({"A": (Attacker, {"kind": "fake", "__doc__": "a"}), "B": (Attacker, {"kind": "fake", "__doc__": "b"})},
     "defines 2 Attacker subclasses (A, B)"),
    ({"A": (Attacker, {"kind": "other", "__doc__": "a"})}, "A.kind is 'other'; a model's kind is its file's name"),
    ({"A": (LiveChirpAttacker, {"kind": "fake", "__doc__": "a"})}, "A leaves ['response'] undefined"),
    ({"A": (Attacker, {"kind": "fake", "__doc__": None})}, "A has no docstring"),
])
def test_a_malformed_model_file_is_refused_naming_the_file_and_the_fault(classes, culprit):
    with pytest.raises(ImportError) as exc:
        model_class(_module("fake", **classes))
    assert "attacker model file carav_stream.radar.attackers.fake: " in str(exc.value) and culprit in str(exc.value)


def test_a_well_formed_model_file_gives_its_class():
    module = _module("fake", Fake=(LiveChirpAttacker, {"kind": "fake", "__doc__": "Ones on every chirp on the air.\n\n"
                                                       "More.", "response": _reply}))
    cls = model_class(module)
    assert cls is module.Fake and cls.summary() == "Ones on every chirp on the air."


def test_a_live_chirp_model_answers_the_chirps_on_the_air_only_from_its_response(small_scene):
    class Ones(LiveChirpAttacker):
        """Ones on every chirp on the air."""
        kind = "ones"
        params = (Param("gain", float, 2.0, "scale"),)

        def response(self, fidelity):
            main = np.full((self.scene.n_chirps, self.scene.n_samples), self.gain, self.dtype)
            return main, main[::-1] * 0.5

    s = small_scene(iq=True)
    att = Ones(s, start_cycle=1)
    on_air = np.random.default_rng(4).random((5, s.n_chirps)) < 0.5
    on_air[3] = False                                       # a cycle with nothing on the air: no answer
    a, active = att.emit(5, 0, None, Observation(on_air, 0))
    main, tail = att.response("beat")
    expected, expected_active = gate_by_emission(main, tail, on_air, att.on_cycles(5, 0))
    assert a.tobytes() == expected.tobytes() and active.tolist() == expected_active.tolist()
    assert active.tolist() == [False, True, True, False, True] and not a[0].any()
    with pytest.raises(ValueError, match="needs observation="):
        att.emit(1, 0, None)


def test_a_live_chirp_model_without_a_response_cannot_be_built(small_scene):
    class Mute(LiveChirpAttacker):
        kind = "mute"

    with pytest.raises(TypeError, match="response"):
        Mute(small_scene())
