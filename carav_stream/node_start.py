"""How the supervisor starts a node, `python -m carav_stream.node_start SPEC_FILE`, or its zygote, the process that
forks nodes, `python -m carav_stream.node_start --zygote FD ROOM` (runtime/zygote.py, runtime/launcher.py).

A node dies with its supervisor from its first instruction on, even when the supervisor is SIGKILLed while the
node is still importing numpy, ZeroMQ and its block. This module imports nothing of the package and
nothing heavy, and before anything else:

1. asks the kernel to SIGKILL it when its parent dies (Linux prctl PR_SET_PDEATHSIG);
2. checks that its parent is still the supervisor that started it (CARAV_SUPERVISOR_PID, set by the supervisor):
   a supervisor that died between the fork and step 1 left the node adopted by another process, which step 1
   cannot notice; the node then exits at once (status 1, one line on standard error).

Then it runs the node (`carav_stream.runtime.node`, whose own `python -m` entry point does the same two steps), or
the zygote (`carav_stream.runtime.zygote`), whose nodes take the same two steps after the fork.
"""
import ctypes
import gc
import os
import runpy
import signal
import sys

SUPERVISOR_PID_ENV = "CARAV_SUPERVISOR_PID"
ZYGOTE_FLAG = "--zygote"
PR_SET_PDEATHSIG = 1


def parent_death_signal() -> None:
    """Ask the kernel to SIGKILL this process when its parent dies (Linux; elsewhere nothing)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):   # not Linux: no parent-death signal; the start deadline still holds
        pass


def die_with_parent() -> None:
    """Steps 1 and 2 above; exits when the parent is not the supervisor named in CARAV_SUPERVISOR_PID."""
    parent_death_signal()
    expected = os.environ.get(SUPERVISOR_PID_ENV, "")
    if expected.isdigit() and os.getppid() != int(expected):
        sys.exit(f"carav node: its supervisor (pid {expected}) is gone (parent now pid {os.getppid()}); exiting")


def main() -> None:
    die_with_parent()
    # run as a module, not imported: what it imports (numpy, ZeroMQ) comes only now, after the two steps, and the
    # package's own modules keep no import of this launcher's in their graph of imports
    zygote = sys.argv[1:2] == [ZYGOTE_FLAG]
    try:
        runpy.run_module(f"carav_stream.runtime.{'zygote' if zygote else 'node'}", run_name="__main__",
                         alter_sys=True)
    finally:
        # a short exit, as the carav program's (cli.entry): the interpreter's exit does not walk the object graph
        # of numpy, scipy and ZeroMQ once more (a node forked from the zygote ends with os._exit, without it)
        gc.freeze()


if __name__ == "__main__":
    main()
