"""`carav stop [RUN]`: stop a running graph in order (sources first, drain, sinks last)."""
from __future__ import annotations

import argparse

from carav_stream.cli.common import ask, pick_run
from carav_stream.runtime.protocol import Admin


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("run", nargs="?", help="run id or graph name (default: the only running graph)")


def run(args: argparse.Namespace) -> int:
    target = pick_run(args.run)
    ask(target, Admin.STOP, 5)
    print(f"stopping {target['run']}")
    return 0
