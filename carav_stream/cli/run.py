"""`carav run GRAPH`: validate a graph, run it (one process per block) and print its summary."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from carav_stream.cli.common import CommandError, Exit, fail
from carav_stream.cli.options import output_file
from carav_stream.runtime.graph import Graph, GraphError
from carav_stream.runtime.loader import load_graph


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("graph", type=Path)
    run_options(p)


def run_options(p: argparse.ArgumentParser) -> None:
    """The options of `carav run` (shared by `carav record` and `carav replay`)."""
    p.add_argument("--cycles", type=int, help="cycles each source generates (a frame may carry several; default: "
                   "the graph's run.cycles; 0 = until stopped)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                   help="override a node's parameter, a graph-wide one with PARAM=VALUE, a [run] setting with "
                   "run.KEY=VALUE")
    p.add_argument("--json", type=output_file, metavar="FILE", help="write the summary as JSON")
    p.add_argument("--host", help="run only the nodes placed on this host (graphs with [hosts])")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR", help="extra folder of block files")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="live progress line (default: on a terminal)")


def run(args: argparse.Namespace) -> int:
    return execute(load(args.graph, args), args)


def load(path: Path, args: argparse.Namespace, overrides: list[str] = (), shown_as: Path | None = None) -> Graph:
    """The graph file with `overrides`, then the command line's --set and --cycles; CommandError if invalid."""
    cycles = [] if args.cycles is None else [f"run.cycles={args.cycles}"]   # checked like the file's value
    try:
        return load_graph(path, [*overrides, *args.set, *cycles], args.blocks)
    except GraphError as exc:
        raise CommandError(f"{shown_as or path} is not valid:\n" + "\n".join(f"  {p}" for p in exc.problems),
                           Exit.INVALID) from None


def execute(graph: Graph, args: argparse.Namespace, command: str = "run") -> int:
    """Run a loaded graph with the options of `carav run` (host, progress, json) and report it."""
    from carav_stream.runtime.supervisor import Supervisor
    if args.host is not None and args.host not in graph.hosts:
        return fail(f"--host {args.host!r}: the graph's hosts are {sorted(graph.hosts)}", Exit.USAGE)
    for w in graph.warnings:
        print(f"carav {command}: warning: {w}", file=sys.stderr)
    sup = Supervisor(graph, host=args.host, progress=args.progress)
    summary = sup.run()
    print_summary(summary)
    if args.json:
        args.json.write_text(json.dumps(summary, indent=2, default=str))
    if summary["failures"]:
        return Exit.FAILED
    if summary["lost"]:
        return fail(f"{summary['lost']} frame(s) lost in transport: {summary['lost_by_edge']}", Exit.FAILED)
    if summary["stopped_by"] == "signal":
        return Exit.INTERRUPTED           # drained and summarised, but not the run that was asked for
    return Exit.OK


def print_summary(s: dict[str, Any]) -> None:
    print(f"graph {s['graph']}  run {s['run']}")
    print(f"  cycles {s['cycles']}  lost {s['lost']}  rejected {s['rejected']}  unpaired {s['unpaired']}  "
          f"restarts {s['restarts']}  {s['throughput_cycles_per_s']:.1f} cycles/s over {s['wall_s']:.2f} s")
    skip = {"graph", "run", "host", "cycles", "lost", "lost_by_edge", "rejected", "unpaired", "restarts", "failures",
            "swaps", "stopped_by", "wall_s", "throughput_cycles_per_s", "per_node"}
    for k, v in s.items():
        if k not in skip:
            print(f"  {k}: {json.dumps(v, default=str) if isinstance(v, (dict, list)) else v}")
    print("  node            block              in        out       rejected  restarts")
    for n, p in s["per_node"].items():
        print(f"  {n:<15} {p['block']:<18} {sum(p['in'].values()):<9} {sum(p['out'].values()):<9} "
              f"{sum(p['rejected'].values()):<9} {p['restarts']}")
    for sw in s["swaps"]:
        print(f"  swap: {sw['node']} -> {sw['block']}@{sw['version']}#{sw['generation']} from seq {sw['first_seq']}")
    for f in s["failures"]:
        print(f"  FAILURE: {f}")

