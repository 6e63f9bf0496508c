"""Memory for processes that allocate large numpy arrays over and over: glibc malloc settings, and per-thread
scratch buffers for kernels that work a chunk at a time.

By default glibc serves every block above a threshold (128 kB, raised as large blocks are freed, up to 32 MB) with
its own mmap and hands it back to the OS when it is freed, and trims the top of its heap beyond 128 kB of free
space: a kernel whose temporaries are megabytes then faults every page of every temporary in again, every call.
These settings keep freed memory for reuse instead (up to MALLOC_TRIM_THRESHOLD_ of it): the same user time,
far fewer page faults and far less kernel time, in `carav experiment cfar` as in a graph's node with its
multi-megabyte cycles. Other C libraries ignore them.
"""
from __future__ import annotations

import ctypes
import os
import threading
from collections.abc import Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

MALLOC_ENV = {"MALLOC_MMAP_THRESHOLD_": str(256 << 20), "MALLOC_TRIM_THRESHOLD_": str(512 << 20),
              "MALLOC_TOP_PAD_": str(64 << 20)}
_MALLOPT = {"MALLOC_TRIM_THRESHOLD_": -1, "MALLOC_TOP_PAD_": -2, "MALLOC_MMAP_THRESHOLD_": -3}   # glibc's M_*


def keep_freed_memory(env: Mapping[str, str] = os.environ) -> bool:
    """Apply MALLOC_ENV to this running process with mallopt, each setting `env` gives with the user's value (glibc
    read it at start-up already); False where the C library has no mallopt or refuses a value."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    return all([mallopt(code, int(env.get(name, MALLOC_ENV[name]))) == 1 for name, code in _MALLOPT.items()])


_local = threading.local()


def scratch(name: str, n: int, dtype) -> np.ndarray:
    """This thread's reused buffer `name`: n elements of dtype, uninitialised (grown, never shrunk). A kernel that
    works a chunk at a time keeps its temporaries here: a fresh multi-megabyte temporary costs more in page faults
    than the arithmetic on it. Each kernel names its own buffers, so no two kernels write into one."""
    bufs = _local.__dict__.setdefault("bufs", {})
    buf = bufs.get(name)
    if buf is None or buf.size < n or buf.dtype != dtype:
        # start-up time: `carav run` imports this module before it starts its zygote, and numpy only after
        import numpy
        buf = bufs[name] = numpy.empty(n, dtype)
    return buf[:n]
