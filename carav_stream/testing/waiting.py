"""Waiting on processes by their progress, never by the clock alone: a busy machine slows a test, it does not fail it.

    wait_until(predicate, what, progress)    the predicate's first true value

A wait gives up when `progress()` has not risen by `min_step` for `stall_s` seconds (the deadline restarts each
time it does), or after `cap_s` seconds in all, whatever the progress: a graph that advances, however slowly, is
waited for; one that stands still fails in about `stall_s`; one that spins without end fails at the cap.

`progress` is any number that rises with the work awaited: the CPU seconds a process group has used
(`group_cpu_s`, what the integration fixtures pass), cycles judged, lines written. A process that is only polling
uses far less than `min_step` (0.5 CPU-s) in `stall_s` (60 s); a loaded machine still gives a working graph CPU
time, only less of it per second, so its deadline keeps restarting.

Standard library and Linux /proc only.
"""
from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

STALL_S = 60.0      # how long a wait may see no progress
CAP_S = 900.0       # the longest any one wait may take, progress or not
MIN_STEP = 0.5      # the rise that counts as progress (CPU seconds, or any count)
_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")


def group_cpu_s(*pgids: int) -> float:
    """CPU seconds used so far by the live processes of these process groups, their reaped children included.

    Reads /proc/PID/stat (fields pgrp, utime, stime, cutime, cstime); a process that ends between listing and
    reading is skipped. When a process exits its time leaves the sum, which wait_until tolerates (the mark follows
    the sum down)."""
    wanted, total = set(pgids), 0
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat", "rb") as f:
                fields = f.read().rpartition(b")")[2].split()
        except OSError:
            continue
        if int(fields[2]) in wanted:                        # fields[0] is the state, [1] ppid, [2] pgrp
            total += sum(int(v) for v in fields[11:15])     # utime, stime, cutime, cstime
    return total * _TICK_S


def wait_until(predicate: Callable[[], T], what: str, progress: Callable[[], float], stall_s: float = STALL_S,
               cap_s: float = CAP_S, min_step: float = MIN_STEP, interval_s: float = 0.05) -> T:
    """The first true value of `predicate()`; AssertionError naming `what` on a stall or at the cap."""
    start = time.monotonic()
    mark, mark_t = progress(), start
    while True:
        value = predicate()
        if value:
            return value
        now, done = time.monotonic(), progress()
        if done >= mark + min_step:
            mark, mark_t = done, now
        mark = min(mark, done)
        if now - mark_t > stall_s:
            raise AssertionError(f"no progress for {stall_s:.0f} s waiting for {what} "
                                 f"({now - start:.0f} s in all)")
        if now - start > cap_s:
            raise AssertionError(f"still waiting for {what} after {cap_s:.0f} s (the cap), though progressing")
        time.sleep(interval_s)
