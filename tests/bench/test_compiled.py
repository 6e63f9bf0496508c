"""`python3 dev.py bench compiled`: numba's loops give the package's results, the benchmark writes its records, and
the package runs what the records choose (not a timing test)."""
import argparse
import ast
import json
from pathlib import Path

import numpy as np
import pytest

from bench import compiled as bench_compiled
from bench.report import render
from carav_stream.detect.detector import chirp_rms_codes
from carav_stream.radar.adc import adc_codes, adc_step
from carav_stream.radar.noise import standard_normal_rows
from carav_stream.radar.scene_loader import load_scene

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def kernels():
    return bench_compiled.compiled_kernels()


def test_the_loops_give_the_package_results_on_a_table1_frame_with_rails_and_a_nan(kernels):
    got = bench_compiled.check(kernels, bench_compiled._inputs(seed=4))
    assert got["adc"] == 0.0 and got["detector"] == 0.0
    assert 0.0 < got["noise"] < 16.0          # libm against numpy's vector code: last bits only


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("attack_shape", ["per_cycle", "one_for_all", "per_sample_only"])
def test_the_adc_loop_gives_the_same_codes_and_counts_as_adc_codes(kernels, iq, attack_shape):
    scene = load_scene("awr1642", {"iq": iq})
    rng = np.random.default_rng(11)
    lsb = adc_step(scene)
    shape = (3, 4, scene.n_samples)
    dtype = np.complex64 if iq else np.float32
    rx = (rng.standard_normal(shape) * 300 * lsb).astype(np.float32)
    if iq:
        rx = (rx + 1j * (rng.standard_normal(shape) * 300 * lsb)).astype(np.complex64)
    rx[1, 2, 5] = np.inf                                  # a sample off the rails and a NaN in the same cycle
    rx[1, 0, :40] *= 1000
    rx[2, 3, 7] = np.nan
    add_shape = {"per_cycle": shape, "one_for_all": (1,) + shape[1:], "per_sample_only": (1, 1, shape[2])}
    add = (rng.standard_normal(add_shape[attack_shape]) * 100 * lsb).astype(dtype)
    want = adc_codes(scene, rx, add=add)
    got = bench_compiled.adc_compiled(kernels, scene, rx, add, np.empty_like(want[0]))
    assert want[1][1] > 0 and want[2][1] == 1 and want[2][2] == 1
    for a, b in zip(want, got):
        np.testing.assert_array_equal(a, b)


def test_the_detector_loop_gives_chirp_rms_codes_bit_for_bit_loud_chirps_included(kernels):
    rng = np.random.default_rng(2)
    codes = rng.integers(-2048, 2048, (2, 8, 1080), dtype=np.int16)
    codes[0, :4] //= 40                                   # quiet chirps beside full-scale ones
    codes[1, 5] = -32768                                  # a 16-bit extreme: the sum needs 64 bits
    for iq in (False, True):
        c = codes.reshape(2, 8, 540, 2) if iq else codes
        np.testing.assert_array_equal(bench_compiled.rms_compiled(kernels, c, 0.37, iq), chirp_rms_codes(c, 0.37, iq))


def test_the_noise_loop_draws_the_same_words_as_the_package(kernels):
    """Odd row length (the last sine dropped), rows from consecutive words: only the last bits may differ."""
    x = standard_normal_rows(np.random.default_rng(5), 3, 1081, 0.5)
    y = bench_compiled.noise_compiled(kernels, np.random.default_rng(5), 3, 1081, 0.5, np.empty((3, 1081), np.float32))
    np.testing.assert_allclose(y, x, rtol=2e-6, atol=1e-6)


def _kernel(target, kernel, ratio, break_even):
    return {"bench": "kernel", "target": target, "kernel": kernel, "ratio": ratio, "break_even_cycles": break_even}


@pytest.mark.parametrize("rows, expected", [
    ([_kernel("native", "adc", 0.5, 100.0), _kernel("avx2", "adc", 1.2, None)],
     "keep numpy: numba is not faster on avx2"),
    ([_kernel("native", "adc", 0.5, 100.0), _kernel("avx2", "adc", 0.6, 400.0)], "keep numpy: numba is faster on "
     "native, avx2, but its start cost is repaid only after 400 cycles (a default run: 300)"),
    ([_kernel("native", "adc", 0.5, 100.0), _kernel("avx2", "adc", 0.6, 250.0)],
     "numba: faster on every target and repaid after 250 cycles (a default run: 300)"),
    ([_kernel("native", "noise", 0.5, 1.0)], "keep numpy: not measured")])
def test_the_choice_takes_numba_only_when_faster_everywhere_and_repaid_within_a_default_run(rows, expected):
    assert bench_compiled.choice(rows, "adc", 300) == expected


def test_the_package_runs_what_the_records_choose():
    """The package has no compiled path: every kernel's recorded choice must be numpy, and nothing in the package
    imports numba. Records that choose numba fail here until the package uses it."""
    doc = json.loads((ROOT / "docs/bench/records/compiled.json").read_text())
    assert doc["default_run_cycles"] == bench_compiled.default_run_cycles()
    for kernel in bench_compiled.KERNELS:
        assert bench_compiled.choice(doc["records"], kernel, doc["default_run_cycles"]).startswith("keep numpy")
    targets = {r["target"] for r in doc["records"] if r["bench"] == "kernel"}
    assert targets == {"native", "avx2"} and doc["machine"]["simd"] == "AVX512F"
    for path in (ROOT / "carav_stream").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n.split(".")[0] == "numba" for n in names), path


@pytest.mark.slow
def test_the_benchmark_writes_its_records_and_the_report_renders_them(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    bench_compiled.configure(parser)
    out = tmp_path / "compiled.json"
    args = parser.parse_args(["--json", str(out), "--repeats", "1", "--starts", "1", "--targets", "native"])
    assert bench_compiled.run(args) == 0
    doc = json.loads(out.read_text())
    kernels = [r for r in doc["records"] if r["bench"] == "kernel"]
    assert [(r["target"], r["kernel"]) for r in kernels] == [("native", k) for k in bench_compiled.KERNELS]
    assert all(r["numpy_ns_per_sample"] > 0 and r["numba_ns_per_sample"] > 0 for r in kernels)
    assert [r["difference_eps"] == 0 for r in kernels] == [True, True, False]
    starts = [r for r in doc["records"] if r["bench"] == "start"]
    assert [(r["kernel"], r["cache"]) for r in starts] == [(k, c) for k in bench_compiled.KERNELS
                                                           for c in ("cold", "warm")]
    assert all(r["cpu_s"] >= r["import_cpu_s"] > 0 for r in starts)
    printed = capsys.readouterr().out
    for kernel in bench_compiled.KERNELS:
        assert f"{kernel}: {bench_compiled.choice(doc['records'], kernel, doc['default_run_cycles'])}" in printed
    (tmp_path / "docs/bench/records").mkdir(parents=True)
    (tmp_path / "docs/bench/records/compiled.json").write_text(out.read_text())
    text = render(tmp_path)[tmp_path / "BENCHMARKS.md"]
    assert "| adc: numpy or numba | keep numpy" in text or "| adc: numpy or numba | numba" in text
