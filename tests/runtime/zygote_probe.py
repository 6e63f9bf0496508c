"""A stand-in for a node, forked by a zygote in tests/runtime/test_zygote.py: imported by the zygote before any
fork (so that what it holds is what a fork copies), then run as __main__ in each forked process, where it writes
what it finds there as JSON to the file its argument names."""
import json
import os
import random
import sys

import numpy as np

from carav_stream.radar.activation import ActivationSource

if __name__ != "__main__":                  # imported by the zygote, not run again as __main__ in a fork:
    ACTIVATION = ActivationSource("secure")     # made in the zygote, before any fork
    HELD = open(os.devnull)                     # a descriptor the zygote holds, which no fork may inherit


def open_fds() -> list[int]:
    """The descriptors open in this process (looked at one by one: listing /proc/self/fd would open one more)."""
    found = []
    for fd in range(1024):
        try:
            os.fstat(fd)
        except OSError:
            continue
        found.append(fd)
    return found


def what_a_fork_holds() -> dict:
    # the zygote's module, with the objects it made before the fork (this one runs as __main__, a new module)
    from tests.runtime import zygote_probe as before_fork

    reads = []
    urandom = os.urandom

    def counted(n: int) -> bytes:
        reads.append(n)
        return urandom(n)

    os.urandom = counted
    try:
        activation = before_fork.ACTIVATION.next(4, 16)
    finally:
        os.urandom = urandom
    with open("/proc/self/cmdline", "rb") as fh:
        cmdline = fh.read()
    return {"pid": os.getpid(), "ppid": os.getppid(), "fds": open_fds(),
            "fd_inodes": {fd: os.fstat(fd).st_ino for fd in open_fds()},
            "numpy_legacy": np.random.random(4).tolist(), "python_random": [random.random() for _ in range(4)],
            "numpy_default_rng": np.random.default_rng().random(4).tolist(),
            "activation": activation.astype(int).tolist(), "urandom_bytes_read": sum(reads),
            "cmdline": list(cmdline.decode().split("\0")), "env": os.environ.get("PROBE_VALUE"),
            "threads": len(os.listdir("/proc/self/task")), "argv": sys.argv,
            "blocks": sorted(m for m in sys.modules if m.startswith("carav_blocks."))}


if __name__ == "__main__":
    found = what_a_fork_holds()
    with open(sys.argv[1], "w") as out:
        json.dump(found, out)
