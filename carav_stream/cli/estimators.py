"""`carav estimators`: every estimation method as a markdown table, built from the methods' own files.

One row per method of carav_stream/estimate/estimators/ (the registry, METHODS, in its order): how it reads the
range (the beat) and the velocity, from the method's class (`range_words`, `velocity_words`). docs/ESTIMATION.md
quotes this table (`carav reproduce --check` compares them).
"""
from __future__ import annotations

import argparse

from carav_stream.estimate.estimators import REGISTRY

__all__ = ["configure", "run", "method_table"]


def configure(parser: argparse.ArgumentParser) -> None:
    """No options."""


def method_table() -> str:
    """The markdown table of every method of the registry, ending in a newline."""
    lines = ["| method | range (beat) | velocity |", "|---|---|---|"]
    lines += [f"| `{name}` | {m.range_words} | {m.velocity_words} |" for name, m in REGISTRY.items()]
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    print(method_table(), end="")
    return 0
