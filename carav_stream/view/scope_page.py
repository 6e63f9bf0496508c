"""The live view's scope and spectrum (one panel per browser tab): any output port of the running graph, tapped
while it runs (view.tap, runtime/port_tap.py), as GNU Radio's time and frequency sinks show a stream.

The panel: a port selector (every output port of the nodes on the view's host, `node.port (kind)`, the private
ones named so: the supervisor refuses to tap them), a chirp and a receiver selector when the frame has those axes,
the scope (the chosen chirp's samples against fast time, I and Q), the spectrum (view.scope.spectrum_db against
frequency at the scene's sample rate, with range on a second axis for the ADC's and channel's frames), and a line
with the tap's rate and the frames of the port the page skipped, and where.

The port chosen is checked against the ports listed before anything is asked (a browser can send any value).
The tap is this tab's: another port, or the tab's session ending, stops it; a tab closed without a word lets its
lease run out. A copy is shown once the tab has shown the update before it (view.sync); what came meanwhile is
dropped and counted (view.tap.TapSlot).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from carav_stream.view.scope import RANGE_KINDS, beat_range_m, layout, spectrum_db, time_axis_us, trace
from carav_stream.view.tap import TapCopy, TapWatch

TAP_HZ = 4.0          # copies a second a page asks for, at most (and at most its own update rate)
NONE = ""             # the selector's value while no port is tapped
# keeps the range axis above the spectrum in step with its frequency axis while the user zooms or pans
RANGE_FOLLOWS = "r.start = x.start * k; r.end = x.end * k;"


@dataclass
class ScopePanel:
    """The panel's models, the tab's tap, and what it shows."""
    models: dict[str, Any]
    ask: Any                                  # the admin tap request (RunControl.tap), or None without a run
    scene: Any
    geometry: Any
    rate_hz: float
    ports: dict[str, dict[str, Any]] = field(default_factory=dict)   # "node.port" -> its listing
    watch: TapWatch | None = None
    current: TapCopy | None = None
    drawn: tuple | None = None                # what the plots show: (copy, chirp, rx)

    def choose(self, value: str) -> None:
        """Tap the port `value` ("node.port", one listed) instead of the one before; NONE stops tapping."""
        self.close()
        self.current = self.drawn = None
        m = self.models
        m["scope"].data = {"t_us": [], "i": [], "q": []}
        m["spectrum"].data = {"f_mhz": [], "db": []}
        if value == NONE:
            m["text"].text = "no port tapped"
            return
        if value not in self.ports or self.ask is None:
            m["text"].text = f"{value!r} is not a port of this run's graph"
            return
        p = self.ports[value]
        self.watch = TapWatch(self.ask, p["node"], p["port"], self.rate_hz).start()
        m["text"].text = f"tapping {value}: waiting for its first copy"

    def close(self) -> None:
        if self.watch is not None:
            self.watch.stop()
            self.watch = None


def scope_panel(bm: Any, figure: Any, cfg: Any, ask: Any) -> tuple[Any, ScopePanel]:
    """The panel's layout and its state for one tab; `ask(**fields)` is the run's admin tap request (None without
    a run: the selector is disabled)."""
    from bokeh.layouts import column, row
    select = bm.Select(name="scope_port", title="tap a port (node.port, stream kind)", value=NONE,
                       options=[(NONE, "none")], width=330, disabled=ask is None)
    chirp = bm.Spinner(name="scope_chirp", title="chirp", value=0, low=0, step=1, width=90, visible=False)
    rx = bm.Spinner(name="scope_rx", title="receiver", value=0, low=0, step=1, width=90, visible=False)
    text = bm.Div(name="scope_text", text="no port tapped" if ask else "port taps need the run's supervisor "
                  "(carav run --view)", width=980)
    scope_src = bm.ColumnDataSource({"t_us": [], "i": [], "q": []}, name="scope")
    scope_fig = figure(name="scope_plot", height=300, width=485, title="Scope: one chirp of the latest tapped cycle",
                       x_axis_label="fast time (us)", y_axis_label="amplitude (sqrt(W) for ADC codes)",
                       tools="pan,wheel_zoom,box_zoom,reset")
    scope_fig.add_layout(bm.Legend(orientation="horizontal"), "below")
    scope_fig.line("t_us", "i", source=scope_src, legend_label="I (real part)", color="#1f77b4")
    scope_fig.line("t_us", "q", source=scope_src, legend_label="Q (imaginary part; I/Q samples)",
                   color="#ff7f0e")
    spec_src = bm.ColumnDataSource({"f_mhz": [], "db": []}, name="spectrum")
    spec_fig = figure(name="spectrum_plot", height=300, width=485, title="Spectrum of the same samples",
                      x_axis_label="frequency (MHz)", y_axis_label="power (dB, Hann window)",
                      x_range=bm.Range1d(0.0, 1.0, name="spectrum_x"), tools="pan,wheel_zoom,box_zoom,reset")
    spec_fig.line("f_mhz", "db", source=spec_src)
    k = float(cfg.geometry.range_per_hz_m) * 1e6            # metres per MHz of beat
    spec_fig.extra_x_ranges = {"range": bm.Range1d(0.0, k, name="spectrum_range")}
    range_axis = bm.LinearAxis(name="range_axis", x_range_name="range", axis_label="range of the beat (m)",
                               visible=False)
    spec_fig.add_layout(range_axis, "above")
    follow = bm.CustomJS(args={"x": spec_fig.x_range, "r": spec_fig.extra_x_ranges["range"], "k": k},
                         code=RANGE_FOLLOWS)
    spec_fig.x_range.js_on_change("start", follow)
    spec_fig.x_range.js_on_change("end", follow)
    models = {"select": select, "chirp": chirp, "rx": rx, "text": text, "scope": scope_src, "spectrum": spec_src,
              "spec_fig": spec_fig, "range_axis": range_axis}
    panel = ScopePanel(models, ask, cfg.scene, cfg.geometry, min(TAP_HZ, cfg.update_hz))
    select.on_change("value", lambda attr, old, new: panel.choose(new))
    return column(row(select, chirp, rx), text, row(scope_fig, spec_fig)), panel


def port_options(ports: list[dict[str, Any]]) -> list[tuple[str, str]]:
    """The selector's entries for the run's listed output ports."""
    def label(p: dict[str, Any]) -> str:
        notes = [p["kind"], *(["private: not tapped"] if p.get("private") else []),
                 *(["no edge"] if not p.get("edges") else [])]
        return f"{p['node']}.{p['port']} ({', '.join(notes)})"
    return [(NONE, "none"), *((f"{p['node']}.{p['port']}", label(p)) for p in ports)]


def update_scope(panel: ScopePanel, ports: list[dict[str, Any]] | None) -> None:
    """The panel brought up to date: the ports listed once the run gave them, the copy the tap brought since the
    tab showed the last one, the line of counts."""
    m = panel.models
    if ports is not None and not panel.ports:
        panel.ports = {f"{p['node']}.{p['port']}": p for p in ports}
        m["select"].options = port_options(ports)
    if panel.watch is None:
        return
    slot = panel.watch.slot
    slot.shown()                  # the update before this one was shown (view.sync): the next copy may come
    copy = slot.take()
    if copy is not None:
        panel.current = copy
    chosen = (panel.current, int(m["chirp"].value or 0), int(m["rx"].value or 0))
    if panel.current is not None and chosen != panel.drawn:
        panel.drawn = chosen
        _draw(panel, *chosen)
    text = tap_line(f"{panel.watch.node}.{panel.watch.port}", panel.ports, slot.stats(), panel.rate_hz,
                    panel.current, _where(panel))
    if m["text"].text != text:
        m["text"].text = text


def _draw(panel: ScopePanel, copy: TapCopy, chirp: int, rx: int) -> None:
    """The scope and the spectrum of `chirp` (receiver `rx`) of the copy's frame."""
    m, payload = panel.models, copy.frame.payload
    lay = None if payload is None else layout(payload.shape, payload.dtype, bool(panel.scene.iq))
    for name, n in (("chirp", lay.n_chirps if lay else 0), ("rx", lay.n_rx if lay else 0)):
        if m[name].visible != bool(n) or (n and m[name].high != n - 1):
            m[name].visible, m[name].high = bool(n), max(n - 1, 0)
    if lay is None:
        m["scope"].data = {"t_us": [], "i": [], "q": []}
        m["spectrum"].data = {"f_mhz": [], "db": []}
        return
    x = trace(payload, lay, panel.scene, chirp, rx)
    fs = float(panel.scene.fs_hz)
    ranged = panel.ports.get(copy.frame.header.get("stream", ""), {}).get("kind") in RANGE_KINDS
    freqs, db = spectrum_db(x, fs, fft_order=ranged)
    m["scope"].data = {"t_us": time_axis_us(len(x), fs), "i": np.real(x),
                       "q": np.imag(x) if np.iscomplexobj(x) else np.full(len(x), np.nan)}
    m["spectrum"].data = {"f_mhz": freqs / 1e6, "db": db}
    x_range, r_range = m["spec_fig"].x_range, m["spec_fig"].extra_x_ranges["range"]
    lo, hi = float(freqs[0]) / 1e6, float(freqs[-1]) / 1e6
    if (x_range.start, x_range.end) != (lo, hi):
        x_range.start, x_range.end = lo, hi
        r_start, r_end = beat_range_m(np.array([lo, hi]) * 1e6, panel.geometry)
        r_range.start, r_range.end = float(r_start), float(r_end)
    if m["range_axis"].visible != ranged:
        m["range_axis"].visible = ranged


def _where(panel: ScopePanel) -> str:
    """Which cycle, chirp and receiver the plots show."""
    copy = panel.current
    if copy is None or panel.drawn is None:
        return ""
    h, payload = copy.frame.header, copy.frame.payload
    first = (copy.info.get("rows") or [0])[0]
    per = h.get("per_cycle") or {}
    index = per.get("cycle_index")
    cycle = index[first] if isinstance(index, list) and 0 <= first < len(index) else h.get("cycle", 0) + first
    lay = None if payload is None else layout(payload.shape, payload.dtype, bool(panel.scene.iq))
    if lay is None:
        what = "header only: no samples to show" if payload is None else (
            f"payload {payload.dtype} {tuple(payload.shape)}: no fast-time axis to show")
        return f"cycle {cycle}, {what}"
    _, chirp, rx = panel.drawn
    parts = [f"cycle {cycle}"]
    if lay.n_chirps:
        parts.append(f"chirp {min(chirp, lay.n_chirps - 1)} of {lay.n_chirps}")
    if lay.n_rx:
        parts.append(f"receiver {min(rx, lay.n_rx - 1)} of {lay.n_rx}")
    return ", ".join(parts)


def tap_line(name: str, ports: dict[str, dict[str, Any]], s: dict[str, Any], rate_hz: float,
             current: TapCopy | None, where: str) -> str:
    """The line under the selector: the port, what the plots show, the tap's rate, and the frames of the port
    the page skipped since its first copy, by where."""
    kind = ports.get(name, {}).get("kind", "?")
    if s["error"]:
        return f"tap of <b>{name}</b> ({kind}): {s['error']}"
    if current is None:
        return f"tapping <b>{name}</b> ({kind}): waiting for its first copy"
    page = max(0, s["received"] - s["shown"])      # dropped while showing, replaced, or the one waiting
    return (f"<b>{name}</b> ({kind}): {where} &middot; tap at most {rate_hz:g} frames/s, shown "
            f"{s['shown_hz']:.1f}/s &middot; skipped {s['skipped']} of the {s['frames']} frames the port sent since "
            f"the first copy here ({s['at_node']} between the node's samples, {s['in_transit']} in transit, {page} "
            f"on this page: {s['dropped_showing']} came while it showed the one before"
            + (f", {s['unreadable']} unreadable" if s["unreadable"] else "") + ")")
