"""The filter against closed forms, on targets that move as its model says: constant velocity, a white acceleration
of known RMS held over each cycle, white measurement noise of known covariance.

Many targets far apart (one Monte Carlo run each, tracked together) give ensemble figures at every cycle:

- the innovations are white with the covariance the filter predicts: the NIS averaged over every target and cycle
  lies in its chi-square interval (2 N degrees of freedom over N independent values), and the lag-1
  autocorrelation of the normalised innovations is within a few 1 / sqrt(N) of 0;
- the error matches the filter's covariance: the NEES averaged over the targets at a cycle lies in its chi-square
  interval, at every cycle looked at;
- the opt-in NIS alarm fires at its design rate on such targets.

The model, its noise and the reference quantities are written here from the equations, not taken from the code.
"""
import numpy as np
import pytest
from scipy.stats import chi2

from carav_stream.track import TrackerConfig, Tracks, step

DT, SIGMA_A, SIGMA_R, SIGMA_V = 0.04, 2.0, 0.05, 0.08
N_TARGETS, N_CYCLES = 200, 150
ALPHA = 1e-3          # two-sided: each interval holds with probability 0.999 under a consistent filter


def _truth_and_measurements(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """truth (cycles, targets, 2) under x_k+1 = F x_k + G a_k, measurements z = x + N(0, R)."""
    rng = np.random.default_rng(seed)
    f = np.array([[1.0, DT], [0.0, 1.0]])
    g = np.array([DT * DT / 2.0, DT])
    x = np.stack([20.0 + 50.0 * np.arange(N_TARGETS), rng.uniform(-10, 10, N_TARGETS)], axis=1)
    truth = np.empty((N_CYCLES, N_TARGETS, 2))
    for k in range(N_CYCLES):
        truth[k] = x
        x = x @ f.T + np.outer(rng.normal(0.0, SIGMA_A, N_TARGETS), g)
    z = truth + rng.normal(size=truth.shape) * [SIGMA_R, SIGMA_V]
    return truth, z


def _config(**kw) -> TrackerConfig:
    """The model's own figures; a gate wide enough (probability 1 - 1e-9) that none of the 30 000 measurements
    falls outside it, so that the figures are those of the filter, not of the gate's truncation."""
    return TrackerConfig(dt_s=DT, sigma_accel_mps2=SIGMA_A, sigma_range_m=SIGMA_R, sigma_velocity_mps=SIGMA_V,
                         gate_probability=1 - 1e-9, **kw)


def _track(config: TrackerConfig, seed: int = 1):
    """Every cycle's tracks (full covariances) and the innovation each update used, written from the model."""
    truth, z = _truth_and_measurements(seed)
    f = np.array([[1.0, DT], [0.0, 1.0]])
    tracks, states, innovations, reports = Tracks.empty(config), [], [], []
    for k in range(N_CYCLES):
        before = tracks
        tracks, report = step(tracks, z[k], config)
        assert report.id.tolist() == list(range(N_TARGETS)), "a track was lost or born on a consistent target"
        states.append(tracks)
        innovations.append(None if k == 0 else z[k] - before.x @ f.T)
        reports.append(report)
    return truth, states, innovations, reports


@pytest.fixture(scope="module")
def tracked():
    return _track(_config(nis_pfa=0.01))


def test_the_mean_nis_lies_in_its_chi_square_interval(tracked):
    _, _, _, reports = tracked
    nis = np.concatenate([r.nis for r in reports[1:]])
    assert np.isfinite(nis).all() and nis.size == N_TARGETS * (N_CYCLES - 1)
    n = nis.size
    low, high = chi2.ppf(ALPHA / 2, 2 * n) / n, chi2.ppf(1 - ALPHA / 2, 2 * n) / n
    assert low < nis.mean() < high


def test_the_nis_is_what_the_predicted_covariance_makes_of_the_innovation(tracked):
    """NIS = nu^T (F P F^T + Q + R)^-1 nu with every matrix written from the model."""
    _, states, innovations, reports = tracked
    f = np.array([[1.0, DT], [0.0, 1.0]])
    g = np.array([DT * DT / 2.0, DT])
    q, r = SIGMA_A ** 2 * np.outer(g, g), np.diag([SIGMA_R ** 2, SIGMA_V ** 2])
    for k in (1, 7, 80):
        s = f @ states[k - 1].p @ f.T + q + r
        nu = innovations[k]
        expected = np.einsum("ni,nij,nj->n", nu, np.linalg.inv(s), nu)
        np.testing.assert_allclose(reports[k].nis, expected, rtol=1e-9)


def test_the_innovations_are_white(tracked):
    """Lag-1 autocorrelation of the range and the velocity innovations, each normalised by its own predicted
    standard deviation, over every target from cycle 20 on (the gains have settled): N(0, 1 / N) under H0."""
    _, states, innovations, _ = tracked
    f = np.array([[1.0, DT], [0.0, 1.0]])
    g = np.array([DT * DT / 2.0, DT])
    q, r = SIGMA_A ** 2 * np.outer(g, g), np.diag([SIGMA_R ** 2, SIGMA_V ** 2])
    normalised = []
    for k in range(20, N_CYCLES):
        s = f @ states[k - 1].p @ f.T + q + r
        normalised.append(innovations[k] / np.sqrt(np.stack([s[:, 0, 0], s[:, 1, 1]], axis=1)))
    e = np.array(normalised)                                    # (cycles, targets, 2)
    for component in (0, 1):
        a, b = e[:-1, :, component].ravel(), e[1:, :, component].ravel()
        rho = np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b))
        assert abs(rho) < 3.3 / np.sqrt(a.size)
        assert abs(np.mean(e[..., component] ** 2) - 1.0) < 0.05   # and unit variance


def test_the_error_matches_the_filter_covariance_nees(tracked):
    """NEES (x - truth)^T P^-1 (x - truth), averaged over the targets at a cycle: chi-square with 2 N_TARGETS
    degrees of freedom over N_TARGETS, at the first cycle, while the gains settle and in steady state."""
    truth, states, _, _ = tracked
    n = N_TARGETS
    low, high = chi2.ppf(ALPHA / 2, 2 * n) / n, chi2.ppf(1 - ALPHA / 2, 2 * n) / n
    for k in (0, 3, 10, 40, 90, 149):
        e = states[k].x - truth[k]
        nees = np.einsum("ni,nij,nj->n", e, np.linalg.inv(states[k].p), e)
        assert low < nees.mean() < high, f"cycle {k}: mean NEES {nees.mean():.3f} outside [{low:.3f}, {high:.3f}]"


def test_the_nis_alarm_fires_at_its_design_rate_on_a_consistent_target(tracked):
    _, _, _, reports = tracked
    alarms = np.concatenate([r.nis_alarm for r in reports[1:]])
    n, p = alarms.size, 0.01
    assert abs(alarms.mean() - p) < 3.3 * np.sqrt(p * (1 - p) / n)


def test_a_windowed_nis_alarm_keeps_its_design_rate():
    """Sum of the last 5 NIS: chi-square with 10 degrees of freedom; overlapping windows are correlated, which
    widens the spread of the rate by at most sqrt(window)."""
    _, _, _, reports = _track(_config(nis_pfa=0.01, nis_window=5), seed=2)
    alarms = np.concatenate([r.nis_alarm for r in reports[5:]])
    n, p = alarms.size, 0.01
    assert abs(alarms.mean() - p) < 3.3 * np.sqrt(5 * p * (1 - p) / n)
    assert not np.concatenate([r.nis_alarm for r in reports[:5]]).any()   # no alarm before the window is full


def test_the_nis_alarm_fires_on_a_target_the_model_does_not_describe():
    """A measurement that walks away at 3 m/s while its Doppler says the target keeps its speed (a range pull):
    the innovations stop being white and the windowed NIS crosses its threshold."""
    config = _config(nis_pfa=1e-4, nis_window=8)
    rng = np.random.default_rng(5)
    tracks, first = Tracks.empty(config), None
    for k in range(200):
        pull = 3.0 * DT * max(0, k - 100)
        z = np.array([[40.0 + pull, 0.0]]) + rng.normal(size=(1, 2)) * [SIGMA_R, SIGMA_V]
        tracks, report = step(tracks, z, config)
        if first is None and report.nis_alarm.any():
            first = k
    assert first is not None and 100 < first < 130
