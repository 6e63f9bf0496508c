"""`python3 dev.py bench soak`: memory and descriptors sampled from /proc while the demo graph runs with live swaps."""
import json
import mmap
import os

import pytest

from bench import main as run_bench
from bench.soak import (
    HEAP_SLACK_MB,
    floor,
    growth_per_hour,
    heap_bound_mb,
    no_growth,
    proc_figures,
    process_figures,
    segments_mapped_mb,
)
from carav_stream.runtime import shm


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


def test_process_figures_come_from_proc_and_count_the_runs_segments_it_maps():
    before = proc_figures(os.getpid())
    assert before["rss"] > 10 and before["fds"] >= 3 and 0 < before["anon"] <= before["rss"]
    assert proc_figures(2 ** 22 + 12345) is None                     # no such process
    fd = shm.create_segment(4, 1, "carav-soaktest")
    try:
        size = os.fstat(fd).st_size + (8 << 20)
        os.ftruncate(fd, size)
        with mmap.mmap(fd, size) as m:
            m[: 4 << 20] = b"x" * (4 << 20)                          # touch 4 MB of the 8+ MB mapped
            now = proc_figures(os.getpid())
            assert now["shm_mapped"] - before["shm_mapped"] == pytest.approx(size / 2 ** 20, abs=0.01)
            assert now["shmem"] - before["shmem"] == pytest.approx(4.0, abs=0.5)
    finally:
        os.close(fd)
    assert segments_mapped_mb("7f00-7f10 rw-s 0 00:01 5 /memfd:other (deleted)\n") == 0


def test_a_process_is_judged_on_its_heap_while_its_shared_pages_are_held_to_its_segments():
    late = [{"t": 2.0 * i, "rss": 100.0 + 3 * i, "anon": 50.0, "shmem": 50.0 + 3 * i, "shm_mapped": 500.0, "fds": 9}
            for i in range(40)]                                     # shared pages rise with frames in flight
    fig = process_figures(late, 10.0)
    assert fig["rss_floor_mb_per_h"] > 1000 and fig["anon_floor_mb_per_h"] == pytest.approx(0.0, abs=1e-6)
    assert fig["shmem_mb_max"] == 50.0 + 3 * 39 and fig["shm_mapped_mb"] == 500.0


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
    procs = {p["node"]: p for p in rec["processes"].values()}
    assert procs["adc"]["shmem_mb_max"] <= procs["adc"]["shm_mapped_mb"] + 1
    assert all(p["heap_bound_mb"] is not None and p["anon_mb_max"] <= p["heap_bound_mb"] for p in procs.values())
    assert procs["adc"]["most_buffered"].keys() == {"rx", "attack"}


def test_a_nodes_heap_bound_is_its_buffers_of_its_largest_frames_in_and_out():
    mb = 2 ** 20
    holds = {"queue_frames": 8, "edges": ["a.out -> b.x", "b.y -> c.z"],
             "nodes": {"b": {"frame_bytes": {"x": 2 * mb}, "most_buffered": {"x": 5}, "buffer_limit": 32},
                       "c": {"frame_bytes": {"z": 1 * mb}, "most_buffered": {}, "buffer_limit": 32},
                       "a": {"frame_bytes": None}}}
    assert heap_bound_mb("b", holds, 100.0) == pytest.approx(100 + HEAP_SLACK_MB + 2 * (32 + 8) + 8 * 1)
    assert heap_bound_mb("c", holds, 10.0) == pytest.approx(10 + HEAP_SLACK_MB + 1 * 40)
    assert heap_bound_mb("a", holds, 10.0) is None and heap_bound_mb("zz", holds, 10.0) is None
