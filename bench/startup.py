"""`python3 dev.py bench startup`: what starting a graph costs, with its nodes forked from the run's zygote and with
every node a fresh interpreter (`docs/RUNTIME.md`, "How a node starts").

Wall time: `carav run graphs/demo.toml --cycles 32` with the zygote (the default) and without (CARAV_ZYGOTE=0), one
interpreter importing what a node needs (`python3 -c "import numpy, scipy.signal, scipy.fft, zmq, msgpack"`), and
`carav validate graphs/demo.toml` (the command's own start and validation, which a zygote does not shorten), in
rounds that run each once, in turn; medians over the rounds. Target: the run with the zygote within
TARGET_RATIO x the one interpreter's imports.

Restart and memory: the demo graph with a restart policy, run until stopped by a supervisor in this process (so
that it can watch its nodes' reports); once the detector has judged frames, the nodes' proportional memory (Pss,
/proc/PID/smaps_rollup: a page shared by n processes counts 1/n in each) is summed (the zygote's included, whose
pages the forked nodes share), the detector is SIGKILLed, and the time from the supervisor seeing it dead to its
successor's ready report, and to its first frame, is taken. The first frame's time is the successor's own
(`first_frame_at` of its counters: time.monotonic() when its block took the frame, the clock the supervisor reads
too), which its next heartbeat brings; target: within TARGET_RESTART_S of the death seen, forked.

Every record says how many of the project's modules had current bytecode (`dev.py` compiles them before any
command) and whether PYTHONDONTWRITEBYTECODE was set: without it, or with stale bytecode, every process compiles
the modules it imports again at its start.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import carav_blocks
import carav_stream
from bench import records as bench_records
from carav_graphs import graph_file
from carav_stream.console.options import count, output_file
from carav_stream.runtime.launcher import ZYGOTE_ENV, Launcher
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.protocol import Report
from carav_stream.runtime.supervisor import Supervisor

TARGET_RATIO = 1.3
TARGET_RESTART_S = 0.1
IMPORTS = "import numpy, scipy.signal, scipy.fft, zmq, msgpack"
VICTIM = "detector"
MODES = ("zygote", "fresh", "import", "validate")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs", type=count(1), default=10, help="rounds of the wall-time modes (default 10)")
    parser.add_argument("--restarts", type=count(0), default=5,
                        help="rounds of the restart and memory measurement, each way (default 5; 0: none)")
    parser.add_argument("--cycles", type=count(1), default=32, help="cycles of each timed run (default 32)")
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")


def timed_run(mode: str, cycles: int, env: dict[str, str], folder: Path) -> tuple[float, dict[str, int]]:
    """Wall seconds of one run of `mode` (MODES), and for a graph run its node_starts."""
    summary = folder / "summary.json"
    argv = {"import": [sys.executable, "-c", IMPORTS],
            "validate": [sys.executable, "-m", "carav_stream.cli", "validate", str(graph_file("demo"))]}.get(
        mode, [sys.executable, "-m", "carav_stream.cli", "run", str(graph_file("demo")), "--cycles", str(cycles),
               "--no-progress", "--json", str(summary)])
    env = {**env, ZYGOTE_ENV: "0" if mode == "fresh" else "1"}
    t0 = time.monotonic()
    out = subprocess.run(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - t0
    if out.returncode != 0:
        raise RuntimeError(f"{mode}: {' '.join(argv)} failed ({out.returncode}):\n{out.stderr[-2000:]}")
    if mode not in ("zygote", "fresh"):
        return wall, {}
    starts = json.loads(summary.read_text())["node_starts"]
    if starts[{"zygote": "fresh", "fresh": "forked"}[mode]]:
        raise RuntimeError(f"{mode}: the nodes did not all start that way: {starts}\n{out.stderr[-2000:]}")
    return wall, starts


def pss_mb(pid: int) -> tuple[float, float]:
    """(Pss, Rss) of a live process in MB, from /proc/PID/smaps_rollup."""
    fields = {}
    for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
        name, _, rest = line.partition(":")
        if name in ("Pss", "Rss"):
            fields[name] = int(rest.split()[0]) / 1024
    return fields["Pss"], fields["Rss"]


class TimedSupervisor(Supervisor):
    """The supervisor, watching its own reports: when the victim has judged frames, it sums its nodes' memory and
    SIGKILLs the victim; it times the victim's restart; once a report of the successor says when it took its first
    frame, it stops the run."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.memory: dict[str, float] | None = None
        self.t_seen = self.t_ready = self.t_first = None

    def on_node_message(self, name: str, msg: dict[str, Any]) -> None:
        super().on_node_message(name, msg)
        st = self.nodes[name]
        if name != VICTIM:
            return
        if st.restarts == 0 and self.memory is None and st.counters.get("processed", 0) >= 2:
            self.memory = self.sum_memory()
            os.kill(st.proc.pid, signal.SIGKILL)
        elif st.restarts == 1 and msg.get("type") == Report.READY and self.t_ready is None:
            self.t_ready = time.monotonic()
        elif st.restarts == 1 and st.counters.get("first_frame_at") is not None and self.t_first is None:
            self.t_first = st.counters["first_frame_at"]
            self.request_stop("benchmark")

    def node_failed(self, st, reason: str) -> None:
        if st.name == VICTIM and self.t_seen is None:
            self.t_seen = time.monotonic()
        super().node_failed(st, reason)

    def sum_memory(self) -> dict[str, float]:
        zygote = self.launcher.zygote
        nodes = [pss_mb(st.proc.pid) for st in self.nodes.values()]
        extra = pss_mb(zygote.proc.pid) if zygote is not None else (0.0, 0.0)
        return {"pss_mb": sum(p for p, _ in nodes) + extra[0], "zygote_pss_mb": extra[0],
                "rss_mb": sum(r for _, r in nodes) + extra[1], "processes": len(nodes) + (zygote is not None)}


def restart_round(zygote: bool, folder: Path) -> dict[str, Any]:
    """One run of the demo graph with a restart policy, until the killed victim's successor took a frame."""
    graph_path = folder / "restarting.toml"
    graph_path.write_text(f'include = "{graph_file("demo")}"\n[run]\ncycles = 0\n[restart]\npolicy = "on-failure"\n')
    said: list[str] = []
    sup = TimedSupervisor(load_graph(graph_path), progress=False, log=said.append,
                          launcher=Launcher(zygote=zygote, log=said.append))
    summary = sup.run()
    wrong_start = summary["node_starts"]["fresh" if zygote else "forked"]
    if summary["failures"] or sup.t_first is None or sup.memory is None or wrong_start:
        raise RuntimeError(f"restart round ({'zygote' if zygote else 'fresh'}) did not restart {VICTIM} as asked: "
                           f"{summary['failures']} {summary['node_starts']}\n" + "\n".join(said))
    return {"seen_to_ready_s": sup.t_ready - sup.t_seen, "seen_to_first_frame_s": sup.t_first - sup.t_seen,
            **sup.memory, "node_starts": summary["node_starts"]}


def bytecode() -> dict[str, Any]:
    """The project's modules (carav_stream and the built-in blocks) and how many have bytecode as new as their source,
    which Python reads instead of compiling the source again; and whether PYTHONDONTWRITEBYTECODE was set (Python
    then writes none itself)."""
    sources = [p for pkg in (carav_stream, carav_blocks) for p in Path(pkg.__file__).parent.rglob("*.py")]
    return {"modules": len(sources), "current": sum(map(current_bytecode, sources)),
            "dont_write_bytecode": bool(os.environ.get("PYTHONDONTWRITEBYTECODE"))}


def current_bytecode(src: Path) -> bool:
    """Whether `src` has bytecode Python would use: its cache file's header names this interpreter's magic number
    and the source's modification time and size, as the import system checks them."""
    try:
        head = Path(importlib.util.cache_from_source(str(src))).read_bytes()[:16]
    except OSError:
        return False
    st = src.stat()
    return (len(head) == 16 and head[:4] == importlib.util.MAGIC_NUMBER and head[4:8] == bytes(4)
            and int.from_bytes(head[8:12], "little") == int(st.st_mtime) & 0xFFFFFFFF
            and int.from_bytes(head[12:16], "little") == st.st_size & 0xFFFFFFFF)


def startup(runs: int, restarts: int, cycles: int) -> dict[str, Any]:
    load_before = [round(x, 2) for x in os.getloadavg()]
    compiled = bytecode()
    with tempfile.TemporaryDirectory(prefix="cs", dir="/tmp") as tmp:    # ipc paths must stay short
        folder = Path(tmp)
        env = {**os.environ, "CARAV_RUN_DIR": tmp}
        walls: dict[str, list[float]] = {m: [] for m in MODES}
        starts: dict[str, dict[str, int]] = {}
        for _ in range(runs):
            for mode in MODES:
                wall, node_starts = timed_run(mode, cycles, env, folder)
                walls[mode].append(wall)
                starts[mode] = node_starts or starts.get(mode, {})
        rounds: dict[str, list[dict[str, Any]]] = {"zygote": [], "fresh": []}
        before = os.environ.get("CARAV_RUN_DIR")
        os.environ["CARAV_RUN_DIR"] = tmp              # the supervisors of this process, and their nodes
        try:
            for _ in range(restarts):
                for mode in rounds:
                    rounds[mode].append(restart_round(mode == "zygote", folder))
        finally:
            if before is None:
                os.environ.pop("CARAV_RUN_DIR")
            else:
                os.environ["CARAV_RUN_DIR"] = before
    median = {m: statistics.median(w) for m, w in walls.items()}
    return {"graph": "graphs/demo.toml", "cycles": cycles, "runs": runs, "imports": IMPORTS, "wall_s": walls,
            "median_s": median, "ratio_zygote_to_import": median["zygote"] / median["import"],
            "ratio_fresh_to_import": median["fresh"] / median["import"],
            "ratio_zygote_to_fresh": median["zygote"] / median["fresh"], "target_ratio": TARGET_RATIO,
            "node_starts": starts, "victim": VICTIM, "restart_rounds": rounds,
            "restart_median_s": {m: _median(r, "seen_to_ready_s") for m, r in rounds.items()},
            "first_frame_median_s": {m: _median(r, "seen_to_first_frame_s") for m, r in rounds.items()},
            "target_restart_s": TARGET_RESTART_S,
            "pss_median_mb": {m: _median(r, "pss_mb") for m, r in rounds.items()},
            "load_average_at_start": load_before, "bytecode": compiled}


def _median(rounds: list[dict[str, Any]], key: str) -> float | None:
    return statistics.median(r[key] for r in rounds) if rounds else None


def met(rec: dict[str, Any]) -> bool:
    return rec["ratio_zygote_to_import"] <= rec["target_ratio"]


def rows(doc: dict) -> list[tuple[str, str, str, str]]:
    """BENCHMARKS.md's rows: figure, measured, target, met."""
    r = doc["records"][0]
    m, ok = r["median_s"], met(r)
    out = [(f"`carav run {r['graph']} --cycles {r['cycles']}`, nodes forked from the zygote, over one interpreter "
            f"importing numpy, scipy.signal, scipy.fft, zmq, msgpack (medians of {r['runs']})",
            f"{r['ratio_zygote_to_import']:.2f} x ({m['zygote']:.2f} / {m['import']:.2f} s)",
            f"<= {r['target_ratio']:g} x", "yes" if ok else "**no**"),
           ("the same run, every node a fresh interpreter", f"{r['ratio_fresh_to_import']:.2f} x ({m['fresh']:.2f} s; "
            f"forked / fresh {r['ratio_zygote_to_fresh']:.2f})", "(reported)", "-"),
           (f"`carav validate {r['graph']}` alone: the command's own start and validation",
            f"{m['validate']:.2f} s ({m['validate'] / m['import']:.2f} x the imports)", "(reported)", "-"),
           (f"what the run adds to that (nodes started, ready, {r['cycles']} cycles, drained), forked / fresh",
            f"{m['zygote'] - m['validate']:.2f} / {m['fresh'] - m['validate']:.2f} s", "(reported)", "-")]
    if r["restart_rounds"]["zygote"]:
        t, p = r["restart_median_s"], r["pss_median_mb"]
        out.append((f"a SIGKILLed {r['victim']}: death seen by the supervisor to its successor's ready report, forked "
                    "/ fresh", f"{t['zygote'] * 1e3:.0f} / {t['fresh'] * 1e3:.0f} ms", "(reported)", "-"))
        if "first_frame_median_s" in r:       # records made before the first frame was timed lack it
            f, target = r["first_frame_median_s"], r["target_restart_s"]
            out.append(("the same, to the successor's first frame (the time its own report gives), forked / fresh",
                        f"{f['zygote'] * 1e3:.0f} / {f['fresh'] * 1e3:.0f} ms", f"<= {target * 1e3:.0f} ms forked",
                        "yes" if f["zygote"] <= target else "**no**"))
        out.append(("the nodes' summed proportional memory (Pss), forked (the zygote's included) / fresh",
                    f"{p['zygote']:.0f} / {p['fresh']:.0f} MB", "(reported)", "-"))
    return out


def table(doc: dict) -> list[str]:
    """docs/bench/startup.md's tables."""
    r = doc["records"][0]
    lines = [f"Load average when it started: {' / '.join(f'{x:g}' for x in r['load_average_at_start'])}.", ""]
    if "bytecode" in r:                       # records made before it was noted lack it
        b = r["bytecode"]
        lines += [f"The project's modules with current bytecode: {b['current']} of {b['modules']}; "
                  f"PYTHONDONTWRITEBYTECODE {'set' if b['dont_write_bytecode'] else 'not set'}.", ""]
    lines += ["| mode | median s | runs (s) | node starts |", "|---|---:|---|---|"]
    for mode, walls in r["wall_s"].items():
        starts = ", ".join(f"{k} {v}" for k, v in r["node_starts"].get(mode, {}).items()) or "-"
        lines.append(f"| {mode} | {r['median_s'][mode]:.2f} | {', '.join(f'{w:.2f}' for w in walls)} | {starts} |")
    if r["restart_rounds"]["zygote"]:
        first = "first_frame_median_s" in r
        lines += ["", f"| mode | {r['victim']} death seen to successor ready, ms (median; rounds) | "
                  + ("to its first frame, ms (median; rounds) | " if first else "")
                  + "nodes' Pss MB (median; rounds) | their Rss MB | zygote's Pss MB | processes |",
                  "|---|---|" + ("---|" if first else "") + "---|---:|---:|---:|"]
        for mode, rounds in r["restart_rounds"].items():
            ms = ", ".join(f"{x['seen_to_ready_s'] * 1e3:.0f}" for x in rounds)
            to_frame = ", ".join(f"{x['seen_to_first_frame_s'] * 1e3:.0f}" for x in rounds) if first else ""
            pss = ", ".join(f"{x['pss_mb']:.0f}" for x in rounds)
            rss = statistics.median(x["rss_mb"] for x in rounds)
            lines.append(f"| {mode} | {r['restart_median_s'][mode] * 1e3:.0f}; {ms} | "
                         + (f"{r['first_frame_median_s'][mode] * 1e3:.0f}; {to_frame} | " if first else "")
                         + f"{r['pss_median_mb'][mode]:.0f}; {pss} | {rss:.0f} | "
                         f"{statistics.median(x['zygote_pss_mb'] for x in rounds):.0f} | {rounds[0]['processes']} |")
    return lines


def run(args: argparse.Namespace) -> int:
    print(bench_records.header(), flush=True)
    rec = startup(args.runs, args.restarts, args.cycles)
    for line in table({"records": [rec]}):
        print(line)
    for figure, measured, target, ok in rows({"records": [rec]}):
        print(f"{figure}: {measured} (target {target}, met {ok})")
    if args.json:
        bench_records.write(args.json, args, [rec])
    return 0
