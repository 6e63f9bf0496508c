"""`python3 dev.py bench soak --minutes N`: the demo graph at full speed (or paced, `--cycles-per-s`) for N minutes,
its attacker swapped every few seconds.

The graph (graphs/demo.toml, until stopped) runs as `carav run` in a process group of its own, with a private
run folder. Every `--sample-s` seconds the benchmark reads each node's resident memory (VmRSS) and open file
descriptors from /proc (the pids come from `carav status`); every `--swap-s` seconds it swaps the attacker's model
(random, smart, none in turn, through the same admin path as `carav swap`). At the end it stops the graph with
`carav stop` and reads the run summary.

Memory: the nodes run with the supervisor's allocator settings (supervisor.NODE_ENV), except glibc's trim
threshold, set by `--trim-mb` (default 0; the node default is 512 MB). glibc keeps up to that much freed heap in each
process (with 512 MB on purpose: large frames are then reused instead of faulted in again), so resident memory
creeps towards the threshold whatever the code does (with 16 MB the run-summary node, whose block keeps constant
state, crept about +30 MB/h over 10 minutes). With 0, resident memory is what is live plus the frames in flight at
the instant of the sample, which come and go; the benchmark therefore fits the floor of the series, the smallest
sample in each `--floor-s` window, which a leak raises and frames in flight do not. `--trim-mb 512` measures the
production setting.

Figures per node: resident memory, of which anonymous (the heap: where a leak grows) and shared (pages of the run's
shared-memory segments, runtime/shm.py), and file descriptors, at the start of the second half of the run and at
the end, and the growth per hour of the memory floors and of the descriptors from a least-squares line through the
second half (the first half is warm-up: caches, allocator pools); the line through every sample is kept in the
record beside it. Shared pages are bounded by design: a segment holds SLOTS_PER_QUEUED_FRAME x queue_frames +
SPARE_SLOTS slots of one frame, a writer takes the lowest free slot, so a process's shared pages follow the most
frames ever in flight at once on its ports (more under load, when consumers lag) and stay resident up to the size of
the segments it maps, which the record gives beside them. Targets: no heap growth beyond noise (its floor's slope
under SOAK_RSS_MB_PER_H per node and hour, or under three standard errors of the fitted slope), shared memory within
the mapped segments, no descriptor growth, and no lost cycle. Memory is sampled per process: a swapped or restarted
node's new process is a new series.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench import records as bench_records
from carav_stream.console.options import count, number, output_file
from carav_stream.runtime.graph import RUN_DEFAULTS

SOAK_RSS_MB_PER_H = 20.0
QUEUE_FRAMES = RUN_DEFAULTS["queue_frames"]        # the demo graph's: it sets none
HEAP_SLACK_MB = 20.0      # beyond frames: the allocator's per-thread arenas and free lists, Python's own objects
MODELS = (("random", ["rarms=3.0"]), ("smart", ["rarms=3.0"]), ("none", []))


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--minutes", type=number(0.0, strict=True), default=10.0, help="how long the graph runs")
    parser.add_argument("--swap-s", type=number(0.5), default=5.0, help="seconds between attacker swaps")
    parser.add_argument("--sample-s", type=number(0.1), default=2.0, help="seconds between memory samples")
    parser.add_argument("--batch", type=count(1), default=32, help="cycles per frame")
    parser.add_argument("--cycles-per-s", type=number(0.0), default=0.0,
                        help="pace the source to at most this many cycles a second (default 0: full speed)")
    parser.add_argument("--trim-mb", type=count(0), default=0,
                        help="glibc's trim threshold in the nodes, MB (the node default is 512; see the module doc)")
    parser.add_argument("--floor-s", type=number(0.1), default=30.0,
                        help="window of the memory floor: the smallest sample per window is fitted (default 30 s)")
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")


def proc_figures(pid: int) -> dict[str, float] | None:
    """A live process's memory in MB (resident, of which anonymous and shared), the size of the run's shared-memory
    segments it maps (MB), and its open descriptors; None if it is gone."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
        maps = Path(f"/proc/{pid}/maps").read_text()
        fds = len(os.listdir(f"/proc/{pid}/fd"))
    except (FileNotFoundError, ProcessLookupError, PermissionError):
        return None
    kb = {line.split(":")[0]: int(line.split()[1]) for line in status.splitlines()
          if line.startswith(("VmRSS:", "RssAnon:", "RssShmem:"))}
    return {"rss": kb["VmRSS"] / 1024, "anon": kb.get("RssAnon", 0) / 1024, "shmem": kb.get("RssShmem", 0) / 1024,
            "shm_mapped": segments_mapped_mb(maps), "fds": fds}


def segments_mapped_mb(maps: str) -> float:
    """MB of the run's shared-memory segments (memfds named carav-<port>, runtime/shm.py) mapped in a /proc maps
    text: what the process's shared resident memory can never exceed."""
    total = 0
    for line in maps.splitlines():
        fields = line.split(maxsplit=5)
        if len(fields) == 6 and fields[5].startswith("/memfd:carav"):
            lo, hi = (int(x, 16) for x in fields[0].split("-"))
            total += hi - lo
    return total / 2 ** 20


def growth_per_hour(t_s: list[float], values: list[float]) -> tuple[float, float]:
    """Slope of a least-squares line and its standard error, per hour ((0, 0) with fewer than 4 samples)."""
    if len(t_s) < 4 or max(t_s) == min(t_s):
        return 0.0, 0.0
    t, v = np.asarray(t_s, float), np.asarray(values, float)
    line = np.polyfit(t, v, 1)
    slope, resid = line[0], v - np.polyval(line, t)
    stderr = math.sqrt(float(resid @ resid) / (len(t) - 2) / float(((t - t.mean()) ** 2).sum()))
    return float(slope * 3600.0), float(stderr * 3600.0)


def floor(t_s: list[float], values: list[float], window_s: float) -> tuple[list[float], list[float]]:
    """The smallest value in each window of window_s seconds from the first sample (at the window's middle);
    windows with fewer than two samples are left out (a floor of one sample is just a sample)."""
    t, v = np.asarray(t_s, float), np.asarray(values, float)
    k = np.floor((t - t[0]) / window_s).astype(int)
    out_t, out_v = [], []
    for w in np.unique(k):
        if np.count_nonzero(k == w) >= 2:
            out_t.append(float(t[0] + (w + 0.5) * window_s))
            out_v.append(float(v[k == w].min()))
    return out_t, out_v


def no_growth(per_h: float, stderr_per_h: float) -> bool:
    """The soak's target: growth under SOAK_RSS_MB_PER_H, or not told apart from noise (under 3 standard errors)."""
    return per_h < max(SOAK_RSS_MB_PER_H, 3.0 * stderr_per_h)


def _cli(*args: str) -> list[str]:
    """The argv of a carav command run by this interpreter."""
    return [sys.executable, "-m", "carav_stream.cli", *args]


def _carav(env: dict[str, str], *args: str, timeout_s: float | None = 60) -> subprocess.CompletedProcess:
    return subprocess.run(_cli(*args), env=env, capture_output=True, text=True, timeout=timeout_s)


def _node_pids(env: dict[str, str]) -> dict[str, int]:
    """{node: pid} of the running graph, from `carav status` ({} while it is not up yet)."""
    try:
        st = _carav(env, "status", "--json", timeout_s=20)
    except subprocess.TimeoutExpired:      # a loaded machine: asked again at the next sample
        return {}
    if st.returncode != 0 or not st.stdout.strip().startswith("["):
        return {}
    return {node: info["pid"] for run in json.loads(st.stdout) for node, info in run["nodes"].items()
            if info.get("pid")}


def _holdings(env: dict[str, str]) -> dict[str, Any]:
    """From `carav status` just before the stop: each node's largest message per input, the most frames its
    pairing buffer held per input, its buffer limit, and the graph's edges and queue_frames ({} if it does not
    answer)."""
    st = _carav(env, "status", "--json", timeout_s=None)
    if st.returncode != 0 or not st.stdout.strip().startswith("["):
        return {}
    (run,) = json.loads(st.stdout)
    nodes = {n: {k: info["counters"].get(k) for k in ("frame_bytes", "most_buffered", "buffer_limit")}
             for n, info in run["nodes"].items() if "counters" in info}
    return {"nodes": nodes, "edges": sorted(run["edges"]), "queue_frames": QUEUE_FRAMES}


def heap_bound_mb(node: str, holdings: dict[str, Any], base_mb: float) -> float | None:
    """What `node`'s heap may hold above `base_mb` by design, in MB: per input, its pairing buffer's limit plus
    ZeroMQ's receive queue of queue_frames, of its largest message; per output edge, ZeroMQ's send queue of
    queue_frames of the largest message its consumer took (frames leave without a copy, so a queued one is still
    the sender's); HEAP_SLACK_MB for the rest. None when the status did not say."""
    info = holdings.get("nodes", {}).get(node)
    if not info or info.get("frame_bytes") is None:
        return None
    q = holdings["queue_frames"]
    total = sum(b * (info["buffer_limit"] + q) for b in info["frame_bytes"].values())
    for edge in holdings["edges"]:
        src, dst = (end.strip() for end in edge.split("->"))
        if src.split(".")[0] == node:
            consumer = holdings["nodes"].get(dst.split(".")[0]) or {}
            total += q * (consumer.get("frame_bytes") or {}).get(dst.split(".")[1], 0)
    return base_mb + HEAP_SLACK_MB + total / 2 ** 20


def _start_swap(env: dict[str, str], i: int) -> subprocess.Popen:
    """Start swap `i` of the attacker (MODELS in turn); it runs beside the caller."""
    model, sets = MODELS[i % len(MODELS)]
    return subprocess.Popen(_cli("swap", "attacker", "attacker", "--set", f"model={model}",
                                 *sum((["--set", s] for s in sets), [])),
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _check_swap(swap: subprocess.Popen, i: int) -> None:
    """Raise if swap `i`, finished, was refused."""
    if swap.returncode != 0:
        raise RuntimeError(f"swap {i} to {MODELS[i % len(MODELS)][0]} refused: {swap.stderr.read().strip()}")


def _going(env: dict[str, str]) -> bool:
    """Whether the run has made cycles yet (from `carav status`)."""
    st = _carav(env, "status", "--json", timeout_s=None)
    return st.returncode == 0 and st.stdout.strip().startswith("[") and \
        any(run.get("cycles", 0) > 0 for run in json.loads(st.stdout))


def soak(minutes: float, swap_s: float, sample_s: float, batch: int, trim_mb: int = 0,
         floor_s: float = 30.0, cycles_per_s: float = 0.0) -> dict[str, Any]:
    from carav_graphs import graph_file
    with tempfile.TemporaryDirectory(prefix="cs", dir="/tmp") as tmp:     # ipc paths must stay short
        env = {**os.environ, "CARAV_RUN_DIR": tmp, "MALLOC_TRIM_THRESHOLD_": str(trim_mb << 20),
               "MALLOC_TOP_PAD_": "0"}          # the user's environment wins over NODE_ENV
        summary_path = Path(tmp) / "summary.json"
        proc = subprocess.Popen(_cli("run", str(graph_file("demo")), "--cycles", "0", "--set", f"batch={batch}",
                                     "--set", f"source.cycles_per_s={cycles_per_s}", "--no-progress",
                                     "--json", str(summary_path)), env=env, start_new_session=True,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        series: dict[tuple[str, int], list[dict[str, float]]] = {}
        holds: dict[str, Any] = {}
        swaps = 0
        swapping: subprocess.Popen | None = None          # the `carav swap` under way, if any
        try:
            # the soak's minutes are minutes of running: its clock starts once the graph makes cycles and its
            # nodes' pids are known (a loaded machine may take a while to start ten processes, and to answer
            # `carav status`: a window spent asking would leave no samples to judge)
            while not _going(env) or not (pids := _node_pids(env)):
                if proc.poll() is not None:
                    raise RuntimeError(f"the graph ended before it ran:\n{proc.stderr.read()[-2000:]}")
                time.sleep(0.2)
            t0 = time.monotonic()
            next_swap = next_sample = t0
            end = t0 + minutes * 60
            while time.monotonic() < end:
                if proc.poll() is not None:
                    raise RuntimeError(f"the graph ended early:\n{proc.stderr.read()[-2000:]}")
                now = time.monotonic()
                if now >= next_sample:
                    next_sample = now + sample_s
                    figs = {node: proc_figures(pid) for node, pid in pids.items()}
                    if not pids or None in figs.values():      # not known yet, or a node was restarted
                        pids = _node_pids(env)
                        figs = {node: proc_figures(pid) for node, pid in pids.items()}
                    for node, f in figs.items():
                        if f:
                            series.setdefault((node, pids[node]), []).append({"t": now - t0, **f})
                if swapping is not None and swapping.poll() is not None:
                    _check_swap(swapping, swaps)
                    swaps += 1
                    swapping, next_swap = None, now + swap_s
                if swapping is None and now >= next_swap and now > t0 + 2:
                    # `carav swap` runs beside the sampling: on a loaded machine it takes seconds, and a sampler
                    # waiting for it would leave the second half of the window without samples to judge
                    swapping = _start_swap(env, swaps)
                time.sleep(0.05)
            if swapping is not None:
                swapping.wait()
                _check_swap(swapping, swaps)
                swaps += 1
            holds = _holdings(env)
            stop = _carav(env, "stop")
            if stop.returncode != 0:
                raise RuntimeError(f"carav stop failed: {stop.stderr.strip()}")
            proc.wait(120)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        summary = json.loads(summary_path.read_text())
    elapsed = time.monotonic() - t0
    sampled = [x["t"] for samples in series.values() for x in samples]
    half = (min(sampled) + max(sampled)) / 2 if sampled else 0.0   # of the sampled run, not of its stop
    nodes = {}
    for (node, pid), samples in sorted(series.items()):
        late = [x for x in samples if x["t"] >= half]
        if len(late) < 3:
            continue       # a process that lived through too little of the second half to judge
        fig = process_figures(late, floor_s)
        base = min(x["anon"] for x in samples)          # the node's heap with nothing in flight, as low as seen
        fig["heap_bound_mb"] = heap_bound_mb(node, holds, base)
        fig["most_buffered"] = (holds.get("nodes", {}).get(node) or {}).get("most_buffered")
        nodes[f"{node}[{pid}]"] = {"node": node, "pid": pid, **fig}
    return {"minutes": minutes, "trim_mb": trim_mb, "floor_s": floor_s, "elapsed_s": elapsed, "swaps": swaps,
            "paced_cycles_per_s": cycles_per_s, "cycles": summary["cycles"],
            "cycles_per_s": summary["throughput_cycles_per_s"], "lost": summary["lost"],
            "failures": summary["failures"], "rejected": summary["rejected"], "processes": nodes}


def process_figures(late: list[dict[str, float]], floor_s: float) -> dict[str, Any]:
    """One process's figures over the second half: growth of its memory floors (all, anonymous: the heap, where a
    leak would grow) and its shared memory against the segments it maps (bounded by design: a segment has
    SLOTS_PER_QUEUED_FRAME x queue_frames + SPARE_SLOTS slots of one frame each, and the lowest free slot is taken,
    so shared pages grow with the most frames ever in flight at once, up to the segment's size, and stay)."""
    t = [x["t"] for x in late]
    out: dict[str, Any] = {"samples": len(late)}
    for key, name in (("rss", "rss"), ("anon", "anon")):
        v = [x[key] for x in late]
        per_h, err = growth_per_hour(t, v)
        t_floor, v_floor = floor(t, v, floor_s)
        floor_per_h, floor_err = growth_per_hour(t_floor, v_floor)
        out.update({f"{name}_mb_start": v[0], f"{name}_mb_end": v[-1], f"{name}_mb_max": max(v),
                    f"{name}_mb_per_h": per_h, f"{name}_mb_per_h_stderr": err, f"{name}_floor_mb_per_h": floor_per_h,
                    f"{name}_floor_mb_per_h_stderr": floor_err})
    out["floor_windows"] = len(floor(t, t, floor_s)[0])
    out["shmem_mb_max"] = max(x["shmem"] for x in late)
    out["shm_mapped_mb"] = max(x["shm_mapped"] for x in late)
    fds = [x["fds"] for x in late]
    out.update({"fds_start": fds[0], "fds_end": fds[-1], "fds_per_h": growth_per_hour(t, fds)[0]})
    return out


def run(args: argparse.Namespace) -> int:
    rec = soak(args.minutes, args.swap_s, args.sample_s, args.batch, args.trim_mb, args.floor_s, args.cycles_per_s)
    print(f"soak: {rec['elapsed_s']:.0f} s, {rec['cycles']} cycles ({rec['cycles_per_s']:.0f} cycles/s), "
          f"{rec['swaps']} swaps, lost {rec['lost']}, rejected {rec['rejected']}, failures {len(rec['failures'])}")
    print(f"{'process':<24}{'RSS MB start':>13}{'end':>8}{'heap floor MB/h':>16}{'+-':>7}{'heap max':>9}"
          f"{'bound':>8}{'shared MB max':>14}{'of mapped':>10}{'fds':>6}{'end':>5}")
    for name, p in rec["processes"].items():
        bound = "-" if p["heap_bound_mb"] is None else f"{p['heap_bound_mb']:.0f}"
        print(f"{name:<24}{p['rss_mb_start']:>13.1f}{p['rss_mb_end']:>8.1f}{p['anon_floor_mb_per_h']:>16.1f}"
              f"{p['anon_floor_mb_per_h_stderr']:>7.1f}{p['anon_mb_max']:>9.1f}{bound:>8}{p['shmem_mb_max']:>14.1f}"
              f"{p['shm_mapped_mb']:>10.1f}{p['fds_start']:>6}{p['fds_end']:>5}")
    if args.json:
        bench_records.write(args.json, args, [rec])
    return 0 if rec["lost"] == 0 and not rec["failures"] else 1
