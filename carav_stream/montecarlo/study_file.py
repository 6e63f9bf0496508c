"""The study file of `carav study`: its settings, scenes and attacks declared with core.params and checked whole, every
problem located (`fig35.toml: scenes[1].preset: no such preset 'x'`), before anything is drawn."""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from carav_stream.core.params import REQUIRED, Param, problems, resolved
from carav_stream.montecarlo.detectors import DETECTORS
from carav_stream.montecarlo.engine import eta_grid
from carav_stream.montecarlo.sources import source_from_spec
from carav_stream.radar.attackers import KINDS
from carav_stream.radar.scene_loader import preset_names
from carav_stream.radar.synth import FIDELITIES

__all__ = ["Group", "Study", "StudyError", "load_study"]


class StudyError(ValueError):
    """A study file that cannot be read or is not valid; the message lists every problem, each located."""


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


# -- declared and checked with core.params, as blocks, attackers and scenes are -----------------------------------
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
    Param("receivers", int, None, "receivers C combines per chirp (default the scene's own; the paper model takes "
          "any count)", low=1, optional=True),
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
    """Read and check a study file; StudyError listing every problem, each located."""
    name = path.name
    if path.is_dir():
        raise StudyError(f"{path}: is a folder, not a study file")
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise StudyError(f"{path}: study file not found") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError, OSError) as exc:
        raise StudyError(f"{name}: not a readable TOML study file: {exc}") from None
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
        raise StudyError(f"{path} is not valid:\n" + "\n".join(f"  {x}" for x in p))
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
    for key in ("nr", "ns", "snr_db", "receivers"):
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
