"""`python3 dev.py bench study`: `carav study` on 1 and 2 local Dask workers, and the scheduler's cost per task.

The same study runs on an embedded LocalCluster of 1 and of 2 single-threaded worker processes, modes interleaved
run by run; the clock runs from the first task submitted to the last result gathered (cluster start-up apart,
measured on its own), so the ratio is the scaling of the work itself. The study: Table I at the paper's 0 dB,
every sample simulated (the path that needs a cluster), 12 points of --trials cycles (the attack-free one, the
random attack at 11 RARMS): 12 tasks of a few seconds each. Scaling efficiency = cycles/s with 2 workers over 1.
The scheduler's overhead: --tasks empty tasks on one worker, wall time per task.

Rare events: --rare-cycles attack-free cycles of Table I in the paper's model (the exact sufficient-statistic
path) on 2 local workers, counted at the threshold whose closed-form PF per cycle is 1e-6 (D0 part exact, stats.
cfar_eta_closed_form; D1 part from stats.pf_pm_closed_form), drawn as `carav study` draws a point (seed 1, job 0,
its batches grouped into tasks of 2e6 cycles), each task returning its count: the brute-force PF with its 95 %
Clopper-Pearson interval beside the closed form.
"""
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import records as bench_records
from carav_stream.console.options import count, output_file
from carav_stream.detect.stats import cfar_eta_closed_form, clopper_pearson, pf_pm_closed_form
from carav_stream.montecarlo.engine import batch_plan
from carav_stream.montecarlo.sources import source_from_spec
from carav_stream.montecarlo.study import plan, run_batches
from carav_stream.montecarlo.study_file import load_study

STUDY = """
description = "dev.py bench study: Table I, every sample, the random attack"
seed = 1
trials = {trials}
eta = "0.5:3:0.01"
method = "samples"
[[scenes]]
preset = "table1"
snr_db = 0.0
[[attacks]]
kind = "random"
rarms = [0.25, 0.5, 0.75, 0.9, 1.0, 1.05, 1.1, 1.2, 1.5, 2.0, 3.0]
"""
TARGET = 1.8


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--repeats", type=count(1), default=3, help="runs per worker count (median reported)")
    parser.add_argument("--trials", type=count(1), default=2000, help="cycles per point")
    parser.add_argument("--tasks", type=count(1), default=500, help="empty tasks for the overhead measurement")
    parser.add_argument("--rare-cycles", type=count(0), default=100_000_000,
                        help="attack-free cycles of the brute-force PF check at 1e-6 (0: skip)")


def _noop(i: int) -> int:
    return i


def _timed_run(study, workers: int) -> tuple[float, float]:
    """(seconds from first submission to last result, cluster start-up seconds) of the study's points."""
    from dask.distributed import Client, LocalCluster, wait

    t0 = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        client.wait_for_workers(workers)
        started = time.perf_counter() - t0
        import json
        t1 = time.perf_counter()
        futures = [client.submit(run_batches, json.dumps(study.groups[p.group].spec, sort_keys=True),
                                 study.groups[p.group].detector, p.attack, p.rarms, p.used, study.seed, batches,
                                 pure=False) for p in plan(study) for batches in p.tasks()]
        wait(futures)
        return time.perf_counter() - t1, started


def count_alarms(spec_json: str, used: str, seed: int, batches: list, eta: float) -> int:
    """A task of the rare-event check: alarms (Q >= eta) among its batches, only the count leaves the worker."""
    q, _ = run_batches(spec_json, "carav", "none", 0.0, used, seed, batches)
    return int(np.count_nonzero(q >= eta))


def _rare(cycles: int) -> dict:
    import json

    from dask.distributed import Client, LocalCluster, as_completed

    spec = {"model": "paper", "preset": "table1"}
    source = source_from_spec(spec)
    cf = source.closed_form("none")
    eta = cfar_eta_closed_form(1e-6, n_chirps=cf["n_chirps"], dof=cf["dof"])
    pf = float(pf_pm_closed_form(eta, **cf)["p_alarm"])
    used, sizes = batch_plan(source, "none", cycles, method="energy")
    batches = [(size, [0, b]) for b, size in enumerate(sizes)]
    per = max(1, 2_000_000 // sizes[0])
    t0 = time.perf_counter()
    alarms = 0
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        futures = [client.submit(count_alarms, json.dumps(spec, sort_keys=True), used, 1, batches[i: i + per], eta,
                                 pure=False) for i in range(0, len(batches), per)]
        for fut in as_completed(futures):
            alarms += fut.result()
    lo, hi = clopper_pearson(alarms, cycles, 0.95)
    return {"rare_cycles": cycles, "rare_eta": eta, "rare_pf_closed_form": pf, "rare_alarms": alarms,
            "rare_pf": alarms / cycles, "rare_pf_lo": float(lo), "rare_pf_hi": float(hi),
            "rare_agrees": bool(lo <= pf <= hi), "rare_seconds": time.perf_counter() - t0}


def _overhead(n: int) -> float:
    from dask.distributed import Client, LocalCluster, wait
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster, Client(cluster) as client:
        wait([client.submit(_noop, i, pure=False) for i in range(20)])      # warm
        t0 = time.perf_counter()
        wait([client.submit(_noop, i, pure=False) for i in range(n)])
        return (time.perf_counter() - t0) / n


def run(args: argparse.Namespace) -> int:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench.toml"
        path.write_text(STUDY.format(trials=args.trials))
        study = load_study(path)
    cycles = args.trials * len(study.jobs)
    runs: dict[int, list[float]] = {1: [], 2: []}
    startup: dict[int, list[float]] = {1: [], 2: []}
    for _ in range(args.repeats):           # worker counts interleaved: the ratio compares like with like
        for workers in (1, 2):
            seconds, started = _timed_run(study, workers)
            runs[workers].append(cycles / seconds)
            startup[workers].append(started)
            print(f"{workers} worker(s): {cycles / seconds:8.1f} cycles/s  ({seconds:.1f} s, cluster start "
                  f"{started:.1f} s)", flush=True)
    ratios = [b / a for a, b in zip(runs[1], runs[2])]
    per_task = statistics.median(_overhead(args.tasks) for _ in range(args.repeats))
    record = {"study": "table1, 0 dB, every sample, random attack at 11 RARMS + attack-free", "points": len(study.jobs),
              "tasks": len(study.jobs), "trials": args.trials, "cycles": cycles, "repeats": args.repeats,
              "cores": os.cpu_count(),
              "cycles_per_s": {str(w): statistics.median(r) for w, r in runs.items()},
              "runs_cycles_per_s": {str(w): r for w, r in runs.items()},
              "cluster_start_s": {str(w): statistics.median(s) for w, s in startup.items()},
              "speedup_2_over_1": statistics.median(ratios), "runs_speedup": ratios,
              "overhead_s_per_task": per_task, "overhead_tasks": args.tasks}
    print(f"2 workers over 1: x{record['speedup_2_over_1']:.2f} (median of {args.repeats}; target >= {TARGET:g}); "
          f"scheduler overhead {per_task * 1e3:.2f} ms per task")
    if args.rare_cycles:
        record.update(_rare(args.rare_cycles))
        print(f"rare events: {record['rare_alarms']} alarms in {args.rare_cycles} cycles at eta "
              f"{record['rare_eta']:.4f}: PF {record['rare_pf']:.3g} [{record['rare_pf_lo']:.3g}, "
              f"{record['rare_pf_hi']:.3g}] against the closed form {record['rare_pf_closed_form']:.3g} "
              f"({record['rare_seconds']:.0f} s)")
    if args.json:
        bench_records.write(args.json, args, [record])
    return 0
