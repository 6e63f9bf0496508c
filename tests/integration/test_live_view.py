"""`carav run --view` in a real headless browser (Debian's Chromium driven by Selenium): the page loads, its plots
update while the graph runs, and a swap made from the page reaches the attacker node, shows in `carav status` and
in the run summary, and the alarms follow it. CI installs the browser (.ci/run); a local run without one skips
this test and says why."""
import json
import os
import re
import socket
import urllib.error
import urllib.request

import pytest

from bench.browser import DEEP_FIND, headless_chromium, missing, model
from carav_stream.view.server import free_port
from tests.integration.conftest import PACED, ROOT, wait_until

pytestmark = pytest.mark.integration
BATCH = 32   # table1_smart's cycles per frame (radar_chain.toml)


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


def test_the_page_updates_while_the_graph_runs_and_a_swap_from_it_reaches_the_attacker(carav):
    from selenium.webdriver.support.ui import Select
    port = free_port("127.0.0.1")
    run = carav.run(ROOT / "graphs" / "table1_smart.toml", "--view", "--port", str(port), "--cycles", "0", *PACED)
    wait_until(lambda: "live view at " in run.stderr(), "the page's address", run, interval_s=0.2)
    url = re.search(r"live view at (\S+)", run.stderr()).group(1)
    assert url.startswith(f"http://127.0.0.1:{port}/?token=") and len(url.split("token=")[1]) >= 32

    def page_up():
        try:
            return urllib.request.urlopen(url, timeout=2).status == 200
        except OSError:
            assert run.proc.poll() is None, run.stderr()
            return False
    wait_until(page_up, "the live view page", run, interval_s=0.2)
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


def test_a_graph_without_a_gate_has_nothing_to_watch(carav):
    body = 'connections = ["src.out -> log.inp"]\n[blocks]\nsrc = { type = "counter_source" }\n' \
           'log = { type = "jsonl_sink", path = "out.jsonl" }\n'
    r = carav.cli("run", str(carav.graph(body)), "--view", "--port", "0")
    assert r.returncode == 3 and "--view watches the gate's verdicts; the graph has no gate" in r.stderr
    assert not any(carav.run_root.rglob("*.spec"))                                     # nothing started
