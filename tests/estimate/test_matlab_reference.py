"""Table1 against MATLAB's published FMCWExample numbers (42.9976 m, 1.0830 m/s), within our Monte Carlo."""
import numpy as np
import pytest

from carav_stream.estimate import estimate
from carav_stream.estimate.matlab_reference import (
    MATLAB_TABLE1_CLOSING_SPEED_MPS,
    MATLAB_TABLE1_RANGE_M,
    TABLE1_TRUE_CLOSING_SPEED_MPS,
    TABLE1_TRUE_RANGE_M,
    fmcw_example_estimate,
    rootmusic_vector,
)
from carav_stream.estimate.matlab_reference import fmcw_example_geometry as table1_geometry
from carav_stream.estimate.tones import synth_beat


def test_matlab_style_rootmusic_recovers_noise_free_tone():
    f = rootmusic_vector(np.exp(2j * np.pi * 0.0371 * np.arange(200)), 1)
    assert f[0] == pytest.approx(0.0371, abs=1e-7)


@pytest.fixture(scope="module")
def table1_runs():
    g = table1_geometry()
    rng = np.random.default_rng(2026)
    rho = np.ones((60, 64), bool)
    x = synth_beat(g, rho, [TABLE1_TRUE_RANGE_M], [-TABLE1_TRUE_CLOSING_SPEED_MPS], snr_sample_db=2.2, rng=rng,
                   migrate=True)
    return g, x, rho, fmcw_example_estimate(x, g)


def test_matlab_published_table1_result_lies_within_our_replica_spread(table1_runs):
    _, _, _, ref = table1_runs
    for key, published in (("range_m", MATLAB_TABLE1_RANGE_M), ("closing_speed_mps", MATLAB_TABLE1_CLOSING_SPEED_MPS)):
        z = (published - ref[key].mean()) / ref[key].std(ddof=1)
        assert abs(z) < 3.0, (key, published, ref[key].mean(), ref[key].std())


def test_ml_beat_range_carries_the_coupling_and_matches_matlab_within_3_sigma(table1_runs):
    g, x, rho, _ = table1_runs
    e = estimate(x, rho, g, method="ml")
    beat_only = e.beat_hz[:, 0] * g.range_per_hz_m
    # truth of the beat-only range: mid-frame range plus the -4.2 mm coupling
    mid = TABLE1_TRUE_RANGE_M - TABLE1_TRUE_CLOSING_SPEED_MPS * 31.5 * g.t_chirp_s
    expected = mid - g.range_per_hz_m * 2 * TABLE1_TRUE_CLOSING_SPEED_MPS / g.wavelength_m
    assert beat_only.mean() == pytest.approx(expected, abs=4 * beat_only.std() / np.sqrt(len(beat_only)))
    assert abs(MATLAB_TABLE1_RANGE_M - beat_only.mean()) < 3 * beat_only.std()
    assert abs(-MATLAB_TABLE1_CLOSING_SPEED_MPS - e.velocity_mps.mean()) < 0.03
    np.testing.assert_allclose(e.range_m.mean(), mid, atol=1e-3)
