"""`carav replay DIR`: a recording made by `carav record` through detection, gate and ranging again.

By default through the packaged graphs/replay.toml, with the recording's scene and batch and the recorded
detector's and estimator's settings (eta, sigma_n, method, n_targets, detection, pfa, max_targets), so that the
verdicts, Q and estimates are those of the live run, bit for bit; `--graph FILE` replays through another graph
(its sigmf_source node gets the recording; the scene and batch are set as well). `--set` comes last and overrides
all of it. The run summary is printed (and written with --json) as by `carav run`.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from carav_graphs import graph_file as default_graph
from carav_stream.capture.sigmf_io import Recording, RecordingError, open_recording
from carav_stream.cli import run as run_command
from carav_stream.console.errors import CommandError, Exit
from carav_stream.runtime.loader import read_graph_file

RECORDED = {"rms_detector": ("eta", "sigma_n"),
            "range_estimator": ("method", "n_targets", "detection", "pfa", "max_targets", "sigma_n",
                                "max_speed_mps")}


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("recording", type=Path, help="a folder written by carav record, or a recording's base name")
    p.add_argument("--graph", type=Path, help="graph to replay through (default: graphs/replay.toml)")
    p.add_argument("--paced", action="store_true", help="release cycles at the radar's cycle rate")
    run_command.run_options(p)


def player_nodes(graph_file: Path) -> tuple[list[str], dict]:
    """The sigmf_source nodes of a graph file (read without validating: their path is not set yet) and its blocks."""
    problems: list[str] = []
    source = read_graph_file(graph_file, problems)
    if source is None:
        raise CommandError(f"{graph_file} is not valid:\n" + "\n".join(f"  {p}" for p in problems), Exit.INVALID)
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


def run(args: argparse.Namespace) -> int:
    graph_file = args.graph or default_graph("replay")
    (player,), blocks = player_nodes(graph_file)
    unchecked = any(s.replace(" ", "") == f"{player}.verify=false" for s in args.set)
    try:   # the player compares the hash itself; a recording without one is refused here unless asked otherwise
        rec = open_recording(args.recording, verify_hash=False, require_hash=not unchecked)
    except RecordingError as exc:
        raise CommandError(str(exc), Exit.INVALID) from None
    overrides = overrides_for(rec, player, blocks, recorded_settings=args.graph is None, paced=args.paced)
    return run_command.execute(run_command.load(graph_file, args, overrides), args, "replay",
                               expected_cycles=min(len(rec.cycles), args.cycles or len(rec.cycles)))
