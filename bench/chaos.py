"""`python3 dev.py bench chaos`: SIGKILL a random node of the radar chain every `--every-s` seconds for
`--seconds`, with restart on failure, on each data plane; then check what the run's logs and its summary say.

The graph (bench/chaos.toml) is graphs/radar_chain.toml with every node restarted after a crash, the smart
attacker at RARMS 1.05 (about 60 % of its cycles alarmed, the rest passed to ranging) and two jsonl sinks: `vlog`
logs every verdict of the detector, `glog` every gated cycle (the estimates of the cycles passed to ranging, the
alarms and refusals of the others). It runs as `carav run` in a session of its own with a private run folder;
the victims are drawn (seeded, `--seed`) among every node of the graph, sinks and the summary included, from the
live processes found in /proc. At the end `carav stop` drains the graph.

Figures per data plane:
- cycles judged twice: a cycle in the verdict log twice, or in the gated log twice (0);
- out of order: a log line whose cycle comes before one already logged (0);
- clean without a clean verdict: a cycle passed to ranging whose gated record, or whose logged detector
  verdict, is not clean (0);
- the summary's judged cycles against the gated log's: every cycle the gate judged reaches both the summary and
  `glog` (within 1 %: what a killed node had in hand when it died is lost on one branch and not the other). A
  restarted run_summary's figures cover the cycles from its restart on, and say so (`figures_cover`): the gated
  log is then compared over the cycles the summary says it covers. The
  cycles the source generated exceed those judged by what died with killed nodes in their queues and in hand;
  the summary counts those frames as lost (`lost`), and `carav run` exits 1 for them;
- each sink's lines against the frames the summary counts into it, over all its incarnations: equal for a sink
  never killed; a killed incarnation's count is its last heartbeat's (up to half a second old), so a killed sink
  may have written more than it was counted for (that difference is reported, never hidden);
- processes of the run alive and files of its run folder left `--settle-s` (10) seconds after `carav run`
  returned (0).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench import records as bench_records
from carav_stream.console.options import count, number, output_file
from carav_stream.runtime.graph import TRANSPORTS
from carav_stream.runtime.loader import load_graph
from carav_stream.testing.graphs import node_pids, read_jsonl

GRAPH = Path(__file__).with_name("chaos.toml")
SINKS = {"vlog": "verdicts.jsonl", "glog": "gated.jsonl"}     # the sinks and their files
AGREEMENT = 0.01        # the summary's judged cycles against the gated log's


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seconds", type=number(1.0), default=60.0, help="how long nodes are killed (per plane)")
    parser.add_argument("--every-s", type=number(0.2), default=2.0, help="seconds between two kills")
    parser.add_argument("--seed", type=count(0), default=1, help="seed of the victims' draw")
    parser.add_argument("--settle-s", type=number(0.0), default=10.0,
                        help="seconds after the run returned before looking for its processes and files")
    parser.add_argument("--transport", choices=TRANSPORTS, action="append",
                        help="data plane (repeat for both; default: both)")
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")


def cycles_of(record: dict[str, Any]) -> list[int]:
    per = record.get("per_cycle") or {}
    return list(per.get("cycle_index") or range(record["cycle"], record["cycle"] + record.get("cycles", 1)))


def column(record: dict[str, Any], name: str, n: int) -> list[Any]:
    """A per-cycle field of a logged frame, or its header's value for every cycle."""
    per = record.get("per_cycle") or {}
    return list(per[name]) if name in per else [record.get(name)] * n


def check_logs(verdicts: list[dict], gated: list[dict]) -> dict[str, Any]:
    """The invariants of the two logs (module doc)."""
    verdict_of: dict[int, bool] = {}
    twice = out_of_order = 0
    last = -1
    for r in verdicts:
        cycles = cycles_of(r)
        for c, alarm in zip(cycles, column(r, "alarm", len(cycles))):
            twice += c in verdict_of
            out_of_order += c < last
            last = max(last, c)
            verdict_of[c] = bool(alarm)
    seen: set[int] = set()
    last_by_port: dict[str, int] = {}
    clean_unverified = passed = 0
    for r in gated:
        cycles = cycles_of(r)
        port = r.get("port", "")
        for c, verdict in zip(cycles, column(r, "verdict", len(cycles))):
            twice += c in seen
            seen.add(c)
            out_of_order += c < last_by_port.get(port, -1)
            last_by_port[port] = max(last_by_port.get(port, -1), c)
            if port == "inp":
                passed += 1
                clean_unverified += verdict != "clean" or verdict_of.get(c) is True
    return {"verdict_log_cycles": len(verdict_of), "gated_log_cycles": len(seen), "passed_to_ranging": passed,
            "judged_twice": twice, "out_of_order": out_of_order, "clean_without_clean_verdict": clean_unverified}


def session_processes(sid: int) -> list[int]:
    """Pids of the live processes of session `sid` (zombies left out)."""
    out = []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            fields = p.joinpath("stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[0] != "Z" and int(fields[3]) == sid:
            out.append(int(p.name))
    return out


def chaos(transport: str, seconds: float, every_s: float, seed: int, settle_s: float = 10.0) -> dict[str, Any]:
    nodes = sorted(load_graph(GRAPH).nodes)
    rng = random.Random(f"{seed}-{transport}")
    with tempfile.TemporaryDirectory(prefix="cc", dir="/tmp") as tmp:     # ipc paths must stay short
        tmp_path = Path(tmp)
        work, runs = tmp_path / "work", tmp_path / "runs"
        work.mkdir()
        env = {**os.environ, "CARAV_RUN_DIR": str(runs)}
        summary_path = tmp_path / "summary.json"
        proc = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", "run", str(GRAPH), "--cycles", "0",
                                 "--set", f"run.transport={transport}", "--no-progress", "--json", str(summary_path)],
                                cwd=work, env=env, start_new_session=True, stdout=subprocess.DEVNULL,
                                stderr=(tmp_path / "stderr.txt").open("w"))
        kills: dict[str, int] = {}
        try:
            while not read_jsonl(work / SINKS["glog"]):        # going: cycles gated (no file yet reads as none)
                if proc.poll() is not None:
                    raise RuntimeError(f"the graph ended early:\n{(tmp_path / 'stderr.txt').read_text()[-2000:]}")
                time.sleep(0.1)
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                time.sleep(every_s)
                if proc.poll() is not None:
                    raise RuntimeError(f"the graph ended:\n{(tmp_path / 'stderr.txt').read_text()[-2000:]}")
                victim = rng.choice(nodes)
                pids = node_pids(runs, victim)
                if len(pids) == 1:      # not while its restart is under way
                    os.kill(pids[0], signal.SIGKILL)
                    kills[victim] = kills.get(victim, 0) + 1
            stop = subprocess.run([sys.executable, "-m", "carav_stream.cli", "stop"], env=env, capture_output=True,
                                  text=True)
            code = proc.wait()
            time.sleep(settle_s)      # the window the run's processes and files have to be gone in
            left_processes = session_processes(proc.pid)
            left_files = [str(p.relative_to(runs)) for p in runs.rglob("*") if p.is_file()] if runs.exists() else []
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        summary = json.loads(summary_path.read_text())
        verdicts, gated = read_jsonl(work / SINKS["vlog"]), read_jsonl(work / SINKS["glog"])
        sink_lines = {s: len((work / f).read_text().splitlines()) for s, f in SINKS.items()}
    logs = check_logs(verdicts, gated)
    per_node = summary["per_node"]
    sinks = {s: {"lines": sink_lines[s], "counted": sum(per_node[s]["in"].values()), "killed": kills.get(s, 0)}
             for s in SINKS}
    judged = summary["cycles_judged"]
    cover = summary.get("figures_cover")      # a restarted run_summary's figures cover the cycles it saw
    gated_cycles = {c for r in gated for c in cycles_of(r)}
    if cover and cover.get("first_cycle") is not None:
        compared = sum(cover["first_cycle"] <= c <= cover["last_cycle"] for c in gated_cycles)
    else:
        compared = len(gated_cycles) if not cover else 0
    return {"transport": transport, "seconds": seconds, "every_s": every_s, "seed": seed, "settle_s": settle_s,
            "kills": kills,
            "n_kills": sum(kills.values()), "restarts": summary["restarts"], "exit_code": code,
            "stop_exit_code": stop.returncode, "cycles": summary["cycles"], "cycles_judged": judged,
            "lost": summary["lost"], "rejected": summary["rejected"], "failures": summary["failures"],
            "estimated_counts": summary.get("estimated_counts", []), **logs,
            "summary_covers": cover["text"] if cover else "figures cover the whole run",
            "gated_log_cycles_compared": compared,
            "judged_agreement": abs(judged - compared) / max(compared, 1),
            "sinks": sinks, "left_processes": len(left_processes), "left_files": left_files}


def met(r: dict[str, Any]) -> dict[str, bool]:
    """Each target of the module doc, met or not."""
    return {"judged_twice": r["judged_twice"] == 0, "out_of_order": r["out_of_order"] == 0,
            "clean_without_clean_verdict": r["clean_without_clean_verdict"] == 0,
            "judged_agreement": r["judged_agreement"] <= AGREEMENT,
            "sinks": all(s["lines"] == s["counted"] for s in r["sinks"].values() if not s["killed"]),
            "left": r["left_processes"] == 0 and not r["left_files"]}


def run(args: argparse.Namespace) -> int:
    recs = []
    for transport in args.transport or TRANSPORTS:
        r = chaos(transport, args.seconds, args.every_s, args.seed, args.settle_s)
        recs.append(r)
        sinks = ", ".join(f"{k} {s['lines']} lines / {s['counted']} counted ({s['killed']} kills)"
                          for k, s in r["sinks"].items())
        print(f"chaos {transport}: {r['n_kills']} kills ({r['restarts']} restarts) in {r['seconds']:g} s, "
              f"{r['cycles']} cycles, {r['cycles_judged']} judged, lost {r['lost']}; judged twice "
              f"{r['judged_twice']}, out of order {r['out_of_order']}, clean without a clean verdict "
              f"{r['clean_without_clean_verdict']}; gated log {r['gated_log_cycles']} cycles "
              f"({r['judged_agreement']:.2%} from the summary); {sinks}; left {r['left_processes']} processes, "
              f"{len(r['left_files'])} files", flush=True)
    if args.json:
        bench_records.write(args.json, args, recs, agreement=AGREEMENT)
    return 0 if all(all(met(r).values()) for r in recs) else 1
