"""What every command shares about failing: one exit code per class of outcome, and the one-line error a command
raises for the user (the command-line entry point prints it and exits with its code)."""
from __future__ import annotations

import sys
from enum import IntEnum

__all__ = ["Exit", "EXIT_CODES_HELP", "CommandError", "fail"]


class Exit(IntEnum):
    """One exit code per class of outcome, the same for every command (listed by `carav --help`)."""

    OK = 0
    FAILED = 1          # the work failed: a node crashed, frames were lost, a benchmark run broke, a swap refused
    USAGE = 2           # a bad command line: unknown option, bad value, output path that cannot be written
    INVALID = 3         # an invalid graph, scene or block parameter
    INTERRUPTED = 130   # stopped by Ctrl-C or SIGTERM, or its reader closed the output pipe, before it finished


EXIT_CODES_HELP = "exit codes: " + ", ".join(f"{int(c)} {c.name.lower()}" for c in Exit)


class CommandError(Exception):
    """A user-facing error: one line, naming the option, file or field; `code` is its Exit class."""

    def __init__(self, text: str, code: Exit = Exit.USAGE) -> None:
        super().__init__(text)
        self.code = code


def fail(text: str, code: Exit = Exit.USAGE) -> int:
    print(f"carav: {text}", file=sys.stderr)
    return int(code)
