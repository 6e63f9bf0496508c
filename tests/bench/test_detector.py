"""The detector benchmark's exact reference and its stress records."""
from __future__ import annotations

import numpy as np
import pytest

from bench import detector as bench
from carav_stream.detect.detector import detect


def test_exact_reference_agrees_with_detect_to_rounding():
    rng = np.random.default_rng(0)
    rho = np.array([1, 0, 1, 0, 0, 1], dtype=bool)
    x = rng.standard_normal((6, 9))
    q = detect(x, rho, 0.7).q
    assert float(bench.exact_q(x, rho, 0.7)) == pytest.approx(q, rel=1e-14)


def test_exact_reference_sees_an_error_of_one_ulp_in_the_samples():
    x = np.array([[1.0, 2.0], [3.0, 4.0]])
    rho = np.array([1, 0], dtype=bool)
    a = bench.exact_q(x, rho, 1.0)
    x[1, 1] = np.nextafter(4.0, 5.0)
    assert bench.exact_q(x, rho, 1.0) != a


def test_stress_benchmark_finds_q_accurate_to_a_few_ulps_at_every_scale_and_dtype():
    records = bench.bench_stress(quick=True)
    assert {r["dtype"] for r in records} == {"float32", "float64", "complex64", "complex128"}
    for r in records:
        assert r["max_rel_err_q"] < 1e-14, r


def test_the_int16_path_is_given_per_code_beside_its_bound_and_a_read(capsys):
    r = bench.bench_codes(repeat=1, n_cycles=4)
    assert r["bench"] == "kernel_codes" and r["dtype"] == "int16"
    assert r["shape"] == [4, 64, 1080] and r["codes"] == 4 * 64 * 1080          # table1: 64 chirps x 1080 samples
    for key in ("ns_per_code", "bound_ns_per_code", "read_ns_per_code", "x_bound", "x_read"):
        assert isinstance(r[key], float) and np.isfinite(r[key]) and r[key] > 0, (key, r[key])
    assert r["x_bound"] == pytest.approx(r["ns_per_code"] / r["bound_ns_per_code"], rel=1e-12)
    assert r["x_read"] == pytest.approx(r["ns_per_code"] / r["read_ns_per_code"], rel=1e-12)
    bench._print([r])
    printed = capsys.readouterr().out
    assert "adc_chirp_rms" in printed and f"{r['ns_per_code']:.3f} ns/code" in printed
    assert f"bound {r['bound_ns_per_code']:.3f} ns/code" in printed
