"""Modules found as files in folders: what the block registry (runtime/registry.py) and the data-plane registry
(runtime/planes) share. A built-in file is imported as a module of its package; a file from a user's folder under a
name unique to that folder, once per process, so two folders may each hold a module of the same name."""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType


def module_files(folder: Path) -> dict[str, Path]:
    """Module name -> file of the folder's public modules (no leading underscore), by name; {} for no folder."""
    if not folder.is_dir():
        return {}
    return {p.stem: p for p in sorted(folder.glob("*.py")) if not p.stem.startswith("_")}


def import_file(path: Path, builtin_dir: Path, builtin_package: str, prefix: str) -> ModuleType:
    """The module of `path`: `builtin_package`'s own when it lies in `builtin_dir`, else `prefix`_<folder digest>.
    <stem>. A module that fails to import is forgotten (a later call tries again) and its exception propagates."""
    if path.parent == builtin_dir:
        return importlib.import_module(f"{builtin_package}.{path.stem}")
    digest = hashlib.sha1(str(path.parent.resolve()).encode()).hexdigest()[:10]
    name = f"{prefix}_{digest}.{path.stem}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module
