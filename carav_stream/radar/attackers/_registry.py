"""The attacker models by name, built from this package's files: every module whose name does not start with an
underscore is one model, a file named after its ``kind`` that defines one Attacker subclass. A new model is one new
file; the attacker block, its parameters, the graph validator and the documents' model table all read this registry.

Order: ``none`` (the attacker block's default) first, then the others by name.
"""
import importlib
import inspect
import pkgutil
from pathlib import Path
from types import ModuleType

from carav_stream.core.params import suggest
from carav_stream.radar.attackers._base import Attacker, AttackerError
from carav_stream.radar.scene import Scene

PACKAGE = __name__.rpartition(".")[0]
FIRST = "none"


def model_class(module: ModuleType) -> type[Attacker]:
    """The one Attacker subclass that model file ``module`` defines, checked: one, concrete, of kind the file's
    name, with a docstring for the listings. Raises ImportError naming the file otherwise."""
    name = module.__name__.rpartition(".")[2]
    found = [c for c in vars(module).values()
             if inspect.isclass(c) and issubclass(c, Attacker) and c.__module__ == module.__name__]
    where = f"attacker model file {getattr(module, '__file__', None) or module.__name__}"
    if len(found) != 1:
        raise ImportError(f"{where}: defines {len(found)} Attacker subclasses "
                          f"({', '.join(c.__name__ for c in found) or 'none'}); a model file defines one")
    cls = found[0]
    if cls.kind != name:
        raise ImportError(f"{where}: {cls.__name__}.kind is {cls.kind!r}; a model's kind is its file's name {name!r}")
    if inspect.isabstract(cls):
        raise ImportError(f"{where}: {cls.__name__} leaves {sorted(cls.__abstractmethods__)} undefined")
    if not cls.summary():
        raise ImportError(f"{where}: {cls.__name__} has no docstring saying what it puts on the air")
    return cls


def _models() -> dict[str, type[Attacker]]:
    names = sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])
                   if not m.name.startswith("_") and not m.ispkg)
    names.sort(key=lambda n: n != FIRST)
    return {name: model_class(importlib.import_module(f"{PACKAGE}.{name}")) for name in names}


KINDS: dict[str, type[Attacker]] = _models()


def make_attacker(kind: str, scene: Scene, *, azimuth_deg: float = 0.0, **params) -> Attacker:
    """Build an attacker of ``kind`` (``carav attackers`` lists the models and their parameters) whose antenna the
    radar sees at ``azimuth_deg`` (its place in the scene, not a model parameter).

    Raises :class:`AttackerError` (a ValueError) listing every bad parameter.
    """
    if kind not in KINDS:
        raise AttackerError(str(kind), [("kind", f"unknown attacker kind {kind!r}{suggest(str(kind), KINDS)}")])
    return KINDS[kind](scene, azimuth_deg=azimuth_deg, **params)
