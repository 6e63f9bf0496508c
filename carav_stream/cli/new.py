"""`carav new block NAME [--kind filter|source|sink] [--dir DIR]`: a block to start from, its test and a graph.

Writes into DIR (default: the current folder), refusing to overwrite anything:

    NAME.py           the block: docstring with its equation, ports and a graph line; Param declarations; process
                      (or generate, for a source)
    test_NAME.py      its tests with the test kit (carav_stream.testing): the block in-process, whole and split at
                      random frame boundaries, against a reference computed here from the equation; and the graph
                      below run as real processes through the kit's pytest fixture `carav`
    NAME_graph.toml   a graph that wires the block (block_paths = ["."]: the block is found next to it)

`pytest DIR` passes as written; then change the block and its reference together.
"""
from __future__ import annotations

import argparse
import keyword
import re
from pathlib import Path

from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import output_folder
from carav_stream.runtime.registry import BUILTIN_PACKAGE, builtin_dir

__all__ = ["configure", "run", "files_for"]

KINDS = ("filter", "source", "sink")

FILTER = '''"""{title}: every sample of every cycle times a gain.

    out[c, ...] = gain * inp[c, ...]

Ports   in  inp   float32 | complex64 (cycles, ...)   samples of the cycles, cycles on axis 0
        out out   the same dtype and shape             the samples times `gain`
Graph   {name} = {{ type = "{name}", gain = 2.0 }}
"""
import numpy as np

from carav_stream.runtime import Block, Frame, In, Out, Param


class {cls}(Block):
    inputs = (In("inp", kind="any", dtypes=("float32", "complex64")),)      # kind: a label validation matches
    outputs = (Out("out", kind="any", dtypes=("float32", "complex64")),)
    params = (Param("gain", float, 1.0, "linear gain applied to every sample"),)

    def process(self, inp: Frame) -> Frame:
        x = inp.payload                                   # read-only: compute into a new array
        y = self.output_buffer("out", x.shape, x.dtype)   # in a shared-memory slot where the graph has one
        np.multiply(x, x.dtype.type(self.gain), out=y)
        return inp.derive(y)
'''

SOURCE = '''"""{title}: a ramp, one row of `n_values` values per cycle.

    out[c, k] = first + step * (c * n_values + k)

Ports   out out   float32 (cycles, n_values)   `batch` cycles per frame, the last frame sized to the run's cycles
Graph   {name} = {{ type = "{name}", n_values = 8, batch = 4 }}
"""
import numpy as np

from carav_stream.runtime import Block, Frame, Out, Param


class {cls}(Block):
    outputs = (Out("out", kind="any", dtypes=("float32",)),)
    params = (Param("n_values", int, 8, "values per cycle", low=1),
              Param("first", float, 0.0, "first value"),
              Param("step", float, 1.0, "increment from value to value"),
              Param("batch", int, 4, "cycles per frame", low=1))

    def start(self) -> None:
        self.next_cycle = 0

    def generate(self, seq: int) -> Frame | None:
        n = min(self.batch, self.cycle_budget or self.batch)   # cycle_budget: cycles still wanted (None: no end)
        if n <= 0:
            return None
        c0, self.next_cycle = self.next_cycle, self.next_cycle + n
        k = np.arange(c0 * self.n_values, (c0 + n) * self.n_values, dtype=np.float64)
        return Frame.of((self.first + self.step * k).astype(np.float32).reshape(n, self.n_values),
                        cycle=c0, cycles=n)
'''

SINK = '''"""{title}: count the cycles it receives and the energy of their samples.

    cycles += C,  energy += sum |inp|^2   over every frame of C cycles

Ports   in  inp   any numeric dtype (cycles, ...)   frames to account for
Graph   {name} = {{ type = "{name}" }}
Summary {{"cycles": cycles counted, "energy": sum of |samples|^2, "frames": frames received}}
"""
import numpy as np

from carav_stream.runtime import Block, Frame, In, n_cycles


class {cls}(Block):
    inputs = (In("inp", kind="any"),)

    def start(self) -> None:
        self.cycles, self.frames, self.energy = 0, 0, 0.0

    def process(self, inp: Frame) -> None:
        self.cycles += n_cycles(inp)
        self.frames += 1
        if inp.payload is not None:
            self.energy += float(np.sum(np.abs(inp.payload.astype(np.float64)) ** 2))

    def summary(self) -> dict:
        return {{"cycles": self.cycles, "frames": self.frames, "energy": self.energy}}
'''

FILTER_TEST = '''"""Tests of {name}: the block in-process against its equation (whole and split at random frame
boundaries), and a graph that wires it, run as real processes."""
from pathlib import Path

import numpy as np
import pytest

from carav_stream.testing import BlockHarness, assert_outputs, random_bounds
from carav_stream.testing.graphs import by_cycle, read_jsonl
from {name} import {cls}

HERE = Path(__file__).resolve().parent


@pytest.mark.parametrize("dtype", [np.float32, np.complex64])
def test_{name}_multiplies_every_sample_by_its_gain_whole_and_split(dtype):
    rng = np.random.default_rng(1)
    x = rng.standard_normal((7, 4, 5)).astype(dtype)
    want = (x * np.float64(2.5)).astype(dtype)                     # the equation, computed here in float64
    for bounds in (None, random_bounds(len(x), seed=3)):
        out = BlockHarness({cls}, gain=2.5).run({{"inp": x}}, bounds=bounds)
        assert_outputs(out.payloads(), {{"out": want}}, rtol=1e-6, where=f"frames {{bounds}}")


def test_{name}_graph_runs_as_processes_and_keeps_every_cycle(carav):
    run = carav.run(HERE / "{name}_graph.toml", "--cycles", "12")
    assert run.wait() == 0, run.stderr()
    cycles = by_cycle(read_jsonl(carav.workdir / "{name}.jsonl"))
    assert sorted(cycles) == list(range(12))
    assert run.summary()["lost"] == 0
'''

SOURCE_TEST = '''"""Tests of {name}: the block in-process against its equation, and a graph that wires it, run as real
processes."""
from pathlib import Path

import numpy as np

from carav_stream.testing import BlockHarness, check_declared
from carav_stream.testing.graphs import by_cycle, read_jsonl
from {name} import {cls}

HERE = Path(__file__).resolve().parent


def test_{name}_gives_the_ramp_of_its_equation_in_frames_of_batch_cycles():
    block = BlockHarness({cls}, n_values=3, first=1.0, step=0.5, batch=4).block
    block.cycle_budget = 10
    frames = []
    while block.cycle_budget > 0 and (frame := block.generate(len(frames))) is not None:
        check_declared(block, {{"out": frame}})
        block.cycle_budget -= frame.header["cycles"]
        frames.append(frame)
    assert [f.header["cycles"] for f in frames] == [4, 4, 2]
    got = np.concatenate([f.payload for f in frames])
    want = (1.0 + 0.5 * np.arange(30)).reshape(10, 3).astype(np.float32)   # the equation, computed here
    np.testing.assert_array_equal(got, want)


def test_{name}_graph_runs_as_processes_and_sends_every_cycle(carav):
    run = carav.run(HERE / "{name}_graph.toml", "--cycles", "10")
    assert run.wait() == 0, run.stderr()
    assert sorted(by_cycle(read_jsonl(carav.workdir / "{name}.jsonl"))) == list(range(10))
    assert run.summary()["lost"] == 0
'''

SINK_TEST = '''"""Tests of {name}: the block in-process against its equation, and a graph that wires it, run as real
processes."""
from pathlib import Path

import numpy as np

from carav_stream.testing import BlockHarness, random_bounds
from {name} import {cls}

HERE = Path(__file__).resolve().parent


def test_{name}_counts_cycles_and_energy_whole_and_split():
    x = np.random.default_rng(2).standard_normal((9, 3)).astype(np.float32)
    for bounds in (None, random_bounds(len(x), seed=5)):
        h = BlockHarness({cls})
        h.run({{"inp": x}}, bounds=bounds)
        s = h.block.summary()
        assert s["cycles"] == 9 and s["frames"] == len(bounds or [0])
        assert np.isclose(s["energy"], np.sum(x.astype(np.float64) ** 2), rtol=1e-12)


def test_{name}_graph_runs_as_processes_and_counts_every_cycle(carav):
    run = carav.run(HERE / "{name}_graph.toml", "--cycles", "12")
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["lost"] == 0 and s["per_node"]["{name}"]["history"][-1]["summary"]["cycles"] == 12
'''

FILTER_GRAPH = '''# {name} between a radar's receiver (Table I chirps and echoes) and a log of what it sends.
description = "{name} wired: chirp_source -> channel -> {name} -> jsonl_sink"
block_paths = ["."]
scene = "table1"
seed = 1
batch = 4
connections = ["source.tx -> channel.tx", "channel.rx -> {name}.inp", "{name}.out -> log.inp"]

[run]
cycles = 12

[blocks]
source  = {{ type = "chirp_source" }}
channel = {{ type = "channel" }}
{name} = {{ type = "{name}", gain = 2.0 }}
log     = {{ type = "jsonl_sink", path = "{name}.jsonl" }}
'''

SOURCE_GRAPH = '''# {name} into a log of what it sends.
description = "{name} wired: {name} -> jsonl_sink"
block_paths = ["."]
connections = ["{name}.out -> log.inp"]

[run]
cycles = 10

[blocks]
{name} = {{ type = "{name}", n_values = 8, batch = 4 }}
log    = {{ type = "jsonl_sink", path = "{name}.jsonl" }}
'''

SINK_GRAPH = '''# {name} at the end of a radar's receiver (Table I chirps and echoes).
description = "{name} wired: chirp_source -> channel -> {name}"
block_paths = ["."]
scene = "table1"
seed = 1
batch = 4
connections = ["source.tx -> channel.tx", "channel.rx -> {name}.inp"]

[run]
cycles = 12

[blocks]
source  = {{ type = "chirp_source" }}
channel = {{ type = "channel" }}
{name} = {{ type = "{name}" }}
'''

TEMPLATES = {"filter": (FILTER, FILTER_TEST, FILTER_GRAPH), "source": (SOURCE, SOURCE_TEST, SOURCE_GRAPH),
             "sink": (SINK, SINK_TEST, SINK_GRAPH)}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("what", choices=["block"], help="what to make")
    parser.add_argument("name", help="the block's graph type: a lower-case Python name (my_gain)")
    parser.add_argument("--kind", choices=KINDS, default="filter",
                        help="filter (one input, one output), source (no input) or sink (no output)")
    parser.add_argument("--dir", type=output_folder, default=Path("."), metavar="DIR",
                        help="where to write the three files (created if missing)")


def files_for(name: str, kind: str) -> dict[str, str]:
    """{file name: text} of a new block NAME of `kind`."""
    cls = "".join(part.capitalize() for part in name.split("_"))
    title = name.replace("_", " ").capitalize()
    block, test, graph = TEMPLATES[kind]
    fields = {"name": name, "cls": cls, "title": title}
    return {f"{name}.py": block.format(**fields), f"test_{name}.py": test.format(**fields),
            f"{name}_graph.toml": graph.format(**fields)}


def run(args: argparse.Namespace) -> int:
    name = args.name
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name) or keyword.iskeyword(name):
        raise CommandError(f"block name {name!r}: expected a lower-case Python name such as my_gain", Exit.USAGE)
    if (builtin_dir() / f"{name}.py").exists():
        raise CommandError(f"block name {name!r}: a built-in block ({BUILTIN_PACKAGE}.{name}) has it; choose another")
    files = files_for(name, args.kind)
    taken = [f for f in files if (args.dir / f).exists()]
    if taken:
        raise CommandError(f"{args.dir}: {', '.join(taken)} exist already; nothing written")
    args.dir.mkdir(parents=True, exist_ok=True)
    for f, text in files.items():
        (args.dir / f).write_text(text)
    print(f"wrote {', '.join(str(args.dir / f) for f in files)}\nrun its tests: pytest {args.dir}")
    return 0
