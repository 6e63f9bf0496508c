"""Frames that carry several cycles: their per-cycle header fields.

A frame of `cycles` cycles keeps what differs from cycle to cycle in one header map, `per_cycle`
{name: list of one value per cycle}; everything else in the header holds for the whole frame. A block that
passes on some of the cycles (a gate, say) takes the same rows of every list with `pick`, so no field can
fall out of step with the cycles it describes. `cycle_index` names the cycles when they are not consecutive.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from carav_stream.runtime.frames import Frame


def n_cycles(frame: Frame) -> int:
    return int(frame.header.get("cycles", 1))


def cycle_indices(frame: Frame) -> list[int]:
    """The cycle index of every cycle the frame carries."""
    per = frame.header.get("per_cycle") or {}
    if "cycle_index" in per:
        return list(per["cycle_index"])
    return list(range(frame.cycle, frame.cycle + n_cycles(frame)))


def per_cycle(frame: Frame) -> dict[str, list[Any]]:
    """The frame's per-cycle fields, each checked to hold one value per cycle (ValueError naming the field)."""
    per = frame.header.get("per_cycle") or {}
    if not isinstance(per, dict):
        raise ValueError(f"frame seq {frame.seq}: header per_cycle must be a map, got {type(per).__name__}")
    n = n_cycles(frame)
    for name, values in per.items():
        if not isinstance(values, list) or len(values) != n:
            raise ValueError(f"frame seq {frame.seq}: per_cycle field {name!r} must list {n} values, one per cycle")
    return per


def pick(frame: Frame, rows: Sequence[int], **extra: list[Any]) -> dict[str, list[Any]]:
    """The per-cycle fields of `rows` (positions within the frame), with cycle_index, plus `extra` lists."""
    per = per_cycle(frame)
    out = {name: [values[i] for i in rows] for name, values in per.items()}
    index = cycle_indices(frame)
    out["cycle_index"] = [index[i] for i in rows]
    out.update(extra)
    return out
