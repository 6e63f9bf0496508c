"""The live view's page: one Bokeh document per browser tab, updated up to `update_hz` times a second from ViewState.

Plots: Q per cycle with the threshold eta, coloured by the detector's decision (clean, D0, D1, opt-in detectors,
fail-closed refusals drawn at Q = 0 with their reason on hover); the range and the velocity estimates of every
listed target against the scene's true targets; the range-Doppler map of the latest clean cycle (dB over the
noise); with a tracker (PageConfig.tracks), its confirmed tracks' range per cycle, updated or coasting, with their
ids on hover and the latest cycle's in words; the attacker node's block, model and RARMS with a form to swap them;
per-node rates and per-edge queue
fill from the supervisor's status; the display counters (maps drawn, clean frames not drawn, frames the taps
skipped); the scope and spectrum of any output port the user taps (view.scope_page). Every model carries a
`name` so tests (and scripts) find it in the browser's Bokeh document.

The plots of clean cycles (range, velocity, the map) say, in the line between them, why they stand still: the
latest clean cycle and the cycles the gate refused after it, by class (one line for the three: each text that
changes makes the browser lay the whole page out again). Legends sit in a panel beside or below their plot,
never over it. A tab gets its next update only once it has shown the last one (view.sync): a browser short of CPU
sees the present, less often, rather than an ever older past. The tables are Bokeh DataTables, which redraw only
when their row set changes (BokehJS redraws a table on a change of its CDSView's indices, and new figures in as
many rows leave those equal): a new status makes its table redraw (`_redraw_on_new_data`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.adc import from_codes
from carav_stream.view.control import RunControl, models
from carav_stream.view.scope_page import ScopePanel, scope_panel, update_scope
from carav_stream.view.state import CATEGORIES, TrackPoint, ViewState, rd_map_db

REFUSALS = {"D0": "alarms by D0", "D1": "alarms by D1", "opt-in": "alarms by an opt-in detector",
            "refused": "refusals without a verdict"}

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
    tracks: bool = False        # the graph has a tracker: its confirmed tracks get a plot


@dataclass
class _Models:
    """The models the page's update changes, and what this page has drawn so far (`seen`)."""
    q_src: dict[str, Any]
    eta_line: Any
    eta_div: Any
    est_src: Any
    pause_div: Any
    rd_src: Any
    rd_div: Any
    attacker_div: Any
    model_in: Any
    rarms_in: Any
    swap_div: Any
    node_src: Any
    edge_src: Any
    info: Any
    choices: list[str]
    sync: Any
    scope: ScopePanel
    tracks_src: Any = None      # None: no tracker
    tracks_div: Any = None
    seen: dict[str, Any] = field(default_factory=lambda: {"points": 0, "estimates": 0, "map": 0, "status": None,
                                                          "model": None, "tracks": 0})


def make_document(doc: Any, state: ViewState, control: RunControl | None, cfg: PageConfig) -> None:
    """The page in `doc` (one per browser tab), updated from `state` up to `cfg.update_hz` times a second."""
    # Bokeh is the view extra's: imported when a page is made, not with the package
    import bokeh.models as bm
    from bokeh.layouts import column, row
    from bokeh.plotting import figure

    # a Bokeh model class (view.sync): the view extra's too
    from carav_stream.view.sync import page_sync

    doc.title = cfg.title
    q_fig, q_src, eta_line, eta_div = _q_plot(bm, figure, cfg)
    r_fig, v_fig, est_src = _estimate_plots(bm, figure, cfg)
    pause_div = bm.Div(name="pause_text", text="no clean cycle yet", width=980)
    rd_fig, rd_src, rd_div = _rd_plot(bm, figure, cfg.geometry)
    attacker_div, model_in, rarms_in, swap_button, swap_div, choices = _swap_form(bm, control)
    nodes, node_src, edges, edge_src = _tables(bm)
    info = bm.Div(name="info", text="", width=980)
    scope, scope_state = scope_panel(bm, figure, cfg, control.tap if control is not None else None)

    t_fig, tracks_src, tracks_div = _tracks_plot(bm, figure, cfg) if cfg.tracks else (None, None, None)
    doc.add_root(column(
        bm.Div(text=f"<h2>{cfg.title}</h2>"), info, row(q_fig), eta_div, row(r_fig, v_fig), pause_div,
        *((t_fig, tracks_div) if cfg.tracks else ()),
        row(column(rd_fig, rd_div), column(attacker_div, row(model_in, rarms_in), swap_button, swap_div, nodes)),
        edges, scope))
    m = _Models(q_src, eta_line, eta_div, est_src, pause_div, rd_src, rd_div, attacker_div, model_in, rarms_in,
                swap_div, node_src, edge_src, info, choices, page_sync(doc), scope_state, tracks_src, tracks_div)
    doc.on_session_destroyed(lambda context: scope_state.close())     # the tab's tap ends with it
    doc.add_periodic_callback(lambda: _update(m, state, cfg), max(50, int(1000 / cfg.update_hz)))


def _q_plot(bm: Any, figure: Any, cfg: PageConfig) -> tuple[Any, dict[str, Any], Any, Any]:
    """Q per cycle by category, with the threshold's line: (figure, sources by category, eta line, eta text)."""
    q_fig = figure(name="q_plot", height=300, width=980, title="Detector statistic Q per cycle against eta",
                   x_axis_label="cycle", y_axis_label="Q (dimensionless)", tools="pan,wheel_zoom,box_zoom,reset",
                   y_range=bm.DataRange1d(start=0.0))   # from 0: eta and the refusals (drawn at 0) stay in view
    # in the panel right of the plot, covering no point (the glyphs name it: legend_name)
    q_fig.add_layout(bm.Legend(name="q_legend", click_policy="hide"), "right")
    q_src = {c: bm.ColumnDataSource({"cycle": [], "q": [], "detail": [], "attacked": []}, name=f"q_{c}")
             for c in CATEGORIES}
    for c in CATEGORIES:
        q_fig.scatter("cycle", "q", source=q_src[c], color=COLOURS[c], size=4 if c == "clean" else 6,
                      marker="x" if c == "refused" else "circle", legend_label=LABELS[c], legend_name="q_legend")
    q_fig.add_tools(bm.HoverTool(tooltips=[("cycle", "@cycle"), ("Q", "@q"), ("by / reason", "@detail"),
                                           ("attack on", "@attacked")]))
    eta_line = bm.Span(name="eta_line", location=cfg.eta if cfg.eta is not None else float("nan"),
                       dimension="width", line_color="black", line_dash="dashed", line_width=1.5)
    q_fig.add_layout(eta_line)
    return q_fig, q_src, eta_line, bm.Div(name="eta_text", text="")


def _estimate_plots(bm: Any, figure: Any, cfg: PageConfig) -> tuple[Any, Any, Any]:
    """Range and velocity estimates against the true targets: (range figure, velocity figure, their source)."""
    est_src = bm.ColumnDataSource({"cycle": [], "range_m": [], "velocity_mps": []}, name="estimates")
    r_fig = figure(name="range_plot", height=260, width=485, title="Range estimates against the true targets",
                   x_axis_label="cycle", y_axis_label="range (m)", tools="pan,wheel_zoom,box_zoom,reset")
    v_fig = figure(name="velocity_plot", height=260, width=485, title="Velocity estimates against the true targets",
                   x_axis_label="cycle", y_axis_label="range rate (m/s)", tools="pan,wheel_zoom,box_zoom,reset")
    for fig in (r_fig, v_fig):
        fig.add_layout(bm.Legend(orientation="horizontal"), "below")
    r_fig.scatter("cycle", "range_m", source=est_src, size=4, legend_label="estimate (every listed target)")
    v_fig.scatter("cycle", "velocity_mps", source=est_src, size=4, legend_label="estimate (every listed target)")
    for fig, truths in ((r_fig, cfg.truth_range_m), (v_fig, cfg.truth_velocity_mps)):
        for t in truths:   # the legend item of a Span needs a glyph: a zero-length line carries it
            fig.add_layout(bm.Span(location=t, dimension="width", line_color="green", line_width=2))
        if truths:
            fig.line([0, 0], [truths[0], truths[0]], line_color="green", line_width=2, legend_label="true target")
    return r_fig, v_fig, est_src


TRACK_COLOURS = {False: "#1f77b4", True: "#7f7f7f"}     # updated, coasting


def _tracks_plot(bm: Any, figure: Any, cfg: PageConfig) -> tuple[Any, Any, Any]:
    """The tracker's confirmed tracks, range per cycle, against the true targets: (figure, its source, the latest
    cycle's tracks in words)."""
    src = bm.ColumnDataSource({"cycle": [], "range_m": [], "velocity_mps": [], "track": [], "status": [],
                               "colour": []}, name="tracks")
    fig = figure(name="tracks_plot", height=260, width=980, title="Confirmed tracks (the tracker's): range per cycle",
                 x_axis_label="cycle", y_axis_label="range (m)", tools="pan,wheel_zoom,box_zoom,reset")
    fig.add_layout(bm.Legend(orientation="horizontal"), "below")
    fig.scatter("cycle", "range_m", source=src, size=4, color="colour", legend_field="status")
    fig.add_tools(bm.HoverTool(tooltips=[("track", "@track"), ("cycle", "@cycle"), ("range (m)", "@range_m"),
                                         ("range rate (m/s)", "@velocity_mps"), ("status", "@status")]))
    for t in cfg.truth_range_m:
        fig.add_layout(bm.Span(location=t, dimension="width", line_color="green", line_width=2))
    return fig, src, bm.Div(name="tracks_text", text="no confirmed track yet", width=980)


def tracks_text(t: TrackPoint | None) -> str:
    """The latest cycle's confirmed tracks in words, one per id."""
    if t is None:
        return "no confirmed track yet"
    if not t.track_id:
        return f"cycle {t.cycle}: no confirmed track"
    return f"cycle {t.cycle}: " + "; ".join(
        f"track {i} at {r:.2f} m, {v:+.2f} m/s ({'coasting' if c else 'updated'})"
        for i, r, v, c in zip(t.track_id, t.range_m, t.velocity_mps, t.coasting))


def _draw_tracks(m: _Models, state: ViewState, cfg: PageConfig) -> None:
    """The confirmed tracks of the cycles that came since the last update, and the latest cycle's in words."""
    new, m.seen["tracks"] = state.tracks_since(m.seen["tracks"])
    if not new:
        return
    flat = [(t.cycle, r, v, str(i), "coasting" if c else "updated", TRACK_COLOURS[c])
            for t in new for i, r, v, c in zip(t.track_id, t.range_m, t.velocity_mps, t.coasting)]
    if flat:
        keys = ("cycle", "range_m", "velocity_mps", "track", "status", "colour")
        m.tracks_src.stream(dict(zip(keys, (list(x) for x in zip(*flat)))), rollover=cfg.history)
    m.tracks_div.text = tracks_text(new[-1])


def _rd_plot(bm: Any, figure: Any, g: Geometry) -> tuple[Any, Any, Any]:
    """The range-Doppler map of the latest clean cycle: (figure, its image source, its caption)."""
    n_range = g.n_samples if g.iq else (g.n_samples - 1) // 2
    r_max = float(g.range_from_beat(n_range * g.fs_hz / g.n_samples))
    v_max = float(g.max_velocity_mps)
    mapper = bm.LinearColorMapper(palette="Viridis256", low=0.0, high=40.0)
    rd_src = bm.ColumnDataSource({"image": [np.zeros((2, 2), dtype=np.float32)], "x": [0.0], "y": [-v_max],
                                  "dw": [r_max], "dh": [2 * v_max]}, name="rd_map")
    rd_fig = figure(name="rd_plot", height=360, width=485, title="Range-Doppler map of the latest clean cycle",
                    x_axis_label="range (m)", y_axis_label="range rate (m/s)", x_range=(0, r_max),
                    y_range=(-v_max, v_max), tools="pan,wheel_zoom,box_zoom,reset")
    rd_fig.image("image", x="x", y="y", dw="dw", dh="dh", source=rd_src, color_mapper=mapper)
    rd_fig.add_layout(bm.ColorBar(color_mapper=mapper, title="power over noise (dB)"), "right")
    return rd_fig, rd_src, bm.Div(name="rd_text", text="no clean cycle yet")


def _swap_form(bm: Any, control: RunControl | None) -> tuple[Any, Any, Any, Any, Any, list[str]]:
    """The attacker's line and the form that swaps it: (attacker text, model select, RARMS spinner, button, swap
    log, the models offered)."""
    attacker_div = bm.Div(name="attacker", text="attacker: waiting for the run's status", width=470)
    choices = models()
    model_in = bm.Select(name="swap_model", title="attacker model", value=choices[0], options=choices, width=150)
    rarms_in = bm.Spinner(name="swap_rarms", title="RARMS (sigma_a / sigma_n)", value=3.0, low=0.0, step=0.1,
                          width=150)
    swap_button = bm.Button(name="swap_button", label="swap attacker", button_type="warning", width=150,
                            disabled=control is None)
    swap_div = bm.Div(name="swap_log", text="" if control else "swaps need the run's supervisor (carav run --view)")
    if control is not None:
        swap_button.on_click(lambda: control.swap(model_in.value, rarms_in.value))
    return attacker_div, model_in, rarms_in, swap_button, swap_div, choices


def _tables(bm: Any) -> tuple[Any, Any, Any, Any]:
    """The node and edge tables: (node table, its source, edge table, its source)."""
    node_src = bm.ColumnDataSource({k: [] for k in NODE_COLUMNS}, name="nodes")
    nodes = bm.DataTable(name="node_table", source=node_src, width=470, height=230, index_position=None, columns=[
        bm.TableColumn(field="node", title="node"), bm.TableColumn(field="block", title="block"),
        bm.TableColumn(field="state", title="state"), bm.TableColumn(field="cycles", title="cycles"),
        bm.TableColumn(field="frames_s", title="frames/s (last s)"),
        bm.TableColumn(field="cycles_s", title="cycles/s (last s)"),
        bm.TableColumn(field="restarts", title="restarts")])
    _redraw_on_new_data(bm, nodes)
    edge_src = bm.ColumnDataSource({k: [] for k in ("edge", "fill", "skipped")}, name="edges")
    # the page's width: the reason an edge reads beyond its capacity is a sentence
    edges = bm.DataTable(name="edge_table", source=edge_src, width=980, height=230, index_position=None, columns=[
        bm.TableColumn(field="edge", title="edge", width=230),
        bm.TableColumn(field="fill", title="in flight / queue capacity (why beyond it)", width=650),
        bm.TableColumn(field="skipped", title="skipped (tap)", width=100)])
    _redraw_on_new_data(bm, edges)
    return nodes, node_src, edges, edge_src


def _redraw_on_new_data(bm: Any, table: Any) -> None:
    """Make `table` redraw whenever its source's data is replaced. BokehJS's DataTable redraws on its CDSView's
    change, which fires only when the view's row indices change: new figures in the same rows left the rendered
    table as it was first drawn while its data moved on. The view's change, emitted here, is the one it listens to."""
    table.source.js_on_change("data", bm.CustomJS(args={"view": table.view}, code="view.change.emit()"))


def _update(m: _Models, state: ViewState, cfg: PageConfig) -> None:
    """What the page shows, brought up to `state`: new points and estimates, the threshold, the latest map and why
    the plots of clean cycles stand still, the tables and the attacker's form (when a new status came), the
    counters. Nothing while the tab has not shown the last update (view.sync)."""
    if m.sync.shown < m.sync.sent:
        return
    _draw_points(m, state, cfg)
    if m.tracks_src is not None:
        _draw_tracks(m, state, cfg)
    _draw_map(m, state, cfg)
    _draw_pause(m, state)
    update_scope(m.scope, state.ports)
    status, status_error = _draw_status(m, state, cfg)
    k = state.counts()
    skipped = sum(e.get("skipped", 0) for e in (status or {}).get("edges", {}).values())
    info_text = (f"latest cycle {k['last_cycle']} &middot; cycles run {(status or {}).get('cycles', 'n/a')} "
                 f"&middot; range-Doppler maps drawn {k['maps_drawn']}, clean frames not drawn "
                 f"{k['frames_not_drawn']} &middot; frames the taps skipped for display {skipped} (not lost)"
                 + (f" &middot; status: {status_error}" if status_error else ""))
    if m.info.text != info_text:
        m.info.text = info_text
    m.sync.sent += 1       # the update's last change: the tab acknowledges it once it has shown all of it


def _draw_points(m: _Models, state: ViewState, cfg: PageConfig) -> None:
    """The Q points and the estimates that came since the last update; the threshold once it is known."""
    pts, m.seen["points"], est, m.seen["estimates"] = state.since(m.seen["points"], m.seen["estimates"])
    for c in CATEGORIES:
        mine = [p for p in pts if p.category == c]
        if mine:
            m.q_src[c].stream({"cycle": [p.cycle for p in mine],
                               "q": [0.0 if p.q is None else p.q for p in mine],
                               "detail": [p.detail for p in mine], "attacked": [p.attacked for p in mine]},
                              rollover=cfg.history)
    if est:
        flat = [(e.cycle, r, v) for e in est for r, v in zip(e.range_m, e.velocity_mps)]
        if flat:
            c, r, v = zip(*flat)
            m.est_src.stream({"cycle": list(c), "range_m": list(r), "velocity_mps": list(v)}, rollover=cfg.history)
    eta = cfg.eta if cfg.eta is not None else state.eta
    if eta is not None and m.eta_line.location != eta:
        m.eta_line.location = eta
    text = ("" if eta is None else f"dashed line: the detector's threshold eta = {eta:g} (an alarm when Q >= eta)")
    if state.attacker is not None:       # a receiver array's: the attacker's direction the detector estimated
        text = f"{text}<br>{state.attacker[1]}" if text else state.attacker[1]
    if text and m.eta_div.text != text:
        m.eta_div.text = text


def _draw_map(m: _Models, state: ViewState, cfg: PageConfig) -> None:
    """The range-Doppler map of the latest clean cycle not drawn yet, if any."""
    latest = state.latest_clean(m.seen["map"])
    if latest is None:
        return
    m.seen["map"], cycle, x, rho = latest
    samples = from_codes(cfg.scene, np.asarray(x)[None])[0]
    db, ranges, velocities = rd_map_db(samples, np.asarray(rho, bool), cfg.geometry, cfg.scene.sigma_n)
    m.rd_src.data = {"image": [db], "x": [float(ranges[0])], "y": [float(velocities[0])],
                     "dw": [float(ranges[-1] - ranges[0])], "dh": [float(velocities[-1] - velocities[0])]}
    m.rd_div.text = f"cycle {cycle}: peak {float(db.max()):.1f} dB over the noise"
    state.drawn(m.seen["map"])


def _draw_pause(m: _Models, state: ViewState) -> None:
    """The line under the range and velocity plots: up to which clean cycle the plots of clean cycles go, and
    why they stand still."""
    text = pause_text(*state.paused())
    if m.pause_div.text != text:
        m.pause_div.text = text


def pause_text(last_clean: int, refused: dict[str, int]) -> str:
    """What the plots of clean cycles (range, velocity, range-Doppler) show up to, and, when the gate refused
    cycles after the latest clean one, that they paused and why: how many, by class."""
    n = sum(refused.values())
    if not n:
        return (f"range, velocity and range-Doppler plots: up to cycle {last_clean}, the latest clean cycle"
                if last_clean >= 0 else "no clean cycle yet")
    since = f"after cycle {last_clean}" if last_clean >= 0 else "from the start"
    by = ", ".join(f"{refused[c]} {REFUSALS[c]}" for c in REFUSALS if refused.get(c))
    return (f"<b>range, velocity and range-Doppler plots paused {since}</b>: the gate refused the {n} "
            f"cycle{'s' if n != 1 else ''} since ({by}; every cycle that reached the view)")


def _draw_status(m: _Models, state: ViewState, cfg: PageConfig) -> tuple[dict[str, Any] | None, str | None]:
    """The tables, the attacker's line and its form from a status the page has not drawn, and the swap log:
    returns (the latest status, the error of reading it)."""
    with state.lock:
        status, status_error, swaps = state.status, state.status_error, list(state.swap_log[-5:])
    if status is not None and status is not m.seen["status"]:   # a new one comes once a second: tables
        before, m.seen["status"] = m.seen["status"], status      # redrawn only then (the browser's work)
        recent = [p.attacked for p in state.recent(200)]
        on = (f"attack on in {sum(recent)} of the last {len(recent)} cycles shown" if recent
              else "no cycle shown yet")
        m.node_src.data = node_rows(status, before)
        m.edge_src.data = edge_rows(status)
        m.attacker_div.text = attacker_text(status, cfg.attacker, on)
        running = ((status.get("nodes", {}).get(cfg.attacker) or {}).get("params") or {})
        if running.get("model") in m.choices and running.get("model") != m.seen["model"]:
            # the form shows what runs whenever that changes (a swap from here, the CLI or a restart); a
            # choice the user is making in between is left alone
            m.seen["model"] = m.model_in.value = running["model"]
            if isinstance(running.get("rarms"), int | float):
                m.rarms_in.value = float(running["rarms"])
    if swaps and m.swap_div.text != "<br>".join(swaps):
        m.swap_div.text = "<br>".join(swaps)
    return status, status_error


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
