"""Option types for the command line: every value is checked when the command line is read, before any work
starts, and a bad one is refused in one line that names the option (argparse adds "argument --json: ").

    p.add_argument("--trials", type=count(1), default=1000)
    p.add_argument("--rarms", type=float_list(low=0.0), default="0.5,1,2")
    p.add_argument("--json", type=output_file, metavar="FILE")
"""
from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path

from carav_stream.core.params import Param

Error = argparse.ArgumentTypeError


def _checked(param: Param, value):
    """The value, or the problem the parameter system finds with it (the same rules and words as in graphs)."""
    value, problem = param.check(value)
    if problem:
        raise Error(problem)
    return value


def count(low: int = 0) -> Callable[[str], int]:
    """An integer >= low."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise Error(f"expected a whole number, got {text!r}") from None
        return _checked(Param("value", int, low=low), value)
    parse.__name__ = "count"
    return parse


def even_count(low: int = 0) -> Callable[[str], int]:
    """An even integer >= low (chirps per cycle: half of them are active)."""
    whole = count(low)

    def parse(text: str) -> int:
        value = whole(text)
        if value % 2:
            raise Error(f"must be an even number (half the chirps are active), got {value}")
        return value
    parse.__name__ = "even count"
    return parse


def number(low: float | None = None, strict: bool = False) -> Callable[[str], float]:
    """A finite float, >= low (> low if strict)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise Error(f"expected a number, got {text!r}") from None
        return _checked(Param("value", float, low=low, strict=strict), value)
    parse.__name__ = "number"
    return parse


def float_list(low: float | None = None) -> Callable[[str], list[float]]:
    """Comma-separated finite numbers, each >= low: "0.5,1,2"."""
    one = number(low)

    def parse(text: str) -> list[float]:
        items = [t.strip() for t in text.split(",") if t.strip()]
        if not items:
            raise Error(f"expected comma-separated numbers, got {text!r}")
        out = []
        for t in items:
            try:
                out.append(one(t))
            except Error as exc:
                raise Error(f"{t!r} in {text!r}: {exc}") from None
        return out
    parse.__name__ = "list of numbers"
    return parse


def _writable_folder(folder: Path, text: str) -> None:
    if not folder.is_dir():
        raise Error(f"{text}: folder {str(folder)!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise Error(f"{text}: folder {str(folder)!r} is not writable")


def output_file(text: str) -> Path:
    """A file this command will write: not a folder, in an existing, writable folder."""
    path = Path(text)
    if not text or path.is_dir():
        raise Error(f"{text!r} is a folder, not a file")
    _writable_folder(path.parent, text)
    return path


def output_folder(text: str) -> Path:
    """A folder this command will write into: an existing one, or a new one in an existing, writable folder
    (created only when something is written)."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise Error(f"{text!r} is a file, not a folder")
    if not path.exists():
        _writable_folder(path.parent, text)
    elif not os.access(path, os.W_OK | os.X_OK):
        raise Error(f"{text}: folder is not writable")
    return path


def span(text: str) -> tuple[int | None, int | None]:
    """A:B, the whole numbers A <= n < B (either end may be left out: "100:", ":500")."""
    first, colon, stop = text.partition(":")
    if not colon:
        raise Error(f"expected A:B (from A up to, not including, B), got {text!r}")
    ends = []
    for part in (first, stop):
        try:
            ends.append(count(0)(part) if part.strip() else None)
        except Error as exc:
            raise Error(f"{text!r}: {exc}") from None
    if None not in ends and ends[0] >= ends[1]:
        raise Error(f"{text!r}: B must be greater than A")
    return ends[0], ends[1]
