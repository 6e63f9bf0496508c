"""`python3 dev.py bench view`: what watching costs the radar chain.

The Table I graph of `python3 dev.py bench pipeline` (graphs/radar_chain.toml, smart attacker from half the run on, beat
fidelity, --batch cycles per frame) is run in three modes, interleaved run by run:
  graph          the graph alone
  view           the graph with `carav run --view`'s live_view node (its inputs are taps), no page open
  view_browser   the same with a headless Chromium showing the page for the whole run (skipped, and said so in
                 the record, when Chromium, its driver or selenium is missing)
Figures: cycles/s (median of --repeats), each view mode over the graph alone in the same round, the frames the
taps skipped for display, and with the browser the Q points the page held at the end (its plots did move).
The view node and the browser run on the same cores as the chain: a ratio below 1 is their CPU, not waiting
(the taps never block; `tests/integration/test_runtime_processes.py` shows a slow tap skipping instead).
"""
from __future__ import annotations

import argparse
import shutil
import statistics
import threading
import time

from bench import browser
from bench import records as bench_records
from bench.pipeline import pipeline_overrides
from carav_graphs import graph_file
from carav_stream.cli.view import view_graph
from carav_stream.console.options import count, output_file
from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.supervisor import Supervisor
from carav_stream.view.server import free_port, new_token, page_url

PRESET, FIDELITY = "table1", "beat"
TARGET = 0.9          # the view node, no page open: at least this fraction of the graph's own rate
MODES = ("graph", "view", "view_browser")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--repeats", type=count(1), default=3, help="rounds of the three modes (median reported)")
    parser.add_argument("--cycles", type=count(100), default=16000, help="cycles per run")
    parser.add_argument("--batch", type=count(1), default=32, help="cycles per frame")


def _graph(n: int, batch: int, view_port: int | None, token: str = ""):
    overrides = pipeline_overrides(PRESET, FIDELITY, n, "fft_peak", batch)
    graph = load_graph(graph_file("radar_chain"), overrides)
    if view_port is None:
        return graph, None
    path = view_graph(graph, "127.0.0.1", view_port, token)
    return load_graph(path, overrides), path.parent


def _run_once(n: int, batch: int, mode: str) -> dict:
    port, token = (free_port("127.0.0.1") if mode != "graph" else None), new_token()
    graph, folder = _graph(n, batch, port, token)
    watcher: dict = {}
    stop = threading.Event()
    if mode == "view_browser":
        driver = browser.headless_chromium()      # started before the clock: its start-up is not the view's cost

        def watch() -> None:        # open the page as soon as it serves, keep it open until the run ends
            while not stop.is_set():
                try:
                    driver.get(page_url("127.0.0.1", port, token))
                    break
                except Exception:   # noqa: BLE001 (not serving yet)
                    time.sleep(0.1)
            while not stop.wait(0.25):
                points = browser.model(driver, "q_D0", 'data["cycle"]')
                if points is not None:
                    watcher["points"] = len(points)
        thread = threading.Thread(target=watch, daemon=True)
        thread.start()
    try:
        summary = Supervisor(graph, cycles=n, progress=False, log=lambda text: None).run()
    finally:
        stop.set()
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
    if mode == "view_browser":
        thread.join(30)
        driver.quit()
    if summary["failures"] or summary["lost"] or summary["cycles_judged"] != n:
        raise RuntimeError(f"{mode} run failed: {summary['failures']} lost {summary['lost']}")
    return {"rate": summary["throughput_cycles_per_s"],
            "skipped": sum((summary.get("skipped_by_taps") or {}).values()),
            "view_frames": sum(summary["per_node"].get("view", {}).get("in", {}).values()),
            "page_points": watcher.get("points")}


def run(args: argparse.Namespace) -> int:
    lacking = browser.missing()
    modes = [m for m in MODES if m != "view_browser" or not lacking]
    runs: dict[str, list[dict]] = {m: [] for m in modes}
    for _ in range(args.repeats):
        for mode in modes:
            runs[mode].append(_run_once(args.cycles, args.batch, mode))
    graph = [r["rate"] for r in runs["graph"]]
    record = {"preset": PRESET, "fidelity": FIDELITY, "batch": args.batch, "cycles": args.cycles,
              "repeats": args.repeats, "target": TARGET,
              "browser": "skipped: " + ", ".join(lacking) + " missing" if lacking else "headless chromium"}
    for mode in modes:
        rates = [r["rate"] for r in runs[mode]]
        entry = {"cycles_per_s": statistics.median(rates), "runs_cycles_per_s": rates,
                 "skipped_by_taps": [r["skipped"] for r in runs[mode]],
                 "view_frames": [r["view_frames"] for r in runs[mode]]}
        if mode != "graph":
            ratios = [r / g for r, g in zip(rates, graph)]
            entry.update(ratio_to_graph=statistics.median(ratios), runs_ratio=ratios)
        if mode == "view_browser":
            entry["page_points"] = [r["page_points"] for r in runs[mode]]
        record[mode] = entry
        ratio = f"  x{entry['ratio_to_graph']:.2f} the graph alone" if mode != "graph" else ""
        print(f"{mode:<13} {entry['cycles_per_s']:8.0f} cycles/s{ratio}  skipped by taps "
              f"{entry['skipped_by_taps']}", flush=True)
    if lacking:
        print(f"view_browser: skipped ({record['browser']})", flush=True)
    if args.json:
        bench_records.write(args.json, args, [record])
    return 0
