"""Track management: coasting through unmeasured cycles, deletion after misses or the coast limit, M-of-N
confirmation, births, and global nearest neighbour association; each against what the rules and the model say,
written here from the equations."""
import numpy as np
import pytest

from carav_stream.track import TrackerConfig, Tracks, gnn, run, step

DT, SIGMA_A, SIGMA_R, SIGMA_V = 0.05, 1.5, 0.1, 0.05
TARGET = np.array([[30.0, -1.0]])


def _config(**kw) -> TrackerConfig:
    return TrackerConfig(dt_s=DT, sigma_accel_mps2=SIGMA_A, sigma_range_m=SIGMA_R, sigma_velocity_mps=SIGMA_V, **kw)


def _on_target(n: int, k0: int = 0) -> list[np.ndarray]:
    """The noise-free target moving at -1 m/s, cycles k0 .. k0 + n - 1."""
    return [TARGET + [[-1.0 * DT * k, 0.0]] for k in range(k0, k0 + n)]


def _confirmed(config: TrackerConfig, n: int = 10) -> Tracks:
    tracks, reports = run(_on_target(n), config)
    assert reports[-1].status == ("confirmed",)
    return tracks


def test_coasting_grows_the_covariance_as_the_model_predicts():
    """k cycles without a measurement: P_k = F^k P F^kT + sigma_a^2 sum_j (F^j G)(F^j G)^T, F^j = [[1, j dt], [0, 1]],
    and the state moves on at its velocity."""
    config = _config()
    tracks = _confirmed(config)
    p0, x0 = tracks.p[0], tracks.x[0]
    for k in range(1, 40):
        tracks, report = step(tracks, None, config)
        fk = np.array([[1.0, k * DT], [0.0, 1.0]])
        g = [np.array([DT * DT / 2 + j * DT * DT, DT]) for j in range(k)]
        expected = fk @ p0 @ fk.T + SIGMA_A ** 2 * sum(np.outer(v, v) for v in g)
        np.testing.assert_allclose(tracks.p[0], expected, rtol=1e-9)
        np.testing.assert_allclose(tracks.x[0], fk @ x0, rtol=1e-12)
        assert report.status == ("coasting",) and not report.updated[0] and np.isnan(report.nis[0])
        np.testing.assert_allclose([report.var_range_m2[0], report.var_velocity_m2ps2[0]], np.diag(expected))


def test_an_unmeasured_cycle_is_no_miss_and_starts_no_track():
    config = _config(delete_misses=2, coast_cycles=1000)
    tracks = _confirmed(config)
    for _ in range(500):                     # a long refusal: coasting, never a miss
        tracks, report = step(tracks, None, config)
    assert report.id.tolist() == [0] and tracks.misses[0] == 0 and report.born == ()
    tracks, report = step(tracks, np.zeros((0, 2)), config)      # a measured cycle without it: one miss
    assert tracks.misses[0] == 1 and report.status == ("coasting",)


def test_a_confirmed_track_is_deleted_at_its_kth_consecutive_miss_and_not_before():
    k = 4
    config = _config(delete_misses=k)
    tracks = _confirmed(config)
    for i in range(1, k):
        tracks, report = step(tracks, np.zeros((0, 2)), config)
        tracks, report = step(tracks, None, config)               # refused cycles between misses count for nothing
        assert report.id.tolist() == [0] and tracks.misses[0] == i
    tracks, report = step(tracks, np.zeros((0, 2)), config)
    assert report.deleted == (0,) and len(tracks) == 0


def test_a_hit_resets_the_misses():
    config = _config(delete_misses=3)
    tracks, reports = run(_on_target(10) + [np.zeros((0, 2))] * 2 + _on_target(1, 12) + [np.zeros((0, 2))] * 2,
                          config)
    assert tracks.id.tolist() == [0] and tracks.misses[0] == 2 and reports[12].status == ("confirmed",)


@pytest.mark.parametrize("limit", [0, 1, 17])
def test_a_track_coasts_up_to_the_coast_limit_and_is_deleted_after_it(limit):
    config = _config(coast_cycles=limit)
    tracks = _confirmed(config)
    for _ in range(limit):
        tracks, report = step(tracks, None, config)
        assert report.id.tolist() == [0]
    kept, _ = run(_on_target(1, 10 + limit), config, tracks)        # the target again: the track is still there
    assert kept.id.tolist() == [0] and kept.idle[0] == 0
    tracks, report = step(tracks, None, config)
    assert report.deleted == (0,) and len(tracks) == 0


@pytest.mark.parametrize("pattern, confirmed_at, deleted_at", [
    ("hhh", 2, None),          # 3 of the first 3
    ("hmhmh", 4, None),        # the 3rd hit at the 5th measured cycle
    ("hhmmh", 4, None),
    ("hmmm", None, 3),         # 2 misses allowed in 5: the 3rd ends it
    ("hhmmm", None, 4),
    ("hmhmm", None, 4),
])
def test_m_of_n_confirmation(pattern, confirmed_at, deleted_at):
    """M = 3 of N = 5: confirmed at the cycle of the 3rd hit within the first 5 measured cycles; deleted once 3 hits
    can no longer come. Unmeasured cycles between them change nothing."""
    config = _config(confirm_m=3, confirm_n=5, coast_cycles=100)
    tracks = Tracks.empty(config)
    for i, c in enumerate(pattern):
        tracks, report = step(tracks, None, config)                # a refused cycle before each measured one
        assert report.born == () and report.deleted == ()
        tracks, report = step(tracks, TARGET + [[-2 * DT * i, 0]] if c == "h" else np.zeros((0, 2)), config)
        if deleted_at is not None and i == deleted_at:
            assert report.deleted == (0,) and len(tracks) == 0
            return
        assert report.id.tolist() == [0]
        assert report.status[0] == ("confirmed" if confirmed_at is not None and i >= confirmed_at else "tentative")
    assert deleted_at is None


def test_m_of_one_confirms_at_birth():
    _, reports = run(_on_target(1), _config(confirm_m=1, confirm_n=1))
    assert reports[0].status == ("confirmed",) and reports[0].born == (0,)


def test_a_measurement_outside_every_gate_starts_a_tentative_track_beside_the_old():
    config = _config()
    tracks = _confirmed(config)
    far = TARGET + [[-1.0 * DT * 10 + 5.0, 0.0]]
    near = TARGET + [[-1.0 * DT * 10, 0.0]]
    tracks, report = step(tracks, np.concatenate([far, near]), config)
    assert report.id.tolist() == [0, 1] and report.born == (1,)
    assert report.status == ("confirmed", "tentative") and report.range_m[1] == far[0, 0]


def test_gnn_takes_the_global_optimum_where_nearest_first_would_not():
    """Tracks A, B; measurements 1, 2. Nearest first pairs B-1 (0.16) and leaves A with 2 (2.89): 3.05 in all.
    The global optimum is A-1 + B-2 = 0.36 + 0.49."""
    d2 = np.array([[0.36, 2.89], [0.16, 0.49]])
    rows, cols = gnn(d2, np.zeros(2), gamma=9.0)
    assert rows.tolist() == [0, 1] and cols.tolist() == [0, 1]


def test_gnn_leaves_out_what_lies_outside_the_gate_and_weighs_the_covariance():
    d2 = np.array([[10.0, 12.0], [0.5, 11.0]])
    rows, cols = gnn(d2, np.zeros(2), gamma=9.0)
    assert rows.tolist() == [1] and cols.tolist() == [0]
    # one measurement, two tracks at the same distance: the one with the tighter covariance (smaller ln det S) takes it
    rows, cols = gnn(np.array([[1.0], [1.0]]), np.log([4.0, 1.0]), gamma=9.0)
    assert rows.tolist() == [1] and cols.tolist() == [0]
    rows, cols = gnn(np.zeros((0, 3)), np.zeros(0), gamma=9.0)
    assert rows.size == cols.size == 0


def test_one_tracks_pairing_is_the_assignments_whatever_the_measurements():
    """One track takes its nearest measurement within the gate without scipy's assignment: the pairing the
    assignment of the module docstring's costs gives, on random distances within and beyond the gate."""
    from scipy.optimize import linear_sum_assignment
    rng = np.random.default_rng(3)
    for m in (1, 2, 5):
        for _ in range(200):
            d2, log_det, gamma = rng.exponential(8.0, (1, m)), rng.normal(size=1), 9.0
            cost = np.full((1, m + 1), np.inf)
            cost[:, :m] = np.where(d2 <= gamma, d2 + log_det[:, None], np.inf)
            cost[0, m] = gamma + log_det[0]
            r, c = linear_sum_assignment(cost)
            expected = [int(c[0])] if c[0] < m else []
            rows, cols = gnn(d2, log_det, gamma)
            assert cols.tolist() == expected and rows.tolist() == [0] * len(expected)


def test_two_crossing_targets_keep_their_tracks():
    """Two targets 2 m apart closing at 1 m/s each pass each other in range, each measured every cycle: with the
    Doppler in the measurement GNN keeps every track on its own target through the crossing."""
    config = _config()
    steps = [np.array([[20.0 + 1.0 * DT * k, 1.0], [22.0 - 1.0 * DT * k, -1.0]]) for k in range(80)]
    tracks, reports = run(steps, config)
    assert tracks.id.tolist() == [0, 1]
    np.testing.assert_allclose(tracks.x[:, 1], [1.0, -1.0], atol=1e-6)
    assert all(r.born == () for r in reports[1:]) and all(r.deleted == () for r in reports)


@pytest.mark.parametrize("kw, culprit", [
    ({"confirm_m": 4, "confirm_n": 3}, "confirm_m"), ({"delete_misses": 0}, "delete_misses"),
    ({"coast_cycles": -1}, "coast_cycles"), ({"nis_pfa": 1.0}, "nis_pfa"), ({"nis_window": 0}, "nis_window"),
    ({"gate_probability": 1.0}, "gate_probability"), ({"dt_s": 0.0}, "dt_s"), ({"sigma_range_m": 0.0}, "sigma_range_m"),
    ({"sigma_accel_mps2": -1.0}, "sigma_accel_mps2"),
])
def test_a_bad_design_is_refused_by_name(kw, culprit):
    values = {"dt_s": DT, "sigma_accel_mps2": SIGMA_A, "sigma_range_m": SIGMA_R, "sigma_velocity_mps": SIGMA_V, **kw}
    with pytest.raises(ValueError, match=culprit):
        TrackerConfig(**values)
