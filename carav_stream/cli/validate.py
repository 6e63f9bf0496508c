"""`carav validate GRAPH ...`: every problem of every graph file, each located; non-zero on any.

A template (`template = [...]` in the graph file) is checked as one: the parameters it leaves open may stay open."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from carav_stream.console.errors import Exit
from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("graphs", type=Path, nargs="+")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR")


def run(args: argparse.Namespace) -> int:
    bad = 0
    for path in args.graphs:
        try:
            g = load_graph(path, args.set, args.blocks, open_ok=True)
            left = f"; a template leaving {', '.join(g.open_params)} open" if g.open_params else ""
            print(f"{path}: ok ({len(g.nodes)} nodes, {len(g.edges)} connections{left})")
            for note in g.composed:
                print(f"  {note}")
            for w in g.warnings:
                print(f"{path}: warning: {w}", file=sys.stderr)
        except GraphError as exc:
            bad += 1
            print("\n".join(exc.problems), file=sys.stderr)
    return Exit.INVALID if bad else Exit.OK
