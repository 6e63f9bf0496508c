"""The live view's page as Bokeh models, without a browser: one update draws the points by class, the estimates,
the threshold the frames carry, the map of the latest clean cycle, why the plots of clean cycles paused, the tables
and the attacker's form from a new status, and the counters; a second update with nothing new changes nothing; a
tab gets no update before it has shown the last one; no legend sits over a plot; a table redraws on new data."""
import numpy as np
import pytest

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from carav_stream.view.page import PageConfig, make_document
from carav_stream.view.state import CATEGORIES, ViewState
from tests.blocks.helpers import wire
from tests.view.test_state import alarms, estimates, tracks

document = pytest.importorskip("bokeh.document")       # the view extra
Legend = pytest.importorskip("bokeh.models").Legend


def status(model: str) -> dict:
    return {"elapsed_s": 2.0, "cycles": 64, "edges": {"a.out -> b.inp": {"in_flight": 1, "capacity": 8, "skipped": 3}},
            "nodes": {"attacker": {"block": "attacker", "alive": True, "restarts": 0, "cycles_total": 64,
                                   "processed": 2, "cycles_per_s": 32.0, "rate_per_s": 1.0,
                                   "params": {"model": model, "rarms": 2.5}}}}


def page(state: ViewState, eta: float | None = None, with_tracks: bool = False, control=None, doc=None):
    scene = scene_of("table1")
    cfg = PageConfig(scene=scene, geometry=Geometry.from_scene(scene),
                     truth_range_m=[t.range_m for t in scene.targets],
                     truth_velocity_mps=[scene.range_rate_mps(t) for t in scene.targets], eta=eta, history=100,
                     update_hz=10.0, attacker="attacker", title="test page", tracks=with_tracks)
    doc = doc or document.Document()
    make_document(doc, state, control, cfg)
    (callback,) = doc.session_callbacks
    return doc, callback.callback, scene


def shown(doc) -> None:
    """What the browser does once it has shown an update: acknowledge it (view.sync)."""
    sync = doc.get_model_by_name("page_sync")
    sync.shown = sync.sent


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
    assert doc.get_model_by_name("pause_text").text == (
        "range, velocity and range-Doppler plots: up to cycle 3, the latest clean cycle")
    drawn = {name: data(name) for name in ("q_D1", "q_clean", "estimates", "rd_map", "nodes")}
    shown(doc)
    update()
    assert {name: data(name) for name in drawn} == drawn and state.counts()["maps_drawn"] == 1


def test_a_tab_gets_no_update_before_it_has_shown_the_last_one_and_then_gets_all_that_came_meanwhile():
    state = ViewState(history=100)
    doc, update, _ = page(state)
    sync, q_d0 = doc.get_model_by_name("page_sync"), doc.get_model_by_name("q_D0")
    state.add("alarms", alarms([0], ["attack"], ["D0"], [3.0], [True]))
    update()
    assert list(q_d0.data["cycle"]) == [0] and (sync.sent, sync.shown) == (1, 0)
    state.add("alarms", alarms([1], ["attack"], ["D0"], [3.1], [True], seq=1))
    state.status = status("smart")
    update()
    update()                                   # the browser is still busy with the first: it is left alone
    assert list(q_d0.data["cycle"]) == [0] and doc.get_model_by_name("nodes").data["node"] == []
    assert sync.sent == 1
    state.add("alarms", alarms([2], ["attack"], ["D0"], [3.2], [True], seq=2))
    shown(doc)
    update()
    assert list(q_d0.data["cycle"]) == [0, 1, 2] and list(doc.get_model_by_name("nodes").data["node"]) == ["attacker"]
    assert (sync.sent, sync.shown) == (2, 1)


def test_the_plots_of_clean_cycles_say_they_paused_and_how_many_cycles_the_gate_refused_since():
    state = ViewState(history=10)
    doc, update, _ = page(state)
    update()
    assert doc.get_model_by_name("pause_text").text == "no clean cycle yet"
    state.add("estimates", estimates([0, 1], [1.0, 1.0], [[43.0], [43.0]], [[1.0], [1.0]]))
    for k in range(5):    # more refused cycles than the page keeps points of
        state.add("alarms", alarms(list(range(2 + 4 * k, 6 + 4 * k)), ["attack", "attack", "attack", "no_verdict"],
                                   ["D0", "D0", "D1", None], [3.0, 3.0, 2.0, None], [True] * 4, seq=1 + k))
    shown(doc)
    update()
    assert doc.get_model_by_name("pause_text").text == (
        "<b>range, velocity and range-Doppler plots paused after cycle 1</b>: the gate refused the 20 cycles since "
        "(10 alarms by D0, 5 alarms by D1, 5 refusals without a verdict; every cycle that reached the view)")


def test_no_legend_sits_over_a_plot():
    doc, _, _ = page(ViewState(history=10), with_tracks=True)
    for name in ("q_plot", "range_plot", "velocity_plot", "rd_plot", "tracks_plot"):
        fig = doc.get_model_by_name(name)
        assert not [r for r in fig.center if isinstance(r, Legend)], name
    q = doc.get_model_by_name("q_plot")
    assert doc.get_model_by_name("q_legend") in q.right
    assert len(doc.get_model_by_name("q_legend").items) == len(CATEGORIES)


def test_a_table_redraws_whenever_its_data_is_replaced_not_only_when_its_rows_change():
    doc, _, _ = page(ViewState(history=10))
    for name in ("node_table", "edge_table"):
        table = doc.get_model_by_name(name)
        (redraw,) = table.source.js_property_callbacks["change:data"]
        # the change of the table's own view is what BokehJS's DataTable redraws on
        assert redraw.args == {"view": table.view} and redraw.code == "view.change.emit()"


def test_a_threshold_given_to_the_page_wins_over_the_frames():
    state = ViewState(history=100)
    doc, update, _ = page(state, eta=2.0)
    state.add("estimates", estimates([0], [1.0], [[40.0]], [[1.0]]))
    update()
    assert doc.get_model_by_name("eta_line").location == 2.0


def test_with_a_tracker_the_page_plots_each_confirmed_tracks_range_with_its_id_and_says_the_latest_in_words():
    state = ViewState(history=100)
    doc, update, _ = page(state, with_tracks=True)
    update()
    assert doc.get_model_by_name("tracks_text").text == "no confirmed track yet"
    state.add("tracks", tracks([0, 1, 2], [[0], [0, 4], [0, 4]], [["confirmed"], ["coasting", "tentative"],
                                                                  ["confirmed", "confirmed"]],
                               [[43.0], [43.01, 30.0], [43.02, 30.1]], [[0.0], [0.01, 27.0], [0.0, 26.9]]))
    shown(doc)
    update()
    data = doc.get_model_by_name("tracks").data
    assert list(data["cycle"]) == [0, 1, 2, 2] and list(data["track"]) == ["0", "0", "0", "4"]
    assert list(data["status"]) == ["updated", "coasting", "updated", "updated"]
    assert list(data["range_m"]) == [43.0, 43.01, 43.02, 30.1]
    assert doc.get_model_by_name("tracks_text").text == (
        "cycle 2: track 0 at 43.02 m, +0.00 m/s (updated); track 4 at 30.10 m, +26.90 m/s (updated)")
    shown(doc)
    update()                                                  # nothing new: nothing drawn twice
    assert len(doc.get_model_by_name("tracks").data["cycle"]) == 4


def test_without_a_tracker_the_page_has_no_tracks_plot():
    doc, _, _ = page(ViewState(history=10))
    assert doc.get_model_by_name("tracks_plot") is None and doc.get_model_by_name("tracks_text") is None
