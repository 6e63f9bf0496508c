"""A declarative grid of threshold sweeps (`carav study`): the study file, its points and their seeds, and their
execution on Dask distributed (tasks drawn on the workers, results identical to `carav sweep`'s)."""
from __future__ import annotations

import hashlib
import json
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.progress import ProgressBar
from carav_stream.core.params import REQUIRED, Param, problems, resolved
from carav_stream.detect.stats import clopper_pearson
from carav_stream.montecarlo.curves import reference_eta
from carav_stream.montecarlo.detectors import DETECTORS
from carav_stream.montecarlo.engine import QDraw, assemble, batch_plan, batches_independent, draw_batch, eta_grid
from carav_stream.montecarlo.sources import source_from_spec
from carav_stream.radar.attackers import KINDS
from carav_stream.radar.scene_loader import preset_names
from carav_stream.radar.synth import FIDELITIES

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


# -- the study file: declared and checked with core.params, as blocks, attackers and scenes are ------------------
TOP = (
    Param("description", str, "", "what the study is for"),
    Param("seed", int, REQUIRED, "every draw of a study follows from its seed", low=0),
    Param("trials", int, 1000, "cycles per point", low=1),
    Param("eta", str, "0.5:2.5:0.01", "threshold grid of the curves, START:STOP:STEP"),
    Param("detectors", list, ["carav"], "detectors of every scene: carav, spectral, integrated, coherent"),
    Param("method", str, "auto", "as carav sweep --method", choices=("auto", "energy", "samples")),
    Param("target_pf", float, 0.01, "threshold design's false-alarm target (carav sweep --cfar-pf)", low=0.0,
          strict=True),
    Param("design_rarms", float, 3.0, "RARMS the threshold design is made for", low=0.0),
    Param("reference_eta", float, None, "where study.csv counts misses and false alarms", low=0.0, strict=True,
          optional=True),
    Param("task_cycles", int, 2_000_000, "sufficient-statistic batches grouped into tasks of about this many cycles",
          low=1),
    Param("scenes", list, REQUIRED, "[[scenes]] tables: a preset or a file, and carav sweep's options"),
    Param("attacks", list, REQUIRED, "[[attacks]] tables: an attacker model, its RARMS list, its parameters"),
)
SCENE = (
    Param("label", str, None, "names the scene in the results", optional=True),
    Param("preset", str, None, "scene preset (or give a file)", optional=True),
    Param("file", str, None, "scene TOML file, relative to the study file (or give a preset)", optional=True),
    Param("model", str, "radar", "cycle model", choices=("radar", "paper")),
    Param("nr", int, None, "chirps per cycle", low=2, optional=True),
    Param("ns", int, None, "samples per chirp", low=2, optional=True),
    Param("iq", bool, False, "complex (I/Q) samples"),
    Param("snr_db", float, None, "echo SNR per sample", unit="dB", optional=True),
    Param("ideal_adc", bool, False, "no quantisation"),
    Param("activation", str, "seeded", "activation sequence", choices=("seeded", "lfsr", "secure")),
    Param("fidelity", str, "auto", "signal model of the radar chain", choices=FIDELITIES),
)
ATTACK = (
    Param("kind", str, REQUIRED, "attacker model"),
    Param("rarms", list, REQUIRED, "RARMS values, attack RMS over noise RMS"),
    Param("params", dict, {}, "the model's parameters"),
)
RARMS = Param("rarms", float, doc="attack RMS over noise RMS", low=0.0)


def _checked(p: list[str], where: str, declared, table: dict) -> tuple[dict, bool]:
    """(the table's values, defaults filled in, with a bad value left at its default; whether all were good), after
    core.params has named every problem into p."""
    found = problems(declared, table)
    p.extend(f"{where}{name}: {text}" for name, text in found)
    bad = {name for name, _ in found}
    return resolved(declared, {k: v for k, v in table.items() if k not in bad}), not found


def load_study(path: Path) -> Study:
    """Read and check a study file; CommandError (Exit.INVALID) listing every problem, each located."""
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
    top, _ = _checked(p, f"{name}: ", TOP, data)
    eta = None
    try:
        eta = eta_grid(top["eta"])
    except ValueError as exc:
        p.append(f"{name}: eta: {str(exc).removeprefix('eta: ')}")
    detectors = top["detectors"]
    if not detectors:
        p.append(f"{name}: detectors: must name at least one of {', '.join(DETECTORS)}")
    for i, d in enumerate(detectors):
        if d not in DETECTORS:
            p.append(f"{name}: detectors[{i}]: unknown detector {d!r}; expected {', '.join(DETECTORS)}")

    pairs: list[tuple[str, float]] = []
    attack_params: dict[str, dict] = {}
    for where, a in _tables(p, name, data, "attacks", ATTACK):
        kind = a["kind"]
        if kind not in KINDS or kind == "none":
            p.append(f"{where}.kind: expected one of {', '.join(k for k in KINDS if k != 'none')}, got {kind!r}")
            continue
        if kind in attack_params:
            p.append(f"{where}.kind: {kind!r} appears twice; put every RARMS of one model in one table")
            continue
        attack_params[kind] = a["params"]
        if not a["rarms"]:
            p.append(f"{where}.rarms: must list at least one RARMS")
        for k, r in enumerate(a["rarms"]):
            value, problem = RARMS.check(r)
            if problem:
                p.append(f"{where}.rarms[{k}]: {problem}")
            else:
                pairs.append((kind, value))

    groups: list[Group] = []
    labels: set[str] = set()
    for where, sc in _tables(p, name, data, "scenes", SCENE):
        spec = _scene_spec(p, where, sc, path.resolve().parent, preset_names())
        if spec is None:
            continue
        spec["attack_params"] = attack_params
        label = str(sc["label"] or sc["preset"] or Path(sc["file"]).stem)
        if label in labels:
            p.append(f"{where}.label: {label!r} names another scene too; give each a label of its own")
        labels.add(label)
        source = _checked_source(p, where, spec, [k for k, _ in pairs])
        for d in detectors:
            if d != "carav" and spec.get("model") == "paper":
                p.append(f"{where}.model: the paper model gives RMS levels only; detector {d!r} needs the radar "
                         "model")
            groups.append(Group(label, d, spec))
        if source is not None and top["method"] == "energy":
            for kind in ("none", *dict.fromkeys(k for k, _ in pairs)):
                if not source.energy_exact(kind):
                    p.append(f"{name}: method: no exact energy path for attack {kind!r} on {label}; use auto or "
                             "samples")
    if p:
        raise CommandError(f"{path} is not valid:\n" + "\n".join(f"  {x}" for x in p), Exit.INVALID)
    return Study(path, top["description"], top["seed"], top["trials"], eta, top["eta"], top["reference_eta"],
                 top["task_cycles"], top["method"], top["target_pf"], top["design_rarms"], groups, pairs)


def _tables(p: list[str], name: str, data: dict, key: str, declared) -> list[tuple[str, dict]]:
    """The [[key]] tables of a study file, each with where it is (`s.toml: scenes[1]`) and its checked values."""
    tables = data.get(key)
    if not isinstance(tables, list) or not tables:
        if isinstance(tables, list):
            p.append(f"{name}: {key}: at least one [[{key}]] table is required")
        return []                      # a missing or mistyped one is reported by the TOP check
    out = []
    for i, table in enumerate(tables):
        where = f"{name}: {key}[{i}]"
        if not isinstance(table, dict):
            p.append(f"{where}: expected a table, got {table!r}")
            continue
        values, good = _checked(p, f"{where}.", declared, table)
        if good:
            out.append((where, values))
    return out


def _scene_spec(p: list[str], where: str, sc: dict, folder: Path, presets: list[str]) -> dict | None:
    if (sc["preset"] is None) == (sc["file"] is None):
        p.append(f"{where}: give a preset or a file (one of them)")
        return None
    spec: dict[str, Any] = {"model": sc["model"]}
    if sc["preset"] is not None:
        if sc["preset"] not in presets:
            p.append(f"{where}.preset: no such preset {sc['preset']!r} (presets: {', '.join(presets)})")
            return None
        spec["preset"] = sc["preset"]
    else:
        if spec["model"] == "paper":
            p.append(f"{where}.file: the paper model takes a preset (table1 or awr1642)")
            return None
        f = folder / sc["file"]
        if not f.is_file():
            p.append(f"{where}.file: {f} not found")
            return None
        spec["scene"] = str(f)
    for key in ("nr", "ns", "snr_db"):
        if sc[key] is not None:
            spec[key] = sc[key]
    for key in ("iq", "ideal_adc", "activation"):
        spec[key] = sc[key]
    return spec


def _checked_source(p: list[str], where: str, spec: dict, kinds: list[str]):
    """The source of a scene entry, built once here so that a bad scene or attacker parameter is found now."""
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


