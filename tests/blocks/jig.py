"""The golden-vector jig of the project's block tests: the vectors of tests/golden, checked with the kit
(carav_stream.testing.golden: every vector fed whole and split at random frame boundaries, through the codec and the
node's pairing)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from carav_stream.runtime.block import Block
from carav_stream.testing import golden
from carav_stream.testing.golden import Extract
from carav_stream.testing.harness import wire
from tests.golden import golden_io

__all__ = ["GOLDEN", "wire", "resolve", "check_vector", "run", "check_generator_reproduces", "vectors"]

GOLDEN = Path(__file__).resolve().parents[1] / "golden"


def resolve(args: dict) -> dict:
    """A vector's args, with scene files named relative to tests/golden."""
    return {k: str(GOLDEN / v) if isinstance(v, str) and v.endswith(".toml") else v for k, v in args.items()}


def check_vector(block_cls: type[Block], vector: dict, extract: Extract) -> None:
    golden.check_vector(block_cls, vector, extract, args=resolve(vector["args"]))


def run(block_cls: type[Block], vector: dict, extract: Extract, bounds: list[tuple[int, int]]) -> dict[str, np.ndarray]:
    return golden.run_vector(block_cls, vector, extract, bounds, args=resolve(vector["args"]))


def load_generator(block: str):
    """tests/golden/make_<block>.py as a module (its build() returns the vectors it writes)."""
    path = GOLDEN / f"make_{block}.py"
    spec = importlib.util.spec_from_file_location(f"golden_make_{block}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def check_generator_reproduces(block: str) -> None:
    """Rerunning the generator gives the committed .npz, array for array (a changed generator or numpy shows)."""
    committed = np.load(GOLDEN / f"{block}.npz", allow_pickle=False)
    fresh = golden_io.flatten(load_generator(block).build())
    assert sorted(fresh) == sorted(committed.files), f"{block}.npz: fields differ from the generator's"
    for key, value in fresh.items():
        assert value.dtype == committed[key].dtype and value.shape == committed[key].shape, key
        np.testing.assert_array_equal(value, committed[key], err_msg=f"{block}.npz field {key}")


def vectors(block: str) -> dict[str, dict]:
    return golden_io.load(GOLDEN / f"{block}.npz")
