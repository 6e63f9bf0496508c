"""carav: run, validate and steer carav-stream graphs; sweep thresholds; benchmark.

    carav run GRAPH [--cycles N] [--set node.param=value ...] [--json FILE]
    carav validate GRAPH ...
    carav blocks [TYPE]
    carav status | carav stop [RUN] | carav swap NODE BLOCK [--set key=value ...] [--graph RUN]
    carav sweep ...            PF/PM Monte Carlo and threshold design
    carav reproduce ...        regenerate docs/REPRODUCTION.md
    carav experiment secondary-antenna ...
    carav bench transport|synth|detector|estimators|pipeline ...
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
from pathlib import Path
from typing import Any

import msgpack
import zmq

from carav_stream.graph import GraphError, load_graph, parse_value

# Commands implemented by kernel modules: each module has configure(parser) and run(args) -> int.
PLUGINS = {
    "sweep": ("carav_stream.detect.sweep_cli", "PF/PM Monte Carlo over eta and RARMS, with threshold design"),
    "reproduce": ("carav_stream.detect.reproduce", "regenerate docs/REPRODUCTION.md and its figures"),
}
EXPERIMENTS = {
    "secondary-antenna": ("carav_stream.experiments.secondary_antenna", "the paper's Figures 6 to 8"),
}
BENCHES = {
    "transport": ("carav_stream.bench.transport", "frames/s, GB/s and latency through a chain of processes"),
    "synth": ("carav_stream.bench.synth", "signal-chain time per cycle by preset, fidelity and attacker"),
    "detector": ("carav_stream.bench.detector", "detector stability, ns/sample and Monte Carlo speed"),
    "estimators": ("carav_stream.bench.estimators", "run time against error of the range/velocity estimators"),
    "pipeline": ("carav_stream.bench.pipeline", "cycles/s of the multi-process graph against one process"),
}


def _add_plugin(sub, name: str, module: str, help_text: str, wanted: bool) -> None:
    """Plugins import scipy-heavy modules: only the one the command line asks for is imported."""
    p = sub.add_parser(name, help=help_text, description=help_text)
    if not wanted:
        p.set_defaults(func=lambda a: _fail(f"{name}: internal error, plugin not loaded"))
        return
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            p.set_defaults(func=lambda a, m=module: _fail(f"{name}: not available in this build ({m} missing)"))
            return
        raise
    mod.configure(p)
    p.set_defaults(func=mod.run)


def _fail(text: str, code: int = 2) -> int:
    print(f"carav: {text}", file=sys.stderr)
    return code


def build_parser(argv: list[str] = ()) -> argparse.ArgumentParser:
    words = [a for a in argv if not a.startswith("-")]
    ap = argparse.ArgumentParser(prog="carav", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("run", help="run a graph and print its summary")
    p.add_argument("graph", type=Path)
    p.add_argument("--cycles", type=int, help="cycles each source generates (a frame may carry several; default: the graph's run.cycles; 0 = until stopped)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE", help="override a parameter")
    p.add_argument("--json", type=Path, metavar="FILE", help="write the summary as JSON")
    p.add_argument("--host", help="run only the nodes placed on this host (graphs with [hosts])")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR", help="extra folder of block files")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None, help="live progress line (default: on a terminal)")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("validate", help="check graph files without starting anything")
    p.add_argument("graphs", type=Path, nargs="+")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("blocks", help="list block types with their ports and parameters")
    p.add_argument("type", nargs="?", help="show one block's full documentation")
    p.add_argument("--blocks", action="append", default=[], metavar="DIR")
    p.set_defaults(func=cmd_blocks)

    p = sub.add_parser("status", help="running graphs with per-node counters and rates")
    p.add_argument("--json", action="store_true", help="print the raw status as JSON")
    p.set_defaults(func=cmd_status)

    p = sub.add_parser("stop", help="stop a running graph in order (sources first, drain, sinks last)")
    p.add_argument("run", nargs="?", help="run id or graph name (default: the only running graph)")
    p.set_defaults(func=cmd_stop)

    p = sub.add_parser("swap", help="replace a running node's block while frames keep flowing")
    p.add_argument("node")
    p.add_argument("block")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="parameter of the new block")
    p.add_argument("--graph", dest="run", help="run id or graph name (default: the only running graph)")
    p.set_defaults(func=cmd_swap)

    for name, (module, text) in PLUGINS.items():
        _add_plugin(sub, name, module, text, words[:1] == [name])
    p = sub.add_parser("experiment", help="the paper's experiments")
    esub = p.add_subparsers(dest="experiment", required=True, metavar="EXPERIMENT")
    for name, (module, text) in EXPERIMENTS.items():
        _add_plugin(esub, name, module, text, words[:2] == ["experiment", name])
    p = sub.add_parser("bench", help="benchmarks (JSON records, summarised in BENCHMARKS.md)")
    bsub = p.add_subparsers(dest="bench", required=True, metavar="BENCH")
    for name, (module, text) in BENCHES.items():
        _add_plugin(bsub, name, module, text, words[:2] == ["bench", name])
    return ap


def cmd_run(args: argparse.Namespace) -> int:
    from carav_stream.supervisor import Supervisor
    try:
        graph = load_graph(args.graph, args.set, args.blocks)
    except GraphError as exc:
        return _fail(f"{args.graph} is not valid:\n" + "\n".join(f"  {p}" for p in exc.problems))
    if args.host is not None and args.host not in graph.hosts:
        return _fail(f"--host {args.host!r}: the graph's hosts are {sorted(graph.hosts)}")
    sup = Supervisor(graph, host=args.host, cycles=args.cycles, progress=args.progress)
    summary = sup.run()
    print_summary(summary)
    if args.json:
        args.json.write_text(json.dumps(summary, indent=2, default=str))
    if summary["failures"]:
        return 1
    if summary["lost"]:
        return _fail(f"{summary['lost']} frame(s) lost in transport: {summary['lost_by_edge']}", 3)
    return 0


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


def cmd_validate(args: argparse.Namespace) -> int:
    bad = 0
    for path in args.graphs:
        try:
            g = load_graph(path, args.set, args.blocks)
            print(f"{path}: ok ({len(g.nodes)} nodes, {len(g.edges)} connections)")
        except GraphError as exc:
            bad += 1
            print("\n".join(exc.problems), file=sys.stderr)
    return 1 if bad else 0


def cmd_blocks(args: argparse.Namespace) -> int:
    from carav_stream.block import REQUIRED
    from carav_stream.registry import Registry, RegistryError
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
            print(f"  in   {p.name:<12} kind={p.kind:<10} dtypes={','.join(p.dtypes) or 'any':<18} {p.doc}")
        for p in cls.outputs:
            print(f"  out  {p.name:<12} kind={p.kind:<10} dtypes={','.join(p.dtypes) or 'any':<18} {p.doc}")
        for p in cls.params:
            default = "(required)" if p.default is REQUIRED else f"= {p.default!r}"
            unit = f" [{p.unit}]" if p.unit else ""
            where = " (a relative file name in a graph is looked up next to the graph first)" if p.file else ""
            print(f"  param {p.name:<11} {p.type.__name__:<6} {default:<14} {p.doc}{unit}{where}")
        print()
    for c in reg.conflicts:
        print(f"carav: {c}", file=sys.stderr)
    return code


def _runs() -> list[dict[str, Any]]:
    import os
    from carav_stream.supervisor import run_root
    runs = []
    for f in sorted(run_root().glob("*/run.json")):
        try:
            info = json.loads(f.read_text())
            os.kill(info["pid"], 0)
        except (OSError, ValueError, KeyError):
            continue   # a run that ended without cleaning up (killed): not running
        runs.append(info)
    return runs


def _pick_run(which: str | None) -> dict[str, Any]:
    runs = _runs()
    if which:
        runs = [r for r in runs if r["run"] == which or Path(r["graph"]).stem == which or r["graph"] == which]
    if not runs:
        raise SystemExit(_fail(f"no running graph{' matches ' + repr(which) if which else ''}"))
    if len(runs) > 1:
        raise SystemExit(_fail("several graphs are running; name one with its run id: "
                               + ", ".join(r["run"] for r in runs)))
    return runs[0]


def _admin(run: dict[str, Any], request: dict[str, Any], timeout_s: float = 40.0) -> dict[str, Any]:
    ctx = zmq.Context.instance()
    sock = ctx.socket(zmq.REQ)
    sock.linger = 0
    try:
        sock.connect(run["admin"])
        sock.send(msgpack.packb(request, use_bin_type=True))
        if not sock.poll(timeout_s * 1000):
            raise SystemExit(_fail(f"run {run['run']} did not answer within {timeout_s:.0f} s"))
        return msgpack.unpackb(sock.recv(), raw=False, strict_map_key=True)
    finally:
        sock.close()


def cmd_status(args: argparse.Namespace) -> int:
    runs = _runs()
    statuses = [_admin(r, {"cmd": "status"}, 5) for r in runs]
    if args.json:
        print(json.dumps(statuses, indent=2))
        return 0
    if not statuses:
        print("no running graphs")
    for s in statuses:
        print(f"{s['run']}  {s['graph']}  pid {s['pid']}  {s['cycles']} cycles in {s['elapsed_s']:.1f} s")
        for n, st in s["nodes"].items():
            c = st["counters"]
            print(f"  {n:<15} {c.get('block', '?'):<18} {'up' if st['alive'] else 'DOWN':<5} "
                  f"in {sum(c.get('in', {}).values()):<8} out {sum(c.get('out', {}).values()):<8} "
                  f"rejected {sum(c.get('rejected', {}).values()):<5} {st['rate_per_s']:8.1f}/s  restarts {st['restarts']}")
    return 0


def cmd_stop(args: argparse.Namespace) -> int:
    run = _pick_run(args.run)
    _admin(run, {"cmd": "stop"}, 5)
    print(f"stopping {run['run']}")
    return 0


def cmd_swap(args: argparse.Namespace) -> int:
    params = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep:
            return _fail(f"--set {item!r}: expected key=value")
        params[key.strip()] = parse_value(value.strip())
    run = _pick_run(args.run)
    reply = _admin(run, {"cmd": "swap", "node": args.node, "block": args.block, "params": params})
    if not reply.get("ok"):
        return _fail(f"swap refused: {reply.get('error')}", 1)
    print(f"{args.node}: now {reply['block']}@{reply['version']}#{reply['generation']} from seq {reply['next_seq']}")
    return 0


def run_as_command(module: str) -> int:
    """`python -m <plugin module> ARGS` is `carav <its command> ARGS` (the words come from the tables above)."""
    for prefix, table in (([], PLUGINS), (["experiment"], EXPERIMENTS), (["bench"], BENCHES)):
        for name, (mod, _) in table.items():
            if mod == module:
                return main([*prefix, name, *sys.argv[1:]])
    raise LookupError(f"{module} is not a carav command module")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser(argv).parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
