"""Every --json file is standard JSON: non-finite floats and numpy values never leak as Python-only words."""
import json
import math

import numpy as np
import pytest

from carav_stream.console import jsonout


def strict(text: str):
    return json.loads(text, parse_constant=lambda word: pytest.fail(f"not JSON: {word}"))


def test_non_finite_floats_are_spelt_as_strings_that_float_reads_back():
    data = {"a": math.nan, "b": [math.inf, -math.inf, 1.5], "c": {"d": np.float32("nan")}}
    back = strict(jsonout.dumps(data))
    assert back == {"a": "nan", "b": ["inf", "-inf", 1.5], "c": {"d": "nan"}}
    assert math.isnan(float(back["a"])) and float(back["b"][1]) == -math.inf


def test_numpy_values_paths_and_tuples_become_plain_json(tmp_path):
    data = {"n": np.int64(3), "x": np.arange(3, dtype=np.float32), "p": tmp_path, "t": (1, None, True), 4: "k"}
    jsonout.write(tmp_path / "out.json", data, indent=1)
    text = (tmp_path / "out.json").read_text()
    assert text.endswith("}\n")
    assert strict(text) == {"n": 3, "x": [0.0, 1.0, 2.0], "p": str(tmp_path), "t": [1, None, True], "4": "k"}
