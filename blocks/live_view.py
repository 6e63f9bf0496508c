"""Live view: a browser page that watches the radar chain while it runs (`carav run GRAPH --view`).

A sink whose inputs are taps (block.In.tap): the gate's refusals, the estimator's estimates and the gate's clean
frames reach it only when it has room, so a slow or closed browser never slows the chain; what its taps skip is
counted as skipped (`skipped_by_taps` in the run summary), never as lost. The page (carav_stream/view, a Bokeh
server on a thread of this node, on loopback unless `address` says otherwise) shows, up to `update_hz` times a second
(a browser tab gets an update once it has shown the last one): Q per cycle against eta coloured by D0, D1, opt-in
detectors and fail-closed refusals; the range and velocity estimates against the scene's targets; the
range-Doppler map of the latest clean cycle, and why these stand still while the gate refuses cycles (how many,
by class); with a tracker (tracks = true), its confirmed tracks' range per cycle with their ids; the attacker's
model and RARMS with a form that swaps them through the same request as `carav swap`; the nodes' rates and the
edges' queue fill from `carav status`; the scope and the spectrum of any output port a tab chooses, copied by its
node on request (a port tap, never an edge: runtime/port_tap.py; private ports refused). The page's address
carries a per-run token and its websocket takes only the page's own origin (carav_stream/view/server.py).

Ports   in  alarms     header only (tap)      gate.alarms: per_cycle cycle_index, reason, q, raised_by, attack_active
        in  estimates  header only (tap)      range_estimator.estimates: per_cycle q, range_m, velocity_mps, ...
        in  clean      ADC frames + rho (tap) gate.clean: the latest is drawn as a range-Doppler map
        in  tracks     header only (tap)      tracker.tracks: per_cycle track_id, status, range_m, velocity_mps
Graph   view = { type = "live_view", port = 5006 }
"""
import os
import sys

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.streams import SCENE, scene_of
from carav_stream.runtime import Block, Frame, In, Param
from carav_stream.runtime.rundir import RUN_ID_ENV


class LiveView(Block):
    inputs = (In("alarms", kind="alarm", tap=True, required=False),
              In("estimates", kind="estimates", tap=True, required=False),
              In("clean", kind="clean_frame", tap=True, required=False),
              In("tracks", kind="tracks", tap=True, required=False))
    merge_inputs = True
    params = (SCENE,
              Param("address", str, "127.0.0.1", "address the page is served on (loopback: this machine only)"),
              Param("port", int, 5006, "TCP port of the page; 0 = any free port (printed)", low=0, high=65535),
              Param("token", str, "", "access token in the page's address (`carav run --view` draws one per run); "
                    "empty = a new one is drawn and the address printed"),
              Param("update_hz", float, 4.0, "page updates per second, at most", unit="Hz", low=0.2, high=50.0),
              Param("history", int, 2000, "cycles kept on the page's plots", unit="cycles", low=10),
              Param("attacker", str, "attacker", "node the page's swap form swaps"),
              Param("eta", float, 0.0, "threshold line on the Q plot; 0 = the eta the frames carry", low=0.0),
              Param("tracks", bool, False, "plot the tracker's confirmed tracks (the graph has a tracker wired to "
                    "the tracks input)"))

    def check_params(self) -> None:
        self.scene_obj = scene_of(self.scene)

    def start(self) -> None:
        # imported here, in the node's own process: the page needs Bokeh (the view extra), which `carav blocks` and
        # `carav validate`, reading this block's ports, must not need
        from carav_stream.view.control import RunControl
        from carav_stream.view.page import PageConfig, make_document
        from carav_stream.view.server import ViewServer
        from carav_stream.view.state import ViewState
        s = self.scene_obj
        self.state = ViewState(self.history)
        run_id = os.environ.get(RUN_ID_ENV)
        self.control = RunControl(run_id, self.attacker, self.state) if run_id else None
        cfg = PageConfig(scene=s, geometry=Geometry.from_scene(s), truth_range_m=[t.range_m for t in s.targets],
                         truth_velocity_mps=[s.range_rate_mps(t) for t in s.targets], eta=self.eta or None,
                         history=self.history, update_hz=self.update_hz, attacker=self.attacker,
                         title=f"carav live view: {run_id or 'run'} ({self.scene})", tracks=self.tracks)
        self.server = ViewServer(lambda doc: make_document(doc, self.state, self.control, cfg), self.address, self.port,
                                 self.token)
        self.server.start()
        if self.control is not None:
            self.control.start()
        print(f"live view: {self.server.url}", file=sys.stderr, flush=True)

    def process(self, alarms: Frame | None, estimates: Frame | None = None, clean: Frame | None = None,
                tracks: Frame | None = None) -> None:
        for port, frame in (("alarms", alarms), ("estimates", estimates), ("clean", clean), ("tracks", tracks)):
            if frame is not None:
                self.state.add(port, frame)

    def finish(self) -> None:
        if self.control is not None:
            self.control.stop()
        self.server.stop()

    def summary(self) -> dict:
        return {"view": {"url": self.server.url, **self.state.counts()}}
