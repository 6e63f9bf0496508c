"""The estimation methods, one file each: every module of this package whose name does not start with "_" defines
one Method subclass, and the file name is the method's name. Adding a method is adding its file."""
from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

from carav_stream.estimate.estimators._method import Method

PACKAGE = "carav_stream.estimate.estimators"
DEFAULT_METHOD = "ml"


def discover(folder: Path, package: str) -> dict[str, Method]:
    """{name: Method} of the method files of `package` (its folder `folder`), in Method.order, then by name."""
    found = []
    for info in pkgutil.iter_modules([str(folder)]):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{package}.{info.name}")
        classes = [c for _, c in inspect.getmembers(module, inspect.isclass)
                   if issubclass(c, Method) and c is not Method and c.__module__ == module.__name__]
        if len(classes) != 1:
            raise ImportError(f"{module.__file__}: an estimation method's file defines one Method subclass, "
                              f"found {[c.__name__ for c in classes]}")
        if not isinstance(getattr(classes[0], "order", None), int):
            raise ImportError(f"{module.__file__}: {classes[0].__name__} sets no integer `order` (its place in "
                              "METHODS)")
        words = [w for w in ("range_words", "velocity_words") if not isinstance(getattr(classes[0], w, None), str)]
        if words:
            raise ImportError(f"{module.__file__}: {classes[0].__name__} sets no {' and no '.join(words)} (how it "
                              "reads range and velocity, for `carav estimators`)")
        found.append(classes[0](info.name))
    found.sort(key=lambda m: (m.order, m.name))
    return {m.name: m for m in found}


REGISTRY = discover(Path(__file__).parent, PACKAGE)
METHODS = tuple(REGISTRY)


def method_named(name: str) -> Method:
    """The Method called `name`; ValueError naming the known ones otherwise."""
    if name not in METHODS:
        raise ValueError(f"estimate: method must be one of {METHODS}, got {name!r}")
    return REGISTRY[name]
