"""How the supervisor starts a node's process: forked from its zygote (zygote.py), a process that imported once
what every node imports, or as a fresh interpreter, `python -m carav_stream.node_start SPEC` (node_start.py).

Either way the node is a process of its own, with its own pid, whose parent is the supervisor (a forked node is
adopted by it: the supervisor is a child subreaper while it has a zygote), in the supervisor's session and
process group, with /dev/null as standard input, its log as standard output and error, the data plane's
descriptors its spec names and no other, the environment NODE_ENV and the supervisor's own give it, and the same
command line. Both take the same two first steps (node_start.py): the parent-death signal, then the check that
the parent is still the supervisor. What a fork copies and a fresh interpreter would draw anew (random state) is
drawn anew in the forked node (zygote.py).

Nodes are forked unless the graph says `[run] zygote = false` or the environment CARAV_ZYGOTE=0; a node is
started fresh when its command line does not fit in the room the zygote left for it, or when the environment
changed since the zygote started (it was started with the nodes' environment, which settles what an interpreter
reads once: allocator, BLAS threads, import path). When the zygote cannot be used any more (it died, did not
answer within the graph's ready_timeout_s, or could not fork), the supervisor says so in one line and starts
every node after that as a fresh interpreter. The summary counts both kinds (`node_starts`).
"""
from __future__ import annotations

import ctypes
import json
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from carav_stream import node_start
from carav_stream.core.allocator import MALLOC_ENV
from carav_stream.runtime.rundir import RUN_ID_ENV

# The environment of node processes (settings in the user's environment win):
# - glibc malloc keeps freed buffers for reuse rather than handing them back to the OS after every frame
#   (core.allocator: large frames would otherwise be mmap'ed, faulted in and unmapped again every time).
# - BLAS libraries run one thread: a graph's parallelism is its processes, and a threaded BLAS call in one
#   node competing with the other nodes for the cores can stall for milliseconds.
NODE_ENV = {**MALLOC_ENV, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
ZYGOTE_ENV = "CARAV_ZYGOTE"                  # "0": no zygote, every node a fresh interpreter
NODE_ARGV = (sys.executable, "-m", "carav_stream.node_start")
ROOM = 1024                                  # bytes of command line the zygote leaves for a node's spec path
PR_SET_CHILD_SUBREAPER, PR_GET_CHILD_SUBREAPER = 36, 37
MAX_REPLY = 4096


def node_env(run_id: str | None = None) -> dict[str, str]:
    """The environment of this supervisor's node processes (of run `run_id`)."""
    env = {**NODE_ENV, **os.environ, node_start.SUPERVISOR_PID_ENV: str(os.getpid())}
    if run_id is not None:
        env[RUN_ID_ENV] = run_id
    return env


def zygote_wanted() -> bool:
    """False when the environment says CARAV_ZYGOTE=0 (or false, no, off)."""
    return os.environ.get(ZYGOTE_ENV, "1").strip().lower() not in ("0", "false", "no", "off")


def _length(argv: Sequence[str]) -> int:
    """Bytes of a command line in memory: each argument and its NUL."""
    return sum(len(os.fsencode(a)) + 1 for a in argv)


def _but_run_id(env: Mapping[str, str]) -> dict[str, str]:
    return {k: v for k, v in env.items() if k != RUN_ID_ENV}


class ZygoteGone(Exception):
    """The zygote cannot start nodes any more; the message says why, in one line."""


class Forked:
    """A node process forked by the zygote and adopted by the supervisor: what the supervisor uses of
    subprocess.Popen (pid, returncode, poll, wait)."""

    def __init__(self, pid: int, args: Sequence[str]) -> None:
        self.pid, self.args = pid, list(args)
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            try:
                pid, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:       # reaped elsewhere: as subprocess.Popen takes it
                self.returncode = 0
                return 0
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.returncode is None:
            if deadline is None:
                try:
                    self.returncode = os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])
                except ChildProcessError:
                    self.returncode = 0
            elif self.poll() is None:
                if time.monotonic() >= deadline:
                    raise subprocess.TimeoutExpired(self.args, timeout)
                self._until_exit(deadline)
        return self.returncode

    def _until_exit(self, deadline: float) -> None:
        """Wait until the process has ended or the deadline passed: on a pidfd, readable once it has ended (Linux),
        else a few milliseconds at a time."""
        try:
            fd = os.pidfd_open(self.pid)
        except (AttributeError, OSError):    # no pidfd here (or the pid is gone: poll says so next)
            time.sleep(min(0.005, max(0.0, deadline - time.monotonic())))
            return
        try:
            select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        finally:
            os.close(fd)


def _prctl(option: int, value: int = 0) -> int:
    """prctl(option, value); OSError when the kernel refuses or has no prctl."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if option == PR_GET_CHILD_SUBREAPER:
            out = ctypes.c_int(0)
            result = libc.prctl(option, ctypes.byref(out))
            value = out.value
        else:
            result = libc.prctl(option, value)
    except (OSError, AttributeError) as exc:
        raise OSError(f"no prctl here: {exc}") from None
    if result != 0:
        raise OSError(ctypes.get_errno(), f"prctl({option}) refused: {os.strerror(ctypes.get_errno())}")
    return value


class Zygote:
    """The supervisor's end of a zygote, started at once with the environment `env`; `preload` names modules more
    for it to import (tests)."""

    def __init__(self, env: Mapping[str, str], preload: Sequence[str] = ()) -> None:
        self.env = dict(env)
        self.was_subreaper = _prctl(PR_GET_CHILD_SUBREAPER)
        _prctl(PR_SET_CHILD_SUBREAPER, 1)        # its nodes' parent, once their middle process exits
        self.sock, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.out = tempfile.TemporaryFile()      # its standard output and error: read if it dies
        # its command line leaves room for a node's, which a forked node writes over it (zygote.set_command_line)
        argv = [*NODE_ARGV, node_start.ZYGOTE_FLAG, str(theirs.fileno()), "." * ROOM, *preload]
        self.room = _length(argv)
        self.unanswered = 0                      # requests to import blocks whose reply has not been read
        try:
            self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=self.out, stderr=self.out,
                                         pass_fds=[theirs.fileno()], env=self.env)
        except OSError:
            self.close()
            raise
        finally:
            theirs.close()

    def takes(self, argv: Sequence[str], env: Mapping[str, str]) -> bool:
        """Whether a node with this command line and environment can be forked from this zygote."""
        return _length(argv) <= self.room and _but_run_id(env) == _but_run_id(self.env)

    def import_blocks(self, types: Sequence[str]) -> None:
        """Ask the zygote to import the built-in blocks of `types` now, without waiting for it (its reply is read
        before the next fork's); ZygoteGone when its link broke."""
        try:
            self.sock.send(json.dumps({"blocks": list(types)}).encode())
        except OSError as exc:
            raise self.gone(f"its link failed: {exc}") from None
        self.unanswered += 1

    def fork(self, argv: Sequence[str], log_fd: int, fds: Sequence[int], env: Mapping[str, str],
             timeout_s: float, module: str | None = None, block: str | None = None) -> int:
        """The pid of a new node process, forked with this command line, log, descriptors (at their own numbers)
        and environment, after the zygote imported its `block` type; ZygoteGone when the zygote cannot fork it.
        `module`: run instead of runtime.node (tests)."""
        request = json.dumps({"argv": list(argv), "env": dict(env), "fds": list(fds),
                              **({"module": module} if module else {}), **({"blocks": [block]} if block else {})})
        try:
            socket.send_fds(self.sock, [request.encode()], [log_fd, *fds])
            deadline = time.monotonic() + timeout_s
            while True:
                while not select.select([self.sock], [], [], 0.1)[0]:
                    if self.proc.poll() is not None:
                        raise self.gone()
                    if time.monotonic() > deadline:
                        self.proc.kill()
                        raise ZygoteGone(f"the zygote (pid {self.proc.pid}) did not answer within {timeout_s:g} s")
                reply = json.loads(self.sock.recv(MAX_REPLY) or b"null")
                if not self.unanswered or reply is None:
                    break
                self.unanswered -= 1             # the answer to import_blocks: its imports are done
        except OSError as exc:
            if self.proc.poll() is not None:     # it died: that is the reason, its link broke with it
                raise self.gone() from None
            self.proc.kill()                     # its link broke under it: of no use any more
            raise self.gone(f"its link failed: {exc}") from None
        if reply is None:
            raise self.gone()
        if "pid" not in reply:
            raise ZygoteGone(f"the zygote (pid {self.proc.pid}) could not fork a node: {reply.get('error')}")
        return int(reply["pid"])

    def gone(self, why: str = "") -> ZygoteGone:
        """Why the zygote is gone (ending it if it has not ended), with the last line it wrote."""
        try:
            code = self.proc.wait(5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        how = f"signal {signal.Signals(-code).name}" if code < 0 else f"status {code}"
        self.out.seek(0)
        last = (self.out.read().decode(errors="replace").strip().splitlines() or [""])[-1]
        return ZygoteGone(f"the zygote (pid {self.proc.pid}) ended with {how}" + (f"; {why}" if why else "")
                          + (f": {last}" if last else ""))

    def close(self) -> None:
        """End the zygote at once (SIGKILL: it holds nothing to save, and may still be importing) and reap it."""
        self.sock.close()
        proc = getattr(self, "proc", None)
        if proc is not None:
            proc.kill()
            proc.wait()
        self.out.close()
        _prctl(PR_SET_CHILD_SUBREAPER, self.was_subreaper)


class Launcher:
    """Starts one supervisor's node processes; with `zygote` (and CARAV_ZYGOTE not 0) it starts a zygote at once,
    whose imports run while the caller goes on. `log(line)` tells the user."""

    def __init__(self, *, zygote: bool = True, log: Callable[[str], None] | None = None,
                 preload: Sequence[str] = ()) -> None:
        self.log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self.forked = self.fresh = 0
        self.zygote: Zygote | None = None
        if zygote and zygote_wanted():
            try:
                self.zygote = Zygote(node_env(), preload)
            except OSError as exc:
                self.log(f"carav: no zygote ({exc}); every node starts as a fresh interpreter")

    def import_blocks(self, types: Sequence[str]) -> None:
        """Have the zygote import the built-in blocks of `types` while the caller goes on (the graph's, as soon as
        they are read)."""
        if self.zygote is not None:
            try:
                self.zygote.import_blocks(types)
            except ZygoteGone as exc:
                self.log(f"carav: {exc}; every node starts as a fresh interpreter from now on")
                self.close()

    def launch(self, spec_path: Path, log_path: Path, fds: Sequence[int], env: Mapping[str, str],
               timeout_s: float, block: str | None = None) -> subprocess.Popen | Forked:
        """A new process running the node of `spec_path` (a block of type `block`), its log `log_path` (appended to),
        the descriptors `fds` inherited at their numbers, the environment `env`; the zygote waited for at most
        `timeout_s`."""
        argv = [*NODE_ARGV, str(spec_path)]
        with open(log_path, "ab") as logf:
            if self.zygote is not None and self.zygote.takes(argv, env):
                try:
                    proc = Forked(self.zygote.fork(argv, logf.fileno(), fds, env, timeout_s, block=block), argv)
                    self.forked += 1
                    return proc
                except ZygoteGone as exc:
                    self.log(f"carav: {exc}; every node starts as a fresh interpreter from now on")
                    self.close()
            self.fresh += 1
            return subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=logf, stderr=logf, pass_fds=fds,
                                    env=dict(env))

    def counts(self) -> dict[str, int]:
        """Node processes started so far: forked from the zygote, and started as fresh interpreters."""
        return {"forked": self.forked, "fresh": self.fresh}

    def close(self) -> None:
        """Without a zygote from now on."""
        if self.zygote is not None:
            self.zygote.close()
            self.zygote = None
