"""`carav status`: running graphs with per-node counters and rates."""
from __future__ import annotations

import argparse

from carav_stream.cli.common import ask, running_graphs
from carav_stream.cli.run import refused_swap_words, swap_words
from carav_stream.console import jsonout
from carav_stream.runtime.protocol import Admin


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print the raw status as JSON")


def run(args: argparse.Namespace) -> int:
    statuses = [ask(r, Admin.STATUS, 5) for r in running_graphs()]
    if args.json:
        print(jsonout.dumps(statuses, indent=2))
        return 0
    if not statuses:
        print("no running graphs")
    for s in statuses:
        rate = s["cycles"] / s["elapsed_s"] if s["elapsed_s"] else 0.0
        print(f"{s['run']}  {s['graph']}  pid {s['pid']}  {s['cycles']} cycles in {s['elapsed_s']:.1f} s "
              f"({rate:.1f} cycles/s)")
        for n, st in s["nodes"].items():
            c = st["counters"]
            print(f"  {n:<15} {c.get('block', '?'):<18} {'up' if st['alive'] else 'DOWN':<5} "
                  f"frames in {sum(c.get('in', {}).values()):<8} out {sum(c.get('out', {}).values()):<8} "
                  f"rejected {sum(c.get('rejected', {}).values()):<5} {st['rate_per_s']:8.1f} frames/s "
                  f"{st.get('cycles_per_s', 0.0):9.1f} cycles/s  restarts {st['restarts']}")
        for sw in s.get("swaps", []):
            print(f"  {swap_words(sw)}")
        for sw in s.get("refused_swaps", []):
            print(f"  {refused_swap_words(sw)}")
    return 0
