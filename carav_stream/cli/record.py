"""`carav record GRAPH --out DIR`: run a graph (as `carav run`) and record what its ADC delivered, as SigMF.

DIR receives recording.sigmf-data and recording.sigmf-meta (the samples and their metadata, shareable),
recording.activation (the activation sequences: private, mode 0600), record.toml (the graph that made the
recording: GRAPH plus a sigmf_sink wired to the ADC, the detector, the gate, the estimator and the tracker, if the
graph has one: its tracks of every cycle go into the annotations) and, for a scene
that is not a preset, recording.scene.toml. `carav replay DIR` judges the recording again.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from carav_stream.cli import run as run_command
from carav_stream.console.errors import CommandError, Exit
from carav_stream.runtime.graph import Graph

BASE = "recording"
NODE = "recorder"


def configure(p: argparse.ArgumentParser) -> None:
    run_command.configure(p)
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="folder for the recording (created; must not hold one already)")


def out_folder(out: Path) -> Path:
    """DIR, checked before anything runs: a folder (created if its parent exists) without a recording in it."""
    if out.exists() and not out.is_dir():
        raise CommandError(f"--out {out}: is a file, not a folder")
    if not out.exists() and not out.parent.is_dir():
        raise CommandError(f"--out {out}: its parent folder {out.parent} does not exist")
    if (out / f"{BASE}.sigmf-meta").exists() or (out / f"{BASE}.sigmf-data").exists():
        raise CommandError(f"--out {out}: holds a recording already; choose another folder")
    return out


def wiring(graph) -> list[str]:
    """The recorder's connections: the ADC frames and rho the detector reads, its verdicts, the gate's refusals,
    the estimates, the tracker's tracks. CommandError unless the graph has exactly one rms_detector, or if it has
    more than one tracker."""
    detectors = [n for n, node in graph.nodes.items() if node.type == "rms_detector"]
    if len(detectors) != 1:
        raise CommandError(f"{graph.path}: a recording follows the graph's rms_detector; the graph has "
                           f"{len(detectors)}", Exit.INVALID)
    det = detectors[0]
    into = {e.dst_port: f"{e.src}.{e.src_port}" for e in graph.edges_into(det)}
    wires = [f"{into['frames']} -> {NODE}.frames", f"{into['rho']} -> {NODE}.rho", f"{det}.verdict -> {NODE}.verdict"]
    for n, node in graph.nodes.items():
        if node.type == "gate":
            wires.append(f"{n}.alarms -> {NODE}.alarms")
        elif node.type == "range_estimator":
            wires.append(f"{n}.estimates -> {NODE}.estimates")
    trackers = [n for n, node in graph.nodes.items() if node.type == "tracker"]
    if len(trackers) > 1:
        raise CommandError(f"{graph.path}: a recording keeps the tracks of one tracker; the graph has "
                           f"{len(trackers)}: {', '.join(trackers)}", Exit.INVALID)
    wires += [f"{n}.tracks -> {NODE}.tracks" for n in trackers]
    return wires


def record_graph(graph: Graph, out: Path, overrides: list[str] = ()) -> Path:
    """Write OUT/record.toml: the loaded `graph` (its file included) plus the recorder; returns its path."""
    if NODE in graph.nodes:
        raise CommandError(f"{graph.path}: has a node named {NODE!r} already; carav record adds its own", Exit.INVALID)
    described = {"file": str(graph.path), "set": list(overrides),
                 "nodes": {n: {"type": node.type, **node.params} for n, node in graph.nodes.items()}}
    path = out / "record.toml"
    path.write_text(f"include = {json.dumps(str(Path(graph.path).resolve()))}\n"
                    f"connections = {json.dumps(wiring(graph))}\n\n[blocks]\n"
                    f"{NODE} = {{ type = \"sigmf_sink\", restart = \"never\", "
                    f"path = {json.dumps(str((out / BASE).resolve()))}, "
                    f"graph = {json.dumps(json.dumps(described, default=str))} }}\n")
    return path


def run(args: argparse.Namespace) -> int:
    out = out_folder(args.out)
    graph = run_command.load(args.graph, args)
    out.mkdir(exist_ok=True)
    cycles = [] if args.cycles is None else [f"run.cycles={args.cycles}"]
    path = record_graph(graph, out, [*args.set, *cycles])
    return run_command.execute(run_command.load(path, args, shown_as=args.graph), args, "record")
