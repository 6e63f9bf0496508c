"""`carav study STUDY.toml`: a declarative grid of threshold sweeps, run on Dask distributed, identical results.

    carav study STUDY.toml [--workers N | --scheduler tcp://HOST:PORT] [--out DIR] [--plot]

A study file (examples in studies/ at the repository's top):

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
serialisers (task functions by reference): run it on a cluster you trust, or with Dask's TLS security.

Results, in --out DIR (default study-<name>/): points/<hash>.npz, one file per finished point (its Q draws;
an interrupted study run again reads them and computes only the missing points), study.csv (one row per point:
group, attack, RARMS, trials, method, and at the reference threshold (eta 1.5; 1 for the opt-in detectors, whose
statistic is in units of its PF = 1e-6 threshold) the misses or false alarms with their Clopper-Pearson interval),
study.json (every group's result as `carav sweep --json` writes it), and with --plot one figure per group.
"""
from __future__ import annotations

import argparse
import csv
import difflib
import hashlib
import json
import math
import os
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream.cli.common import CommandError, Exit
from carav_stream.cli.options import count

TOP_KEYS = {"description", "seed", "trials", "eta", "detectors", "method", "target_pf", "design_rarms", "scenes",
            "attacks", "reference_eta", "task_cycles"}
SCENE_KEYS = {"label", "preset", "file", "model", "nr", "ns", "iq", "snr_db", "ideal_adc", "activation"}
ATTACK_KEYS = {"kind", "rarms", "params"}
STORE_VERSION = 1


@dataclass
class Group:
    label: str
    detector: str
    spec: dict                      # montecarlo source description (sweep_command.source_from_spec)


@dataclass
class Study:
    path: Path
    description: str
    seed: int
    trials: int
    eta: np.ndarray
    eta_text: str
    reference_eta: float | None
    task_cycles: int
    method: str
    target_pf: float
    design_rarms: float
    groups: list[Group]
    pairs: list[tuple[str, float]]  # attacked points in order, after the attack-free one
    problems: list[str] = field(default_factory=list)

    @property
    def jobs(self) -> list[tuple[str, float]]:
        return [("none", 0.0), *self.pairs]


# -- the study file ------------------------------------------------------------------------------------------------
def _unknown(p: list[str], where: str, table: dict, allowed: set[str]) -> None:
    for key in table:
        if key not in allowed:
            near = difflib.get_close_matches(key, sorted(allowed), n=1)
            p.append(f"{where}{key}: unknown key" + (f" (did you mean {near[0]!r}?)" if near else ""))


def _number(p: list[str], where: str, value: Any, *, integer: bool = False, low: float | None = None,
            strict: bool = False) -> Any:
    kind = int if integer else (int, float)
    if isinstance(value, bool) or not isinstance(value, kind) or (not integer and not math.isfinite(value)):
        p.append(f"{where}: expected {'a whole number' if integer else 'a finite number'}, got {value!r}")
        return None
    if low is not None and (value <= low if strict else value < low):
        p.append(f"{where}: must be {'>' if strict else '>='} {low:g}, got {value!r}")
        return None
    return value


def load_study(path: Path) -> Study:
    """Read and check a study file; CommandError (Exit.INVALID) listing every problem, each located."""
    from carav_stream.montecarlo.detectors import DETECTORS
    from carav_stream.montecarlo.engine import eta_grid
    from carav_stream.radar.attackers import KINDS
    from carav_stream.radar.scene_loader import preset_names

    name = path.name
    if path.is_dir():
        raise CommandError(f"{path}: is a folder, not a study file", Exit.INVALID)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise CommandError(f"{path}: study file not found", Exit.INVALID) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError, OSError) as exc:
        raise CommandError(f"{name}: not a readable TOML study file: {exc}", Exit.INVALID) from None
    p: list[str] = []
    _unknown(p, f"{name}: ", data, TOP_KEYS)
    seed = data.get("seed")
    if seed is None:
        p.append(f"{name}: seed: required (every draw of a study follows from its seed)")
    else:
        seed = _number(p, f"{name}: seed", seed, integer=True, low=0)
    trials = _number(p, f"{name}: trials", data.get("trials", 1000), integer=True, low=1)
    eta_text = data.get("eta", "0.5:2.5:0.01")
    eta = None
    try:
        eta = eta_grid(str(eta_text))
    except ValueError as exc:
        p.append(f"{name}: eta: {str(exc).removeprefix('eta: ')}")
    method = data.get("method", "auto")
    if method not in ("auto", "energy", "samples"):
        p.append(f"{name}: method: expected auto, energy or samples, got {method!r}")
    target_pf = _number(p, f"{name}: target_pf", data.get("target_pf", 0.01), low=0.0, strict=True)
    design_rarms = _number(p, f"{name}: design_rarms", data.get("design_rarms", 3.0), low=0.0)
    reference = data.get("reference_eta")
    if reference is not None:
        reference = _number(p, f"{name}: reference_eta", reference, low=0.0, strict=True)
    task_cycles = _number(p, f"{name}: task_cycles", data.get("task_cycles", 2_000_000), integer=True, low=1)
    detectors = data.get("detectors", ["carav"])
    if not isinstance(detectors, list) or not detectors:
        p.append(f"{name}: detectors: expected a list of {', '.join(DETECTORS)}, got {detectors!r}")
        detectors = []
    for i, d in enumerate(detectors):
        if d not in DETECTORS:
            p.append(f"{name}: detectors[{i}]: unknown detector {d!r}; expected {', '.join(DETECTORS)}")

    pairs: list[tuple[str, float]] = []
    attack_params: dict[str, dict] = {}
    for where, a in _tables(p, name, data, "attacks", ATTACK_KEYS):
        kind = a.get("kind")
        if kind not in KINDS or kind == "none":
            p.append(f"{where}.kind: expected one of {', '.join(k for k in KINDS if k != 'none')}, got {kind!r}")
            continue
        if kind in attack_params:
            p.append(f"{where}.kind: {kind!r} appears twice; put every RARMS of one model in one table")
            continue
        params = a.get("params", {})
        if not isinstance(params, dict):
            p.append(f"{where}.params: expected a table, got {params!r}")
            params = {}
        attack_params[kind] = params
        rarms = a.get("rarms")
        if not isinstance(rarms, list) or not rarms:
            p.append(f"{where}.rarms: expected a list of numbers, got {rarms!r}")
            continue
        for k, r in enumerate(rarms):
            if _number(p, f"{where}.rarms[{k}]", r, low=0.0) is not None:
                pairs.append((kind, float(r)))

    groups: list[Group] = []
    labels: set[str] = set()
    for where, sc in _tables(p, name, data, "scenes", SCENE_KEYS):
        spec = _scene_spec(p, where, sc, path.resolve().parent, preset_names())
        if spec is None:
            continue
        spec["attack_params"] = attack_params
        label = str(sc.get("label") or sc.get("preset") or Path(sc.get("file", "scene")).stem)
        if label in labels:
            p.append(f"{where}.label: {label!r} names another scene too; give each a label of its own")
        labels.add(label)
        source = _checked_source(p, where, spec, [k for k, _ in pairs])
        for d in detectors:
            if d != "carav" and spec.get("model") == "paper":
                p.append(f"{where}.model: the paper model gives RMS levels only; detector {d!r} needs the radar "
                         "model")
            groups.append(Group(label, d, spec))
        if source is not None and method == "energy":
            for kind in ("none", *dict.fromkeys(k for k, _ in pairs)):
                if not source.energy_exact(kind):
                    p.append(f"{name}: method: no exact energy path for attack {kind!r} on {label}; use auto or "
                             "samples")
    if p:
        raise CommandError(f"{path} is not valid:\n" + "\n".join(f"  {x}" for x in p), Exit.INVALID)
    return Study(path, str(data.get("description", "")), seed, trials, eta, str(eta_text), reference, task_cycles,
                 method, target_pf, design_rarms, groups, pairs)


def _tables(p: list[str], name: str, data: dict, key: str, allowed: set[str]) -> list[tuple[str, dict]]:
    """The [[key]] tables of a study file, each with where it is (`s.toml: scenes[1]`), its unknown keys reported."""
    tables = data.get(key)
    if not isinstance(tables, list) or not tables:
        p.append(f"{name}: {key}: at least one [[{key}]] table is required")
        return []
    out = []
    for i, table in enumerate(tables):
        where = f"{name}: {key}[{i}]"
        if not isinstance(table, dict):
            p.append(f"{where}: expected a table, got {table!r}")
            continue
        _unknown(p, f"{where}.", table, allowed)
        out.append((where, table))
    return out


def _scene_spec(p: list[str], where: str, sc: dict, folder: Path, presets: list[str]) -> dict | None:
    if ("preset" in sc) == ("file" in sc):
        p.append(f"{where}: give a preset or a file (one of them)")
        return None
    spec: dict[str, Any] = {"model": sc.get("model", "radar")}
    if spec["model"] not in ("radar", "paper"):
        p.append(f"{where}.model: expected radar or paper, got {spec['model']!r}")
        return None
    if "preset" in sc:
        if sc["preset"] not in presets:
            p.append(f"{where}.preset: no such preset {sc['preset']!r} (presets: {', '.join(presets)})")
            return None
        spec["preset"] = sc["preset"]
    else:
        if spec["model"] == "paper":
            p.append(f"{where}.file: the paper model takes a preset (table1 or awr1642)")
            return None
        f = folder / str(sc["file"])
        if not f.is_file():
            p.append(f"{where}.file: {f} not found")
            return None
        spec["scene"] = str(f)
    for key in ("nr", "ns"):
        if key in sc:
            spec[key] = _number(p, f"{where}.{key}", sc[key], integer=True, low=2)
    if "snr_db" in sc:
        spec["snr_db"] = _number(p, f"{where}.snr_db", sc["snr_db"])
    for key in ("iq", "ideal_adc"):
        if key in sc and not isinstance(sc[key], bool):
            p.append(f"{where}.{key}: expected true or false, got {sc[key]!r}")
        spec[key] = bool(sc.get(key, False))
    spec["activation"] = sc.get("activation", "seeded")
    if spec["activation"] not in ("seeded", "lfsr", "secure"):
        p.append(f"{where}.activation: expected seeded, lfsr or secure, got {spec['activation']!r}")
    return spec


def _checked_source(p: list[str], where: str, spec: dict, kinds: list[str]):
    """The source of a scene entry, built once here so that a bad scene or attacker parameter is found now."""
    from carav_stream.studies.sweep_command import source_from_spec
    try:
        source = source_from_spec(spec)
        for kind in dict.fromkeys(kinds):
            if hasattr(source, "make_attacker"):
                source.make_attacker(kind, 1.0)
            elif kind not in source.attacks:
                p.append(f"{where}.model: the paper model has attacks {', '.join(source.attacks)}, not {kind!r}")
        return source
    except (ValueError, TypeError) as exc:
        p.append(f"{where}: {str(exc).splitlines()[0]}")
        return None


# -- tasks (run on the Dask workers) ------------------------------------------------------------------------------
_SOURCES: dict[str, Any] = {}


def _source(spec_json: str):
    """A worker builds each scene's source once (scene loading, echo templates) and keeps it."""
    if spec_json not in _SOURCES:
        from carav_stream.studies.sweep_command import source_from_spec
        _SOURCES[spec_json] = source_from_spec(json.loads(spec_json))
    return _SOURCES[spec_json]


def run_batches(spec_json: str, detector: str, attack: str, rarms: float, used: str, seed: int,
                batches: list[tuple[int, list[int]]]) -> tuple[np.ndarray, np.ndarray]:
    """One task: the batches (size, spawn key) of one point, in order, from a fresh job of its source."""
    from carav_stream.montecarlo.engine import draw_batch
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
    from carav_stream.montecarlo.engine import batch_plan, batches_independent
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


def execute(study: Study, out: Path, *, workers: int | None = None, scheduler: str | None = None,
            progress: bool = False, log=print) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]:
    """Draws of every point: read back from out/points when stored, computed on Dask otherwise."""
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
    log(f"carav study: {len(points)} points, {len(points) - len(todo)} read back from {store}, {len(todo)} to draw")
    if not todo:
        return draws
    from dask.distributed import Client, LocalCluster, as_completed

    from carav_stream.studies.sweep_command import ProgressBar
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                               dashboard_address=None, host="127.0.0.1")
    client = Client(cluster if cluster is not None else scheduler, timeout="30s")
    try:
        futures, owner, parts = [], {}, {}
        for pt in todo:
            spec = json.dumps(study.groups[pt.group].spec, sort_keys=True)
            for t, batches in enumerate(pt.tasks()):
                fut = client.submit(run_batches, spec, study.groups[pt.group].detector, pt.attack, pt.rarms, pt.used,
                                    study.seed, batches, pure=False, key=f"carav-{pt.key}-{t}")
                futures.append(fut)
                owner[fut.key] = (pt, t, sum(size for size, _ in batches))
        bar = ProgressBar(f"study {study.path.stem}") if progress else None
        total, done = sum(v[2] for v in owner.values()), 0
        for fut in as_completed(futures):
            pt, t, size = owner[fut.key]
            parts.setdefault(pt.key, {})[t] = fut.result()
            fut.release()
            done += size
            if bar:
                bar(done, total)
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


REFERENCE_ETA = {"carav": 1.5}        # opt-in detectors: 1.0, their PF = 1e-6 threshold


def results(study: Study, draws: dict) -> tuple[list[dict], list[dict]]:
    """(JSON result per group, as `carav sweep --json` writes it; CSV rows, one per point)."""
    from carav_stream.detect.stats import clopper_pearson
    from carav_stream.montecarlo.engine import QDraw, assemble, batch_plan
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
        ref = study.reference_eta or REFERENCE_ETA.get(group.detector, 1.0)
        for (attack, r), d in qd.items():
            k = int(np.sum(d.q >= ref)) if attack == "none" else int(np.sum(d.q < ref))
            lo, hi = clopper_pearson(k, study.trials, 0.95)
            rows.append({"scene": group.label, "detector": group.detector, "attack": attack, "rarms": r,
                         "trials": study.trials, "method": d.method, "reference_eta": ref,
                         "measure": "false_alarms" if attack == "none" else "misses", "count": k,
                         "rate": k / study.trials, "rate_lo": float(lo), "rate_hi": float(hi),
                         "q_median": float(np.median(d.q))})
    return groups, rows


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
    study = load_study(args.study)
    out = args.out or Path(f"study-{args.study.stem}")
    if out.exists() and not out.is_dir():
        raise CommandError(f"--out {out}: is a file, not a folder")
    if not out.exists() and not out.resolve().parent.is_dir():
        raise CommandError(f"--out {out}: its parent folder does not exist")
    if args.scheduler is not None and not args.scheduler.startswith(("tcp://", "tls://")):
        raise CommandError(f"--scheduler: expected tcp://HOST:PORT or tls://HOST:PORT, got {args.scheduler!r}")
    t0 = time.perf_counter()
    draws = execute(study, out, workers=args.workers, scheduler=args.scheduler,
                    progress=not args.quiet and sys.stderr.isatty(), log=lambda text: print(text, file=sys.stderr))
    groups, rows = results(study, draws)
    with open(out / "study.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    doc = {"study": str(args.study), "description": study.description, "seed": study.seed, "trials": study.trials,
           "eta": study.eta_text, "groups": groups}
    (out / "study.json").write_text(json.dumps(doc, indent=1))
    if args.plot:
        from carav_stream.studies.sweep_command import plot_curves
        for grp in groups:
            plot_curves(grp["result"], str(out / f"{grp['scene']}_{grp['detector']}.png"),
                        title=f"{grp['scene']} ({study.path.stem})")
    cycles = len(rows) * study.trials
    print(f"{len(rows)} points, {cycles} cycles, {time.perf_counter() - t0:.1f} s: {out / 'study.csv'}, "
          f"{out / 'study.json'}")
    for r in rows:
        print(f"  {r['scene']:<10} {r['detector']:<10} {r['attack']:<8} RARMS {r['rarms']:<5g} "
              f"{r['measure']} {r['count']}/{r['trials']} at eta {r['reference_eta']:g} "
              f"[{r['rate_lo']:.3g}, {r['rate_hi']:.3g}]")
    return 0


if __name__ == "__main__":
    from carav_stream.cli import run_as_command
    raise SystemExit(run_as_command("carav_stream.studies.study"))
