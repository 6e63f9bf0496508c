"""`carav run GRAPH --view [--port N]`: the graph plus a live_view node on taps of its gate and estimator.

The composed graph is a file like `carav record`'s: the user's graph included, the view node and its wiring
added (gate.alarms, range_estimator.estimates, gate.clean, and a tracker's tracks; the attacker node the page swaps;
the detector's eta; the page's per-run token),
written to a private temporary folder named after the graph so the run id reads the same.
"""
from __future__ import annotations

import json
import tempfile
from pathlib import Path

from carav_stream.console.errors import CommandError, Exit
from carav_stream.runtime.graph import Graph

NODE = "view"


def _one(graph: Graph, block_type: str) -> str | None:
    names = [n for n, node in graph.nodes.items() if node.type == block_type]
    if len(names) > 1:
        raise CommandError(f"{graph.path}: --view follows one {block_type}; the graph has {len(names)}: "
                           f"{', '.join(names)}", Exit.INVALID)
    return names[0] if names else None


def view_params(graph: Graph, host: str, port: int, token: str) -> dict:
    attacker, detector = _one(graph, "attacker"), _one(graph, "rms_detector")
    params: dict = {"type": "live_view", "address": host, "port": port, "token": token}
    if attacker:
        params["attacker"] = attacker
    if detector and isinstance(graph.nodes[detector].params.get("eta"), int | float):
        params["eta"] = float(graph.nodes[detector].params["eta"])
    if _one(graph, "tracker"):
        params["tracks"] = True
    return params


def wiring(graph: Graph) -> list[str]:
    """The view's taps: the gate's refusals and clean frames, the estimator's estimates, a tracker's tracks.
    CommandError if the graph has no gate (nothing to watch)."""
    gate, ranging, tracker = _one(graph, "gate"), _one(graph, "range_estimator"), _one(graph, "tracker")
    if gate is None:
        raise CommandError(f"{graph.path}: --view watches the gate's verdicts; the graph has no gate", Exit.INVALID)
    wires = [f"{gate}.alarms -> {NODE}.alarms", f"{gate}.clean -> {NODE}.clean"]
    if ranging:
        wires.append(f"{ranging}.estimates -> {NODE}.estimates")
    if tracker:
        wires.append(f"{tracker}.tracks -> {NODE}.tracks")
    return wires


def view_graph(graph: Graph, host: str, port: int, token: str) -> Path:
    """Write the composed graph into a new private temporary folder (it holds the page's token); returns its path
    (the caller removes the folder). CommandError if Bokeh is not installed."""
    try:
        import bokeh  # noqa: F401
    except ImportError:
        raise CommandError("--view serves its page with Bokeh, which is not installed: pip install "
                           "'carav-stream[view]'") from None
    if NODE in graph.nodes:
        raise CommandError(f"{graph.path}: has a node named {NODE!r} already; --view adds its own", Exit.INVALID)
    params = view_params(graph, host, port, token)
    fields = ", ".join(f"{k} = {json.dumps(v)}" for k, v in params.items())
    folder = Path(tempfile.mkdtemp(prefix="carav-view-"))
    path = folder / Path(graph.path).name
    path.write_text(f"include = {json.dumps(str(Path(graph.path).resolve()))}\n"
                    f"connections = {json.dumps(wiring(graph))}\n\n[blocks]\n{NODE} = {{ {fields} }}\n")
    return path
