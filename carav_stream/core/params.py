"""Typed, documented parameters: one declaration and one check for block, attacker and scene parameters.

    Param("rarms", float, 3.0, "attack RMS over noise RMS, sigma_a / sigma_n", low=0.0)
    Param("eta", float, 1.5, "threshold of C(eta) = Q / eta", low=0.0, strict=True)
    Param("scene", str, REQUIRED, "preset name or scene file", file=True, graph_wide=True)

`check` converts and validates one value; `problems` checks a whole set of values against declarations and
names every problem (unknown names with a suggestion, missing required values, wrong types, ranges, choices).
Floats must be finite: NaN and infinity are refused everywhere a float is declared. Integers must fit in 64 signed
bits (INT_LOW to INT_HIGH) besides their declared range: every parameter travels in msgpack node specs and is used in
numpy int64 arithmetic, where a larger value fails only once the run has started.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

REQUIRED = object()   # default of a parameter that must be given

INT_LOW, INT_HIGH = -2 ** 63, 2 ** 63 - 1   # what an int parameter can hold wherever it goes (module docstring)

_TYPE_NAMES = {int: "int", float: "float", str: "str", bool: "bool", list: "list", dict: "table"}


@dataclass(frozen=True)
class Param:
    """A typed parameter.

    low/high  bounds for numbers (inclusive unless `strict`); choices  the values allowed
    unit      shown by `carav blocks`; doc  a one-line meaning
    optional  None is accepted and means "not set" (for example: a model's own default)
    file      the value may name a file; a relative name written in a graph file is looked up next to the graph
    output    the value names a file the block writes ("-": standard output); validation refuses a folder, or a
              file in a folder that does not exist, before anything runs
    graph_wide  one value for a whole graph (a scene, a seed, a fidelity): written once at the top of a graph
              file, checked once, and refused when two blocks of the graph would use different values
    validate  callable(value) raising ValueError for a value that type and range checks cannot judge (a scene
              name that names no scene); called once per distinct value of a graph-wide parameter
    """

    name: str
    type: type
    default: Any = REQUIRED
    doc: str = ""
    low: float | None = None
    high: float | None = None
    strict: bool = False
    choices: tuple[Any, ...] | None = None
    unit: str = ""
    optional: bool = False
    file: bool = False
    output: bool = False
    graph_wide: bool = False
    validate: Callable[[Any], Any] | None = None

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    @property
    def type_name(self) -> str:
        return _TYPE_NAMES.get(self.type, self.type.__name__)

    def check(self, value: Any) -> tuple[Any, str | None]:
        """(converted value, None) or (value, problem text). Ints are accepted where floats are asked."""
        if value is None and self.optional:
            return value, None
        if self.type is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if self.type is not bool and isinstance(value, bool) or not isinstance(value, self.type):
            return value, f"must be {self.type_name}, got {type(value).__name__} {value!r}"
        if self.type is float and not math.isfinite(value):
            return value, f"must be a finite number, got {value!r}"
        if self.type is int and value > INT_HIGH:
            return value, f"must be <= {INT_HIGH} (64 signed bits), got {value}"
        if self.type is int and value < INT_LOW:
            return value, f"must be >= {INT_LOW} (64 signed bits), got {value}"
        if self.choices is not None and value not in self.choices:
            return value, f"must be one of {list(self.choices)}, got {value!r}"
        if self.low is not None and (value < self.low or (self.strict and value == self.low)):
            return value, f"must be {'>' if self.strict else '>='} {_num(self.low)}, got {_num(value)}"
        if self.high is not None and (value > self.high or (self.strict and value == self.high)):
            return value, f"must be {'<' if self.strict else '<='} {_num(self.high)}, got {_num(value)}"
        return value, None

    def describe(self) -> str:
        """One line for listings: type, default, meaning, unit, range or choices."""
        default = "(required)" if self.required else f"= {self.default!r}"
        parts = [f"{self.type_name:<6} {default:<14} {self.doc}"]
        if self.unit:
            parts.append(f"[{self.unit}]")
        if self.choices is not None:
            parts.append(f"one of {list(self.choices)}")
        elif self.low is not None or self.high is not None:
            lo = "" if self.low is None else f"{'>' if self.strict else '>='} {_num(self.low)}"
            hi = "" if self.high is None else f"{'<' if self.strict else '<='} {_num(self.high)}"
            parts.append(f"({', '.join(p for p in (lo, hi) if p)})")
        if self.graph_wide:
            parts.append("(graph-wide)")
        return " ".join(parts)


def _num(x: float) -> str:
    """A number as a person writes it: 0 for 0.0, -1.5 for -1.5, 1e-07 for 1e-7."""
    return str(int(x)) if isinstance(x, float) and x.is_integer() and abs(x) < 1e15 else repr(x)


def suggest(name: str, known: Iterable[str]) -> str:
    """' (did you mean 'x'?)' for a close known name, else ' (known: a, b, ...)'."""
    known = sorted(known)
    close = difflib.get_close_matches(name, known, n=1)
    return f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(known) or 'none'})"


def problems(declared: Iterable[Param], values: dict[str, Any], owner: str = "") -> list[tuple[str, str]]:
    """Every problem of `values` against the declarations, as (parameter name, text); empty when all is well.
    `owner` names what takes them in the unknown-name message ("attacker 'ghost'")."""
    known = {p.name: p for p in declared}
    found = [(name, f"unknown parameter{' for ' + owner if owner else ''}{suggest(name, known)}")
             for name in values if name not in known]
    for name, p in known.items():
        if name in values:
            _, problem = p.check(values[name])
            if problem:
                found.append((name, problem))
        elif p.required:
            found.append((name, f"missing required parameter ({p.doc or p.type_name})"))
    return found


def resolved(declared: Iterable[Param], values: dict[str, Any]) -> dict[str, Any]:
    """Converted values for every declared parameter (the default where not given). Check `problems` first."""
    return {p.name: p.check(values[p.name])[0] if p.name in values else p.default for p in declared}
