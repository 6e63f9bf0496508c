"""The live view's page as Bokeh models, without a browser: one update draws the points by class, the estimates,
the threshold the frames carry, the map of the latest clean cycle, the tables and the attacker's form from a new
status, and the counters; a second update with nothing new changes nothing."""
import numpy as np
import pytest

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from carav_stream.view.page import PageConfig, make_document
from carav_stream.view.state import ViewState
from tests.blocks.helpers import wire
from tests.view.test_state import alarms, estimates

document = pytest.importorskip("bokeh.document")       # the view extra


def status(model: str) -> dict:
    return {"elapsed_s": 2.0, "cycles": 64, "edges": {"a.out -> b.inp": {"in_flight": 1, "capacity": 8, "skipped": 3}},
            "nodes": {"attacker": {"block": "attacker", "alive": True, "restarts": 0, "cycles_total": 64,
                                   "processed": 2, "cycles_per_s": 32.0, "rate_per_s": 1.0,
                                   "params": {"model": model, "rarms": 2.5}}}}


def page(state: ViewState, eta: float | None = None):
    scene = scene_of("table1")
    cfg = PageConfig(scene=scene, geometry=Geometry.from_scene(scene),
                     truth_range_m=[t.range_m for t in scene.targets],
                     truth_velocity_mps=[scene.range_rate_mps(t) for t in scene.targets], eta=eta, history=100,
                     update_hz=10.0, attacker="attacker", title="test page")
    doc = document.Document()
    make_document(doc, state, None, cfg)
    (callback,) = doc.session_callbacks
    return doc, callback.callback, scene


def test_one_update_draws_what_came_and_a_second_with_nothing_new_changes_nothing():
    state = ViewState(history=100)
    doc, update, scene = page(state)
    assert doc.title == "test page" and doc.get_model_by_name("swap_button").disabled
    assert np.isnan(doc.get_model_by_name("eta_line").location)
    state.add("alarms", alarms([0, 1], ["attack", "no_verdict"], ["D1", None], [3.2, None], [True, True]))
    state.add("estimates", estimates([2, 3], [1.01, 0.98], [[43.0, 80.5], []], [[-1.1, 2.0], []], seq=1))
    rho = balanced_rows(np.random.default_rng(1), 1, scene.n_chirps)
    x = simulate_cycles(scene, rho, np.random.default_rng(2)).frames
    state.add("clean", wire(Frame(dict(cycles=1, per_cycle={"cycle_index": [3]}), {"data": x, "rho": rho}), 2))
    state.status = status("smart")
    update()

    def data(name: str) -> dict:
        return {k: list(v) for k, v in doc.get_model_by_name(name).data.items()}

    assert data("q_D1") == {"cycle": [0], "q": [3.2], "detail": ["D1"], "attacked": [True]}
    assert data("q_refused") == {"cycle": [1], "q": [0.0], "detail": ["no_verdict"], "attacked": [True]}
    assert data("q_clean")["cycle"] == [2, 3]
    assert data("estimates") == {"cycle": [2, 2], "range_m": [43.0, 80.5], "velocity_mps": [-1.1, 2.0]}
    assert doc.get_model_by_name("eta_line").location == 1.5
    assert "eta = 1.5" in doc.get_model_by_name("eta_text").text
    assert doc.get_model_by_name("rd_text").text.startswith("cycle 3: peak ")
    assert np.asarray(data("rd_map")["image"][0]).shape[0] == scene.n_chirps and state.counts()["maps_drawn"] == 1
    assert data("nodes")["node"] == ["attacker"] and data("edges")["fill"] == ["1 / 8"]
    assert "model <b>smart</b>" in doc.get_model_by_name("attacker").text
    assert doc.get_model_by_name("swap_model").value == "smart" and doc.get_model_by_name("swap_rarms").value == 2.5
    info = doc.get_model_by_name("info").text
    assert "latest cycle 3" in info and "cycles run 64" in info and "frames the taps skipped for display 3" in info
    drawn = {name: data(name) for name in ("q_D1", "q_clean", "estimates", "rd_map", "nodes")}
    update()
    assert {name: data(name) for name in drawn} == drawn and state.counts()["maps_drawn"] == 1


def test_a_threshold_given_to_the_page_wins_over_the_frames():
    state = ViewState(history=100)
    doc, update, _ = page(state, eta=2.0)
    state.add("estimates", estimates([0], [1.0], [[40.0]], [[1.0]]))
    update()
    assert doc.get_model_by_name("eta_line").location == 2.0
