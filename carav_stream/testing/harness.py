"""A block in-process, fed as a node feeds it: frames through the codec, paired by seq, outputs collected.

    h = BlockHarness(MyGain, gain=2.0)                         # built with its parameters, start()ed
    out = h.run({"inp": x})                                    # x: (cycles, ...) array, all cycles in one frame
    out = h.run({"inp": x}, bounds=random_bounds(len(x), 7))   # the same cycles in frames cut at random
    assert_outputs(out.payloads(), {"out": 2 * x})

Each input frame goes through `encode`/`decode` first, as on the wire, so a block that changes a received
(read-only) array, or puts something unpacked in a header, fails here as it would in a graph. The frames of every
input are handed to a `runtime.pairing.Pairing`, the node's own input logic: a paired block gets one frame per
input with the same seq, a frame whose partner never comes goes to the block's `unpaired`, a merging block gets
each frame alone. Every output frame must carry a dtype its port declares and one row per cycle
(`check_declared`), and must itself encode.
"""
from __future__ import annotations

import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from carav_stream.runtime.block import Block
from carav_stream.runtime.frames import Frame, decode, encode, end_of_stream
from carav_stream.runtime.pairing import Pairing

__all__ = ["BlockHarness", "Outputs", "wire", "random_bounds", "frames_of", "check_declared", "assert_outputs"]


def wire(frame: Frame, seq: int, stream: str = "src.out") -> Frame:
    """What a block receives: `frame` after a trip through the codec, stamped with `seq`."""
    return decode(encode(frame, seq=seq, stream=stream))


def random_bounds(n_cycles: int, seed: int | str = 0) -> list[tuple[int, int]]:
    """Frame boundaries [a, b) over n_cycles, cut at random (at least one cut when n_cycles > 1)."""
    rng = np.random.default_rng(zlib.crc32(seed.encode()) if isinstance(seed, str) else seed)
    cuts = [c for c in range(1, n_cycles) if rng.random() < 0.5]
    if n_cycles > 1 and not cuts:
        cuts = [int(rng.integers(1, n_cycles))]
    edges = [0, *cuts, n_cycles]
    return list(zip(edges[:-1], edges[1:]))


def frames_of(data: np.ndarray | None, bounds: list[tuple[int, int]], *, cycle0: int = 0,
              header: Mapping[str, Any] | None = None, per_cycle: Mapping[str, Any] | None = None,
              arrays: Mapping[str, np.ndarray] | None = None) -> list[Frame]:
    """One input's frames: rows [a, b) of `data` (cycles on axis 0; None for a header-only input), the header
    fields `header`, the per-cycle columns `per_cycle` and the extra named `arrays` cut the same way."""
    out = []
    for a, b in bounds:
        fields = dict(header or {})
        if per_cycle:
            fields["per_cycle"] = {k: list(v[a:b]) for k, v in per_cycle.items()}
        frame = Frame.of(None if data is None else np.asarray(data)[a:b], cycle=cycle0 + a, cycles=b - a, **fields)
        if arrays:
            frame = frame.derive(keep_data=True, arrays={k: np.asarray(v)[a:b] for k, v in arrays.items()})
        out.append(frame)
    return out


def check_declared(block: Block, outputs: Mapping[str, Frame], n_cycles: int | None = None) -> None:
    """Every output frame goes out on a declared port, with a payload dtype that port declares, one payload row per
    cycle it says it carries (at most n_cycles), and a header that encodes."""
    declared = {o.name: o.dtypes for o in block.outputs}
    for port, frame in outputs.items():
        assert port in declared, f"{type(block).__name__} sent on undeclared port {port!r}"
        cycles = frame.header.get("cycles", 1)
        assert isinstance(cycles, int) and cycles >= 1, f"port {port}: cycles = {cycles!r}"
        assert n_cycles is None or cycles <= n_cycles, f"port {port}: {cycles} cycles out of a frame of {n_cycles}"
        data = frame.payload
        if data is None:
            assert not declared[port] or "none" in declared[port], f"port {port}: no payload, declared {declared[port]}"
        else:
            assert not declared[port] or data.dtype.name in declared[port], \
                f"port {port}: payload {data.dtype}, declared {declared[port]}"
            assert data.shape[0] == cycles, f"port {port}: payload {data.shape} for {cycles} cycles"
        wire(frame, 0)


@dataclass
class Outputs:
    """What a block sent, per output port, in order: the frames (as a consumer receives them) and `unpaired`, the
    input frames the pairing handed to `unpaired` (port, seq)."""

    frames: dict[str, list[Frame]] = field(default_factory=dict)
    unpaired: list[tuple[str, int]] = field(default_factory=list)

    def payloads(self) -> dict[str, np.ndarray]:
        """Each port's payloads joined along the cycle axis."""
        return {p: np.concatenate([f.payload for f in fs]) for p, fs in self.frames.items()
                if fs and all(f.payload is not None for f in fs)}

    def column(self, port: str, name: str) -> list:
        """A per-cycle column of a port (header `per_cycle[name]`), joined over its frames."""
        return [v for f in self.frames.get(port, []) for v in (f.header.get("per_cycle") or {}).get(name, [])]

    def headers(self, port: str) -> list[dict]:
        return [f.header for f in self.frames.get(port, [])]


class BlockHarness:
    """One block, started in this process and fed frames as a node feeds it (see the module docstring)."""

    def __init__(self, block: type[Block] | Block, **params: Any) -> None:
        self.block = block(**params) if isinstance(block, type) else block
        self.block.start()
        self.ports = [p.name for p in self.block.inputs]
        self.seq = 0

    def feed(self, frames: Mapping[str, list[Frame]], *, end: bool = True) -> Outputs:
        """Hand every input's frames (in order; each stamped with the next seq of its input) to the block through
        the node's pairing, then, with `end`, an end of stream on every input and the block's `finish()`."""
        connected = [p for p in self.ports if p in frames]
        unknown = set(frames) - set(self.ports)
        assert not unknown, f"{type(self.block).__name__} has no input {sorted(unknown)}; inputs {self.ports}"
        pairing = Pairing(connected, limit=1 << 30)
        out = Outputs()
        merge = type(self.block).merge_inputs
        for port in connected:
            for i, frame in enumerate(frames[port]):
                received = wire(frame, self.seq + i, f"src.{port}")
                ok, why = pairing.admit(port, received)
                assert ok, f"input {port}: frame {i} refused: {why}"
                pairing.push(port, received)
            if end:
                last = self.seq + len(frames[port])
                pairing.admit(port, wire(end_of_stream(last, count=len(frames[port])), last, f"src.{port}"))
        self.seq += max((len(f) for f in frames.values()), default=0)
        while (nxt := pairing.next_set(merge)) is not None:
            what, got, port = nxt
            if what == "unpaired":
                out.unpaired.append((port, got[0].seq))
                self._collect(out, self.block.unpaired(port, got[0]), got[0])
                continue
            full = {port: got[0]} if merge else dict(zip(connected, got))
            self._collect(out, self.block.process(*map(full.get, self.ports)), got[0])
        if end:
            self._collect(out, self.block.finish(), None)
        return out

    def run(self, inputs: Mapping[str, np.ndarray | None], *, bounds: list[tuple[int, int]] | None = None,
            cycle0: int = 0, headers: Mapping[str, Mapping[str, Any]] | None = None,
            per_cycle: Mapping[str, Mapping[str, Any]] | None = None,
            arrays: Mapping[str, Mapping[str, np.ndarray]] | None = None) -> Outputs:
        """Every input's cycles (arrays with cycles on axis 0; None for a header-only input) in frames cut at
        `bounds` (default: all in one frame), with their header fields, per-cycle columns and extra arrays."""
        n = _n_cycles(inputs, per_cycle)
        bounds = bounds or [(0, n)]
        assert bounds[0][0] == 0 and bounds[-1][1] == n, f"bounds {bounds} do not cover {n} cycles"
        frames = {p: frames_of(x, bounds, cycle0=cycle0, header=(headers or {}).get(p),
                               per_cycle=(per_cycle or {}).get(p), arrays=(arrays or {}).get(p))
                  for p, x in inputs.items()}
        return self.feed(frames)

    def _collect(self, out: Outputs, result: Frame | dict[str, Frame] | None, context: Frame | None) -> None:
        if result is None:
            return
        result = result if isinstance(result, dict) else {self.block.outputs[0].name: result}
        n = None if context is None else context.header.get("cycles", 1)
        check_declared(self.block, result, n)
        for port, frame in result.items():
            out.frames.setdefault(port, []).append(wire(frame, len(out.frames.get(port, [])), f"blk.{port}"))


def _n_cycles(inputs: Mapping[str, np.ndarray | None], per_cycle: Mapping[str, Mapping[str, Any]] | None) -> int:
    counts = {len(x) for x in inputs.values() if x is not None}
    counts |= {len(v) for cols in (per_cycle or {}).values() for v in cols.values()}
    assert len(counts) == 1, f"inputs of different cycle counts: {sorted(counts)}"
    return counts.pop()


def assert_outputs(got: Mapping[str, np.ndarray], expected: Mapping[str, np.ndarray], *, rtol: float = 0.0,
                   atol: float = 0.0, where: str = "") -> None:
    """The same names, and for each the same dtype and shape, and values within rtol/atol (exactly equal by
    default; NaN equals NaN)."""
    where = f"{where}: " if where else ""
    assert set(got) == set(expected), f"{where}outputs {sorted(got)}, expected {sorted(expected)}"
    for name, want in expected.items():
        have, want = np.asarray(got[name]), np.asarray(want)
        assert have.shape == want.shape, f"{where}{name} has shape {have.shape}, expected {want.shape}"
        assert have.dtype == want.dtype or (have.dtype.kind in "UO" and want.dtype.kind in "UO"), \
            f"{where}{name} is {have.dtype}, expected {want.dtype}"
        if rtol == 0 and atol == 0 or have.dtype.kind in "UOb":
            np.testing.assert_array_equal(have, want, err_msg=f"{where}{name}")
        else:
            np.testing.assert_allclose(have, want, rtol=rtol, atol=atol, err_msg=f"{where}{name}")
