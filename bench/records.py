"""What every `python3 dev.py bench NAME --json FILE` writes, and BENCHMARKS.md is rendered from:

    {"command": "python3 dev.py bench transport --repeats 3", "machine": {...}, "records": [...], ...}

`command` is the command line that made the records (without --json/--plot and their files), `machine` the
machine it ran on (CPU model, its widest SIMD extension, cores, memory, Python and numpy versions, load average
when the records were written). Further keys are a benchmark's own (the estimator benchmark's chosen default, for
example).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
from pathlib import Path
from typing import Any

import numpy as np

OUTPUT_OPTIONS = ("--json", "--plot")      # options naming output files: not part of what was measured

SIMD_LEVELS = ("avx512f", "avx2", "sse4_2")    # widest first: numpy's float32 kernels (log, tan, exp) scale with it


def machine() -> dict[str, Any]:
    model, simd = platform.processor() or platform.machine(), None
    try:
        info = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        info = []
    for line in info:
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
        elif line.startswith("flags") and simd is None:
            flags = set(line.split(":", 1)[1].split())
            simd = next((level.upper() for level in SIMD_LEVELS if level in flags), "none of " + "/".join(SIMD_LEVELS))
    try:
        mem_gib = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2 ** 30
    except (ValueError, OSError, AttributeError):
        mem_gib = None
    return {"cpu": model, "simd": simd, "cores": os.cpu_count(), "memory_gib": round(mem_gib, 1) if mem_gib else None,
            "python": platform.python_version(), "numpy": np.__version__,
            "load_average": [round(x, 2) for x in os.getloadavg()]}


def describe(m: dict[str, Any]) -> str:
    """One line for a `machine()`: CPU (widest SIMD extension), cores, memory, Python and numpy, load average."""
    mem = f", {m['memory_gib']:g} GiB" if m.get("memory_gib") else ""
    load = " / ".join(f"{x:g}" for x in m.get("load_average", []))
    simd = f" ({m['simd'] or 'SIMD not detected'})" if "simd" in m else ""
    return (f"{m['cpu']}{simd}, {m['cores']} cores{mem}; Python {m['python']}, numpy {m['numpy']}; "
            f"load average (1 / 5 / 15 min) {load}")


def header() -> str:
    """What a benchmark prints first: the machine it is about to measure, as its record will state it."""
    return f"machine: {describe(machine())} at start"


def command_line(args: argparse.Namespace) -> str:
    """`carav ARGS` as given, without the output options and their values."""
    argv = list(getattr(args, "argv", []))
    kept, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        name = a.split("=", 1)[0]
        if name in OUTPUT_OPTIONS:
            skip = "=" not in a
            continue
        kept.append(a)
    return "python3 dev.py bench " + shlex.join(kept)


def write(path: str | Path, args: argparse.Namespace, records: list[dict[str, Any]], **extra: Any) -> None:
    doc = {"command": command_line(args), "machine": machine(), "records": records, **extra}
    Path(path).write_text(json.dumps(doc, indent=1, default=float) + "\n")


def read(path: str | Path) -> dict[str, Any]:
    doc = json.loads(Path(path).read_text())
    missing = {"command", "machine", "records"} - set(doc) if isinstance(doc, dict) else {"a JSON object"}
    if missing:
        raise ValueError(f"{path}: not a benchmark record file (lacks {', '.join(sorted(missing))}); write it with "
                         "python3 dev.py bench NAME --json FILE")
    return doc
