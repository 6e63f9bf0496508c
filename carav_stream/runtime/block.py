"""The block API: ports, typed parameters and the Block base class.

A block is a plain class that turns frames into frames. It never touches sockets, files or processes: the
runtime pairs its inputs by `seq`, calls `process`, stamps and sends what it returns. Declarations are class
attributes so that the graph validator and `carav blocks` read them without building the block.

    class Scale(Block):
        '''Multiply the payload by a gain.'''
        inputs = (In("x", kind="samples"),)
        outputs = (Out("y", kind="samples"),)
        params = (Param("gain", float, 1.0, "linear gain", low=0.0),)

        def process(self, x: Frame) -> Frame:
            return x.derive(x.payload * self.gain)
"""
from __future__ import annotations

import errno
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from carav_stream.core.params import REQUIRED, Param, problems
from carav_stream.runtime.frames import Frame

__all__ = ["REQUIRED", "Block", "BlockError", "In", "Out", "Param", "writing"]


@dataclass(frozen=True)
class In:
    """An input port. `kind` is a free label checked for compatibility ("any" accepts every kind).

    A `tap` input never slows its producers: when its queue is full the producer skips the frame for it (counted
    per edge as skipped, never as lost) instead of waiting. For observers (a live display), not for processing
    that must see every frame."""

    name: str
    kind: str = "any"
    doc: str = ""
    dtypes: tuple[str, ...] = ()   # accepted payload dtypes; () = any, ("none",) = header-only frames
    required: bool = True
    tap: bool = False


@dataclass(frozen=True)
class Out:
    """An output port. A `private` port's frames go only where the graph's edges take them: a port tap (an
    observer's sampled copy of what a port sends, runtime/port_tap.py) is refused on it."""

    name: str
    kind: str = "any"
    doc: str = ""
    dtypes: tuple[str, ...] = ()
    private: bool = False


class BlockError(ValueError):
    """A block was given parameters it cannot work with, or its input or output cannot go on; the text is the one
    line the user reads. retry=False: a restarted process would meet the same fault (a full disk, a read-only
    folder), so the supervisor fails the node at once whatever its restart policy."""

    def __init__(self, message: str, *, retry: bool = True) -> None:
        super().__init__(message)
        self.retry = retry


# what a block's constructor or its param_warnings() raise about its parameters: a problem of the graph, told at its
# place (validation, a swap, the checks a run makes later), never a crash
PARAM_ERRORS = (BlockError, ValueError, TypeError)


# errno values of a failed write that a restart does not cure: no space, no quota, a read-only file system, no
# permission, a file grown beyond its limit
_LASTING_WRITE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG})


@contextmanager
def writing(path: str) -> Iterator[None]:
    """A failed write (a full disk, a quota, a lost mount) as a BlockError naming the file in one line, not the
    block's traceback; a fault a restart would meet again says so (retry=False)."""
    try:
        yield
    except OSError as exc:
        raise BlockError(f"{exc.filename or path}: cannot write: {exc.strerror or exc}",
                         retry=exc.errno not in _LASTING_WRITE_ERRORS) from None


class Block:
    """Base class. Subclasses declare `inputs`, `outputs`, `params` and implement `process` (or `generate`).

    Life cycle, all inside the block's own process except `__init__` and `check_params`:
      __init__(**params)  check parameters only (no I/O)
      start()             open resources; called once in the block's process before the first frame
      generate(seq)       sources only (no inputs): the frame(s) for output `seq`, or None at end of stream;
                          before each call the runtime sets `self.cycle_budget`, the cycles still wanted
                          (None = until stopped), so that a source putting several cycles in one frame
                          (header `cycles`) can size its last frame
      ready_in(seq)       sources only: seconds until frame `seq` may be generated (default 0: at once); the
                          runtime serves control and heartbeats meanwhile, so a paced source stops and swaps
                          as promptly as a free-running one
      process(*frames)    one frame per input, all with the same seq; returns a Frame (single output), a dict
                          {port: Frame}, or None (nothing this time)
      unpaired(port, f)   a frame whose partners on the other inputs can no longer arrive; default raises
      finish()            at end of stream; may return final frames like process
      summary()           a dict of figures for the run summary (plain types)

    `output_buffer(port, shape, dtype)` gives an empty array to compute an output into: over the shared-memory
    data plane it lies in a slot of that port's segment, so the frame that returns it as its first array (the
    payload) is sent without a copy; elsewhere it is np.empty. Return it from the same process() call, on that
    port, or drop it.
    """

    inputs: ClassVar[tuple[In, ...]] = ()
    outputs: ClassVar[tuple[Out, ...]] = ()
    params: ClassVar[tuple[Param, ...]] = ()
    version: ClassVar[str] = "1"
    # False: inputs are paired by seq (process gets one frame per input). True: inputs are independent
    # streams, merged in arrival order (process gets one frame, None for the other inputs).
    merge_inputs: ClassVar[bool] = False
    # Why a restarted process of this block would leave its output wrong (say, a file whose end it writes from
    # what it held in memory); when set, the graph validator refuses any restart policy but "never" for it.
    not_restartable: ClassVar[str] = ""
    # The parameter that selects a variant whose other parameters depend on it (the attacker's `model`): a graph
    # that includes this node, or a --set, and changes it starts from the new variant's defaults (loader.py).
    variant: ClassVar[str | None] = None
    cycle_budget: int | None = None   # sources: set by the runtime before each generate()
    # (incarnation, generation), set by the runtime before start(): (0, 0) for the block a run starts with; a
    # restarted process counts incarnations, a block swapped in counts generations. A block drawing from a
    # seeded random stream derives it from this too, so that a new instance never replays what one before drew.
    instance: tuple[int, int] = (0, 0)

    # set by the runtime in a node: (port, shape, dtype) -> a writable array, or None (see output_buffer)
    allocate: Any = None

    def output_buffer(self, port: str, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        """An uninitialised array to compute output `port`'s payload into (see the class docstring)."""
        if self.allocate is not None:
            array = self.allocate(port, tuple(shape), np.dtype(dtype))
            if array is not None:
                return array
        return np.empty(shape, dtype)

    def __init__(self, **values: Any) -> None:
        problems = self.param_problems(values)
        if problems:
            raise BlockError("; ".join(f"{name}: {text}" for name, text in problems))
        for p in self.params:
            setattr(self, p.name, p.check(values[p.name])[0] if p.name in values else p.default)
        try:
            self.check_params()
        except BlockError:
            raise
        except ValueError as exc:   # a kernel's own validation (a bad scene file, say) speaks for the block
            raise BlockError(str(exc)) from None

    @classmethod
    def param_problems(cls, values: dict[str, Any]) -> list[tuple[str, str]]:
        """Every problem with `values`, as (parameter name, text); empty when they are fine."""
        return problems(cls.params, values, cls.__name__)

    def check_params(self) -> None:
        """Cross-parameter checks; raise BlockError (or ValueError) naming the parameters."""

    def param_warnings(self) -> list[str]:
        """Legal but doubtful settings, each explained in one line (shown by `carav validate` and `carav run`)."""
        return []

    def start(self) -> None:
        pass

    def generate(self, seq: int) -> Frame | dict[str, Frame] | None:
        raise NotImplementedError(f"{type(self).__name__} has no inputs and must implement generate()")

    def ready_in(self, seq: int) -> float:
        return 0.0

    def process(self, *frames: Frame) -> Frame | dict[str, Frame] | None:
        raise NotImplementedError(f"{type(self).__name__} must implement process()")

    def unpaired(self, port: str, frame: Frame) -> Frame | dict[str, Frame] | None:
        other = [p.name for p in self.inputs if p.name != port]
        raise BlockError(f"frame seq {frame.seq} on input {port!r} has no partner on {other}: "
                         "an upstream node skipped it")

    def finish(self) -> Frame | dict[str, Frame] | None:
        return None

    def summary(self) -> dict[str, Any]:
        return {}

    @classmethod
    def is_source(cls) -> bool:
        return not cls.inputs

