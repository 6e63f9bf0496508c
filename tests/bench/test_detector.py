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
