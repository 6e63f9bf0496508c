"""`python3 dev.py bench startup`: a graph's start with its nodes forked from the zygote and as fresh interpreters."""
import json
import os
import py_compile

import pytest

from bench import main as run_bench
from bench.startup import MODES, bytecode, current_bytecode, pss_mb, rows, table


def test_proportional_memory_comes_from_proc_and_is_at_most_the_resident():
    pss, rss = pss_mb(os.getpid())
    assert 1 < pss <= rss


def record(ratio: float, first_frame_s: float | None = None) -> dict:
    """A record; with `first_frame_s`, the forked successor's first frame that long after the death was seen (a
    record made before the first frame was timed has none)."""
    walls = {"zygote": [ratio], "fresh": [3.0], "import": [1.0], "validate": [0.8]}
    rounds = {"zygote": [{"seen_to_ready_s": 0.05, "pss_mb": 200.0, "rss_mb": 500.0, "zygote_pss_mb": 12.0,
                          "processes": 9}],
              "fresh": [{"seen_to_ready_s": 0.5, "pss_mb": 350.0, "rss_mb": 520.0, "zygote_pss_mb": 0.0,
                         "processes": 8}]}
    rec = {"graph": "graphs/demo.toml", "cycles": 32, "runs": 1, "wall_s": walls,
           "median_s": {m: w[0] for m, w in walls.items()}, "ratio_zygote_to_import": ratio,
           "ratio_fresh_to_import": 3.0, "ratio_zygote_to_fresh": ratio / 3.0, "target_ratio": 1.3,
           "node_starts": {"zygote": {"forked": 8, "fresh": 0}}, "victim": "detector",
           "restart_rounds": rounds, "restart_median_s": {"zygote": 0.05, "fresh": 0.5},
           "pss_median_mb": {"zygote": 200.0, "fresh": 350.0}, "load_average_at_start": [0.5, 1, 2]}
    if first_frame_s is not None:
        rounds["zygote"][0]["seen_to_first_frame_s"], rounds["fresh"][0]["seen_to_first_frame_s"] = first_frame_s, 0.7
        rec.update(first_frame_median_s={"zygote": first_frame_s, "fresh": 0.7}, target_restart_s=0.1)
    return {"records": [rec]}


@pytest.mark.parametrize("ratio, met", [(1.2, "yes"), (1.4, "**no**")])
def test_the_zygote_run_is_judged_against_the_imports_of_one_interpreter(ratio, met):
    first, *rest = rows(record(ratio))
    assert first[1].startswith(f"{ratio:.2f} x ({ratio:.2f} / 1.00 s)") and first[2:] == ("<= 1.3 x", met)
    assert rest[2][1] == f"{ratio - 0.8:.2f} / 2.20 s"              # the run beyond the command's own validation
    assert "50 / 500 ms" in rest[3][1] and "200 / 350 MB" in rest[4][1]
    lines = table(record(ratio))
    assert lines[0] == "Load average when it started: 0.5 / 1 / 2." and "| zygote | 50; 50 | 200; 200 | 500 |" \
        in "\n".join(lines)


def test_bytecode_counts_as_current_only_when_its_header_matches_the_source(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("x = 1\n")
    assert not current_bytecode(src)                                         # none yet
    py_compile.compile(str(src), doraise=True)
    assert current_bytecode(src)
    src.write_text("x = 22\n")                                               # edited: another size
    assert not current_bytecode(src)
    py_compile.compile(str(src), doraise=True)
    st = src.stat()
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns + 2 * 10**9))           # touched: another time
    assert not current_bytecode(src)


def test_the_record_says_how_many_modules_had_current_bytecode(monkeypatch):
    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    found = bytecode()
    assert found["modules"] > 100 and 0 <= found["current"] <= found["modules"] and found["dont_write_bytecode"]
    monkeypatch.delenv("PYTHONDONTWRITEBYTECODE")
    assert not bytecode()["dont_write_bytecode"]
    doc = record(1.2)
    doc["records"][0]["bytecode"] = {"modules": 250, "current": 249, "dont_write_bytecode": True}
    assert "current bytecode: 249 of 250; PYTHONDONTWRITEBYTECODE set." in "\n".join(table(doc))


@pytest.mark.parametrize("first_frame_s, met", [(0.08, "yes"), (0.12, "**no**")])
def test_the_forked_successors_first_frame_is_judged_against_the_restart_target(first_frame_s, met):
    *_, ready, first, memory = rows(record(1.2, first_frame_s))
    assert "ready report" in ready[0] and "50 / 500 ms" in ready[1]
    assert "first frame" in first[0] and first[1:] == (f"{first_frame_s * 1e3:.0f} / 700 ms", "<= 100 ms forked", met)
    assert "200 / 350 MB" in memory[1]
    lines = "\n".join(table(record(1.2, first_frame_s)))
    assert "to its first frame" in lines and f"| zygote | 50; 50 | {first_frame_s * 1e3:.0f}; " \
        f"{first_frame_s * 1e3:.0f} | 200; 200 | 500 |" in lines


@pytest.mark.integration
def test_a_short_startup_benchmark_forks_every_node_and_restarts_the_detector(tmp_path):
    out = tmp_path / "startup.json"
    assert run_bench(["startup", "--runs", "1", "--restarts", "1", "--cycles", "8", "--json", str(out)]) == 0
    rec = json.loads(out.read_text())["records"][0]
    assert set(rec["median_s"]) == set(MODES) and all(w > 0 for w in rec["median_s"].values())
    assert 0 <= rec["bytecode"]["current"] <= rec["bytecode"]["modules"]
    assert rec["node_starts"]["zygote"] == {"forked": 8, "fresh": 0}
    assert rec["node_starts"]["fresh"] == {"forked": 0, "fresh": 8}
    zygote, fresh = rec["restart_rounds"]["zygote"][0], rec["restart_rounds"]["fresh"][0]
    assert zygote["processes"] == 9 and fresh["processes"] == 8 and zygote["zygote_pss_mb"] > 0
    assert 0 < zygote["seen_to_ready_s"] < zygote["seen_to_first_frame_s"]
    assert 0 < fresh["seen_to_ready_s"] < fresh["seen_to_first_frame_s"]
