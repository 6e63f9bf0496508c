"""`carav replay DIR`: a recording made by `carav record` through detection, gate and ranging again.

By default through the packaged graphs/replay.toml, with the recording's scene and batch and the recorded
detector's and estimator's settings (eta, sigma_n, direction_chirps, method, n_targets, detection, pfa,
max_targets; the run summary's azimuth_floor_deg), so that the verdicts, Q and estimates are those of the live run,
bit for bit (a receiver array's too: the attacker's azimuth, the targets' azimuths); `--graph FILE` replays
through another graph (its sigmf_source node gets the recording; the scene and batch are set as well). `--set`
comes last and overrides all of it. The run summary is printed (and written with --json) as by `carav run`.

A recording of a graph with a tracker (its tracks are in the annotations) is replayed with that tracker too, its
recorded settings, on the gate's refusals and the estimates: the replay's estimates are the live run's, so its
tracks are too, and the summary gives their figures; `--tracks FILE` writes them, one JSON line per frame as the
live graph's jsonl_sink did. The composed graph (the replay graph plus the tracker) is written to a private
temporary folder, named as the replay graph so the run id reads the same.
"""
from __future__ import annotations

import argparse
import json
import shutil
import tempfile
from pathlib import Path

from carav_graphs import graph_file as default_graph
from carav_stream.capture.sigmf_io import NS, Recording, RecordingError, open_recording
from carav_stream.cli import run as run_command
from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import output_file
from carav_stream.runtime.loader import read_graph_file
from carav_stream.runtime.registry import Registry

TRACKER, TRACKS_LOG = "tracker", "tracks_log"       # the nodes a replay of a recording with tracks adds
RECORDED = {"rms_detector": ("eta", "sigma_n", "direction_chirps"),
            "range_estimator": ("method", "n_targets", "detection", "pfa", "max_targets", "sigma_n",
                                "max_speed_mps"),
            "run_summary": ("azimuth_floor_deg",)}


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("recording", type=Path, help="a folder written by carav record, or a recording's base name")
    p.add_argument("--graph", type=Path, help="graph to replay through (default: graphs/replay.toml)")
    p.add_argument("--paced", action="store_true", help="release cycles at the radar's cycle rate")
    p.add_argument("--tracks", type=output_file, metavar="FILE", help="a recording with tracks: write the replayed "
                   "tracks as JSON lines (the tracker's frames, as a jsonl_sink writes them)")
    run_command.run_options(p)


def player_nodes(graph_file: Path) -> tuple[list[str], dict]:
    """The sigmf_source nodes of a graph file (read without validating: their path is not set yet) and its blocks."""
    problems: list[str] = []
    source = read_graph_file(graph_file, problems)
    if source is None:
        raise run_command.invalid_graph(graph_file, problems)
    blocks = source.data.get("blocks") if isinstance(source.data.get("blocks"), dict) else {}
    players = [n for n, b in blocks.items() if isinstance(b, dict) and b.get("type") == "sigmf_source"]
    if len(players) != 1:
        raise CommandError(f"{graph_file}: a replay graph needs exactly one sigmf_source node, it has "
                           f"{len(players)}", Exit.INVALID)
    return players, blocks


def overrides_for(rec: Recording, player: str, blocks: dict, recorded_settings: bool, paced: bool = False) -> list[str]:
    """`--set` values that point a replay graph at `rec`: the player's path, the recording's scene and batch, and
    (recorded_settings) the recorded detector's and estimator's settings on the graph's nodes of those types."""
    out = [f"scene={json.dumps(rec.scene_ref)}", f"{player}.path={json.dumps(str(rec.base))}"]
    if isinstance(rec.global_field("batch"), int):
        out.append(f"batch={rec.global_field('batch')}")
    if paced:
        out.append(f"{player}.paced=true")
    if recorded_settings:
        recorded = (rec.global_field("graph") or {}).get("nodes", {})
        for name, spec in blocks.items():
            kind = spec.get("type") if isinstance(spec, dict) else None
            live = [n for n in recorded.values() if n.get("type") == kind]
            out += [f"{name}.{key}={json.dumps(live[0][key])}" for key in RECORDED.get(kind, ())
                    if len(live) == 1 and key in live[0]]
    return out


def recorded_tracker(rec: Recording) -> dict | None:
    """The recorded graph's tracker node (type and parameters), None without one; RecordingError for several."""
    nodes = (rec.global_field("graph") or {}).get("nodes", {})
    trackers = [spec for spec in nodes.values() if spec.get("type") == "tracker"]
    if len(trackers) > 1:
        raise RecordingError(f"{rec.base}.sigmf-meta: global {NS}:graph: {len(trackers)} trackers; a recording "
                             "keeps the tracks of one")
    return trackers[0] if trackers else None


def with_tracker(graph_file: Path, blocks: dict, tracker: dict, tracks_out: Path | None) -> Path:
    """Write graph_file plus `tracker` (its recorded parameters less the graph-wide ones) on the gate's refusals
    and the estimates, and with tracks_out a jsonl_sink of its tracks, into a new private temporary folder; returns
    its path (the caller removes the folder). CommandError unless the graph has one gate and one range_estimator."""
    found = {kind: [n for n, b in blocks.items() if isinstance(b, dict) and b.get("type") == kind]
             for kind in ("gate", "range_estimator")}
    if any(len(names) != 1 for names in found.values()) or TRACKER in blocks or TRACKS_LOG in blocks:
        raise CommandError(f"{graph_file}: replaying the recorded tracker needs one gate, one range_estimator and "
                           f"no node named {TRACKER} or {TRACKS_LOG}; it has " + ", ".join(
                               f"{len(names)} {kind}" for kind, names in found.items()), Exit.INVALID)
    (gate,), (ranging,) = found.values()
    wide = {p.name for p in Registry().get("tracker").cls.params if p.graph_wide}
    params = {"type": "tracker", **{k: v for k, v in tracker.items() if k != "type" and k not in wide}}
    wires = [f"{ranging}.estimates -> {TRACKER}.estimates", f"{gate}.alarms -> {TRACKER}.alarms"]
    nodes = f"{TRACKER} = {{ {', '.join(f'{k} = {json.dumps(v)}' for k, v in params.items())} }}\n"
    if tracks_out is not None:
        wires.append(f"{TRACKER}.tracks -> {TRACKS_LOG}.inp")
        nodes += f"{TRACKS_LOG} = {{ type = \"jsonl_sink\", path = {json.dumps(str(tracks_out.resolve()))} }}\n"
    path = Path(tempfile.mkdtemp(prefix="carav-replay-")) / graph_file.name
    path.write_text(f"include = {json.dumps(str(graph_file.resolve()))}\nconnections = {json.dumps(wires)}\n\n"
                    f"[blocks]\n{nodes}")
    return path


def run(args: argparse.Namespace) -> int:
    graph_file = args.graph or default_graph("replay")
    (player,), blocks = player_nodes(graph_file)
    unchecked = any(s.replace(" ", "") == f"{player}.verify=false" for s in args.set)
    try:   # the player compares the hash itself; a recording without one is refused here unless asked otherwise
        rec = open_recording(args.recording, verify_hash=False, require_hash=not unchecked)
        tracker = recorded_tracker(rec) if args.graph is None else None
    except RecordingError as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    overrides = overrides_for(rec, player, blocks, recorded_settings=args.graph is None, paced=args.paced)
    if args.tracks is not None and tracker is None:
        raise CommandError(f"--tracks: {rec.base} has no tracks to replay (" + (
            "its graph had no tracker)" if args.graph is None else "with --graph, the graph's own sinks write them)"))
    expected = min(len(rec.cycles), args.cycles or len(rec.cycles))
    if tracker is None:
        return run_command.execute(run_command.load(graph_file, args, overrides), args, "replay",
                                   expected_cycles=expected)
    path = with_tracker(graph_file, blocks, tracker, args.tracks)
    try:
        graph = run_command.load(path, args, overrides, shown_as=graph_file)
        return run_command.execute(graph, args, "replay", expected_cycles=expected)
    finally:
        shutil.rmtree(path.parent, ignore_errors=True)
