"""`python3 dev.py bench report`: BENCHMARKS.md and the results of docs/bench/*.md, rendered from benchmark records.

Each benchmark writes its records with `python3 dev.py bench NAME --json docs/bench/records/NAME.json` (bench.records:
the command, the machine, the records). This command renders, from those files and the benchmark list:

    BENCHMARKS.md              one table per benchmark: figure, measured, target, met or not
    docs/bench/NAME.md         between its markers, the full table of the records; in its head (bench.pages), the
                               command, module and record file from the benchmark list

so that no figure in them is typed by hand. `--check` renders without writing and fails if a document differs
from what the records give (a document edited by hand, or records updated without rendering).
"""
from __future__ import annotations

import argparse
import statistics
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench import pages
from bench import records as bench_records
from bench.chaos import met as chaos_met
from bench.compiled import KERNELS, choice
from bench.estimators import LISTS, TARGET_RATIO, TARGET_TIME_FACTOR, pareto, scores, where
from bench.gr_bridge import rows as gr_bridge_rows
from bench.gr_bridge import table as gr_bridge_table
from bench.pipeline import ceiling, tracker_pooled
from bench.soak import SOAK_RSS_MB_PER_H, no_growth
from bench.startup import rows as startup_rows
from bench.startup import table as startup_table
from bench.study import TARGET

BEGIN, END = "<!-- begin: dev.py bench report -->", "<!-- end: dev.py bench report -->"
Row = tuple[str, str, str, str]          # figure, measured, target, met


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--root", type=Path, default=Path("."), help="repository root (default: the working folder)")
    parser.add_argument("--check", action="store_true", help="write nothing; fail if a document is not up to date")


# -- number formatting ---------------------------------------------------------------------------------------
def _g(x: float, digits: int = 3) -> str:
    return f"{x:.{digits}g}" if abs(x) < 10 ** digits else f"{x:.0f}"


def _met(ok: bool) -> str:
    return "yes" if ok else "**no**"


# -- per benchmark: summary rows against targets, and the full table ---------------------------------------
def transport_rows(doc: dict) -> list[Row]:
    rows = []
    for r in doc["records"]:
        if r["transport"] == "raw":
            continue
        shape = "x".join(map(str, r["frame_shape"]))
        shm = r["transport"] == "runtime_shm"
        rows.append((f"runtime{' over shared memory' if shm else ''} / raw pyzmq frames/s, {shape} {r['dtype']} "
                     f"({r['bytes_per_frame']} B), {r['processes']} processes",
                     f"{r['ratio']:.2f} ({r['frames_per_s']:.0f} / {r['raw_frames_per_s']:.0f} frames/s; "
                     f"CPU ratio {r['cpu_ratio']:.2f})", "(reported)" if shm else ">= 0.8",
                     "-" if shm else _met(r["ratio"] >= 0.8)))
    return rows


def transport_table(doc: dict) -> list[str]:
    lines = ["| frame | transport | frames/s (runs) | GB/s per hop | latency median / p99 ms | paced median / p99 ms "
             "| CPU ms/frame | ratio | CPU ratio |", "|---|---|---|---:|---|---|---:|---:|---:|"]
    for r in doc["records"]:
        paced = (f"{r['paced_latency_median_s'] * 1e3:.2f} / {r['paced_latency_p99_s'] * 1e3:.2f}"
                 if "paced_latency_median_s" in r else "-")
        runs = ", ".join(f"{x:.0f}" for x in r["frames_per_s_runs"])
        ratio = f"{r['ratio']:.2f}" if r["transport"] != "raw" else "-"
        cpu_ratio = f"{r['cpu_ratio']:.2f}" if r["transport"] != "raw" else "-"
        lines.append(f"| {'x'.join(map(str, r['frame_shape']))} | {r['transport']} | {r['frames_per_s']:.0f} "
                     f"({runs}) | {r['gb_per_s']:.2f} | {r['latency_median_s'] * 1e3:.1f} / "
                     f"{r['latency_p99_s'] * 1e3:.1f} | {paced} | {r['cpu_ms_per_frame_total']:.3f} | {ratio} "
                     f"| {cpu_ratio} |")
    return lines


def udp_rows(doc: dict) -> list[Row]:
    """The live DCA1000 receiver: every packet the replayer sent at and above the AWR1642's data rate arrived, and
    no cycle was damaged; unpaced, what it could take (damaged cycles there are refused, never judged)."""
    rows = []
    for r in doc["records"]:
        if r["case"] == "replayer":
            rows.append(("the replayer alone (loopback, unpaced)", f"{r['packets_per_s']:.0f} packets/s, "
                         f"{r['mb_per_s']:.1f} MB/s", "(reported: the load it can offer)", "-"))
            continue
        paced = r.get("rate_multiple")
        what = (f"receiver at {paced} x the AWR1642's data rate" if paced else "receiver, replayer unpaced") + \
            f" ({r['offered_mb_per_s']:.1f} MB/s offered)"
        got = (f"{r['packets_received']} of {r['packets_sent']} packets, {r['damaged_cycles']} of "
               f"{r['cycles_sent']} cycles damaged")
        if r.get("packets_dropped_by_host") is not None:
            got += (f"; {r['packets_dropped_by_host']} dropped by this host's kernel "
                    f"({r['rcvbuf_granted_bytes'] / 2 ** 20:g} MiB receive buffer)")
        if paced:
            met = r["packets_lost"] == 0 and r["damaged_cycles"] == 0
            rows.append((what, got, "every packet, no cycle damaged", "yes" if met else "NO"))
        else:
            rows.append((what, got, "(reported: above the radar's rate; damaged cycles are refused)", "-"))
    return rows


def udp_table(doc: dict) -> list[str]:
    return ["| case | measured | target | met |", "|---|---|---|---|",
            *(f"| {' | '.join(row)} |" for row in udp_rows(doc))]


def zerocopy_rows(doc: dict) -> list[Row]:
    rows = []
    for r in doc["records"]:
        z = r["zmq"]
        for mode, what in (("shm", "multiprocessing.shared_memory ring + ZeroMQ notifications"),
                           ("iox", "iceoryx2 publish-subscribe")):
            if mode not in r:
                rows.append((f"{what}, {r['frame']} frame", r["iox"], "(reported)", "-"))
                continue
            m = r[mode]
            rows.append((f"{what} over pyzmq, one hop of a {r['frame']} frame ({r['bytes']} B)",
                         f"{m['ratio_to_zmq']:.2f} x frames/s ({m['frames_per_s']:.0f} / {z['frames_per_s']:.0f}); "
                         f"CPU per frame {m['cpu_us_per_frame']:.0f} / {z['cpu_us_per_frame']:.0f} us "
                         f"({m['cpu_ratio_to_zmq']:.2f} x)"
                         + (f"; frames sent again {sum(m['resent'])}" if mode == "iox" else ""),
                         "(reported: chooses the data plane)", "-"))
    return rows


def zerocopy_table(doc: dict) -> list[str]:
    lines = ["| frame | mode | frames/s (median) | runs | CPU us/frame (median) | over zmq: frames/s, CPU |",
             "|---|---|---:|---|---:|---|"]
    for r in doc["records"]:
        for mode in ("zmq", "shm", "iox"):
            if mode not in r:
                continue
            m = r[mode]
            over = f"{m['ratio_to_zmq']:.2f}, {m['cpu_ratio_to_zmq']:.2f}" if mode != "zmq" else "-"
            lines.append(f"| {r['frame']} ({r['bytes']} B) | {mode} | {m['frames_per_s']:.0f} | "
                         f"{', '.join(f'{x:.0f}' for x in m['runs_frames_per_s'])} | {m['cpu_us_per_frame']:.0f} | "
                         f"{over} |")
    return lines


def _synth_case(r: dict) -> str:
    return f"{r['preset']} {r['fidelity']} {r['attacker']} {'I/Q' if r['iq'] else 'I'}"


def synth_rows(doc: dict) -> list[Row]:
    rows = [(f"signal chain, {_synth_case(r)}, one core",
             f"{r['cpu_time_per_cycle_s'] * 1e6:.0f} us CPU per cycle = {r['realtime_factor']:.3g} x real time",
             "report", "-")
            for r in doc["records"] if r["bench"] == "synth"]
    return rows + [(f"{r['stage']} stage of one beat cycle, {r['preset']} {'I/Q' if r['iq'] else 'I'}, per {r['per']}",
                    f"{r['ns_per_sample']:.2f} ns = {r['x_bound']:.2f} x its bound measured beside it "
                    f"({r['bound_ns_per_sample']:.2f} ns: {r['bound']})", "report", "-")
                   for r in doc["records"] if r["bench"] == "synth_stage" and "ns_per_sample" in r]


def synth_table(doc: dict) -> list[str]:
    lines = ["| case | wall us/cycle | CPU us/cycle | cycles/s | radar cycles/s | x real time | first batch extra ms |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in doc["records"]:
        if r["bench"] == "synth":
            lines.append(f"| {_synth_case(r)} | {r['time_per_cycle_s'] * 1e6:.0f} | "
                         f"{r['cpu_time_per_cycle_s'] * 1e6:.0f} | {r['cycles_per_s']:.0f} | "
                         f"{r['radar_cycles_per_s']:.0f} | {r['realtime_factor']:.3g} | {r['cold_s'] * 1e3:.1f} |")
    stages = [r for r in doc["records"] if r["bench"] == "synth_stage"]
    if stages:
        lines += ["", "Stages of one beat cycle without attacker (us):", "",
                  "| preset | I/Q | " + " | ".join(dict.fromkeys(r["stage"] for r in stages)) + " |",
                  "|---|---|" + "---:|" * len(dict.fromkeys(r["stage"] for r in stages))]
        keys = dict.fromkeys((r["preset"], r["iq"]) for r in stages)
        for preset, iq in keys:
            cells = [f"{r['time_per_cycle_s'] * 1e6:.0f}" for r in stages if (r["preset"], r["iq"]) == (preset, iq)]
            lines.append(f"| {preset} | {'I/Q' if iq else 'I'} | " + " | ".join(cells) + " |")
    bounded = [r for r in stages if "ns_per_sample" in r]
    if bounded:
        lines += ["", "The same stages per sample (I/Q: per real value), each beside its bound measured in the same "
                  "run on the same shapes:", "",
                  "| preset | I/Q | stage | us/cycle | ns/sample | bound ns/sample | x bound | bound |",
                  "|---|---|---|---:|---:|---:|---:|---|"]
        lines += [f"| {r['preset']} | {'I/Q' if r['iq'] else 'I'} | {r['stage']} | {r['time_per_cycle_s'] * 1e6:.0f} | "
                  f"{r['ns_per_sample']:.3f} | {r['bound_ns_per_sample']:.3f} | {r['x_bound']:.2f} | {r['bound']} |"
                  for r in bounded]
    return lines


def _numba_cpu(r: dict) -> str:
    """The CPU numba compiled a compiled-kernel record's loops for."""
    return "this CPU" if r["numba_cpu"] == "host" else r["numba_cpu"]


def _compiled_case(r: dict) -> str:
    code = ("AVX-512" if r["numpy_avx512"] else "AVX2") + " numpy, numba for " + _numba_cpu(r)
    return f"{r['kernel']}, {r['target']} ({code})"


def _same(r: dict) -> str:
    if r["difference_eps"] == 0:
        return "the same result"
    return f"results within {r['difference_eps']:.3g} float32 eps of each sample's magnitude"


def compiled_rows(doc: dict) -> list[Row]:
    recs = doc["records"]
    rows = [(f"{_compiled_case(r)}, per table1 sample",
             f"numpy {r['numpy_ns_per_sample']:.3f} ns, numba {r['numba_ns_per_sample']:.3f} ns "
             f"({r['ratio']:.2f} x); {_same(r)}", "report", "-") for r in recs if r["bench"] == "kernel"]
    rows += [(f"numba at a node's start, {r['kernel']} loop, cache {r['cache']}",
              f"{r['cpu_s']:.2f} s CPU (import {r['import_cpu_s']:.2f} s)", "report", "-")
             for r in recs if r["bench"] == "start"]
    runs = doc["default_run_cycles"]
    rows += [(f"{kernel}: numpy or numba", choice(recs, kernel, runs),
              f"numba if faster on every target, its CPU in the zygote repaid within a default run ({runs} "
              "cycles) and a graph's start kept within the start-up target", "-")
             for kernel in KERNELS]
    return rows


def compiled_table(doc: dict) -> list[str]:
    lines = ["| kernel | target | numpy | numba | numpy us/cycle | numba us/cycle | numba / numpy "
             "| ns/sample numpy | numba | result | break-even cycles |",
             "|---|---|---|---|---:|---:|---:|---:|---:|---|---:|"]
    for r in doc["records"]:
        if r["bench"] == "kernel":
            even = f"{r['break_even_cycles']:.3g}" if r["break_even_cycles"] else "never"
            lines.append(f"| {r['kernel']} | {r['target']} | {'AVX-512' if r['numpy_avx512'] else 'AVX2'} "
                         f"| {r['numba']} for {_numba_cpu(r)}{', SVML' if r['svml'] else ''} "
                         f"| {r['numpy_us_per_cycle']:.1f} | {r['numba_us_per_cycle']:.1f} | {r['ratio']:.2f} "
                         f"| {r['numpy_ns_per_sample']:.3f} | {r['numba_ns_per_sample']:.3f} | {_same(r)} | {even} |")
    lines += ["", "numba's cost at a process's start (CPU seconds, median of the processes):", "",
              "| loop | cache | processes | CPU s | of which import s | wall s |", "|---|---|---:|---:|---:|---:|"]
    lines += [f"| {r['kernel']} | {r['cache']} | {r['processes']} | {r['cpu_s']:.2f} | {r['import_cpu_s']:.2f} "
              f"| {r['wall_s']:.2f} |" for r in doc["records"] if r["bench"] == "start"]
    return lines + _zygote_table(doc["records"])


def _zygote_table(records: list[dict]) -> list[str]:
    """numba imported and the loops called in the zygote before it forks (bench compiled's records, if any)."""
    zygotes = [r for r in records if r["bench"] == "zygote"]
    graph = [r for r in records if r["bench"] == "graph_start"]
    if not zygotes or not graph:
        return []
    lines = ["", "numba in the zygote, before it forks the nodes (median of the processes; a node's first calls: "
             "all three loops, in a node forked from it):", "",
             "| numba | processes | ready after s | zygote's imports CPU s | numba CPU s | loaded from the cache "
             "| a node's first calls ms | compiled again in the node |", "|---|---:|---:|---:|---:|---|---:|---|"]
    for r in zygotes:
        case = f"| {'cache ' + r['cache'] if r['cache'] != 'none' else 'not imported'} | {r['processes']} " \
               f"| {r['ready_wall_median_s']:.2f} | {r['preload_cpu_s']:.2f} "
        if r["cache"] == "none":
            lines.append(case + "| - | - | - | - |")
            continue
        lines.append(case + f"| {r['import_cpu_s'] + sum(r['loop_cpu_s'].values()):.2f} "
                     f"| {', '.join(r['from_cache']) or '-'} | {sum(r['node_wall_s'].values()) * 1e3:.1f} "
                     f"| {', '.join(r['recompiled']) or 'none'} |")
    g = graph[0]
    lines += ["", f"A graph's start in the same sitting (bench startup's runs, median of {g['runs']}): "
              f"{g['graph_s']:.2f} s, one interpreter's imports {g['import_s']:.2f} s "
              f"({g['graph_s'] / g['import_s']:.2f} x; target <= {g['target_ratio']:g} x)."]
    return lines


STRESS_TARGET = 1e-12


def detector_rows(doc: dict) -> list[Row]:
    recs = doc["records"]
    rows = []
    stress = [r for r in recs if r["bench"] == "stress"]
    if stress:
        worst = max(r["max_rel_err_q"] for r in stress)
        cases = "; ".join(f"{r['dtype']} {r['scales']}" for r in stress)
        rows.append((f"Q against an exact reference ({cases})", f"max relative error {worst:.2g}",
                     f"<= {STRESS_TARGET:g}", _met(worst <= STRESS_TARGET)))
    for r in recs:
        if r["bench"] == "kernel":
            rows.append((f"detect() cost, {r['dtype']}", f"{r['ns_per_sample_detect']:.2f} ns/sample "
                         f"(memory copy bandwidth {r['memory_gb_per_s']:.1f} GB/s)", "report", "-"))
        elif r["bench"] == "kernel_codes":
            rows.append((f"adc_chirp_rms() cost, int16 codes (the graph's path), {r['preset']} "
                         f"{' x '.join(map(str, r['shape']))}",
                         f"{r['ns_per_code']:.3f} ns/code = {r['x_bound']:.2f} x its bound "
                         f"({r['bound_ns_per_code']:.3f} ns: {r['bound']}) = {r['x_read']:.1f} x a read "
                         f"({r['read_ns_per_code']:.3f} ns: {r['read']})", "report", "-"))
        elif r["bench"] == "sweep":
            rows.append((f"table1 sweep, {r['source']}, {r['rarms']} RARMS x {r['trials']} trials x {r['eta']} eta, "
                         "full samples", f"{r['seconds']:.2f} s", "<= 10 s", _met(r["seconds"] <= 10)))
        elif r["bench"] == "energy" and r["workers"] == max(x["workers"] for x in recs if x["bench"] == "energy"):
            rows.append((f"sufficient-statistic Monte Carlo, {r['attack']} attack, {r['workers']} workers",
                         f"{r['cycles_per_s']:.3g} cycles/s", ">= 1e6 cycles/s", _met(r["cycles_per_s"] >= 1e6)))
    return rows


def detector_table(doc: dict) -> list[str]:
    lines = ["| bench | case | figure |", "|---|---|---|"]
    for r in doc["records"]:
        b = r["bench"]
        if b == "stress":
            lines.append(f"| stress | {r['dtype']}, scales {r['scales']} | max relative error of Q "
                         f"{r['max_rel_err_q']:.2g} (at {r['at_scale']}; eps {r['eps']:.1g}) |")
        elif b == "memory":
            lines.append(f"| memory | {r['what']} | {r['gb_per_s']:.1f} GB/s read + write |")
        elif b == "kernel":
            lines.append(f"| kernel | {r['dtype']} | detect {r['ns_per_sample_detect']:.3f} ns/sample "
                         f"({r['ns_per_cycle_detect'] / 1e3:.1f} us per Table I cycle, {r['gb_per_s_read']:.1f} GB/s); "
                         f"chirp_rms {r['ns_per_sample_rms']:.3f} ns/sample |")
        elif b == "kernel_codes":
            lines.append(f"| kernel | int16 codes, {r['preset']} {' x '.join(map(str, r['shape']))} | adc_chirp_rms "
                         f"{r['ns_per_code']:.3f} ns/code; bound {r['bound_ns_per_code']:.3f} ({r['bound']}), "
                         f"x {r['x_bound']:.2f}; read {r['read_ns_per_code']:.3f} ({r['read']}), x {r['x_read']:.1f} |")
        elif b == "sweep":
            lines.append(f"| sweep | table1 {r['source']}, {r['rarms']} RARMS x {r['trials']} trials x {r['eta']} "
                         f"eta | {r['seconds']:.2f} s ({r['cycles_per_s']:.0f} cycles/s) |")
        elif b == "energy":
            lines.append(f"| energy | {r['scene']}, {r['attack']}, {r['workers']} workers | "
                         f"{r['cycles_per_s']:.3g} cycles/s ({r['cycles']} cycles in {r['seconds']:.2f} s) |")
    return lines


def estimators_rows(doc: dict) -> list[Row]:
    recs = doc["records"]
    presets = sorted({r["preset"] for r in recs})
    fidelities = sorted({r["fidelity"] for r in recs if r.get("source") == "chain"})
    frames = [s for s in ("tones",) if any(r.get("source", "tones") == s for r in recs)]
    frames += [f"the radar chain at {' and '.join(fidelities)} fidelity"] if fidelities else []
    over = f"({', '.join(presets)}; {', '.join(frames)})"
    target = f"<= {TARGET_RATIO:g} x CRLB at <= {TARGET_TIME_FACTOR:g} x fft_peak time"
    rows = []
    for m, (ratio, tf) in sorted(scores(recs, presets).items(), key=lambda kv: kv[1][1]):
        if m in LISTS:
            rows.append((f"`{m}` target list (CFAR stage + ml), strongest listed target, worst RMSE / CRLB from 10 to "
                         f"30 dB {over}, median time over fft_peak", f"{_g(ratio)} x CRLB at {tf:.2f} x",
                         "(reported: the stage a target list adds)", "-"))
            continue
        rows.append((f"`{m}`, worst RMSE / CRLB from 10 to 30 dB {over}, median time over fft_peak",
                     f"{_g(ratio)} x CRLB at {tf:.2f} x", target,
                     _met(ratio <= TARGET_RATIO and tf <= TARGET_TIME_FACTOR)))
    default, reason = doc.get("default"), doc.get("reason")
    rows.append(("default estimator chosen by the benchmark", reason if default else f"None: {reason}",
                 "one estimator meets the target", _met(default is not None)))
    return rows


def estimators_table(doc: dict) -> list[str]:
    recs = doc["records"]
    lines = ["| preset | frames | estimator | rho | SNR dB | range RMSE / CRLB | velocity RMSE / CRLB | us per cycle "
             "| x fft_peak | missing |", "|---|---|---|---|---:|---:|---:|---:|---:|---:|"]
    order = {"tones": 0, "chain": 1}
    for r in sorted(recs, key=lambda r: (r["preset"], order.get(r.get("source", "tones"), 2), r.get("fidelity") or "",
                                         r["estimator"], r["rho"], r["snr_db"])):
        tf = "-" if r["time_ratio_to_fft_peak"] is None else f"{r['time_ratio_to_fft_peak']:.2f}"
        lines.append(f"| {r['preset']} | {where(r)} | {r['estimator']} | {r['rho']} | {r['snr_db']:g} | "
                     f"{_g(r['range_ratio'])} | {_g(r['velocity_ratio'])} | {r['time_per_cycle_s'] * 1e6:.0f} | {tf} | "
                     f"{r['n_missing']} |")
    snr = doc.get("pareto_snr")
    if snr is None:
        return lines
    lines += ["", f"Pareto front at {snr:g} dB after integration, range RMSE against time per cycle, frame by frame "
              "(* = no other estimator is faster and not worse beyond the Monte Carlo noise, or no slower and better "
              "beyond it: bench/estimators.py, `dominates`):", "",
              "| preset | frames | front | estimator | us per cycle | range RMSE / CRLB |",
              "|---|---|---|---|---:|---:|"]
    groups = sorted({(r["preset"], r.get("source", "tones"), r.get("fidelity")) for r in recs},
                    key=lambda g: (g[0], order.get(g[1], 2), g[2] or ""))
    for preset, source, fidelity in groups:
        for r in pareto(recs, preset, snr, source, fidelity):
            lines.append(f"| {preset} | {where(r)} | {'*' if r['pareto'] else ''} | {r['estimator']} | "
                         f"{r['time_per_cycle_s'] * 1e6:.0f} | {_g(r['range_ratio'])} |")
    return lines


FUSED_TARGET = 1.3
SHM_TARGETS = (2.5, 1.6)     # the pipeline over shared memory: x real time, x the fused chain


def _pipeline_ceiling(r: dict, doc: dict) -> tuple[float, str] | None:
    """(cycles/s, what binds) of a pipeline record's ceiling on the recording machine's cores (bench.pipeline), or
    None for a record without the nodes' CPU outside their blocks."""
    if r["mode"] != "pipeline" or "outside_us_per_cycle" not in r or not doc["machine"].get("cores"):
        return None
    return ceiling(r["busy_us_per_cycle"], r["outside_us_per_cycle"], doc["machine"]["cores"])


def tracker_pooled_rows(doc: dict) -> list[Row]:
    """The tracker's loss per scene, every paired run of its cases pooled (bench.pipeline.tracker_pooled)."""
    rows = []
    for p in tracker_pooled(doc["records"]):
        rows.append((f"the tracker after the target list on the {p['preset']} graph (scene {p['scene']}): cycles/s "
                     f"lost, every paired run of its cases pooled ({p['runs']} runs)",
                     f"{p['mean_loss']:.1%} mean (a run's spread {p['sd']:.1%}, standard error {p['se']:.1%}; "
                     f"one-sided 95 % upper bound {p['upper_95']:.1%})",
                     f"<= {p['target']:.0%} (the upper bound)" if p["judged"] else "(reported)",
                     _met(p["upper_95"] <= p["target"]) if p["judged"] else "-"))
    return rows


def pipeline_rows(doc: dict) -> list[Row]:
    rows = []
    for r in doc["records"]:
        case = f"{r['preset']} {r['fidelity']}, batch {r['batch']}"
        if r["mode"] in ("record", "replay"):
            what = ("the graph recording its ADC output (carav record)" if r["mode"] == "record" else
                    "a recording replayed through detection and ranging (carav replay)")
            rows.append((f"{what} against the radar's real time, {case}",
                         f"{r['cycles_per_s']:.0f} cycles/s = {r['real_time_factor']:.3g} x real time, "
                         f"{r['ratio_to_pipeline']:.2f} x the live graph, {r['bytes_per_cycle'] / 1e3:.1f} kB/cycle",
                         f">= 1 x ({r['radar_cycles_per_s']:.0f} cycles/s)", _met(r["real_time_factor"] >= 1)))
        if r["mode"] == "tracker":
            born = statistics.median(t["born"] for t in r["runs_tracks"])
            rows.append((f"the tracker after the target list: cycles/s lost against the same graph without it, "
                         f"{case} (scene {r['tracker_scene']}; tracks born {born:g} a run)",
                         f"{r['cycles_per_s_loss']:.1%} ({r['cycles_per_s']:.0f} cycles/s, "
                         f"{r['ratio_to_pipeline']:.3f} x the graph without it, median of "
                         f"{len(r['runs_cycles_per_s'])} runs paired run by run; the tracker's block "
                         f"{r['busy_us_per_cycle']['tracker']:.1f} us/cycle)", "(reported: judged pooled, below)", "-"))
        if r["mode"] != "pipeline":
            continue
        transport = r.get("transport", "zmq")
        real_time, fused = SHM_TARGETS if transport == "shm" else (1.0, FUSED_TARGET)
        plane = "arrays in shared memory" if transport == "shm" else "arrays in ZeroMQ messages"
        nodes = f"{len(r['busy_us_per_cycle'])} processes, " if r.get("busy_us_per_cycle") else ""
        top = _pipeline_ceiling(r, doc)
        at_top = ("" if top is None else f" (its ceiling on {doc['machine']['cores']} cores: {top[0]:.0f} cycles/s = "
                  f"{top[0] / r['radar_cycles_per_s']:.3g} x, bound by {top[1]})")
        rows.append((f"pipeline ({nodes}{plane}) against the radar's real time, {case}",
                     f"{r['cycles_per_s']:.0f} cycles/s = {r['real_time_factor']:.3g} x real time{at_top}",
                     f">= {real_time:g} x ({r['radar_cycles_per_s']:.0f} cycles/s)",
                     _met(r["real_time_factor"] >= real_time)))
        at_top = ("" if top is None else
                  f" ({r['speedup_over_fused'] * top[0] / r['cycles_per_s']:.2f} x at its ceiling)")
        rows.append((f"pipeline ({plane}) against the same chain in one process, {case}",
                     f"{r['speedup_over_fused']:.2f} x{at_top}", f">= {fused:g} x",
                     _met(r["speedup_over_fused"] >= fused)))
        if "busy_ns_per_sample" in r:
            rows.append((f"each node's block per sample ({plane}), {case}",
                         "; ".join(f"{node} {ns:.2f}" for node, ns in r["busy_ns_per_sample"].items())
                         + f" ns/sample (busy us/cycle over {r['samples_per_cycle']} samples a cycle)", "report", "-"))
    return rows + tracker_pooled_rows(doc)


def pipeline_table(doc: dict) -> list[str]:
    lines = ["| preset | fidelity | batch | mode | transport | cycles/s (runs) | x real time | x fused "
             "| bottleneck (busy us/cycle) or CPU us/cycle; the nodes' CPU outside their blocks (us/cycle) |",
             "|---|---|---:|---|---|---|---:|---:|---|"]
    for r in doc["records"]:
        runs = ", ".join(f"{x:.0f}" for x in r["runs_cycles_per_s"])
        extra = (f"{r['bottleneck_node']} ({r['busy_us_per_cycle'][r['bottleneck_node']]:.0f})"
                 if "bottleneck_node" in r else f"{r['cpu_us_per_cycle']:.0f} CPU")
        if "busy_ns_per_sample" in r:
            extra = extra[:-1] + f" = {r['busy_ns_per_sample'][r['bottleneck_node']]:.2f} ns/sample)"
        if "outside_us_per_cycle" in r:
            extra += f"; outside the blocks {sum(r['outside_us_per_cycle'].values()):.0f}"
            if "cpu_us_per_cycle" in r:
                extra += f"; all the nodes' CPU {r['cpu_us_per_cycle']:.0f}"
        top = _pipeline_ceiling(r, doc)
        if top is not None:
            extra += f"; ceiling {top[0]:.0f} cycles/s ({top[1]}), {r['cycles_per_s'] / top[0]:.0%} of it reached"
        if "bytes_per_cycle" in r:
            extra += f"; {r['bytes_per_cycle'] / 1e3:.1f} kB/cycle on disk"
        if r["mode"] == "tracker":
            extra += (f"; {r['ratio_to_pipeline']:.3f} x the graph without it (runs "
                      f"{', '.join(f'{x:.3f}' for x in r['runs_ratio_to_pipeline'])}), tracker "
                      f"{r['busy_us_per_cycle']['tracker']:.1f} us/cycle")
        lines.append(f"| {r['preset']} | {r['fidelity']} | {r['batch']} | {r['mode']} "
                     f"| {r.get('transport', 'zmq')} | {r['cycles_per_s']:.0f} ({runs}) | {r['real_time_factor']:.3g} "
                     f"| {r['speedup_over_fused']:.2f} | {extra} |")
    nodes = [r for r in doc["records"] if "busy_ns_per_sample" in r]
    if nodes:
        lines += ["", "Each node's busy time (inside its block) per cycle and per sample (us/cycle over the samples "
                  "of a cycle):", "",
                  "| preset | fidelity | batch | mode | transport | samples/cycle "
                  "| busy us/cycle (ns/sample) by node |",
                  "|---|---|---:|---|---|---:|---|"]
        lines += [f"| {r['preset']} | {r['fidelity']} | {r['batch']} | {r['mode']} | {r['transport']} | "
                  f"{r['samples_per_cycle']} | "
                  + ", ".join(f"{node} {r['busy_us_per_cycle'][node]:.0f} ({ns:.2f})"
                              for node, ns in r["busy_ns_per_sample"].items()) + " |" for r in nodes]
    return lines


def soak_rows(doc: dict) -> list[Row]:
    r = doc["records"][0]
    rows = [(f"lost cycles over {r['elapsed_s'] / 60:.1f} min, {r['cycles']} cycles, {r['swaps']} attacker swaps "
             f"(glibc trim threshold {r.get('trim_mb', 512)} MB)",
             f"{r['lost']} (failures: {len(r['failures'])})", "0", _met(r["lost"] == 0 and not r["failures"]))]
    for p in r["processes"].values():
        err = p["anon_floor_mb_per_h_stderr"]
        rows.append((f"{p['node']}: heap (anonymous) memory floor growth, second half",
                     f"{p['anon_floor_mb_per_h']:+.1f} +- {err:.1f} MB/h "
                     f"({p['anon_mb_start']:.1f} -> {p['anon_mb_end']:.1f} MB)",
                     f"< {SOAK_RSS_MB_PER_H:g} MB/h or < 3 standard errors",
                     _met(no_growth(p["anon_floor_mb_per_h"], err))))
        if p.get("heap_bound_mb") is not None:
            rows.append((f"{p['node']}: heap, most in the second half, against what its buffers can hold",
                         f"{p['anon_mb_max']:.1f} MB", f"<= {p['heap_bound_mb']:.0f} MB (its lowest heap + buffers x "
                         "largest frames)", _met(p["anon_mb_max"] <= p["heap_bound_mb"])))
        if p["shm_mapped_mb"] > 0:         # the shm data plane: segments mapped (the zmq plane maps none)
            rows.append((f"{p['node']}: shared memory resident, most in the second half",
                         f"{p['shmem_mb_max']:.1f} MB", f"<= the segments it maps, {p['shm_mapped_mb']:.0f} MB",
                         _met(p["shmem_mb_max"] <= p["shm_mapped_mb"] + 1.0)))
        rows.append((f"{p['node']}: open file descriptors, second half", f"{p['fds_start']} -> {p['fds_end']}",
                     "no growth", _met(p["fds_end"] <= p["fds_start"])))
    return rows


def soak_table(doc: dict) -> list[str]:
    r = doc["records"][0]
    lines = [f"{r['cycles']} cycles in {r['elapsed_s']:.0f} s ({r['cycles_per_s']:.0f} cycles/s), {r['swaps']} swaps, "
             f"lost {r['lost']}, rejected {r['rejected']}", "",
             f"Glibc trim threshold {r['trim_mb']} MB; memory floor = smallest sample per {r['floor_s']:g} s window; "
             "heap = anonymous resident memory, shared = the run's shared-memory segments' pages resident in the "
             "process (bounded by the segments it maps).",
             "",
             "| process | samples | RSS MB start / end | heap MB start / end / most | heap bound MB | "
             "heap floor MB/h (+- std. error) | RSS floor MB/h | shared MB most / mapped | descriptors start / end |",
             "|---|---:|---|---|---:|---:|---:|---|---|"]
    for name, p in r["processes"].items():
        lines.append(f"| {name} | {p['samples']} | {p['rss_mb_start']:.1f} / {p['rss_mb_end']:.1f} | "
                     f"{p['anon_mb_start']:.1f} / {p['anon_mb_end']:.1f} / {p['anon_mb_max']:.1f} | "
                     f"{'-' if p.get('heap_bound_mb') is None else format(p['heap_bound_mb'], '.0f')} | "
                     f"{p['anon_floor_mb_per_h']:+.1f} (+- {p['anon_floor_mb_per_h_stderr']:.1f}) | "
                     f"{p['rss_floor_mb_per_h']:+.1f} | {p['shmem_mb_max']:.1f} / {p['shm_mapped_mb']:.0f} | "
                     f"{p['fds_start']} / {p['fds_end']} |")
    return lines


def chaos_rows(doc: dict) -> list[Row]:
    rows = []
    for r in doc["records"]:
        ok = chaos_met(r)
        head = f"{r['transport']}, {r['n_kills']} SIGKILLs in {r['seconds']:g} s:"
        rows += [(f"{head} cycles judged twice / out of order", f"{r['judged_twice']} / {r['out_of_order']}",
                  "0 / 0", _met(ok["judged_twice"] and ok["out_of_order"])),
                 (f"{head} cycles passed to ranging without a clean verdict",
                  f"{r['clean_without_clean_verdict']} of {r['passed_to_ranging']}", "0",
                  _met(ok["clean_without_clean_verdict"])),
                 (f"{head} the summary's judged cycles against the gated log's",
                  f"{r['cycles_judged']} / {r.get('gated_log_cycles_compared', r['gated_log_cycles'])} "
                  f"({r['judged_agreement']:.2%} apart; {r.get('summary_covers', 'figures cover the whole run')})",
                  f"within {doc.get('agreement', 0.01):.0%}", _met(ok["judged_agreement"])),
                 (f"{head} each sink's lines against the frames counted into it",
                  "; ".join(f"{k} {v['lines']} / {v['counted']} ({v['killed']} kills)" for k, v in r["sinks"].items()),
                  "equal for a sink never killed", _met(ok["sinks"])),
                 (f"{head} processes and run files left {r.get('settle_s', 10):g} s after the run",
                  f"{r['left_processes']} / {len(r['left_files'])}", "0 / 0", _met(ok["left"]))]
    return rows


def chaos_table(doc: dict) -> list[str]:
    lines = ["| plane | kills (by node) | restarts | cycles generated | judged | lost frames | verdict log cycles "
             "| gated log cycles | passed to ranging | exit |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in doc["records"]:
        kills = ", ".join(f"{k} {v}" for k, v in sorted(r["kills"].items()))
        lines.append(f"| {r['transport']} | {r['n_kills']} ({kills}) | {r['restarts']} | {r['cycles']} "
                     f"| {r['cycles_judged']} | {r['lost']} | {r['verdict_log_cycles']} | {r['gated_log_cycles']} "
                     f"| {r['passed_to_ranging']} | {r['exit_code']} |")
    return lines


def study_rows(doc: dict) -> list[Row]:
    r = doc["records"][0]
    return [(f"carav study, 2 local workers over 1 on {r['cores']} cores ({r['points']} points of {r['trials']} "
             "cycles, every sample)", f"{r['speedup_2_over_1']:.2f} x ({r['cycles_per_s']['1']:.0f} -> "
             f"{r['cycles_per_s']['2']:.0f} cycles/s)", f">= {TARGET:g} x", _met(r["speedup_2_over_1"] >= TARGET)),
            (f"Dask scheduler overhead per task ({r['overhead_tasks']} empty tasks, one worker)",
             f"{r['overhead_s_per_task'] * 1e3:.2f} ms", "(reported)", "-")] + ([
            (f"brute-force PF of {r['rare_cycles']:.0e} attack-free Table I cycles at the closed-form 1e-6 threshold "
             f"(eta {r['rare_eta']:.4f}), 2 workers, {r['rare_seconds']:.0f} s",
             f"{r['rare_alarms']} alarms: {r['rare_pf']:.3g} [{r['rare_pf_lo']:.3g}, {r['rare_pf_hi']:.3g}]",
             f"contains the closed form {r['rare_pf_closed_form']:.3g}", _met(r["rare_agrees"]))]
            if "rare_cycles" in r else [])


def study_table(doc: dict) -> list[str]:
    r = doc["records"][0]
    lines = ["| workers | cycles/s (median) | runs | cluster start-up s |", "|---:|---:|---|---:|"]
    for w in ("1", "2"):
        runs = ", ".join(f"{x:.0f}" for x in r["runs_cycles_per_s"][w])
        lines.append(f"| {w} | {r['cycles_per_s'][w]:.0f} | {runs} | {r['cluster_start_s'][w]:.1f} |")
    lines += ["", f"2 workers over 1, run by run: {', '.join(f'{x:.2f}' for x in r['runs_speedup'])}; scheduler "
              f"overhead {r['overhead_s_per_task'] * 1e3:.2f} ms per empty task."]
    return lines


def view_rows(doc: dict) -> list[Row]:
    r = doc["records"][0]
    case = f"{r['preset']} {r['fidelity']}, batch {r['batch']}, {r['cycles']} cycles"
    rows = [(f"graph with the live view node, no page open, over the graph alone ({case})",
             f"{r['view']['ratio_to_graph']:.2f} x ({r['view']['cycles_per_s']:.0f} / "
             f"{r['graph']['cycles_per_s']:.0f} cycles/s)", f">= {r['target']:g} x", _met(r['view']['ratio_to_graph']
                                                                                         >= r["target"]))]
    if "view_browser" in r:
        b = r["view_browser"]
        rows.append((f"the same with a headless Chromium showing the page on the same cores ({case})",
                     f"{b['ratio_to_graph']:.2f} x ({b['cycles_per_s']:.0f} cycles/s); frames skipped by the taps "
                     f"{', '.join(map(str, b['skipped_by_taps']))}", "(reported: the browser's own CPU)", "-"))
    else:
        rows.append(("the same with a headless browser", r["browser"], "(reported)", "-"))
    return rows


def view_table(doc: dict) -> list[str]:
    r = doc["records"][0]
    lines = ["| mode | cycles/s (median) | runs | over the graph alone, run by run | skipped by taps | frames to the "
             "view |", "|---|---:|---|---|---|---|"]
    for mode in ("graph", "view", "view_browser"):
        if mode not in r:
            continue
        m = r[mode]
        ratios = ", ".join(f"{x:.2f}" for x in m.get("runs_ratio", [])) or "-"
        lines.append(f"| {mode} | {m['cycles_per_s']:.0f} | {', '.join(f'{x:.0f}' for x in m['runs_cycles_per_s'])} "
                     f"| {ratios} | {', '.join(map(str, m['skipped_by_taps']))} | "
                     f"{', '.join(map(str, m['view_frames']))} |")
    if "view_browser" in r:
        lines += ["", "Q points the page held at the end of each browser run: "
                  + ", ".join(str(x) for x in r["view_browser"]["page_points"]) + "."]
    else:
        lines += ["", f"Browser runs: {r['browser']}."]
    return lines


BENCHMARKS: dict[str, tuple[str, Callable[[dict], list[Row]], Callable[[dict], list[str]]]] = {
    "transport": ("Transport: runtime against raw pyzmq", transport_rows, transport_table),
    "zerocopy": ("Zero copy: one same-host hop by three data planes", zerocopy_rows, zerocopy_table),
    "synth": ("Signal chain per simulated cycle", synth_rows, synth_table),
    "detector": ("Detector: numerical stability, cost, Monte Carlo speed", detector_rows, detector_table),
    "compiled": ("Compiled kernels: numpy against numba, on AVX-512 and AVX2 code", compiled_rows, compiled_table),
    "estimators": ("Estimators: error against run time", estimators_rows, estimators_table),
    "pipeline": ("Pipeline: the multi-process radar graph", pipeline_rows, pipeline_table),
    "soak": ("Soak: the demo graph for minutes with live swaps", soak_rows, soak_table),
    "chaos": ("Chaos: a random node SIGKILLed every 2 s, restarted by policy", chaos_rows, chaos_table),
    "startup": ("Start-up: nodes forked from the zygote against fresh interpreters", startup_rows, startup_table),
    "study": ("Studies on Dask: scaling over local workers", study_rows, study_table),
    "view": ("Live view: what watching costs the chain", view_rows, view_table),
    "dca1000_udp": ("Live capture: the DCA1000 UDP receiver against the AWR1642's data rate", udp_rows, udp_table),
    "gr_bridge": ("GNU Radio bridge: gr_zmq_sink and gr_zmq_source each way, beside raw pyzmq", gr_bridge_rows,
                  gr_bridge_table),
}
# Evaluations whose benchmark is not in the tree: their records stay, rendered with this note beside the command.
RECORDED_ONLY = {"zerocopy": "a recorded evaluation (iceoryx2 against the standard library's shared memory); its "
                             "benchmark is not part of this tree, so the command does not run here"}

INTRO = """# Benchmarks

Rendered by `python3 dev.py bench report` from the records in `docs/bench/records/` (each written by the command
shown with its section, `--json docs/bench/records/NAME.json`); do not edit by hand: rerun the benchmark, then
`python3 dev.py bench report`. Methods and the full tables: `docs/bench/NAME.md`. Figures are medians over several
runs and comparisons are ratios measured in the same run, modes interleaved: the machines are shared, and absolute
times vary between runs by more than the ratios do. Older code against newer: `python3 dev.py bench compare REV --
NAME [OPTIONS]` runs both in turn, round by round.
"""


def _machine(m: dict[str, Any]) -> str:
    return f"{bench_records.describe(m)} when written"


def render(root: Path) -> dict[Path, str]:
    """Every document as the records give it: {path: text}. A benchmark's page gets its head from the benchmark
    list (bench.pages) and, when its records exist, their full table."""
    folder = root / "docs" / "bench" / "records"
    out: dict[Path, str] = {}
    parts = [INTRO]
    for name, (title, rows_of, table_of) in BENCHMARKS.items():
        path = folder / f"{name}.json"
        page = root / "docs" / "bench" / f"{name}.md"
        text = page.read_text() if page.exists() else None
        if text is not None:
            text = pages.splice(text, pages.HEAD_BEGIN, pages.HEAD_END, pages.head(name, RECORDED_ONLY.get(name)),
                                str(page))
        parts.append(f"## {title} (`docs/bench/{name}.md`)\n")
        if not path.exists():
            command = (pages.command_of(name) or (name,))[0]
            parts.append(f"No records yet: run `python3 dev.py bench {command} --json "
                         f"docs/bench/records/{name}.json`.\n")
        else:
            doc = bench_records.read(path)
            note = f" ({RECORDED_ONLY[name]})" if name in RECORDED_ONLY else ""
            parts.append(f"Command: `{doc['command']}`{note}  \nMachine: {_machine(doc['machine'])}\n")
            parts.append("\n".join(["| figure | measured | target | met |", "|---|---|---|---|",
                                    *(f"| {' | '.join(r)} |" for r in rows_of(doc))]) + "\n")
            if text is not None:
                body = [f"Command: `{doc['command']}`{note}  ", f"Machine: {_machine(doc['machine'])}", "",
                        *table_of(doc)]
                text = pages.splice(text, BEGIN, END, body, str(page))
        if text is not None:
            out[page] = text
    out[root / "BENCHMARKS.md"] = "\n".join(parts)
    return out


def run(args: argparse.Namespace) -> int:
    try:
        docs = render(args.root)
    except (ValueError, KeyError, OSError) as exc:
        print(f"dev.py bench report: {exc}", file=sys.stderr)
        return 1
    stale = [p for p, text in docs.items() if not p.exists() or p.read_text() != text]
    if args.check:
        for p in stale:
            print(f"dev.py bench report: {p} is not what its records give; run dev.py bench report", file=sys.stderr)
        return 1 if stale else 0
    for p in stale:
        p.write_text(docs[p])
        print(f"wrote {p}")
    return 0

