"""A declarative grid of threshold sweeps (`carav study`): the points of a study file (study_file.py) and their seeds,
and their execution on Dask distributed (tasks drawn on the workers, results identical to `carav sweep`'s)."""
from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream.detect.stats import clopper_pearson
from carav_stream.montecarlo.curves import reference_eta
from carav_stream.montecarlo.engine import QDraw, assemble, batch_plan, batches_independent, draw_batch
from carav_stream.montecarlo.sources import source_from_spec
from carav_stream.montecarlo.study_file import Study

STORE_VERSION = 1


# -- tasks (run on the Dask workers) ------------------------------------------------------------------------------
_SOURCES: dict[str, Any] = {}


def _source(spec_json: str):
    """A worker builds each scene's source once (scene loading, echo templates) and keeps it."""
    if spec_json not in _SOURCES:
        _SOURCES[spec_json] = source_from_spec(json.loads(spec_json))
    return _SOURCES[spec_json]


def run_batches(spec_json: str, detector: str, attack: str, rarms: float, used: str, seed: int,
                batches: list[tuple[int, list[int]]]) -> tuple[np.ndarray, np.ndarray]:
    """One task: the batches (size, spawn key) of one point, in order, from a fresh job of its source."""
    source = _source(spec_json)
    if hasattr(source, "begin_job"):
        source.begin_job(attack, rarms)
    parts = [draw_batch(source, attack, rarms, size, np.random.SeedSequence(seed, spawn_key=tuple(key)), used,
                        detector) for size, key in batches]
    return np.concatenate([q for q, _ in parts]), np.concatenate([b for _, b in parts])


# -- the run ------------------------------------------------------------------------------------------------------
@dataclass
class Point:
    group: int
    job: int
    attack: str
    rarms: float
    used: str
    sizes: list[int]
    independent: bool
    key: str                         # file name of its stored draws
    per_task: int = 1                # batches per task (independent points)

    def tasks(self) -> list[list[tuple[int, list[int]]]]:
        batches = [(size, [self.job, b]) for b, size in enumerate(self.sizes)]
        if not self.independent:
            return [batches]
        return [batches[i: i + self.per_task] for i in range(0, len(batches), self.per_task)]


def plan(study: Study) -> list[Point]:
    """Every point of the study with its batches and the name its draws are stored under."""
    points = []
    for g, group in enumerate(study.groups):
        source = _source(json.dumps(group.spec, sort_keys=True))
        for j, (attack, r) in enumerate(study.jobs):
            used, sizes = batch_plan(source, attack, study.trials, method=study.method, detector=group.detector)
            ident = json.dumps({"v": STORE_VERSION, "spec": group.spec, "detector": group.detector, "attack": attack,
                                "rarms": r, "job": j, "trials": study.trials, "seed": study.seed, "used": used},
                               sort_keys=True)
            points.append(Point(g, j, attack, r, used, sizes, batches_independent(source, used),
                                hashlib.sha256(ident.encode()).hexdigest()[:24],
                                max(1, study.task_cycles // max(sizes))))
    return points


def _store(folder: Path, point: Point, q: np.ndarray, by_d1: np.ndarray) -> None:
    tmp = folder / f".{point.key}.tmp.npz"
    np.savez(tmp, q=q, by_d1=by_d1)
    os.replace(tmp, folder / f"{point.key}.npz")     # a point is stored whole or not at all


def _stored(folder: Path, point: Point, trials: int) -> tuple[np.ndarray, np.ndarray] | None:
    f = folder / f"{point.key}.npz"
    if not f.is_file():
        return None
    try:
        with np.load(f, allow_pickle=False) as z:
            q, by_d1 = z["q"], z["by_d1"]
    except (OSError, ValueError, KeyError):
        return None                                   # unreadable: computed again
    return (q, by_d1) if q.shape == (trials,) and by_d1.shape == (trials,) else None


def local_cluster(workers: int):
    """The embedded Dask cluster of `carav study`: `workers` single-threaded worker processes on loopback, speaking
    TLS with a key and certificate made for this cluster alone (Dask's Security.temporary): another local process
    can neither join it nor submit tasks to it. Returns (cluster, security), the security for the client."""
    from dask.distributed import LocalCluster  # the study extra: imported when used
    from distributed.security import Security

    security = Security.temporary()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           host="127.0.0.1", protocol="tls://", security=security)
    return cluster, security


def execute(study: Study, out: Path, *, workers: int | None = None, scheduler: str | None = None,
            progress: Callable[[int, int], None] | None = None, log: Callable[[str], None] | None = None
            ) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]:
    """Draws of every point: read back from out/points when stored, computed on Dask otherwise. `progress(done,
    total)` hears of the cycles drawn as tasks finish; `log` gets one line on what is read back and what is drawn."""
    store = out / "points"
    store.mkdir(parents=True, exist_ok=True)
    points = plan(study)
    draws = {}
    todo = []
    for pt in points:
        got = _stored(store, pt, study.trials)
        if got is None:
            todo.append(pt)
        else:
            draws[(pt.group, pt.job)] = got
    if log is not None:
        log(f"{len(points)} points, {len(points) - len(todo)} read back from {store}, {len(todo)} to draw")
    if not todo:
        return draws
    from dask.distributed import Client, as_completed  # the study extra: imported when used
    cluster, security = (None, None) if scheduler is not None else local_cluster(workers or os.cpu_count() or 1)
    client = Client(cluster if cluster is not None else scheduler, security=security, timeout="30s")
    try:
        futures, owner, parts = [], {}, {}
        for pt in todo:
            spec = json.dumps(study.groups[pt.group].spec, sort_keys=True)
            for t, batches in enumerate(pt.tasks()):
                fut = client.submit(run_batches, spec, study.groups[pt.group].detector, pt.attack, pt.rarms, pt.used,
                                    study.seed, batches, pure=False, key=f"carav-{pt.key}-{t}")
                futures.append(fut)
                owner[fut.key] = (pt, t, sum(size for size, _ in batches))
        total, done = sum(v[2] for v in owner.values()), 0
        for fut in as_completed(futures):
            pt, t, size = owner[fut.key]
            parts.setdefault(pt.key, {})[t] = fut.result()
            fut.release()
            done += size
            if progress is not None:
                progress(done, total)
            if len(parts[pt.key]) == len(pt.tasks()):
                chunks = [parts[pt.key][i] for i in range(len(pt.tasks()))]
                q = np.concatenate([c[0] for c in chunks])
                by_d1 = np.concatenate([c[1] for c in chunks])
                _store(store, pt, q, by_d1)
                draws[(pt.group, pt.job)] = (q, by_d1)
                del parts[pt.key]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return draws




def results(study: Study, draws: dict) -> tuple[list[dict], list[dict]]:
    """(JSON result per group, as `carav sweep --json` writes it; CSV rows, one per point)."""
    groups, rows = [], []
    for g, group in enumerate(study.groups):
        source = _source(json.dumps(group.spec, sort_keys=True))
        qd = {}
        for j, (attack, r) in enumerate(study.jobs):
            used, _ = batch_plan(source, attack, study.trials, method=study.method, detector=group.detector)
            qd[(attack, r)] = QDraw(*draws[(g, j)], used)
        res = assemble(source, qd, pairs=study.pairs, n_trials=study.trials, eta=study.eta, seed=study.seed,
                       target_pf=study.target_pf, design_rarms=study.design_rarms, detector=group.detector)
        groups.append({"scene": group.label, "detector": group.detector, "spec": group.spec, "result": res})
        ref = study.reference_eta or reference_eta(group.detector)
        for (attack, r), d in qd.items():
            k = int(np.sum(d.q >= ref)) if attack == "none" else int(np.sum(d.q < ref))
            lo, hi = clopper_pearson(k, study.trials, 0.95)
            rows.append({"scene": group.label, "detector": group.detector, "attack": attack, "rarms": r,
                         "trials": study.trials, "method": d.method, "reference_eta": ref,
                         "measure": "false_alarms" if attack == "none" else "misses", "count": k,
                         "rate": k / study.trials, "rate_lo": float(lo), "rate_hi": float(hi),
                         "q_median": float(np.median(d.q))})
    return groups, rows


