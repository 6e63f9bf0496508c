"""`carav attackers [--brief]`: every attacker model as a markdown table, built from the models' own files.

One row per model of carav_stream/radar/attackers/ (the registry, `KINDS`): what it puts on the air (the first
paragraph of its class docstring), what it hears of the victim (nothing, the past cycles' emission, or the chirps on
the air as they come: a LiveChirpAttacker), the fidelity it needs, and its own parameters with their defaults and
units; then the parameters every model takes. `--brief` leaves the parameters out. The documents quote this table
(`carav reproduce --check` compares them); a parameter's meaning is in `carav blocks attacker`.
"""
from __future__ import annotations

import argparse

from carav_stream.core.params import Param
from carav_stream.radar.attackers import KINDS, Attacker, LiveChirpAttacker

__all__ = ["configure", "run", "model_table"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--brief", action="store_true", help="without the parameters column")


def _default(p: Param) -> str:
    value = p.default
    if value is None:
        return "none"
    text = f"{value:g}" if isinstance(value, float) else str(value)
    return f"{text} {p.unit}" if p.unit else text


def _hears(cls: type[Attacker]) -> str:
    if issubclass(cls, LiveChirpAttacker):
        return "each chirp on the air, as it comes"
    return "past cycles' emission" if cls._listens else "nothing"


def model_table(brief: bool = False) -> str:
    """The markdown table of every model of the registry (module docstring), ending in a newline."""
    head = ["model", "what it puts on the air", "hears of the victim", "fidelity"] + ([] if brief else
                                                                                   ["its own parameters (default)"])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for kind, cls in KINDS.items():
        row = [f"`{kind}`", cls.summary(), _hears(cls), "waveform" if cls.needs_waveform else "beat or waveform"]
        if not brief:
            row.append(", ".join(f"`{p.name}` = {_default(p)}" for p in cls.params) or "-")
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |")
    common = "; ".join(f"`{p.name}` = {_default(p)}: {p.doc}" for p in Attacker.COMMON)
    return "\n".join(lines) + f"\n\nEvery model also takes {common}.\n"


def run(args: argparse.Namespace) -> int:
    print(model_table(args.brief), end="")
    return 0
