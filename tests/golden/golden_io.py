"""Golden-vector files: one .npz per block, several vectors in it, every field named "<vector>.<field>".

    vectors                  json list of the vector names, in order
    <v>.args                 json: the block's parameters
    <v>.description          str, derived from the generator's arguments ("2 cycles, smart attack, rarms 3.0")
    <v>.generator            str, the generator script's name
    <v>.tolerance            json: {output: {"rtol": r, "atol": a}}; outputs not named are compared exactly
    <v>.in.<port>            the input port's payload, cycles on axis 0 (the jig splits it)
    <v>.in.<port>@<array>    a further named array of that port's frames (the gate's "rho"), cycles on axis 0
    <v>.hdr.<port>           json: the port's header fields; "per_cycle" holds one list entry per cycle
    <v>.out.<name>           the expected per-cycle output, cycles on axis 0

Only plain arrays are stored (strings as numpy unicode arrays), so np.load needs no pickle.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def save(path: Path, vectors: dict[str, dict]) -> None:
    """vectors: name -> {args, description, generator, tolerance, inputs, headers, outputs}."""
    np.savez_compressed(path, **flatten(vectors))


def flatten(vectors: dict[str, dict]) -> dict[str, np.ndarray]:
    out = {"vectors": np.array(json.dumps(list(vectors)))}
    for name, v in vectors.items():
        assert "." not in name, name
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


def load(path: Path) -> dict[str, dict]:
    """The vectors of a file, in the shape `save` takes (json fields decoded)."""
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
            field = {"in": "inputs", "hdr": "headers", "out": "outputs"}[parts[1]]
            v[field][parts[2]] = json.loads(str(a)) if field == "headers" else a
        vectors[name] = v
    return vectors
