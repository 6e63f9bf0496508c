"""`python3 dev.py bench report`: the benchmark documents are rendered from records; the committed ones are current."""
import argparse
import json
import statistics
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from bench import pages, report
from bench import records as bench_records

ROOT = Path(__file__).resolve().parents[2]
HEAD = f"{pages.HEAD_BEGIN}\n{pages.HEAD_END}\n"          # a page's head, rendered from the benchmark list


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
    (tmp_path / "docs" / "bench" / "transport.md").write_text(f"# T\n\n{HEAD}\nmethod\n\n{report.BEGIN}\nold\n"
                                                                  f"{report.END}\n")
    docs = report.render(tmp_path)
    summary = docs[tmp_path / "BENCHMARKS.md"]
    assert f"| {ratio:.2f} ({100 * ratio:.0f} / 100 frames/s; CPU ratio 0.90) | >= 0.8 | {met} |" in summary
    assert "No records yet: run `python3 dev.py bench pipeline --json docs/bench/records/pipeline.json`" in summary
    page = docs[tmp_path / "docs" / "bench" / "transport.md"]
    assert page.startswith(f"# T\n\n{pages.HEAD_BEGIN}\n`python3 dev.py bench transport [--json FILE]")
    assert "\nmethod\n\n" in page and "old" not in page and "| 4x8 | runtime |" in page
    args = argparse.Namespace(root=tmp_path, check=True)
    assert report.run(args) == 1                                   # not written yet
    assert report.run(argparse.Namespace(root=tmp_path, check=False)) == 0
    assert report.run(args) == 0                                   # now current


def test_a_page_head_names_the_command_module_and_records_from_the_benchmark_list(tmp_path):
    """The head states the benchmark's own options, its module and its record file; a page without records gets
    its head all the same, a page without the head's markers is refused."""
    (tmp_path / "docs" / "bench" / "records").mkdir(parents=True)
    page_file = tmp_path / "docs" / "bench" / "dca1000_udp.md"
    page_file.write_text(f"# D\n\n{HEAD}\nprose\n\n{report.BEGIN}\n{report.END}\n")
    page = report.render(tmp_path)[page_file]
    head = page.split(pages.HEAD_BEGIN)[1].split(pages.HEAD_END)[0]
    assert head.startswith("\n`python3 dev.py bench dca1000-udp [--json FILE] [--cycles CYCLES]")
    assert "Module `bench/dca1000_udp.py`; records `docs/bench/records/dca1000_udp.json`" in head
    assert all(len(line) <= pages.WIDTH for line in head.splitlines())
    page_file.write_text(f"# D\n\n{report.BEGIN}\n{report.END}\n")
    with pytest.raises(ValueError, match="dca1000_udp.md: lacks the markers <!-- begin: dev.py bench report, head"):
        report.render(tmp_path)


def test_a_long_usage_breaks_between_options_only():
    text = "`prog [--a A] [--shapes {x,y} [{x,y} ...]] [--json FILE]`"
    assert pages.wrap(text, 20) == ["`prog [--a A]", "[--shapes {x,y} [{x,y} ...]]", "[--json FILE]`"]


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
           "outside_us_per_cycle": {"channel": 20.0, "adc": 30.0}, "cpu_us_per_cycle": 450.0}
    (tmp_path / "docs" / "bench" / "records").mkdir(parents=True)
    (tmp_path / "docs" / "bench" / "records" / "pipeline.json").write_text(json.dumps(
        {**transport_doc(1.0), "command": "python3 dev.py bench pipeline", "records": [rec]}))
    (tmp_path / "docs" / "bench" / "pipeline.md").write_text(f"# P\n\n{HEAD}\n{report.BEGIN}\n{report.END}\n")
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
    assert f"outside the blocks 50; all the nodes' CPU 450; ceiling {top:.0f} cycles/s (channel), " \
           f"{2131 * rtf / top:.0%} of it reached |" in page


def test_no_committed_pipeline_run_beats_its_ceiling():
    """The ceiling is an upper bound: a run above it (beyond the spread of medians of separate figures) would mean
    the nodes' CPU times are misattributed or the model misses how they overlap."""
    doc = bench_records.read(ROOT / "docs" / "bench" / "records" / "pipeline.json")
    ratios = {(r["preset"], r["fidelity"], r["batch"], r["transport"]): r["cycles_per_s"] / top[0]
              for r in doc["records"] if (top := report._pipeline_ceiling(r, doc)) is not None}
    assert ratios and max(ratios.values()) <= 1.05, ratios


def render_one(tmp_path: Path, name: str, records: list[dict], **machine) -> tuple[str, str]:
    """BENCHMARKS.md and docs/bench/NAME.md as `records` (one benchmark's) render them."""
    (tmp_path / "docs" / "bench" / "records").mkdir(parents=True)
    doc = transport_doc(1.0)
    doc.update(command=f"python3 dev.py bench {name}", records=records, machine={**doc["machine"], **machine})
    (tmp_path / "docs" / "bench" / "records" / f"{name}.json").write_text(json.dumps(doc))
    (tmp_path / "docs" / "bench" / f"{name}.md").write_text(f"# {name}\n\n{HEAD}\n{report.BEGIN}\n{report.END}\n")
    docs = report.render(tmp_path)
    return docs[tmp_path / "BENCHMARKS.md"], docs[tmp_path / "docs" / "bench" / f"{name}.md"]


def test_the_machine_line_names_the_widest_simd_extension(tmp_path):
    summary, page = render_one(tmp_path, "transport", transport_doc(1.0)["records"], simd="AVX512F")
    for text in (summary, page):
        assert "Machine: test cpu (AVX512F), 2 cores, 1 GiB; Python 3, numpy 2;" in text
    assert bench_records.header().startswith(f"machine: {bench_records.machine()['cpu']} "
                                             f"({bench_records.machine()['simd']}), ")


def test_a_synth_stage_renders_per_sample_beside_its_bound(tmp_path):
    stage = {"bench": "synth_stage", "preset": "table1", "fidelity": "beat", "attacker": "none", "iq": True,
             "stage": "noise", "n_chirps": 64, "n_samples": 1080, "time_per_cycle_s": 669e-6,
             "real_values_per_cycle": 138240, "per": "real value (I or Q)", "ns_per_sample": 4.84,
             "bound_time_per_cycle_s": 180e-6, "bound_ns_per_sample": 1.30, "bound": "log, sqrt, cos, sin",
             "x_bound": 3.72}
    summary, page = render_one(tmp_path, "synth", [stage])
    assert ("| noise stage of one beat cycle, table1 I/Q, per real value (I or Q) | 4.84 ns = 3.72 x its bound "
            "measured beside it (1.30 ns: log, sqrt, cos, sin) | report | - |") in summary
    assert "| table1 | I/Q | noise | 669 | 4.840 | 1.300 | 3.72 | log, sqrt, cos, sin |" in page


def test_the_int16_detector_path_renders_per_code_beside_its_bound_and_a_read(tmp_path):
    codes = {"bench": "kernel_codes", "preset": "table1", "dtype": "int16", "shape": [32, 64, 1080],
             "codes": 2211840, "ns_per_code": 0.283, "bound_ns_per_code": 0.270, "x_bound": 1.048,
             "bound": "astype + matmul", "read_ns_per_code": 0.043, "x_read": 6.58, "read": "np.copyto"}
    summary, page = render_one(tmp_path, "detector", [codes])
    assert ("| adc_chirp_rms() cost, int16 codes (the graph's path), table1 32 x 64 x 1080 | 0.283 ns/code = 1.05 x "
            "its bound (0.270 ns: astype + matmul) = 6.6 x a read (0.043 ns: np.copyto) | report | - |") in summary
    assert ("| kernel | int16 codes, table1 32 x 64 x 1080 | adc_chirp_rms 0.283 ns/code; bound 0.270 "
            "(astype + matmul), x 1.05; read 0.043 (np.copyto), x 6.6 |") in page


def test_each_nodes_busy_time_renders_per_sample(tmp_path):
    rec = {"preset": "table1", "fidelity": "beat", "batch": 32, "mode": "pipeline", "transport": "shm",
           "cycles_per_s": 1600.0, "runs_cycles_per_s": [1600.0], "real_time_factor": 0.75,
           "radar_cycles_per_s": 2131.0, "speedup_over_fused": 1.3, "bottleneck_node": "channel",
           "busy_us_per_cycle": {"channel": 550.0, "adc": 150.0}, "samples_per_cycle": 69120,
           "busy_ns_per_sample": {"channel": 550e3 / 69120, "adc": 150e3 / 69120}}
    summary, page = render_one(tmp_path, "pipeline", [rec])
    assert ("| each node's block per sample (arrays in shared memory), table1 beat, batch 32 | channel 7.96; adc 2.17 "
            "ns/sample (busy us/cycle over 69120 samples a cycle) | report | - |") in summary
    assert "| channel (550 = 7.96 ns/sample) |" in page
    assert "| table1 | beat | 32 | pipeline | shm | 69120 | channel 550 (7.96), adc 150 (2.17) |" in page


def test_the_estimators_page_shows_both_frames_and_stars_only_the_front(tmp_path):
    def rec(m, source, fidelity, t, ratio):
        return {"estimator": m, "preset": "table1", "source": source, "fidelity": fidelity, "rho": "random",
                "snr_db": 20.0, "time_per_cycle_s": t, "time_ratio_to_fft_peak": t / 1e-4, "range_rmse_m": ratio,
                "range_ratio": ratio, "velocity_ratio": 1.0, "n_cycles": 1000, "n_missing": 0}
    recs = [rec("fft_peak", "tones", None, 1e-4, 100.0), rec("ml", "tones", None, 2e-4, 0.98),
            rec("os_cfar", "tones", None, 6e-3, 0.979), rec("fft_peak", "chain", "beat", 1e-4, 100.0),
            rec("ml", "chain", "beat", 2e-4, 1.0), rec("music", "chain", "beat", 7e-4, 1.2)]
    doc = {"command": "python3 dev.py bench estimators", "records": recs, "pareto_snr": 20.0, "default": "ml",
           "reason": "r", "machine": transport_doc(1.0)["machine"]}
    lines = report.estimators_table(doc)
    assert "| table1 | chain, beat | ml | random | 20 | 1 | 1 | 200 | 2.00 | 0 |" in lines
    front = [line for line in lines if line.startswith("| table1 |") and line.count("|") == 7]
    assert "| table1 | tones | * | ml | 200 | 0.98 |" in front
    assert "| table1 | tones |  | os_cfar | 6000 | 0.979 |" in front          # ml's error, 30 times the time
    assert "| table1 | chain, beat |  | music | 700 | 1.2 |" in front


def _tracker_record(preset: str, batch: int, ratios: list[float]) -> dict:
    ratio = statistics.median(ratios)
    return {"preset": preset, "fidelity": "beat", "batch": batch, "mode": "tracker", "transport": "zmq",
            "cycles_per_s": 1000.0 * ratio, "runs_cycles_per_s": [1000.0 * r for r in ratios],
            "real_time_factor": 1000.0 * ratio / 2131.0, "radar_cycles_per_s": 2131.0, "speedup_over_fused": 1.1,
            "bottleneck_node": "channel", "busy_us_per_cycle": {"channel": 550.0, "tracker": 12.5},
            "runs_ratio_to_pipeline": ratios, "ratio_to_pipeline": ratio, "cycles_per_s_loss": 1 - ratio,
            "loss_target": 0.05, "tracker_scene": f"{preset}_following" if preset == "table1" else preset,
            "runs_paired_pipeline_cycles_per_s": [1000.0] * len(ratios),
            "runs_tracks": [{"born": b, "deleted": b - 1} for b in range(1, len(ratios) + 1)]}


@pytest.mark.parametrize("ratios, met", [([0.97, 0.95, 0.99, 0.98, 0.96, 0.97], "yes"),
                                         ([0.97, 0.95, 0.99, 0.90, 0.93, 0.99], "**no**"),
                                         ([0.90, 0.93, 0.92, 0.94, 0.91, 0.93], "**no**")])
def test_the_trackers_loss_is_judged_on_the_table1_runs_pooled_by_the_upper_bound_of_their_mean(tmp_path, ratios,
                                                                                                 met):
    recs = [_tracker_record("table1", 16, ratios[:3]), _tracker_record("table1", 32, ratios[3:]),
            _tracker_record("awr1642", 16, [0.8, 0.85, 0.9])]
    summary, page = render_one(tmp_path, "pipeline", recs)
    first = recs[0]["ratio_to_pipeline"]
    assert (f"| the tracker after the target list: cycles/s lost against the same graph without it, table1 beat, "
            f"batch 16 (scene table1_following; tracks born 2 a run) | {1 - first:.1%} ({1000 * first:.0f} cycles/s, "
            f"{first:.3f} x the graph without it, median of "
            f"3 runs paired run by run; the tracker's block 12.5 us/cycle) | (reported: judged pooled, below) | - |"
            ) in summary
    losses = [1 - r for r in ratios]
    mean, se = np.mean(losses), np.std(losses, ddof=1) / np.sqrt(len(losses))
    upper = stats.t.interval(0.90, len(losses) - 1, loc=mean, scale=se)[1]     # the one-sided 95 % bound
    assert (met == "yes") == (upper <= 0.05)
    assert (f"| the tracker after the target list on the table1 graph (scene table1_following): cycles/s lost, every "
            f"paired run of its cases pooled (6 runs) | {mean:.1%} mean (a run's spread {np.std(losses, ddof=1):.1%}, "
            f"standard error {se:.1%}; one-sided 95 % upper bound {upper:.1%}) | <= 5% (the upper bound) | {met} |"
            ) in summary
    assert ("| the tracker after the target list on the awr1642 graph (scene awr1642): cycles/s lost, every paired "
            "run of its cases pooled (3 runs) | 15.0% mean") in summary and summary.count("(the upper bound)") == 1
    assert (f"; {first:.3f} x the graph without it (runs {', '.join(f'{r:.3f}' for r in ratios[:3])}), tracker 12.5 "
            "us/cycle |") in page
