"""`carav run --view` in a real headless browser (Debian's Chromium driven by Selenium): the page loads, its plots
update while the graph runs, and a swap made from the page reaches the attacker node, shows in `carav status` and
in the run summary, and the alarms follow it; a tracker's confirmed tracks are drawn with their ids. On a machine
loaded by two processes spinning on its two cores, the tables as drawn follow the run, the plots of clean cycles
that paused say why with the count of refused cycles, and no legend sits over a plot. CI installs the browser
(.ci/run); a local run without one skips these tests and says why. A port chosen in the page's port selector shows
its scope and spectrum while the graph runs, and a private port is refused."""
import json
import os
import re
import socket
import subprocess
import sys
import urllib.error
import urllib.request

import pytest

from bench.browser import DEEP_FIND, headless_chromium, missing, model
from carav_stream.node_start import parent_death_signal
from carav_stream.view.server import free_port
from tests.integration.conftest import PACED, ROOT, wait_until

pytestmark = pytest.mark.integration
BATCH = 32   # table1_smart's cycles per frame (radar_chain.toml)
ATTACK_FROM = 100   # table1_smart's attacker switches on at this cycle, and the gate refuses every cycle from there
# The cells of the row of node arguments[0] as the node table draws them (SlickGrid rows in Bokeh's shadow roots),
# or null: what a user reads, not the table's data.
DRAWN_ROW = """const rows = [];
(function walk(root) {
  for (const el of root.querySelectorAll('.slick-row'))
    rows.push([...el.querySelectorAll('.slick-cell')].map(c => c.textContent.trim()));
  for (const el of root.querySelectorAll('*')) if (el.shadowRoot) walk(el.shadowRoot);
})(document);
return rows.find(cells => cells[0] === arguments[0]) || null;"""
# For each figure named in arguments[0]: how many legends sit in its center (over the plot) and in its side panels.
LEGENDS = """const doc = Bokeh.documents[0]; const out = {};
for (const name of arguments[0]) {
  const fig = doc.get_model_by_name(name); out[name] = {};
  for (const side of ["center", "left", "right", "above", "below"])
    out[name][side] = fig[side].filter(r => r.constructor.__name__ === "Legend").length;
}
return out;"""


SELECT_OFFERING = """const want = arguments[0] + " "; let found = null;
(function walk(root) {
  for (const el of root.querySelectorAll('select')) {
    const o = [...el.options].find(o => o.text.startsWith(want)); if (!found && o) found = [el, o.text];
  }
  for (const el of root.querySelectorAll('*')) if (el.shadowRoot) walk(el.shadowRoot);
})(document);
return found;"""
# Column arguments[1] of the data source named arguments[0] as a plain list (numpy's arrays arrive as typed arrays).
COLUMN = """const m = Bokeh.documents[0].get_model_by_name(arguments[0]);
return m && m.data[arguments[1]] ? Array.from(m.data[arguments[1]]) : null;"""

def browser():
    """A headless Chromium, or a skip (a fail under CI, which must run this test) naming what is missing."""
    lacking = missing()
    if lacking:
        why = f"no headless browser: {', '.join(lacking)} not installed (apt-get install chromium chromium-driver)"
        if os.environ.get("CI"):
            pytest.fail(f"CI must run the browser test; {why}")
        pytest.skip(why)
    return headless_chromium()


def handshake(port: int, origin: str | None) -> str:
    """The status line a websocket upgrade of the page's /ws gets, with the given Origin header (None: none)."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                   "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                   "Sec-WebSocket-Protocol: bokeh, x\r\n"
                   + (f"Origin: {origin}\r\n" if origin else "") + "\r\n").encode())
        return s.recv(4096).decode(errors="replace").split("\r\n")[0]


@pytest.fixture
def two_busy_cores():
    """Two processes spinning on the CPU for the test's length (the machine as loaded as the user's who saw the
    node table stand still), each stopped by its pid in teardown, and killed by the kernel if the test dies."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True,
                                 preexec_fn=parent_death_signal) for _ in range(2)]
    yield spinners
    for p in spinners:
        p.kill()
        p.wait()


def start_viewed(carav, port: int, graph: str = "table1_smart"):
    """The graph run until stopped, paced, with its live view on `port`: (the run, the page's address) once the
    page answers."""
    run = carav.run(ROOT / "graphs" / f"{graph}.toml", "--view", "--port", str(port), "--cycles", "0", *PACED)
    wait_until(lambda: "live view at " in run.stderr(), "the page's address", run, interval_s=0.2)
    url = re.search(r"live view at (\S+)", run.stderr()).group(1)

    def page_up():
        try:
            return urllib.request.urlopen(url, timeout=2).status == 200
        except OSError:
            assert run.proc.poll() is None, run.stderr()
            return False
    wait_until(page_up, "the live view page", run, interval_s=0.2)
    return run, url


def test_the_page_updates_while_the_graph_runs_and_a_swap_from_it_reaches_the_attacker(carav):
    from selenium.webdriver.support.ui import Select
    port = free_port("127.0.0.1")
    run, url = start_viewed(carav, port)
    assert url.startswith(f"http://127.0.0.1:{port}/?token=") and len(url.split("token=")[1]) >= 32
    # without the run's token, or with another, the page is refused; its websocket takes only the page's origin
    for wrong in (f"http://127.0.0.1:{port}/", url[:-4] + "AAAA"):
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(wrong, timeout=5)
        assert refused.value.code == 403
    assert " 403 " in handshake(port, None) and " 403 " in handshake(port, "http://evil.example:80")
    assert " 101 " in handshake(port, f"http://127.0.0.1:{port}")
    driver = browser()
    try:
        driver.get(url)
        data = lambda name, col: model(driver, name, f"data[{json.dumps(col)}]") or []  # noqa: E731
        text = lambda name: model(driver, name, "text") or ""  # noqa: E731
        # the smart attacker (RARMS 3 from cycle 100) raises D0 alarms; cycles 0-99 are clean, estimated, mapped
        wait_until(lambda: len(data("q_D0", "cycle")) > 50 and len(data("estimates", "range_m")) > 10,
                   "alarm and estimate points on the page", run)
        assert all(abs(r - 43.0) < 1.0 for r in data("estimates", "range_m"))        # the car at 43 m
        wait_until(lambda: "peak" in text("rd_text"), "the range-Doppler map", run)
        assert "RARMS <b>3.0</b>" in text("attacker") and "model <b>smart</b>" in text("attacker")
        assert model(driver, "swap_model", "value") == "smart"                  # the menu shows what runs
        assert model(driver, "swap_rarms", "value") == 3.0
        rows = lambda: dict(zip(data("nodes", "node"), data("nodes", "cycles")))  # noqa: E731
        wait_until(lambda: rows().get("source", 0) > 0, "the node table", run)
        source_cycles = rows()["source"]
        wait_until(lambda: rows()["source"] > source_cycles, "the node table refreshing", run)
        first = max(data("q_D0", "cycle"))
        wait_until(lambda: max(data("q_D0", "cycle")) > first + 10 * BATCH, "the Q plot moving on", run)

        # swap from the page: the model select, the RARMS field, the button, as a user would
        Select(driver.execute_script(DEEP_FIND, "select")).select_by_value("none")
        driver.execute_script(DEEP_FIND, "button.bk-btn").click()
        wait_until(lambda: "swapped attacker" in text("swap_log"), "the page's swap answer", run)
        assert "{'model': 'none'}" in text("swap_log"), text("swap_log")
        status = json.loads(carav.cli("status", "--json").stdout)[0]
        swaps = [s for s in status["swaps"] if s["node"] == "attacker"]
        assert len(swaps) == 1 and status["nodes"]["attacker"]["params"]["model"] == "none"
        after = swaps[0]["first_seq"] * BATCH
        # the alarms follow: clean cycles after the swap, no alarm from a cycle the silent attacker produced
        wait_until(lambda: max(data("q_clean", "cycle"), default=0) > after + 10 * BATCH,
                   "clean cycles after the swap", run)
        assert max(data("q_D0", "cycle")) < after + BATCH
        wait_until(lambda: "model <b>none</b>" in text("attacker"), "the attacker panel following the swap", run)
        assert model(driver, "swap_model", "value") == "none"
        fills = data("edges", "fill")
        assert fills and all("/" in f for f in fills)
    except BaseException:
        driver.save_screenshot(str(carav.workdir / "live_view.png"))
        raise
    finally:
        driver.quit()
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["lost"] == 0 and [w["node"] for w in s["swaps"]] == ["attacker"]
    assert re.search(r"swap: node attacker runs block attacker \(version 1\) \(none\) from cycle \d+ \(frame seq",
                     run.stdout()), run.stdout()
    view = s["per_node"]["view"]
    assert view["block"] == "live_view" and view["in"]["alarms"] > 0 and view["in"]["clean"] > 0
    assert view["history"][0]["summary"]["view"]["maps_drawn"] >= 1


def test_on_a_loaded_machine_the_tables_follow_the_run_paused_plots_say_why_and_no_legend_covers_a_plot(
        carav, two_busy_cores):
    """Every check runs and every problem is reported together: one viewed run on a loaded machine is long."""
    run, url = start_viewed(carav, free_port("127.0.0.1"))
    driver = browser()
    problems = []
    try:
        driver.set_script_timeout(300)          # the browser runs on the loaded cores too
        driver.get(url)
        data = lambda name, col: model(driver, name, f"data[{json.dumps(col)}]") or []  # noqa: E731
        wait_until(lambda: model(driver, "q_plot", "name"), "the page's Bokeh document", run, interval_s=0.5)

        figures = ["q_plot", "range_plot", "velocity_plot", "rd_plot"]
        legends = driver.execute_script(LEGENDS, figures)
        over = {name: sides["center"] for name, sides in legends.items() if sides["center"]}
        if over or not legends["q_plot"]["right"]:
            problems.append(f"legends over a plot: {over}; the Q plot's legends by side: {legends['q_plot']}")

        # the node table as drawn: its figures change between two readings, and reach what the run had done
        # before the second one began; a page whose table's data moves on without it fails as soon as the data
        # has changed five times
        drawn = lambda: driver.execute_script(DRAWN_ROW, "source")  # noqa: E731
        first = wait_until(lambda: (row := drawn()) and int(row[3]) > 0 and row, "the node table drawn", run,
                           interval_s=0.5)
        ran = json.loads(carav.cli("status", "--json").stdout)[0]["cycles"]
        data_seen = set()

        def table_followed():
            row, cycles = drawn(), dict(zip(data("nodes", "node"), data("nodes", "cycles"))).get("source")
            data_seen.add(cycles)
            if row != first and int(row[3]) >= ran:
                return "ok"
            if len(data_seen) > 5:
                return (f"the node table as drawn stands at {row} (first drawn {first}) while its data moved on "
                        f"to cycles {cycles}, and the run to {ran}")
            return None
        result = wait_until(table_followed, "the node table as drawn to move on", run, interval_s=0.5)
        if result != "ok":
            problems.append(result)

        # the range and velocity plots stop at the last clean cycle; the page says why, with the count
        moved_on = ATTACK_FROM + 10 * BATCH
        wait_until(lambda: max(data("q_D0", "cycle"), default=0) > moved_on, "alarms on the Q plot", run)
        if max(data("estimates", "cycle")) != ATTACK_FROM - 1:
            problems.append(f"estimates after the attack began: up to cycle {max(data('estimates', 'cycle'))}")
        texts = lambda: driver.execute_script(  # noqa: E731
            "const d = Bokeh.documents[0]; return ['pause_text', 'info'].map(n => d.get_model_by_name(n))"
            ".map(m => m ? m.text : '')")
        said = re.compile(r"plots paused after cycle (\d+)</b>: the gate refused the (\d+) cycles since "
                          r"\((\d+) alarms by D0; every cycle that reached the view\)")

        def reason():
            pause, info = texts()
            return said.search(pause), int(re.search(r"latest cycle (\d+)", info).group(1)), pause
        why, latest, pause = wait_until(lambda: (r := reason())[1] > moved_on and r, "the page's text", run)
        if why is None:
            problems.append(f"the plots of clean cycles paused at cycle {ATTACK_FROM - 1} and the page does not "
                            f"say why: {pause!r}")
        else:
            last_clean, n, by_d0 = (int(g) for g in why.groups())
            # every cycle after the last clean one that reached the view was refused, and counted (taps may skip)
            if not (last_clean == ATTACK_FROM - 1 and 0 < n == by_d0 <= latest - last_clean):
                problems.append(f"the pause misreads the run: {why.group(0)!r} with the latest cycle {latest}")
            later = wait_until(lambda: (r := reason())[0] and int(r[0].group(2)) > n and r[0], "the count", run)
            assert int(later.group(1)) == ATTACK_FROM - 1
    except BaseException:
        driver.save_screenshot(str(carav.workdir / "live_view_loaded.png"))
        raise
    finally:
        driver.quit()
    assert not problems, "\n".join(problems)
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    assert run.summary()["lost"] == 0


def test_a_graphs_tracker_shows_its_confirmed_tracks_with_their_ids(carav):
    """graphs/table1_tracks.toml viewed: the car's track (id 0, confirmed at its third cycle) drawn at the car's
    range, and named in words; it coasts once the pull-off begins (cycle 200), which the gate refuses."""
    run, url = start_viewed(carav, free_port("127.0.0.1"), "table1_tracks")
    driver = browser()
    try:
        driver.get(url)
        data = lambda col: model(driver, "tracks", f"data[{json.dumps(col)}]") or []  # noqa: E731
        wait_until(lambda: "coasting" in data("status"), "a coasting track on the page", run)
        assert set(data("track")) == {"0"} and all(abs(r - 43.0) < 0.05 for r in data("range_m"))
        # none before its third cycle (its tap may skip frames for a busy view, so maybe later)
        assert min(data("cycle")) >= 2 and "track 0 at 43.0" in model(driver, "tracks_text", "text")
    except BaseException:
        driver.save_screenshot(str(carav.workdir / "live_view_tracks.png"))
        raise
    finally:
        driver.quit()
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    assert run.summary()["per_node"]["view"]["in"]["tracks"] > 0


def test_a_graph_without_a_gate_has_nothing_to_watch(carav):
    body = 'connections = ["src.out -> log.inp"]\n[blocks]\nsrc = { type = "counter_source" }\n' \
           'log = { type = "jsonl_sink", path = "out.jsonl" }\n'
    r = carav.cli("run", str(carav.graph(body)), "--view", "--port", "0")
    assert r.returncode == 3 and "--view watches the gate's verdicts; the graph has no gate" in r.stderr
    assert not any(carav.run_root.rglob("*.spec"))                                     # nothing started


def test_a_port_chosen_on_the_page_is_tapped_and_its_scope_and_spectrum_follow_the_run(carav):
    """As a user: choose the ADC's frames in the port selector, see the scope, the spectrum and the tap's line come
    and move on to later cycles; choose the activation sequences and read why they are not shown; the chain loses
    nothing."""
    from selenium.webdriver.support.ui import Select
    run, url = start_viewed(carav, free_port("127.0.0.1"))
    driver = browser()
    try:
        driver.get(url)
        text = lambda: model(driver, "scope_text", "text") or ""  # noqa: E731
        select, label = wait_until(lambda: driver.execute_script(SELECT_OFFERING, "adc.frames"), "the port selector",
                                   run, interval_s=0.2)
        Select(select).select_by_visible_text(label)
        shown = re.compile(r"adc\.frames</b> \(adc_frame\): cycle (\d+), chirp 0 of 64 .* shown [\d.]+/s "
                           r"&middot; skipped (\d+) of the (\d+) frames")
        first = wait_until(lambda: shown.search(text()), "the tap's first copy on the page", run)
        spectrum = lambda: driver.execute_script(COLUMN, "spectrum", "db")  # noqa: E731
        before = spectrum()
        assert len(driver.execute_script(COLUMN, "scope", "t_us")) == 1080 and len(before) == 541   # table1's samples
        assert model(driver, "range_axis", "visible") and model(driver, "scope_chirp", "visible")
        later = wait_until(lambda: (m := shown.search(text())) and int(m.group(1)) > int(first.group(1)) and m,
                           "the scope moving on to a later cycle", run)
        assert int(later.group(3)) > int(first.group(3)) and spectrum() != before
        taps = json.loads(carav.cli("status", "--json").stdout)[0]["nodes"]["adc"]["counters"].get("taps", {})
        assert taps.get("frames", {}).get("sent", 0) >= 2, taps               # the node's own count of copies

        select, label = driver.execute_script(SELECT_OFFERING, "source.rho")
        Select(select).select_by_visible_text(label)
        wait_until(lambda: "refused: source.rho is private" in text(), "the refusal of a private port", run)
    except BaseException:
        driver.save_screenshot(str(carav.workdir / "live_view_scope.png"))
        raise
    finally:
        driver.quit()
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    assert run.summary()["lost"] == 0
