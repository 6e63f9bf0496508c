"""The live view's page: one Bokeh document per browser tab, updated `update_hz` times a second from ViewState.

Plots: Q per cycle with the threshold eta, coloured by the detector's decision (clean, D0, D1, opt-in detectors,
fail-closed refusals drawn at Q = 0 with their reason on hover); the range and the velocity estimates of every
listed target against the scene's true targets; the range-Doppler map of the latest clean cycle (dB over the
noise); the attacker node's block, model and RARMS with a form to swap them; per-node rates and per-edge queue
fill from the supervisor's status; the display counters (maps drawn, clean frames not drawn, frames the taps
skipped). Every model carries a `name` so tests (and scripts) find it in the browser's Bokeh document.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.adc import from_codes
from carav_stream.view.control import RunControl, models
from carav_stream.view.state import CATEGORIES, ViewState, rd_map_db

COLOURS = {"clean": "#1f77b4", "D0": "#d62728", "D1": "#ff7f0e", "opt-in": "#9467bd", "refused": "#7f7f7f"}
NODE_COLUMNS = ("node", "block", "state", "cycles", "frames_s", "cycles_s", "restarts")
LABELS = {"clean": "clean (passed to ranging)", "D0": "alarm raised by D0", "D1": "alarm raised by D1",
          "opt-in": "alarm raised by an opt-in detector", "refused": "refused without a verdict (fail closed, at Q=0)"}


@dataclass(frozen=True)
class PageConfig:
    scene: Any                  # radar.scene.Scene: the samples' scale (ADC codes) and sigma_n
    geometry: Geometry
    truth_range_m: Sequence[float]
    truth_velocity_mps: Sequence[float]
    eta: float | None
    history: int
    update_hz: float
    attacker: str
    title: str


def make_document(doc: Any, state: ViewState, control: RunControl | None, cfg: PageConfig) -> None:
    from bokeh.layouts import column, row
    from bokeh.models import (
        Button,
        ColorBar,
        ColumnDataSource,
        DataRange1d,
        DataTable,
        Div,
        HoverTool,
        LinearColorMapper,
        Select,
        Span,
        Spinner,
        TableColumn,
    )
    from bokeh.plotting import figure

    doc.title = cfg.title
    q_fig = figure(name="q_plot", height=300, width=980, title="Detector statistic Q per cycle against eta",
                   x_axis_label="cycle", y_axis_label="Q (dimensionless)", tools="pan,wheel_zoom,box_zoom,reset",
                   y_range=DataRange1d(start=0.0))   # from 0: eta and the refusals (drawn at 0) stay in view
    q_src = {c: ColumnDataSource({"cycle": [], "q": [], "detail": [], "attacked": []}, name=f"q_{c}")
             for c in CATEGORIES}
    for c in CATEGORIES:
        q_fig.scatter("cycle", "q", source=q_src[c], color=COLOURS[c], size=4 if c == "clean" else 6,
                      marker="x" if c == "refused" else "circle", legend_label=LABELS[c])
    q_fig.add_tools(HoverTool(tooltips=[("cycle", "@cycle"), ("Q", "@q"), ("by / reason", "@detail"),
                                        ("attack on", "@attacked")]))
    eta_line = Span(name="eta_line", location=cfg.eta if cfg.eta is not None else float("nan"), dimension="width",
                    line_color="black", line_dash="dashed", line_width=1.5)
    q_fig.add_layout(eta_line)
    q_fig.legend.location = "top_left"
    q_fig.legend.click_policy = "hide"
    eta_div = Div(name="eta_text", text="")

    est_src = ColumnDataSource({"cycle": [], "range_m": [], "velocity_mps": []}, name="estimates")
    r_fig = figure(name="range_plot", height=260, width=485, title="Range estimates against the true targets",
                   x_axis_label="cycle", y_axis_label="range (m)", tools="pan,wheel_zoom,box_zoom,reset")
    v_fig = figure(name="velocity_plot", height=260, width=485, title="Velocity estimates against the true targets",
                   x_axis_label="cycle", y_axis_label="range rate (m/s)", tools="pan,wheel_zoom,box_zoom,reset")
    r_fig.scatter("cycle", "range_m", source=est_src, size=4, legend_label="estimate (every listed target)")
    v_fig.scatter("cycle", "velocity_mps", source=est_src, size=4, legend_label="estimate (every listed target)")
    for fig, truths in ((r_fig, cfg.truth_range_m), (v_fig, cfg.truth_velocity_mps)):
        for t in truths:   # the legend item of a Span needs a glyph: a zero-length line carries it
            fig.add_layout(Span(location=t, dimension="width", line_color="green", line_width=2))
        if truths:
            fig.line([0, 0], [truths[0], truths[0]], line_color="green", line_width=2, legend_label="true target")
        fig.legend.location = "top_left"

    g = cfg.geometry
    n_range = g.n_samples if g.iq else (g.n_samples - 1) // 2
    r_max = float(g.range_from_beat(n_range * g.fs_hz / g.n_samples))
    v_max = float(g.max_velocity_mps)
    mapper = LinearColorMapper(palette="Viridis256", low=0.0, high=40.0)
    rd_src = ColumnDataSource({"image": [np.zeros((2, 2), dtype=np.float32)], "x": [0.0], "y": [-v_max],
                               "dw": [r_max], "dh": [2 * v_max]}, name="rd_map")
    rd_fig = figure(name="rd_plot", height=360, width=485, title="Range-Doppler map of the latest clean cycle",
                    x_axis_label="range (m)", y_axis_label="range rate (m/s)", x_range=(0, r_max),
                    y_range=(-v_max, v_max), tools="pan,wheel_zoom,box_zoom,reset")
    rd_fig.image("image", x="x", y="y", dw="dw", dh="dh", source=rd_src, color_mapper=mapper)
    rd_fig.add_layout(ColorBar(color_mapper=mapper, title="power over noise (dB)"), "right")
    rd_div = Div(name="rd_text", text="no clean cycle yet")

    attacker_div = Div(name="attacker", text="attacker: waiting for the run's status", width=470)
    choices = models()
    model_in = Select(name="swap_model", title="attacker model", value=choices[0], options=choices, width=150)
    rarms_in = Spinner(name="swap_rarms", title="RARMS (sigma_a / sigma_n)", value=3.0, low=0.0, step=0.1, width=150)
    swap_button = Button(name="swap_button", label="swap attacker", button_type="warning", width=150,
                         disabled=control is None)
    swap_div = Div(name="swap_log", text="" if control else "swaps need the run's supervisor (carav run --view)")
    if control is not None:
        swap_button.on_click(lambda: control.swap(model_in.value, rarms_in.value))

    node_src = ColumnDataSource({k: [] for k in NODE_COLUMNS}, name="nodes")
    nodes = DataTable(name="node_table", source=node_src, width=470, height=230, index_position=None, columns=[
        TableColumn(field="node", title="node"), TableColumn(field="block", title="block"),
        TableColumn(field="state", title="state"), TableColumn(field="cycles", title="cycles"),
        TableColumn(field="frames_s", title="frames/s (last s)"),
        TableColumn(field="cycles_s", title="cycles/s (last s)"),
        TableColumn(field="restarts", title="restarts")])
    edge_src = ColumnDataSource({k: [] for k in ("edge", "fill", "skipped")}, name="edges")
    edges = DataTable(name="edge_table", source=edge_src, width=470, height=230, index_position=None, columns=[
        TableColumn(field="edge", title="edge", width=300),
        TableColumn(field="fill", title="in flight / queue capacity (why beyond it)", width=320),
        TableColumn(field="skipped", title="skipped (tap)")])
    info = Div(name="info", text="", width=980)

    doc.add_root(column(
        Div(text=f"<h2>{cfg.title}</h2>"), info, row(q_fig), eta_div, row(r_fig, v_fig),
        row(column(rd_fig, rd_div), column(attacker_div, row(model_in, rarms_in), swap_button, swap_div, nodes)),
        edges))

    seen: dict[str, Any] = {"points": 0, "estimates": 0, "map": 0, "status": None,   # what this page has drawn
                            "model": None}

    def update() -> None:
        pts, seen["points"], est, seen["estimates"] = state.since(seen["points"], seen["estimates"])
        for c in CATEGORIES:
            mine = [p for p in pts if p.category == c]
            if mine:
                q_src[c].stream({"cycle": [p.cycle for p in mine],
                                 "q": [0.0 if p.q is None else p.q for p in mine],
                                 "detail": [p.detail for p in mine], "attacked": [p.attacked for p in mine]},
                                rollover=cfg.history)
        if est:
            flat = [(e.cycle, r, v) for e in est for r, v in zip(e.range_m, e.velocity_mps)]
            if flat:
                c, r, v = zip(*flat)
                est_src.stream({"cycle": list(c), "range_m": list(r), "velocity_mps": list(v)}, rollover=cfg.history)
        eta = cfg.eta if cfg.eta is not None else state.eta
        if eta is not None and eta_line.location != eta:
            eta_line.location = eta
            eta_div.text = f"dashed line: the detector's threshold eta = {eta:g} (an alarm when Q >= eta)"
        latest = state.latest_clean(seen["map"])
        if latest is not None:
            seen["map"], cycle, x, rho = latest
            samples = from_codes(cfg.scene, np.asarray(x)[None])[0]
            db, ranges, velocities = rd_map_db(samples, np.asarray(rho, bool), g, cfg.scene.sigma_n)
            rd_src.data = {"image": [db], "x": [float(ranges[0])], "y": [float(velocities[0])],
                           "dw": [float(ranges[-1] - ranges[0])], "dh": [float(velocities[-1] - velocities[0])]}
            rd_div.text = f"cycle {cycle}: peak {float(db.max()):.1f} dB over the noise"
            state.drawn(seen["map"])
        with state.lock:
            status, status_error, swaps = state.status, state.status_error, list(state.swap_log[-5:])
        if status is not None and status is not seen["status"]:   # a new one comes once a second: tables
            before, seen["status"] = seen["status"], status        # redrawn only then (the browser's work)
            recent = [p.attacked for p in state.recent(200)]
            on = (f"attack on in {sum(recent)} of the last {len(recent)} cycles shown" if recent
                  else "no cycle shown yet")
            node_src.data = node_rows(status, before)
            edge_src.data = edge_rows(status)
            attacker_div.text = attacker_text(status, cfg.attacker, on)
            running = ((status.get("nodes", {}).get(cfg.attacker) or {}).get("params") or {})
            if running.get("model") in choices and running.get("model") != seen["model"]:
                # the form shows what runs whenever that changes (a swap from here, the CLI or a restart); a
                # choice the user is making in between is left alone
                seen["model"] = model_in.value = running["model"]
                if isinstance(running.get("rarms"), int | float):
                    rarms_in.value = float(running["rarms"])
        if swaps and swap_div.text != "<br>".join(swaps):
            swap_div.text = "<br>".join(swaps)
        k = state.counts()
        skipped = sum(e.get("skipped", 0) for e in (status or {}).get("edges", {}).values())
        info_text = (f"latest cycle {k['last_cycle']} &middot; cycles run {(status or {}).get('cycles', 'n/a')} "
                     f"&middot; range-Doppler maps drawn {k['maps_drawn']}, clean frames not drawn "
                     f"{k['frames_not_drawn']} &middot; frames the taps skipped for display {skipped} (not lost)"
                     + (f" &middot; status: {status_error}" if status_error else ""))
        if info.text != info_text:
            info.text = info_text

    doc.add_periodic_callback(update, max(50, int(1000 / cfg.update_hz)))


def node_rows(status: dict[str, Any], before: dict[str, Any] | None) -> dict[str, list]:
    """The node table: each node's block, state, cycles so far, and its rates over the interval since the status
    `before` (the run's average while there is none, or when the node is new to it)."""
    nodes, old = status.get("nodes", {}), (before or {}).get("nodes", {})
    dt = status.get("elapsed_s", 0.0) - (before or {}).get("elapsed_s", 0.0)

    def rate(name: str, n: dict[str, Any], key: str, average: str) -> float:
        if before is None or dt <= 0 or name not in old:
            return round(n.get(average, 0.0), 1)
        return round((n.get(key, 0) - old[name].get(key, 0)) / dt, 1)

    return {"node": list(nodes), "block": [n.get("block", "?") for n in nodes.values()],
            "state": ["up" if n.get("alive") else "DOWN" for n in nodes.values()],
            "cycles": [n.get("cycles_total", 0) for n in nodes.values()],
            "frames_s": [rate(k, n, "processed", "rate_per_s") for k, n in nodes.items()],
            "cycles_s": [rate(k, n, "cycles_total", "cycles_per_s") for k, n in nodes.items()],
            "restarts": [n.get("restarts", 0) for n in nodes.values()]}


def edge_rows(status: dict[str, Any]) -> dict[str, list]:
    """The edge table: frames in flight against the queue's capacity, with the supervisor's reason when they
    exceed it, and what a tap skipped."""
    edges = status.get("edges", {})
    return {"edge": list(edges),
            "fill": [f"{e['in_flight']} / {e['capacity']}" + (f" ({e['beyond_capacity']})"
                                                             if e.get("beyond_capacity") else "")
                     for e in edges.values()],
            "skipped": [e.get("skipped", 0) for e in edges.values()]}


def attacker_text(status: dict[str, Any], attacker: str, on: str) -> str:
    a = status.get("nodes", {}).get(attacker)
    if a is None:
        return f"attacker: the graph has no node {attacker!r}"
    p = a.get("params", {})
    swaps = [s for s in status.get("swaps", []) if s.get("node") == attacker]
    return (f"<b>attacker</b> node {attacker}: block {a.get('block')}, model <b>{p.get('model')}</b>, "
            f"RARMS <b>{p.get('rarms', 'n/a')}</b>, {len(swaps)} swap(s) so far; {on}")
