"""`carav run --view` in a real headless browser (Debian's Chromium driven by Selenium): the page loads, its plots
update while the graph runs, and a swap made from the page reaches the attacker node, shows in `carav status` and
in the run summary, and the alarms follow it. CI installs the browser (.ci/run); a local run without one skips
this test and says why."""
import json
import os
import urllib.request

import pytest

from bench.browser import DEEP_FIND, headless_chromium, missing, model
from carav_stream.view.server import free_port
from tests.integration.conftest import ROOT, wait_until

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


def test_the_page_updates_while_the_graph_runs_and_a_swap_from_it_reaches_the_attacker(carav):
    from selenium.webdriver.support.ui import Select
    port = free_port("127.0.0.1")
    run = carav.run(ROOT / "graphs" / "table1_smart.toml", "--view", "--port", str(port), "--cycles", "0")
    url = f"http://127.0.0.1:{port}/"

    def page_up():
        try:
            return urllib.request.urlopen(url, timeout=2).status == 200
        except OSError:
            assert run.proc.poll() is None, run.stderr()
            return False
    wait_until(page_up, "the live view page", run, interval_s=0.2)
    assert f"live view at {url}" in run.stderr()
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
    except BaseException:
        driver.save_screenshot(str(carav.workdir / "live_view.png"))
        raise
    finally:
        driver.quit()
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    s = run.summary()
    assert s["lost"] == 0 and [w["node"] for w in s["swaps"]] == ["attacker"]
    assert "swap: node attacker runs block attacker (version 1) (none) from frame seq" in run.stdout()
    view = s["per_node"]["view"]
    assert view["block"] == "live_view" and view["in"]["alarms"] > 0 and view["in"]["clean"] > 0
    assert view["history"][0]["summary"]["view"]["maps_drawn"] >= 1


def test_a_graph_without_a_gate_has_nothing_to_watch(carav):
    body = 'connections = ["src.out -> log.inp"]\n[blocks]\nsrc = { type = "counter_source" }\n' \
           'log = { type = "jsonl_sink", path = "out.jsonl" }\n'
    r = carav.cli("run", str(carav.graph(body)), "--view", "--port", "0")
    assert r.returncode == 3 and "--view watches the gate's verdicts; the graph has no gate" in r.stderr
    assert not any(carav.run_root.rglob("*.spec"))                                     # nothing started
