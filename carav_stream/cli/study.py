"""`carav study STUDY.toml`: a declarative grid of threshold sweeps, run on Dask distributed, identical results.

    carav study STUDY.toml [--workers N | --scheduler tcp://HOST:PORT] [--out DIR] [--plot]

A study file (examples in examples/ at the repository's top):
    description = "..."
    seed = 2026                     # required: every draw of the study follows from it
    trials = 1000                   # cycles per point
    eta = "0.5:3:0.01"              # threshold grid of the curves
    detectors = ["carav"]           # carav, spectral, integrated, coherent (carav sweep --detector)
    method = "auto"                 # auto | energy | samples, as carav sweep --method
    target_pf = 0.01                # threshold design (carav sweep --cfar-pf), design_rarms = 3.0
    reference_eta = 1.5             # where study.csv counts misses and false alarms (opt-in detectors: 1.0)
    task_cycles = 2000000           # sufficient-statistic batches grouped into tasks of about this many cycles
    [[scenes]]                      # one or more: preset or file (relative to the study file), and the options
    preset = "table1"               #   of carav sweep: model ("radar" | "paper"), nr, ns, iq, snr_db, ideal_adc,
    label = "table1"                #   activation ("seeded" | "lfsr" | "secure"); label names it in the results
    [[attacks]]                     # one or more: an attacker model, its RARMS list, its parameters
    kind = "random"
    rarms = [0.5, 1, 2, 3, 5]
    params = {}

The whole file is checked before anything runs; every problem is reported at once, located
(`fig35.toml: scenes[1].preset: no such preset 'x'`).

Points and seeds. A group is a scene and a detector; its points are the attack-free cycles (PF) and every
(attack, RARMS) in file order: point j of a group draws from SeedSequence(seed, spawn_key=(j, b)) for its batches b,
cut as `carav sweep` cuts them (montecarlo.engine.batch_plan), so a group's curves equal `carav sweep` with the same
seed, scene, attacks and RARMS, bit for bit, whatever runs them. On the sufficient-statistic path every batch is a
task; on full samples a point is one task (its attacker and activation stream keep state from batch to batch).

Execution. Dask distributed: with no option an embedded local cluster of one single-threaded worker process per
core (`--workers N` sets how many); `--scheduler tcp://HOST:PORT` sends the tasks to an existing cluster whose
workers import this package (the same version). A worker that dies loses nothing: Dask runs its tasks again
elsewhere, and the results are the same numbers. Dask's own protocol moves task arguments and results with its
serialisers (task functions by reference): the embedded cluster listens on loopback with TLS and a key of its own
(montecarlo.study.local_cluster); an existing cluster must be one you trust, or use tls:// with Dask's TLS config.

Results, in --out DIR (default study-<name>/): points/<hash>.npz, one file per finished point (its Q draws;
an interrupted study run again reads them and computes only the missing points), study.csv (one row per point:
group, attack, RARMS, trials, method, and at the reference threshold (eta 1.5; 1 for the opt-in detectors, whose
statistic is in units of its PF = 1e-6 threshold) the misses or false alarms with their Clopper-Pearson interval),
study.json (every group's result as `carav sweep --json` writes it), and with --plot one figure per group.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import count
from carav_stream.console.progress import ProgressBar
from carav_stream.montecarlo.curves import plot_curves
from carav_stream.montecarlo.study import execute, results
from carav_stream.montecarlo.study_file import StudyError, load_study


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("study", type=Path, help="the study file (TOML)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=count(1), default=None,
                       help="worker processes of the embedded local cluster (default: one per core)")
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="an existing Dask scheduler")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="results folder (default: study-<name>/); finished points in it are not drawn again")
    parser.add_argument("--plot", action="store_true", help="one PF/PM figure per group into DIR")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    try:
        study = load_study(args.study)
    except StudyError as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    out = args.out or Path(f"study-{args.study.stem}")
    if out.exists() and not out.is_dir():
        raise CommandError(f"--out {out}: is a file, not a folder")
    if not out.exists() and not out.resolve().parent.is_dir():
        raise CommandError(f"--out {out}: its parent folder does not exist")
    if args.scheduler is not None and not args.scheduler.startswith(("tcp://", "tls://")):
        raise CommandError(f"--scheduler: expected tcp://HOST:PORT or tls://HOST:PORT, got {args.scheduler!r}")
    t0 = time.perf_counter()
    bar = ProgressBar(f"study {study.path.stem}") if ProgressBar.wanted(args.quiet) else None
    draws = execute(study, out, workers=args.workers, scheduler=args.scheduler, progress=bar,
                    log=lambda text: print(f"carav study: {text}", file=sys.stderr))
    groups, rows = results(study, draws)
    with open(out / "study.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    doc = {"study": str(args.study), "description": study.description, "seed": study.seed, "trials": study.trials,
           "eta": study.eta_text, "groups": groups}
    (out / "study.json").write_text(json.dumps(doc, indent=1))
    plots = [out / f"{grp['scene']}_{grp['detector']}.png" for grp in groups] if args.plot else []
    for grp, png in zip(groups, plots):
        plot_curves(grp["result"], str(png), title=f"{grp['scene']} ({study.path.stem})")
    cycles = len(rows) * study.trials
    print(f"{len(rows)} points, {cycles} cycles, {time.perf_counter() - t0:.1f} s: {out / 'study.csv'}, "
          f"{out / 'study.json'}")
    for png in plots:
        print(f"plot: {png} (PF and PM against eta on a log axis, the ROC beneath)")
    for r in rows:
        print(f"  {r['scene']:<10} {r['detector']:<10} {r['attack']:<8} RARMS {r['rarms']:<5g} "
              f"{r['measure']} {r['count']}/{r['trials']} at eta {r['reference_eta']:g} "
              f"[{r['rate_lo']:.3g}, {r['rate_hi']:.3g}]")
    return 0
