"""`python3 dev.py bench report`: the benchmark documents are rendered from records; the committed ones are current."""
import argparse
import json
from pathlib import Path

import pytest

from bench import records as bench_records
from bench import report

ROOT = Path(__file__).resolve().parents[2]


def test_the_committed_benchmark_documents_are_what_the_committed_records_give():
    stale = [str(p) for p, text in report.render(ROOT).items() if not p.exists() or p.read_text() != text]
    assert stale == [], "rerun `python3 dev.py bench report` (documents edited by hand, or records updated without it)"


def transport_doc(ratio: float) -> dict:
    rec = {"frame_shape": [4, 8], "dtype": "complex64", "bytes_per_frame": 256, "processes": 6, "transport": "runtime",
           "ratio": ratio, "runtime_frames_per_s": 100 * ratio, "raw_frames_per_s": 100.0, "cpu_ratio": 0.9,
           "frames_per_s": 100 * ratio, "frames_per_s_runs": [100 * ratio], "gb_per_s": 0.1,
           "latency_median_s": 0.01, "latency_p99_s": 0.02, "cpu_ms_per_frame_total": 1.0}
    return {"command": "python3 dev.py bench transport", "records": [rec],
            "machine": {"cpu": "test cpu", "cores": 2, "memory_gib": 1, "python": "3", "numpy": "2",
                        "load_average": [0, 0, 0]}}


@pytest.mark.parametrize("ratio, met", [(0.85, "yes"), (0.79, "**no**")])
def test_a_figure_is_judged_against_its_target(tmp_path, ratio, met):
    (tmp_path / "docs" / "bench" / "records").mkdir(parents=True)
    (tmp_path / "docs" / "bench" / "records" / "transport.json").write_text(json.dumps(transport_doc(ratio)))
    (tmp_path / "docs" / "bench" / "transport.md").write_text(f"# T\n\nmethod\n\n{report.BEGIN}\nold\n{report.END}\n")
    docs = report.render(tmp_path)
    summary = docs[tmp_path / "BENCHMARKS.md"]
    assert f"| {ratio:.2f} ({100 * ratio:.0f} / 100 frames/s; CPU ratio 0.90) | >= 0.8 | {met} |" in summary
    assert "No records yet: run `python3 dev.py bench pipeline --json docs/bench/records/pipeline.json`" in summary
    page = docs[tmp_path / "docs" / "bench" / "transport.md"]
    assert page.startswith("# T\n\nmethod\n\n") and "old" not in page and "| 4x8 | runtime |" in page
    args = argparse.Namespace(root=tmp_path, check=True)
    assert report.run(args) == 1                                   # not written yet
    assert report.run(argparse.Namespace(root=tmp_path, check=False)) == 0
    assert report.run(args) == 0                                   # now current


def test_a_record_file_without_command_or_machine_is_refused(tmp_path):
    (tmp_path / "r.json").write_text("[]")
    with pytest.raises(ValueError, match="not a benchmark record file"):
        bench_records.read(tmp_path / "r.json")


def test_the_recorded_command_leaves_out_output_files():
    args = argparse.Namespace(argv=["synth", "--json", "x.json", "--cycles", "4", "--plot=p.png"])
    assert bench_records.command_line(args) == "python3 dev.py bench synth --cycles 4"


@pytest.mark.parametrize("transport, speedup, rtf, met", [
    ("shm", 1.7, 2.6, ("yes", "yes")), ("shm", 1.5, 2.6, ("yes", "**no**")), ("shm", 1.7, 2.4, ("**no**", "yes")),
    ("zmq", 1.5, 1.2, ("yes", "yes"))])
def test_the_pipeline_over_shared_memory_is_judged_against_its_own_targets(tmp_path, transport, speedup, rtf, met):
    """The targets for the shared-memory plane (2.5 x real time, 1.6 x fused), the older ones for ZeroMQ."""
    rec = {"preset": "table1", "fidelity": "beat", "batch": 32, "mode": "pipeline", "transport": transport,
           "cycles_per_s": 2131.0 * rtf, "runs_cycles_per_s": [2131.0 * rtf], "real_time_factor": rtf,
           "radar_cycles_per_s": 2131.0, "speedup_over_fused": speedup, "bottleneck_node": "channel",
           "busy_us_per_cycle": {"channel": 250.0, "adc": 150.0},
           "outside_us_per_cycle": {"channel": 20.0, "adc": 30.0}}
    (tmp_path / "docs" / "bench" / "records").mkdir(parents=True)
    (tmp_path / "docs" / "bench" / "records" / "pipeline.json").write_text(json.dumps(
        {**transport_doc(1.0), "command": "python3 dev.py bench pipeline", "records": [rec]}))
    (tmp_path / "docs" / "bench" / "pipeline.md").write_text(f"# P\n\n{report.BEGIN}\n{report.END}\n")
    docs = report.render(tmp_path)
    summary = docs[tmp_path / "BENCHMARKS.md"]
    targets = ("2.5", "1.6") if transport == "shm" else ("1", "1.3")
    # the ceiling on the record's 2 cores: the channel's block (250 us a cycle) binds before the cores (2 / 450 us)
    top = 1e6 / 250
    assert (f"= {rtf:.3g} x real time (its ceiling on 2 cores: {top:.0f} cycles/s = {top / 2131:.3g} x, bound by "
            f"channel) | >= {targets[0]} x (2131 cycles/s) | {met[0]} |") in summary
    assert (f"| {speedup:.2f} x ({speedup * top / (2131 * rtf):.2f} x at its ceiling) | >= {targets[1]} x | {met[1]} |"
            in summary)
    page = docs[tmp_path / "docs" / "bench" / "pipeline.md"]
    assert f"ceiling {top:.0f} cycles/s (channel), {2131 * rtf / top:.0%} of it reached |" in page


def test_no_committed_pipeline_run_beats_its_ceiling():
    """The ceiling is an upper bound: a run above it (beyond the spread of medians of separate figures) would mean
    the nodes' CPU times are misattributed or the model misses how they overlap."""
    doc = bench_records.read(ROOT / "docs" / "bench" / "records" / "pipeline.json")
    ratios = {(r["preset"], r["fidelity"], r["batch"], r["transport"]): r["cycles_per_s"] / top[0]
              for r in doc["records"] if (top := report._pipeline_ceiling(r, doc)) is not None}
    assert ratios and max(ratios.values()) <= 1.05, ratios
