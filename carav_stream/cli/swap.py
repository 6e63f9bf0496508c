"""`carav swap NODE BLOCK [--set key=value ...]`: replace a running node's block at a frame boundary."""
from __future__ import annotations

import argparse

from carav_stream.cli.common import ask, pick_run
from carav_stream.cli.run import params_words
from carav_stream.console.errors import Exit, fail
from carav_stream.runtime.graph import parse_value
from carav_stream.runtime.protocol import Admin


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("node")
    p.add_argument("block")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="parameter of the new block")
    p.add_argument("--graph", dest="run", help="run id or graph name (default: the only running graph)")


def run(args: argparse.Namespace) -> int:
    params = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep:
            return fail(f"--set {item!r}: expected key=value")
        params[key.strip()] = parse_value(value.strip())
    target = pick_run(args.run)
    reply = ask(target, Admin.SWAP, node=args.node, block=args.block, params=params)
    if not reply.get("ok"):
        return fail(f"swap refused: {reply.get('error')}", Exit.INVALID)
    what = params_words(reply.get("params", {}), params)
    where = (f"from cycle {reply['next_cycle']} (frame seq {reply['next_seq']})" if reply.get("next_cycle") is not None
             else f"from frame seq {reply['next_seq']}")
    print(f"{args.node}: now {reply['block']}@{reply['version']}#{reply['generation']}{' ' + what if what else ''} "
          f"{where}")
    return Exit.OK
