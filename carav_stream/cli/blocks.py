"""`carav blocks [TYPE]`: every block type with its ports and parameters (meaning, unit, range)."""
from __future__ import annotations

import argparse
import sys

from carav_stream.runtime.registry import Registry, RegistryError


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("type", nargs="?", help="show one block's full documentation")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR")


def run(args: argparse.Namespace) -> int:
    reg = Registry(args.blocks)
    names = [args.type] if args.type else reg.names()
    code = 0
    for name in names:
        try:
            bt = reg.get(name)
        except RegistryError as exc:
            print(f"carav: {exc}", file=sys.stderr)
            code = 2
            continue
        cls = bt.cls
        first = bt.doc.splitlines()[0] if bt.doc else ""
        print(f"{name}  ({cls.__name__} v{cls.version}, {bt.path})\n  {first}")
        if args.type:
            print("\n".join("    " + line for line in bt.doc.splitlines()[1:]))
        for p in cls.inputs:
            tap = "tap (skips frames rather than slow its producer) " if p.tap else ""
            print(f"  in   {p.name:<12} kind={p.kind:<10} dtypes={','.join(p.dtypes) or 'any':<18} {tap}{p.doc}")
        for p in cls.outputs:
            private = "private (never copied to a port tap) " if p.private else ""
            print(f"  out  {p.name:<12} kind={p.kind:<10} dtypes={','.join(p.dtypes) or 'any':<18} {private}{p.doc}")
        for p in cls.params:
            where = " (a relative file name in a graph is looked up next to the graph first)" if p.file else ""
            print(f"  param {p.name:<16} {p.describe()}{where}")
        print()
    for c in reg.conflicts:
        print(f"carav: {c}", file=sys.stderr)
    return code
