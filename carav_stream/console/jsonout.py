"""JSON as every command writes it (--json): standard JSON that any reader parses.

Python's json module writes a non-finite float as the bare words NaN, Infinity and -Infinity, which are not JSON
(a strict reader such as jq, JavaScript's JSON.parse or Go's encoding/json refuses the whole file). Here such a
value is written as the string "nan", "inf" or "-inf" (float() reads each back), and anything else that is not
JSON (a numpy scalar or array, a path) as a number, a list or its text.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def plain(obj: Any) -> Any:
    """obj with every non-finite float spelt as a string and numpy values as Python ones, recursively."""
    if isinstance(obj, dict):
        return {str(k) if not isinstance(k, str) else k: plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, np.generic):
        return plain(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return "nan" if math.isnan(obj) else ("inf" if obj > 0 else "-inf")
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    return str(obj)


def dumps(obj: Any, **kwargs: Any) -> str:
    """Standard JSON text of obj (json.dumps's keyword arguments, such as indent)."""
    return json.dumps(plain(obj), allow_nan=False, **kwargs)


def write(path: str | Path, obj: Any, **kwargs: Any) -> None:
    """Write obj to path as standard JSON, with a final newline."""
    Path(path).write_text(dumps(obj, **kwargs) + "\n")
