"""Golden vectors: a block's per-cycle outputs for given inputs, computed by a reference written from the
equations (never by the code under test), checked in one frame and in frames cut at random boundaries.

A vector is a dict:

    {"name": "smart_rarms3", "description": "...", "args": {block parameters},
     "inputs": {port: array (cycles on axis 0), "port@name": an extra named array of that input},
     "headers": {port: {header fields, "per_cycle": {column: list}}},
     "outputs": {name: array, one row per cycle}, "tolerance": {name: {"rtol": .., "atol": ..}
                                                              or {"atol": .., "max_mismatch": n}}}

`extract(outputs, n)` turns what the block sent for one input frame of n cycles ({port: Frame}) into
{name: per-cycle array}: the test says what of the block's output the vector pins down. `save_vectors` and
`load_vectors` keep a block's vectors in one .npz (numpy arrays only, loaded without pickle); the file's layout is
described beside them.
"""
from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream.runtime.block import Block
from carav_stream.runtime.frames import Frame
from carav_stream.testing.harness import BlockHarness, frames_of, random_bounds

__all__ = ["Extract", "check_vector", "run_vector", "compare_vector", "save_vectors", "load_vectors", "flatten"]

Extract = Callable[[dict[str, Frame], int], dict[str, np.ndarray]]


def run_vector(block_cls: type[Block], vector: dict, extract: Extract, bounds: list[tuple[int, int]],
               cycle0: int = 100, args: dict | None = None) -> dict[str, np.ndarray]:
    """Feed the vector's cycles to a fresh block, one frame [a, b) of `bounds` per input at a time; the extracted
    outputs joined by cycle. `args` replaces the vector's block parameters (file names made absolute, say)."""
    h = BlockHarness(block_cls, **(vector["args"] if args is None else args))
    ports = [p.name for p in h.block.inputs if any(k == p.name or k.startswith(p.name + "@") for k in
                                                     (*vector["inputs"], *vector.get("headers", {})))]
    parts: dict[str, list] = {}
    for a, b in bounds:
        frames = {}
        for p in ports:
            header = dict(vector.get("headers", {}).get(p, {}))
            per = header.pop("per_cycle", None)
            extra = {k.split("@", 1)[1]: v for k, v in vector["inputs"].items() if k.startswith(p + "@")}
            frames[p] = frames_of(vector["inputs"].get(p), [(a, b)], cycle0=cycle0, header=header, per_cycle=per,
                                  arrays=extra or None)
        out = h.feed(frames, end=False)
        assert not out.unpaired, f"frames handed to unpaired: {out.unpaired}"
        sent = {}
        for port, fs in out.frames.items():
            assert len(fs) == 1, f"port {port}: {len(fs)} frames for one input frame"
            sent[port] = fs[0]
        for name, values in extract(sent, b - a).items():
            assert len(values) == b - a, f"{name}: {len(values)} values for {b - a} cycles"
            parts.setdefault(name, []).append(np.asarray(values))
    return {name: np.concatenate(v) for name, v in parts.items()}


def compare_vector(got: dict[str, np.ndarray], vector: dict, how: str) -> None:
    """The extracted outputs against the vector's, name by name: shape, dtype kind, values within tolerance."""
    where = f"vector {vector['name']!r} ({vector.get('description', '')}), {how}"
    assert set(got) == set(vector["outputs"]), f"{where}: outputs {sorted(got)}, golden {sorted(vector['outputs'])}"
    for name, want in vector["outputs"].items():
        have = got[name]
        assert have.shape == want.shape, f"{where}: {name} has shape {have.shape}, golden {want.shape}"
        assert have.dtype.kind == want.dtype.kind and (want.dtype.kind in "UO" or have.dtype == want.dtype), \
            f"{where}: {name} is {have.dtype}, golden {want.dtype}"
        tol = vector.get("tolerance", {}).get(name)
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


def check_vector(block_cls: type[Block], vector: dict, extract: Extract, args: dict | None = None) -> None:
    """The vector's outputs from one frame of all its cycles, and from frames cut at random boundaries (seeded by
    the vector's name)."""
    n = {len(a) for a in vector["inputs"].values()}
    assert len(n) == 1, f"vector {vector['name']!r}: inputs of different cycle counts {sorted(n)}"
    n = n.pop()
    compare_vector(run_vector(block_cls, vector, extract, [(0, n)], args=args), vector, "all cycles in one frame")
    bounds = random_bounds(n, vector["name"])
    compare_vector(run_vector(block_cls, vector, extract, bounds, args=args), vector, f"frames {bounds}")


# -- storage: one .npz per block, several vectors in it, no pickle ------------------------------------------------
# Every field is named "<vector>.<field>":
#     vectors                  json list of the vector names, in order
#     <v>.args                 json: the block's parameters
#     <v>.description          str: what the vector is ("2 cycles, smart attack, rarms 3.0")
#     <v>.generator            str: the reference generator's name
#     <v>.tolerance            json: {output: {"rtol": r, "atol": a}}; outputs not named are compared exactly
#     <v>.in.<port>            the input port's payload, cycles on axis 0
#     <v>.in.<port>@<array>    a further named array of that port's frames, cycles on axis 0
#     <v>.hdr.<port>           json: the port's header fields; "per_cycle" holds one list entry per cycle
#     <v>.out.<name>           the expected per-cycle output, cycles on axis 0
# Only plain arrays are stored (strings as numpy unicode arrays), so np.load needs no pickle.
def flatten(vectors: dict[str, dict]) -> dict[str, np.ndarray]:
    """vectors (name -> {args, description, generator, tolerance, inputs, headers, outputs}) as .npz fields."""
    out = {"vectors": np.array(json.dumps(list(vectors)))}
    for name, v in vectors.items():
        assert "." not in name, f"vector name {name!r}: no dots"
        out[f"{name}.args"] = np.array(json.dumps(v["args"], sort_keys=True))
        out[f"{name}.description"] = np.array(v["description"])
        out[f"{name}.generator"] = np.array(v["generator"])
        out[f"{name}.tolerance"] = np.array(json.dumps(v.get("tolerance", {}), sort_keys=True))
        for port, a in v["inputs"].items():
            out[f"{name}.in.{port}"] = np.asarray(a)
        for port, h in v.get("headers", {}).items():
            out[f"{name}.hdr.{port}"] = np.array(json.dumps(h, sort_keys=True))
        for key, a in v["outputs"].items():
            out[f"{name}.out.{key}"] = np.asarray(a)
    return out


def save_vectors(path: str | Path, vectors: dict[str, dict]) -> None:
    np.savez_compressed(path, **flatten(vectors))


def load_vectors(path: str | Path) -> dict[str, dict[str, Any]]:
    """The vectors of a file, in the shape `save_vectors` takes (json fields decoded)."""
    with np.load(path, allow_pickle=False) as z:
        flat = {k: z[k] for k in z.files}
    vectors = {}
    for name in json.loads(str(flat["vectors"])):
        v = {"name": name, "args": json.loads(str(flat[f"{name}.args"])),
             "description": str(flat[f"{name}.description"]), "generator": str(flat[f"{name}.generator"]),
             "tolerance": json.loads(str(flat[f"{name}.tolerance"])), "inputs": {}, "headers": {}, "outputs": {}}
        for key, a in flat.items():
            parts = key.split(".", 2)
            if parts[0] != name or len(parts) < 3:
                continue
            part = {"in": "inputs", "hdr": "headers", "out": "outputs"}[parts[1]]
            v[part][parts[2]] = json.loads(str(a)) if part == "headers" else a
        vectors[name] = v
    return vectors
