"""Data planes: where the arrays of a frame travel on the edges of a run that stay on one host. ZeroMQ carries every
message; a plane may keep a frame's arrays elsewhere and put in the header, under "shm", the reference (a list)
that its consumers resolve. The graph chooses one plane for the run with `[run] transport = NAME`.

A plane is one module defining one `Plane` subclass, named after the file: the built-in ones are the modules of
this package (`zmq`: the arrays inside the ZeroMQ messages; `shm`: in shared memory), and every module of a
folder named in CARAV_PLANE_PATH (folders separated by the path separator, as in CARAV_BLOCK_PATH) adds one; a
folder's module named like a plane found before it is not used.

    supervisor   plane = Plane(run, run_dir)                     one per run, after the run folder exists
                 plane.open_port("node.port", edges)             for each output port whose edges all stay on the
                     -> PortResources(producer, consumers, fds)  host: what its ends open, the fds they inherit;
                     -> None                                     or the port's frames go inline
                 plane.close()                                   when the run ends, whatever the way
    producer     writer = Plane.writer(resources, taps)
                 ref = writer.place(buffers, cut, idle)          the reference for the header, or None: inline
                 writer.delivered(ref, missed)                   after the message went; `missed`: edges it missed
                 writer.resume_fields()                          header fields of a resume marker (restarts)
    consumer     reader = Plane.reader(resources)
                 reader.resolve(ref, sizes)                      one read-only buffer per array, or ValueError
                 reader.resume(header)                           on the producer's resume marker

The resources are msgpack data (they travel in the node specs); the file descriptors are inherited by the nodes
that use them. A reader refuses what it cannot honour with a ValueError whose text says why (the frame is then
rejected and counted like any bad message), and must never hand out bytes a writer may still change.
"""
from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from carav_stream.core.modules import import_file, module_files

PATH_ENV = "CARAV_PLANE_PATH"
DEFAULT = "zmq"         # the plane of a graph that names none (graph.RUN_DEFAULTS), listed first


class PlaneError(LookupError):
    pass


@dataclass(frozen=True)
class PortResources:
    """What the ends of one output port open: the producer's resources, one for each edge's consumer (in the
    order of the edges given to open_port), and the file descriptors both inherit."""

    producer: Any
    consumers: list[Any]
    fds: tuple[int, ...] = field(default_factory=tuple)


class Writer:
    """The producer's end of a plane on one output port."""

    waiting = False          # waiting for room on the plane (a node's state line says it)
    waits_for = "room on its data plane"

    def place(self, buffers: list[Any], cut: Collection[str], idle: Callable[[], None]) -> list[Any] | None:
        """Keep a frame's buffers on the plane: the reference that goes in the header (the message is then the
        header alone), or None for a frame that goes inline. `cut`: edges of the port whose consumer is gone for
        good; `idle` serves the node's control while this waits."""
        raise NotImplementedError

    def delivered(self, ref: list[Any] | None, missed: Sequence[str]) -> None:
        """The message of the frame last placed (`ref`, None if it went inline) went out, except on `missed`."""

    def reserve(self, shape: tuple[int, ...], dtype: Any, cut: Collection[str],
                idle: Callable[[], None]) -> Any:
        """A writable array on the plane for a block to compute its payload into (Block.output_buffer), or None."""
        return None

    def resume_fields(self) -> dict[str, Any]:
        """Header fields of the resume marker sent on a fresh connection to a restarted consumer."""
        return {}

    def counters(self) -> dict[str, Any]:
        return {}

    def close(self) -> None:
        pass


class Reader:
    """A consumer's end of a plane on one input port."""

    def resolve(self, ref: Any, sizes: list[int]) -> list[Any]:
        """The read-only buffers (one per array, of `sizes` bytes) a header's reference names; ValueError for a
        reference that cannot be honoured, saying why."""
        raise NotImplementedError

    def resume(self, header: Mapping[str, Any]) -> None:
        """The producer connected afresh and sent this resume marker first."""

    def close(self) -> None:
        pass


class Plane:
    """A data plane of one run, on its supervisor's side; `writer` and `reader` open its ends in the nodes."""

    name = ""                # set by the registry: the module's name
    header_only = False      # its messages are mostly headers alone: ZeroMQ gets small kernel buffers for them

    def __init__(self, run: Mapping[str, Any], run_dir: Path) -> None:
        self.run, self.run_dir = run, run_dir

    def open_port(self, port: str, edges: list[str]) -> PortResources | None:
        """The resources of output `port` ("node.port") whose `edges` all stay on the host, or None (inline)."""
        return None

    def close(self) -> None:
        """Free what open_port made (the run has ended)."""

    @classmethod
    def writer(cls, resources: Any, taps: Collection[str]) -> Writer:
        """The producer's end; `taps`: edges of the port whose consumer is a tap (never waited for)."""
        raise NotImplementedError

    @classmethod
    def reader(cls, resources: Any) -> Reader:
        raise NotImplementedError


def _files() -> dict[str, Path]:
    """Plane name -> its module file: the built-in ones, then those of CARAV_PLANE_PATH's folders."""
    folders = [Path(__file__).parent, *(Path(p).resolve() for p in os.environ.get(PATH_ENV, "").split(os.pathsep) if p)]
    found: dict[str, Path] = {}
    for folder in folders:
        for name, path in module_files(folder).items():
            found.setdefault(name, path)
    return found


def names() -> tuple[str, ...]:
    """The planes a graph may name: the default first, then the other built-in ones and the folders' by name."""
    builtin = Path(__file__).parent
    order = sorted(_files().items(), key=lambda item: (item[0] != DEFAULT, item[1].parent != builtin, item[0]))
    return tuple(name for name, _ in order)


def get(name: str) -> type[Plane]:
    """The Plane subclass of plane `name`; PlaneError for an unknown name or a module that does not define one."""
    path = _files().get(name)
    if path is None:
        raise PlaneError(f"unknown data plane {name!r}; known planes: {', '.join(names())}")
    module = _load(path)
    classes = [c for c in vars(module).values()
               if inspect.isclass(c) and issubclass(c, Plane) and c is not Plane and c.__module__ == module.__name__]
    if len(classes) != 1:
        raise PlaneError(f"{path}: a plane module must define exactly one Plane subclass, found "
                         f"{[c.__name__ for c in classes] or 'none'}")
    classes[0].name = name
    return classes[0]


def _load(path: Path) -> Any:
    try:
        return import_file(path, Path(__file__).parent, __name__, "carav_user_planes")
    except BaseException as exc:
        raise PlaneError(f"{path}: plane module failed to import: {type(exc).__name__}: {exc}") from exc
