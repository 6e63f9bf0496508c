"""bench estimators: record contents on a tiny run, and the Pareto / threshold / default-choice logic."""
import numpy as np
import pytest

from bench import estimators as bench
from carav_stream.estimate import Geometry

SMALL = Geometry(fs_hz=20e6, slope_hz_per_s=4e12, fc_hz=77e9, t_chirp_s=50e-6, n_samples=128, iq=False)
REQUIRED = {"estimator", "preset", "snr_db", "time_per_cycle_s", "range_rmse_m", "range_crlb_m", "velocity_rmse_mps"}


def test_measure_writes_required_fields_and_ml_beats_fft_peak():
    recs = bench.measure("small", SMALL, 32, 30.0, 2.0, 20.0, ["fft_peak", "ml"], n_cycles=24, batch=12, repeat=1,
                         rng=np.random.default_rng(1))
    assert len(recs) == 2 and all(REQUIRED <= set(r) for r in recs)
    by = {r["estimator"]: r for r in recs}
    assert by["ml"]["range_rmse_m"] < 0.2 * by["fft_peak"]["range_rmse_m"]
    assert by["ml"]["range_ratio"] < 2.0
    assert by["fft_peak"]["time_ratio_to_fft_peak"] == pytest.approx(1.0)


def test_measure_chain_scores_the_radar_chains_frames_against_the_bound_of_the_echos_samples():
    recs = bench.measure_chain("table1", "beat", 20.0, ["fft_peak", "ml"], n_cycles=32, batch=16, repeat=1,
                               rng=np.random.default_rng(2))
    by = {r["estimator"]: r for r in recs}
    assert all(REQUIRED <= set(r) and r["source"] == "chain" and r["fidelity"] == "beat" for r in recs)
    assert 0.6 < by["ml"]["range_ratio"] < 1.6 and 0.6 < by["ml"]["velocity_ratio"] < 1.6
    assert by["fft_peak"]["range_ratio"] > 50                                 # grid-limited


def _rec(m, snr, ratio, t, rmse=None, vratio=1.0, xp=None, n=1000, missing=0):
    return {"estimator": m, "preset": "p", "rho": "random", "snr_db": snr, "range_ratio": ratio,
            "velocity_ratio": vratio, "time_per_cycle_s": t, "range_rmse_m": rmse if rmse is not None else ratio,
            "time_ratio_to_fft_peak": xp if xp is not None else t, "n_cycles": n, "n_missing": missing}


def test_threshold_is_lowest_snr_from_which_ratio_stays_below_two():
    recs = [_rec("a", s, r, 1.0) for s, r in [(-10, 9.0), (0, 1.5), (10, 3.0), (20, 1.1), (30, 1.0)]]
    assert bench.threshold_snr(recs, "a", "p") == 20
    assert bench.threshold_snr([_rec("b", 30, 5.0, 1.0)], "b", "p") is None


def test_pareto_marks_dominated_estimators():
    recs = [_rec("fast", 20, 5.0, 1.0), _rec("good", 20, 1.0, 2.0), _rec("bad", 20, 6.0, 3.0)]
    front = {r["estimator"]: r["pareto"] for r in bench.pareto(recs, "p", 20)}
    assert front == {"fast": True, "good": True, "bad": False}


def test_an_error_tied_within_the_monte_carlo_noise_does_not_save_a_slower_estimator():
    # a CFAR list refined by ml scores ml's error to a hair below: 30 times slower, it is dominated
    ml, cfar = _rec("ml", 20, 0.984, 0.2e-3), _rec("os_cfar", 20, 0.983, 6e-3)
    front = {r["estimator"]: r["pareto"] for r in bench.pareto([ml, cfar], "p", 20)}
    assert front == {"ml": True, "os_cfar": False}
    assert bench.dominates(ml, cfar) and not bench.dominates(cfar, ml)
    # clearly better beyond the noise (2 / sqrt(1000) = 6 %): the slower one stays on the front
    assert not bench.dominates(ml, _rec("sharp", 20, 0.9, 6e-3))
    # with 10 cycles a point the noise is 63 %: 0.9 against 0.984 is a tie again
    assert bench.dominates(_rec("ml", 20, 0.984, 0.2e-3, n=10), _rec("sharp", 20, 0.9, 6e-3, n=10))


def test_equal_times_and_errors_dominate_neither_way_and_misses_count():
    a, b = _rec("a", 20, 1.0, 1.0), _rec("b", 20, 1.0, 1.0)
    assert not bench.dominates(a, b) and not bench.dominates(b, a)
    assert not bench.dominates(a, a)
    # faster and as good, but it misses cycles the other lists: not dominating
    assert not bench.dominates(_rec("lossy", 20, 1.0, 0.5, missing=3), b)
    # a NaN error (every cycle missed) is the worst error
    assert bench.dominates(a, _rec("none", 20, float("nan"), 2.0, rmse=float("nan")))


def test_pareto_compares_only_records_of_the_same_frames():
    tones, chain = _rec("ml", 20, 1.0, 1.0), dict(_rec("music", 20, 1.0, 2.0), source="chain", fidelity="beat")
    assert [r["pareto"] for r in bench.pareto([tones, chain], "p", 20)] == [True]
    assert [r["pareto"] for r in bench.pareto([tones, chain], "p", 20, "chain", "beat")] == [True]


def test_default_is_fastest_estimator_meeting_both_targets():
    recs = []
    for s in (10, 20, 30):
        recs += [_rec("fft_peak", s, 100.0, 1.0, xp=1.0), _rec("ml", s, 1.05, 1.5, xp=1.5),
                 _rec("slow", s, 1.0, 9.0, xp=9.0), _rec("biased", s, 1.3, 1.1, xp=1.1)]
    name, reason = bench.choose_default(recs, ["p"])
    assert name == "ml" and "1.50 x" in reason
