"""Find block types: the built-in `blocks/` folder plus folders a user names (graph `block_paths`, --blocks,
CARAV_BLOCK_PATH). A block file `name.py` defines one Block subclass; its graph type is the file name."""
from __future__ import annotations

import importlib
import inspect
import os
import sys
from dataclasses import dataclass
from pathlib import Path

from carav_stream.core.modules import import_file, module_files
from carav_stream.runtime.block import Block

BUILTIN_PACKAGE = "carav_blocks"


class RegistryError(LookupError):
    pass


@dataclass(frozen=True)
class BlockType:
    name: str
    path: Path
    cls: type[Block]

    @property
    def doc(self) -> str:
        module = sys.modules.get(self.cls.__module__)
        return inspect.cleandoc((module.__doc__ if module else None) or self.cls.__doc__ or "")


def builtin_dir() -> Path:
    return Path(importlib.import_module(BUILTIN_PACKAGE).__file__).parent


def search_path(extra: list[str | Path] = ()) -> list[Path]:
    env = [p for p in os.environ.get("CARAV_BLOCK_PATH", "").split(os.pathsep) if p]
    return [builtin_dir(), *(Path(p).resolve() for p in [*env, *extra])]


def load_block_file(path: Path) -> BlockType:
    """Import one block file and return its Block subclass (the one defined in that file)."""
    try:
        module = import_file(path, builtin_dir(), BUILTIN_PACKAGE, "carav_user_blocks")
    except Exception as exc:
        raise RegistryError(f"{path}: block file failed to import: {type(exc).__name__}: {exc}") from exc
    classes = [c for c in vars(module).values()
               if inspect.isclass(c) and issubclass(c, Block) and c is not Block and c.__module__ == module.__name__]
    if len(classes) != 1:
        raise RegistryError(f"{path}: a block file must define exactly one Block subclass, found "
                            f"{[c.__name__ for c in classes] or 'none'}")
    return BlockType(path.stem, path, classes[0])


class Registry:
    """Block types by name; a user folder may not silently shadow a built-in block."""

    def __init__(self, extra_paths: list[str | Path] = ()) -> None:
        self.paths = search_path(list(extra_paths))
        self.files: dict[str, Path] = {}
        self.conflicts: list[str] = []
        for folder in self.paths:
            for name, path in module_files(folder).items():
                if name in self.files and self.files[name] != path:
                    self.conflicts.append(f"block type {name!r} is defined twice: {self.files[name]} and {path}")
                    continue
                self.files[name] = path
        self._cache: dict[str, BlockType] = {}

    def names(self) -> list[str]:
        return sorted(self.files)

    def get(self, name: str) -> BlockType:
        if name not in self._cache:
            if name not in self.files:
                raise RegistryError(f"unknown block type {name!r}; known types: {', '.join(self.names())}")
            self._cache[name] = load_block_file(self.files[name])
        return self._cache[name]
