"""Progress of long commands on stderr, with an estimate of the time left.

On a terminal, a one-line bar redrawn at most every 0.2 s. Redirected (a log file, a pipe, CI), a plain line at
most every `every_s` seconds (EVERY_S, 10, by default), the first only once that much time has passed, so a command
that ends quickly prints nothing and a long one is never silent:

    interference: 40.0 % (4000/10000 cycles), 52.1 s, about 78 s left
"""
from __future__ import annotations

import sys
import time

__all__ = ["ProgressBar", "left_words", "EVERY_S"]

EVERY_S = 10.0          # seconds between two redirected lines (tests shorten it)


def left_words(elapsed_s: float, done: int, total: int) -> str:
    """'about 78 s left' from a constant rate so far; empty before the first unit is done."""
    if not done or done >= total:
        return ""
    left = elapsed_s * (total - done) / done
    if left >= 3600:
        return f"about {left / 3600:.1f} h left"
    return f"about {left / 60:.0f} min left" if left >= 120 else f"about {left:.0f} s left"


class ProgressBar:
    """Call it with (done, total) as work advances. `ProgressBar.wanted(quiet)`: unless --quiet (a bar on a
    terminal, lines every few seconds elsewhere)."""

    @staticmethod
    def wanted(quiet: bool = False) -> bool:
        return not quiet

    def __init__(self, label: str, stream=None, width: int = 30, unit: str = "cycles", every_s: float | None = None,
                 clock=time.perf_counter):
        self.label, self.stream, self.width, self.unit = label, stream or sys.stderr, width, unit
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every_s = 0.2 if self.terminal else EVERY_S if every_s is None else every_s
        self.clock = clock
        self.t0 = clock()
        self.last = self.t0
        self.lines = 0
        self.ended = False              # the line of the end is written once, however often the end is told

    def __call__(self, done: int, total: int) -> None:
        now = self.clock()
        finished = done >= total
        if self.ended or now - self.last < self.every_s and not (finished and (self.terminal or self.lines)):
            return
        self.last, self.ended = now, finished
        frac = done / total if total else 1.0
        elapsed = now - self.t0
        left = left_words(elapsed, done, total)
        if self.terminal:
            bar = "#" * int(frac * self.width)
            self.stream.write(f"\r{self.label} [{bar:<{self.width}}] {frac:5.1%} {done}/{total} {self.unit} "
                              f"{elapsed:6.1f} s{'  ' + left if left else ''}\033[K" + ("\n" if finished else ""))
        else:
            self.stream.write(f"{self.label}: {100 * frac:.1f} % ({done}/{total} {self.unit}), {elapsed:.1f} s"
                              f"{', ' + left if left else ''}\n")
        self.lines += 1
        self.stream.flush()
