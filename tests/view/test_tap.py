"""A page's port tap (view.tap, view.scope_page), without a browser: a copy that arrives while the page shows the one
before is dropped and counted, the frames the page skipped are counted by where; a watch asks the supervisor for
its tap, renews it, receives the node's copies and ends it; a refused tap says why; the panel lists the run's
ports, taps only one of them, and draws the scope and the spectrum of what comes."""
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.adc import adc_codes
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from carav_stream.runtime.port_tap import PortTaps, tap_endpoint
from carav_stream.view import tap as view_tap
from carav_stream.view.state import ViewState
from carav_stream.view.tap import TapSlot, TapWatch

DEADLINE_S = 20.0


def info(frames, sent, incarnation=0):
    return {"port": "frames", "frames": frames, "sent": sent, "rate_hz": 4.0, "rows": [31, 32],
            "incarnation": incarnation}


def wait_for(what, check):
    deadline = time.monotonic() + DEADLINE_S
    while not (got := check()):
        assert time.monotonic() < deadline, f"waited {DEADLINE_S} s for {what}"
        time.sleep(0.01)
    return got


def test_a_copy_that_arrives_while_the_page_shows_the_one_before_is_dropped_and_counted():
    slot, f = TapSlot(), Frame({})
    slot.arrived(info(1, 1), f)
    first = slot.take()
    assert first is not None and slot.take() is None          # one at a time
    slot.arrived(info(5, 2), f)                                # the page is still showing the first
    assert slot.take() is None and slot.stats()["dropped_showing"] == 1
    slot.shown()
    slot.arrived(info(9, 3), f)
    slot.arrived(info(13, 4), f)                               # a newer one before the page took it
    assert slot.take().info["frames"] == 13 and slot.stats()["replaced"] == 1
    s = slot.stats()
    assert (s["frames"], s["sent"], s["received"], s["shown"]) == (13, 4, 4, 2)
    assert s["skipped"] == 11 and s["at_node"] == 9 and s["in_transit"] == 0


def test_the_counts_carry_on_across_a_restarted_node_and_copies_lost_in_transit_are_counted():
    slot, f = TapSlot(), Frame({})
    slot.arrived(info(10, 3), f)          # the page's first copy: its counts start here
    slot.arrived(info(20, 6), f)          # copies 4 and 5 never came
    slot.arrived(info(2, 1, incarnation=1), f)     # the node restarted: its counts start afresh
    s = slot.stats()
    assert s["frames"] == 11 + 2 and s["sent"] == 4 + 1 and s["received"] == 3 and s["in_transit"] == 2


@pytest.fixture
def run_dir():
    d = Path(tempfile.mkdtemp(prefix="vt", dir="/tmp"))
    yield d
    shutil.rmtree(d, ignore_errors=True)


class Supervisor:
    """The admin tap request as the supervisor answers it, passed to a node's PortTaps as its control would be."""

    def __init__(self, run_dir, refuse: str = ""):
        import zmq
        self.ctx = zmq.Context()
        self.taps = PortTaps(self.ctx, "adc")
        self.run_dir, self.refuse, self.asked = run_dir, refuse, []

    def ask(self, **fields):
        self.asked.append(fields)
        if self.refuse:
            return {"ok": False, "error": self.refuse}
        fields = {**fields, "endpoint": tap_endpoint(self.run_dir, fields["node"])}
        self.taps.apply({k: v for k, v in fields.items() if k != "node"})
        return {"ok": True, "topic": f"{fields['node']}.{fields['port']}", **fields}

    def send(self, frame, seq):
        """The node sends `frame` on adc.frames, a copy due each time."""
        if "frames" in self.taps.ports:
            self.taps.ports["frames"].next_at = 0.0
            self.taps.offer("frames", {"stream": "adc.frames", "seq": seq, "cycle": 32 * seq, "cycles": 32}, frame)

    def close(self):
        self.taps.close()
        self.ctx.term()


def test_a_watch_asks_for_its_tap_receives_the_copies_renews_and_ends_it(run_dir, monkeypatch):
    monkeypatch.setattr(view_tap, "RENEW_S", 0.05)
    sup = Supervisor(run_dir)
    watch = TapWatch(sup.ask, "adc", "frames", 4.0).start()
    frame = Frame({}, {"data": np.arange(2 * 3 * 8, dtype=np.int16).reshape(2, 3, 8)})
    seq = 0

    def arrived():
        nonlocal seq
        sup.send(frame, seq)
        seq += 1
        return watch.slot.stats()["received"] >= 1 and len(sup.asked) >= 3
    wait_for("a copy and two renewals", arrived)
    copy = watch.slot.take()
    np.testing.assert_array_equal(copy.frame.payload, frame.payload[1:])
    assert copy.frame.header["stream"] == "adc.frames" and copy.info["rows"] == [1, 2]
    assert sup.asked[0] == {"node": "adc", "port": "frames", "rate_hz": 4.0, "rows": 1, "for_s": view_tap.LEASE_S}
    watch.stop()
    watch.thread.join(DEADLINE_S)
    assert sup.asked[-1]["for_s"] == 0.0 and "frames" not in sup.taps.ports     # ended at once, not by its lease
    sup.close()


def test_a_refused_tap_says_why_and_is_not_asked_again(run_dir):
    sup = Supervisor(run_dir, refuse="source.rho is private: its frames go only where the graph's edges take them")
    watch = TapWatch(sup.ask, "source", "rho", 4.0).start()
    watch.thread.join(DEADLINE_S)
    assert not watch.thread.is_alive() and len(sup.asked) == 1
    assert watch.slot.stats()["error"].startswith("refused: source.rho is private")
    sup.close()


document = pytest.importorskip("bokeh.document")       # the view extra


def test_the_panel_taps_a_listed_port_draws_its_scope_and_spectrum_and_says_what_it_skipped(run_dir):
    from tests.view.test_document import page, shown
    scene = scene_of("table1")
    sup = Supervisor(run_dir)
    state = ViewState(history=100)
    control = type("Control", (), {"tap": staticmethod(sup.ask)})()
    doc, update, _ = page(state, control=control)
    state.ports = [{"node": "adc", "port": "frames", "kind": "adc_frame", "dtypes": ["int16"], "private": False,
                    "edges": 2},
                   {"node": "source", "port": "rho", "kind": "rho", "dtypes": ["bool"], "private": True, "edges": 1}]
    update()
    select = doc.get_model_by_name("scope_port")
    assert [v for v, _ in select.options] == ["", "adc.frames", "source.rho"]
    assert "private: not tapped" in dict(select.options)["source.rho"]
    select.value = "nowhere.out"                                   # a value no option has: nothing is asked
    assert "not a port of this run's graph" in doc.get_model_by_name("scope_text").text and not sup.asked
    select.value = "adc.frames"
    rho = balanced_rows(np.random.default_rng(1), 2, scene.n_chirps)
    codes, _, _ = adc_codes(scene, simulate_cycles(scene, rho, np.random.default_rng(2)).frames, None)
    frame, seq = Frame({}, {"data": codes, "rho": rho}), 0
    text = doc.get_model_by_name("scope_text")

    def drawn():
        nonlocal seq
        sup.send(frame, seq)
        seq += 1
        shown(doc)
        update()
        return len(doc.get_model_by_name("spectrum").data["db"]) and "shown" in text.text
    wait_for("the scope and the spectrum", drawn)
    scope = doc.get_model_by_name("scope").data
    assert len(scope["t_us"]) == scene.n_samples and np.isnan(scope["q"]).all()     # I-only: no Q
    assert len(doc.get_model_by_name("spectrum").data["f_mhz"]) == scene.n_samples // 2 + 1
    assert doc.get_model_by_name("range_axis").visible and doc.get_model_by_name("scope_chirp").visible
    assert doc.get_model_by_name("scope_chirp").high == scene.n_chirps - 1
    assert not doc.get_model_by_name("scope_rx").visible
    assert "adc.frames</b> (adc_frame): cycle " in text.text and "chirp 0 of 64" in text.text
    assert "tap at most 4 frames/s" in text.text and "skipped" in text.text
    doc.get_model_by_name("scope_chirp").value = 5
    shown(doc)
    update()
    assert "chirp 5 of 64" in text.text
    select.value = ""                                              # stop tapping: the supervisor is told
    wait_for("the tap's end", lambda: sup.asked[-1]["for_s"] == 0.0)
    assert text.text == "no port tapped"
    sup.close()


def test_the_panel_without_a_run_offers_no_tap():
    from tests.view.test_document import page
    doc, _, _ = page(ViewState(history=10))
    assert doc.get_model_by_name("scope_port").disabled
    assert "need the run's supervisor" in doc.get_model_by_name("scope_text").text


def test_only_one_copy_is_drawn_per_update_the_tab_has_shown():
    """Copies keep arriving on the watch's thread while the page draws: the page takes one when the tab has
    shown the last update, and the others are dropped or replaced, and counted."""
    slot = TapSlot()
    stop = threading.Event()

    def feed():
        k = 0
        while not stop.is_set():
            k += 1
            slot.arrived(info(k, k), Frame({}))
            time.sleep(0.001)
    threading.Thread(target=feed, daemon=True).start()
    taken = []
    for _ in range(20):
        got = wait_for("a copy", slot.take)
        taken.append(got.info["frames"])
        slot.shown()
    stop.set()
    s = slot.stats()
    assert taken == sorted(taken) and s["shown"] == 20
    assert s["received"] == s["shown"] + s["dropped_showing"] + s["replaced"] + (slot.pending is not None)
