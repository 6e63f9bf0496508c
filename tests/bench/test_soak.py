"""`python3 dev.py bench soak`: memory and descriptors sampled from /proc while the demo graph runs with live swaps."""
import json
import os

import pytest

from bench import main as run_bench
from bench.soak import floor, growth_per_hour, no_growth, proc_figures


def test_growth_per_hour_is_the_slope_of_a_least_squares_line_with_its_standard_error():
    slope, err = growth_per_hour([0, 10, 20, 30], [5.0, 6.0, 7.0, 8.0])
    assert slope == pytest.approx(360.0) and err == pytest.approx(0.0, abs=1e-9)
    slope, err = growth_per_hour([0, 10, 20, 30, 40], [5.0, 7.0, 5.0, 7.0, 5.0])   # noise, no trend
    assert slope == pytest.approx(0.0, abs=1e-9) and err > 0
    assert growth_per_hour([0, 1], [1.0, 9.0]) == (0.0, 0.0)            # too few samples to judge
    assert no_growth(10.0, 1.0) and no_growth(50.0, 20.0) and not no_growth(50.0, 5.0)


def test_the_memory_floor_ignores_frames_in_flight_and_follows_a_leak():
    t = [i * 1.0 for i in range(60)]
    spikes = [100.0 + (40.0 if i % 3 == 0 else 0.0) for i in range(60)]           # frames come and go, no leak
    ft, fv = floor(t, spikes, 10.0)
    assert ft == [5.0, 15.0, 25.0, 35.0, 45.0, 55.0] and fv == [100.0] * 6
    assert growth_per_hour(ft, fv) == pytest.approx((0.0, 0.0), abs=1e-6) and growth_per_hour(t, spikes)[1] > 1
    leak = [v + 0.01 * i for i, v in enumerate(spikes)]                          # 36 MB/h under the same spikes
    assert growth_per_hour(*floor(t, leak, 10.0))[0] == pytest.approx(36.0, rel=0.05)
    assert floor([0.0, 1.0, 25.0], [1.0, 2.0, 3.0], 10.0) == ([5.0], [1.0])       # a lone sample is no floor


def test_process_figures_come_from_proc():
    rss, fds = proc_figures(os.getpid())
    assert rss > 10 and fds >= 3
    assert proc_figures(2 ** 22 + 12345) is None                     # no such process


@pytest.mark.integration
def test_a_short_soak_swaps_the_attacker_samples_every_node_and_loses_nothing(tmp_path):
    out = tmp_path / "soak.json"
    assert run_bench(["soak", "--minutes", "0.3", "--swap-s", "2", "--sample-s", "0.25", "--batch", "8",
                      "--cycles-per-s", "400", "--json", str(out)]) == 0
    rec = json.loads(out.read_text())["records"][0]
    assert rec["lost"] == 0 and not rec["failures"] and rec["swaps"] >= 3 and rec["cycles"] > 0
    assert rec["paced_cycles_per_s"] == 400 and rec["cycles_per_s"] <= 400 * 1.05   # never faster than paced
    nodes = {p["node"] for p in rec["processes"].values()}
    assert nodes == {"source", "channel", "attacker", "adc", "detector", "gate", "ranging", "summary"}
    assert all(p["rss_mb_end"] > 1 and p["fds_end"] > 0 for p in rec["processes"].values())
    assert rec["trim_mb"] == 0 and all("rss_floor_mb_per_h" in p for p in rec["processes"].values())
