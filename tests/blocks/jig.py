"""The golden-vector jig shared by the block tests (STYLE.md, "Tests").

A vector (tests/golden/golden_io.py) is fed to a fresh block twice: all cycles in one frame, then the same
cycles split at random frame boundaries (seeded by the vector's name); every frame goes through the codec
first, as in a graph. Both runs must give the vector's per-cycle outputs within its tolerance, and every
output frame must carry a dtype its port declares and one row per cycle.
"""
from __future__ import annotations

import importlib.util
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from carav_stream.runtime.block import Block
from carav_stream.runtime.frames import Frame, decode, encode

GOLDEN = Path(__file__).resolve().parents[1] / "golden"

# block outputs (a Frame or {port: Frame}) of one input frame -> {name: per-cycle array, cycles on axis 0}
Extract = Callable[[dict[str, Frame], int], dict[str, np.ndarray]]


def wire(frame: Frame, seq: int, stream: str = "x.y") -> Frame:
    """What a block receives: the frame after a trip through the codec."""
    return decode(encode(frame, seq=seq, stream=stream))


def splits(name: str, n_cycles: int) -> list[tuple[int, int]]:
    """Random frame boundaries for n_cycles (at least one cut when n_cycles > 1), seeded by the vector."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    cuts = [c for c in range(1, n_cycles) if rng.random() < 0.5]
    if n_cycles > 1 and not cuts:
        cuts = [int(rng.integers(1, n_cycles))]
    bounds = [0, *cuts, n_cycles]
    return list(zip(bounds[:-1], bounds[1:]))


def input_frame(vector: dict, port: str, a: int, b: int, cycle0: int) -> Frame:
    header = dict(vector["headers"].get(port, {}))
    if "per_cycle" in header:
        header["per_cycle"] = {k: v[a:b] for k, v in header["per_cycle"].items()}
    data = vector["inputs"].get(port)
    frame = Frame.of(None if data is None else data[a:b], cycle=cycle0 + a, cycles=b - a, **header)
    extra = {key.split("@", 1)[1]: v[a:b] for key, v in vector["inputs"].items() if key.startswith(port + "@")}
    return frame.derive(keep_data=True, arrays=extra) if extra else frame


def resolve(args: dict) -> dict:
    """A vector's args, with scene files named relative to tests/golden."""
    return {k: str(GOLDEN / v) if isinstance(v, str) and v.endswith(".toml") else v for k, v in args.items()}


def check_declared(block: Block, outputs: dict[str, Frame], n: int) -> None:
    """Every output frame's payload dtype is one its port declares, with one row per cycle it carries."""
    declared = {o.name: o.dtypes for o in block.outputs}
    for port, frame in outputs.items():
        assert port in declared, f"{type(block).__name__} sent on undeclared port {port!r}"
        cycles = frame.header.get("cycles", 1)
        assert 1 <= cycles <= n, f"port {port}: {cycles} cycles out of a frame of {n}"
        data = frame.payload
        if data is None:
            assert not declared[port] or "none" in declared[port], f"port {port}: no payload, declared {declared[port]}"
        else:
            assert not declared[port] or data.dtype.name in declared[port], \
                f"port {port}: payload {data.dtype}, declared {declared[port]}"
            assert data.shape[0] == cycles, f"port {port}: payload {data.shape} for {cycles} cycles"
        wire(frame, 0)   # and it must go on the wire


def run(block_cls: type[Block], vector: dict, extract: Extract, bounds: list[tuple[int, int]],
        cycle0: int = 100) -> dict[str, np.ndarray]:
    """Feed the vector's cycles to a fresh block in frames [a, b) of `bounds`; the outputs joined by cycle."""
    block = block_cls(**resolve(vector["args"]))
    block.start()
    ports = [p.name for p in block.inputs]
    parts: dict[str, list] = {}
    for seq, (a, b) in enumerate(bounds, start=1):
        frames = [wire(input_frame(vector, p, a, b, cycle0), seq, f"src.{p}") if p in vector["inputs"] else None
                  for p in ports]
        while frames and frames[-1] is None:   # an optional port left unconnected
            frames.pop()
        out = block.process(*frames)
        out = {} if out is None else out if isinstance(out, dict) else {block.outputs[0].name: out}
        check_declared(block, out, b - a)
        for name, values in extract({k: wire(f, seq) for k, f in out.items()}, b - a).items():
            assert len(values) == b - a, f"{name}: {len(values)} values for {b - a} cycles"
            parts.setdefault(name, []).append(np.asarray(values))
    return {name: np.concatenate(v) for name, v in parts.items()}


def compare(got: dict[str, np.ndarray], vector: dict, how: str) -> None:
    where = f"vector {vector['name']!r} ({vector['description']}), {how}"
    assert set(got) == set(vector["outputs"]), f"{where}: outputs {sorted(got)}, golden {sorted(vector['outputs'])}"
    for name, want in vector["outputs"].items():
        have = got[name]
        assert have.shape == want.shape, f"{where}: {name} has shape {have.shape}, golden {want.shape}"
        assert have.dtype.kind == want.dtype.kind and (want.dtype.kind in "UO" or have.dtype == want.dtype), \
            f"{where}: {name} is {have.dtype}, golden {want.dtype}"
        tol = vector["tolerance"].get(name)
        if tol is None:
            np.testing.assert_array_equal(have, want, err_msg=f"{where}: {name}")
        elif "max_mismatch" in tol:   # integers: at most that many elements off, each by at most atol
            off = np.flatnonzero((have != want).ravel())
            assert off.size <= tol["max_mismatch"], f"{where}: {name} differs in {off.size} elements, e.g. " \
                f"{have.ravel()[off[:5]].tolist()} for {want.ravel()[off[:5]].tolist()} at {off[:5].tolist()}"
            np.testing.assert_allclose(have, want, rtol=0, atol=tol["atol"], err_msg=f"{where}: {name}")
        else:
            np.testing.assert_allclose(have, want, rtol=tol.get("rtol", 0), atol=tol.get("atol", 0),
                                       err_msg=f"{where}: {name}")


def check_vector(block_cls: type[Block], vector: dict, extract: Extract) -> None:
    """The vector's outputs, from one frame of all cycles and from frames split at random boundaries."""
    n = next(iter(vector["inputs"].values())).shape[0]
    assert all(a.shape[0] == n for a in vector["inputs"].values()), "inputs of different cycle counts"
    compare(run(block_cls, vector, extract, [(0, n)]), vector, "all cycles in one frame")
    bounds = splits(vector["name"], n)
    compare(run(block_cls, vector, extract, bounds), vector, f"frames {bounds}")


def load_generator(block: str):
    """tests/golden/make_<block>.py as a module (its build() returns the vectors it writes)."""
    path = GOLDEN / f"make_{block}.py"
    spec = importlib.util.spec_from_file_location(f"golden_make_{block}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def check_generator_reproduces(block: str) -> None:
    """Rerunning the generator gives the committed .npz, array for array (a changed generator or numpy shows)."""
    from tests.golden import golden_io
    committed = np.load(GOLDEN / f"{block}.npz", allow_pickle=False)
    fresh = golden_io.flatten(load_generator(block).build())
    assert sorted(fresh) == sorted(committed.files), f"{block}.npz: fields differ from the generator's"
    for key, value in fresh.items():
        assert value.dtype == committed[key].dtype and value.shape == committed[key].shape, key
        np.testing.assert_array_equal(value, committed[key], err_msg=f"{block}.npz field {key}")


def vectors(block: str) -> dict[str, dict]:
    from tests.golden import golden_io
    return golden_io.load(GOLDEN / f"{block}.npz")
