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


def _rec(m, snr, ratio, t, rmse=None, vratio=1.0, xp=None):
    return {"estimator": m, "preset": "p", "rho": "random", "snr_db": snr, "range_ratio": ratio,
            "velocity_ratio": vratio, "time_per_cycle_s": t, "range_rmse_m": rmse if rmse is not None else ratio,
            "time_ratio_to_fft_peak": xp if xp is not None else t}


def test_threshold_is_lowest_snr_from_which_ratio_stays_below_two():
    recs = [_rec("a", s, r, 1.0) for s, r in [(-10, 9.0), (0, 1.5), (10, 3.0), (20, 1.1), (30, 1.0)]]
    assert bench.threshold_snr(recs, "a", "p") == 20
    assert bench.threshold_snr([_rec("b", 30, 5.0, 1.0)], "b", "p") is None


def test_pareto_marks_dominated_estimators():
    recs = [_rec("fast", 20, 5.0, 1.0), _rec("good", 20, 1.0, 2.0), _rec("bad", 20, 6.0, 3.0)]
    front = {r["estimator"]: r["pareto"] for r in bench.pareto(recs, "p", 20)}
    assert front == {"fast": True, "good": True, "bad": False}


def test_default_is_fastest_estimator_meeting_both_targets():
    recs = []
    for s in (10, 20, 30):
        recs += [_rec("fft_peak", s, 100.0, 1.0, xp=1.0), _rec("ml", s, 1.05, 1.5, xp=1.5),
                 _rec("slow", s, 1.0, 9.0, xp=9.0), _rec("biased", s, 1.3, 1.1, xp=1.1)]
    name, reason = bench.choose_default(recs, ["p"])
    assert name == "ml" and "1.50 x" in reason
