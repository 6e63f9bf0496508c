"""The zygote: a warm process that starts one supervisor's nodes by forking, so that a node's start costs a fork and
not an interpreter importing numpy, scipy, ZeroMQ and its block. The supervisor's side is launcher.py.

    supervisor --Popen--> python -m carav_stream.node_start --zygote FD ROOM   (dies with the supervisor)
    supervisor --request, the node's descriptors (SCM_RIGHTS)--> zygote --fork--> middle --fork--> node
    middle exits at once: the node is the supervisor's child (a child subreaper); the zygote answers its pid

Imports. Once, what every node imports (`runtime.node`, the data planes, and through them numpy, ZeroMQ,
msgpack), then the built-in blocks the run names (a request `{"blocks": [type, ...]}`, which the supervisor sends as
soon as the graph's node types are read: the zygote imports them while the command validates the graph) and, before
it forks a node, that node's block if it has not imported it yet (a swap to another type, say), each once; after
every import `gc.freeze()`, so that the nodes' collections leave the shared pages alone. A block's own import
(scipy.signal for the waveform fidelity, say) is paid only by graphs that use it.
The zygote makes no ZeroMQ context, no thread and opens no descriptor but its link to the supervisor: a fork
copies none into a node (tests/runtime/test_zygote.py holds it to that). With more than one thread after its
imports (a BLAS told to start threads) it exits, saying so, and the supervisor starts nodes as before.

Parenthood. The supervisor marked itself a child subreaper (prctl PR_SET_CHILD_SUBREAPER) before starting the
zygote. For each request the zygote forks a middle process, which forks the node and exits: the orphaned node is
adopted by the supervisor, which is then its parent as it is of a node it starts with Popen, and the only process
that can reap it (the pid trust of senders.py). The zygote answers with the node's pid only after it reaped the
middle (the adoption is done by then), and only then lets the node go on, by one byte on a pipe: a node never
runs before its supervisor knows its pid, and a node whose zygote died before answering exits at once.

The node, before it runs `runtime.node` as __main__ (what node_start.py runs):
- descriptors: /dev/null as standard input, its log as standard output and error, its data plane's descriptors
  (spec.inherit_fds, received from the supervisor) at the numbers the spec names; every other one is closed;
- its environment is the one the supervisor sends; its command line (/proc/PID/cmdline) is the one Popen would
  have given it, written over the zygote's, which the supervisor made long enough (the rest NUL bytes);
- random state a fork copies is drawn afresh from the OS: numpy's legacy global generator and Python's `random`
  (no other module-level generator is loaded: tests/runtime/test_zygote.py); the activation sequence's secure
  source reads the OS's generator at every draw (radar/activation.py) and holds nothing a fork could copy;
- as node_start.py does for a node it starts: the parent-death signal, then the check that its parent is the
  supervisor named in its environment (a supervisor that died before the adoption left it to another parent).
Its exit: the status of runtime.node's main, after threads, atexit handlers and the standard streams are done.
"""
from __future__ import annotations

import atexit
import ctypes
import fcntl
import gc
import importlib
import json
import os
import random
import runpy
import signal
import socket
import sys
import threading
import traceback
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import carav_stream.runtime.node  # noqa: F401  (imported once here, for every node forked from this process)
from carav_stream import node_start
from carav_stream.runtime import planes
from carav_stream.runtime.registry import builtin_dir, load_block_file

NODE_MODULE = "carav_stream.runtime.node"
MAX_REQUEST = 1 << 20          # bytes of one request (its environment included)
MAX_FDS = 250                  # descriptors of one request: the log and the data plane's


def preload(extra: Sequence[str] = ()) -> list[str]:
    """Import the data planes (and `extra` modules); the problems, one line each (a module that fails here fails
    again in the node that needs it, which reports it)."""
    problems = []
    folder = Path(planes.__file__).parent
    for name in [*(f"{planes.__name__}.{p.stem}" for p in sorted(folder.glob("[!_]*.py"))), *extra]:
        try:
            importlib.import_module(name)
        except Exception as exc:
            problems.append(f"{name}: {type(exc).__name__}: {exc}")
    return problems


def import_blocks(types: Sequence[str]) -> list[str]:
    """Import the built-in blocks of these types (each once; a type that is not a built-in block, a user's, is left to
    its node); the problems, one line each (a block that fails here fails again in its node, which reports it)."""
    problems = []
    for name in types:
        path = builtin_dir() / f"{name}.py"
        if not (isinstance(name, str) and name.isidentifier() and path.is_file()) or name in _imported:
            continue
        _imported.add(name)
        try:
            load_block_file(path)
        except Exception as exc:
            problems.append(f"{path.name}: {exc}")
    return problems


_imported: set[str] = set()         # the built-in block types this process imported (import_blocks)


def threads() -> int:
    """Threads of this process, as the kernel counts them (ZeroMQ's and BLAS's included)."""
    return len(os.listdir("/proc/self/task"))


def set_command_line(argv: Sequence[str]) -> bool:
    """Write `argv` over this process's command line, NUL-padded (what /proc/PID/cmdline and ps show); False when it
    does not fit in the room the process started with (nothing written). The room lies between arg_start and
    arg_end of /proc/self/stat (fields 48 and 49), in the process's own memory; the interpreter keeps copies of
    its arguments elsewhere and never reads it again."""
    with open("/proc/self/stat", "rb") as fh:
        stat = fh.read()
    fields = stat[stat.rfind(b")") + 2:].split()
    start, end = int(fields[45]), int(fields[46])
    text = b"\0".join(os.fsencode(a) for a in argv) + b"\0"
    if not start or len(text) > end - start:
        return False
    ctypes.memmove(start, text.ljust(end - start, b"\0"), end - start)
    return True


def place_fds(log: int, given: Sequence[int], targets: Sequence[int], keep: int) -> int:
    """Descriptors of a forked node: /dev/null as 0, `log` as 1 and 2, each of `given` at the number `targets` names;
    every other descriptor closed but `keep` (the go pipe), whose number after the move is returned."""
    top = max([2, *targets]) + 1
    moved = [fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, top) for fd in (log, *given, keep)]
    log, *given, keep = moved
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.dup2(log, 1)
    os.dup2(log, 2)
    for fd, target in zip(given, targets):
        os.dup2(fd, target)          # inheritable, as Popen's pass_fds leaves them
    for fd in set(map(int, os.listdir("/proc/self/fd"))) - {0, 1, 2, *targets, keep}:
        try:
            os.close(fd)
        except OSError:          # the listing's own descriptor, closed once listed
            pass
    return keep


def reseed() -> None:
    """Draw afresh, from the OS, the random state a fork copied (module docstring)."""
    np.random.seed()
    random.seed()


def become_node(request: dict, fds: list[int], go: int, link: socket.socket) -> None:
    """The forked node: never returns (os._exit with the node's status)."""
    status = 1
    try:
        link.close()
        go = place_fds(fds[0], fds[1:], request["fds"], go)
        os.environ.clear()
        os.environ.update(request["env"])
        set_command_line(request["argv"])
        reseed()
        if os.read(go, 1) != b"g":
            sys.exit("carav node: its zygote ended before the supervisor knew its pid; exiting")
        os.close(go)
        node_start.die_with_parent()
        sys.argv = [node_start.__file__, *request["argv"][3:]]
        runpy.run_module(request.get("module", NODE_MODULE), run_name="__main__", alter_sys=True)
        status = 0
    except SystemExit as exc:
        status = _exit_status(exc.code)
    except BaseException:
        traceback.print_exc()
    finally:
        try:
            threading._shutdown()        # as the interpreter's own exit: non-daemon threads, then atexit
            atexit._run_exitfuncs()
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(status)


def _exit_status(code: object) -> int:
    """The status sys.exit(code) gives a process: None 0, an int itself, anything else printed and 1."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code & 0xFF
    print(code, file=sys.stderr)
    return 1


def fork_node(request: dict, fds: list[int], link: socket.socket) -> tuple[int, int]:
    """Fork the node of `request` through a middle process; (its pid, the write end of its go pipe)."""
    pid_r, pid_w = os.pipe()
    go_r, go_w = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        middle = os.fork()
    except OSError:
        for fd in (pid_r, pid_w, go_r, go_w):
            os.close(fd)
        raise
    if middle == 0:
        status = 1
        try:
            os.close(pid_r)
            os.close(go_w)
            node = os.fork()
            if node == 0:
                os.close(pid_w)
                become_node(request, fds, go_r, link)
            os.write(pid_w, str(node).encode())
            status = 0
        finally:
            os._exit(status)
    os.close(pid_w)
    os.close(go_r)
    with os.fdopen(pid_r, "rb") as fh:
        text = fh.read()
    os.waitpid(middle, 0)        # the node is the supervisor's child from here on
    if not text:
        os.close(go_w)
        raise OSError("the middle process could not fork the node")
    return int(text), go_w


def warm(types: Sequence[str]) -> None:
    """Import the blocks of `types` (import_blocks), then freeze what they made out of the collector; exits (status
    1, saying why) when an import left a thread: a fork would copy only one of them."""
    for problem in import_blocks(types):
        print(f"carav zygote: not preloaded: {problem}", file=sys.stderr, flush=True)
    if threads() > 1:
        sys.exit(f"carav zygote: {threads()} threads after its imports; a fork copies only one of them, so nodes are "
                 "not forked from it (is a BLAS told to start threads?)")
    gc.freeze()


def serve(link: socket.socket) -> None:
    """Answer the supervisor's requests, one at a time and each with one reply, until it closes the link: blocks to
    import (`{"blocks": [...]}`), or a node to fork."""
    while True:
        msg, fds, _, _ = socket.recv_fds(link, MAX_REQUEST, MAX_FDS)
        if not msg:
            return
        go = -1
        try:
            request = json.loads(msg)
            warm(request.get("blocks", ()))
            if "argv" in request:
                pid, go = fork_node(request, fds, link)
                reply = {"pid": pid}
            else:
                reply = {"imported": sorted(_imported)}
        except (OSError, ValueError, KeyError, AttributeError, TypeError) as exc:
            reply = {"error": f"{type(exc).__name__}: {exc}"}
        finally:
            for fd in fds:
                os.close(fd)
        link.send(json.dumps(reply).encode())
        if go >= 0:
            os.write(go, b"g")
            os.close(go)


def main(argv: Sequence[str]) -> int:
    """`--zygote FD ROOM [MODULE ...]`: serve on the link socket FD; MODULE: more to import first (tests)."""
    # Ctrl-C and a group-wide SIGTERM go to the supervisor, which stops the nodes in order; the zygote ends when
    # the supervisor closes its link, or with the supervisor (parent-death signal)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    link = socket.socket(fileno=int(argv[1]))
    for problem in preload(argv[3:]):
        print(f"carav zygote: not preloaded: {problem}", file=sys.stderr, flush=True)
    warm(())
    set_command_line(argv_of_zygote(argv[1]))
    serve(link)
    return 0


def argv_of_zygote(fd: str) -> list[str]:
    """What the zygote's command line says once it runs (the room it started with is for its nodes)."""
    return [sys.executable, "-m", "carav_stream.node_start", "--zygote", fd]


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
