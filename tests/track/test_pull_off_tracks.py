"""What a range-gate pull-off does to the car's picture of the road, with and without CARAV, on the kernels: the
radar chain in one process (run_algorithm1 on table1_following: Table I's radar behind the car at its own speed,
which keeps its range from cycle to cycle) and the tracker on its estimates, the cycles the detector refused
unmeasured. The tracker is the graph's (graphs/table1_tracks.toml): R from the clean chain's own errors.

Without the detector (eta too high to alarm) the repeater (RARMS 3) sits on the car, then drags its echo away: the
picture follows the false echo at the drag's speed and loses the car (not as one track: while the two echoes share
a range cell the measurements jump beyond the gate, and tracks break and re-form on the false echo). With CARAV
every attacked cycle is refused: no track ever leaves the car; its track coasts through the attack and is kept
when the attack is shorter than the coast limit, deleted when it is longer (and the car found again once the
attack ends)."""
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from carav_stream.firmware.algorithm1 import run_algorithm1
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.loader import load_graph
from carav_stream.track import TrackerConfig, run

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SCENE = scene_of("table1_following")
CAR_M = SCENE.targets[0].range_m
START, CAPTURE = 100, 100
PULL = {"rarms": 3.0, "start_cycle": START, "capture_cycles": CAPTURE, "pull_mps": 4.0, "pull_accel_mps2": 16.0}
COAST = 64
CONFIG = TrackerConfig(dt_s=SCENE.t_cycle_s, sigma_accel_mps2=8.0, sigma_range_m=0.0025, sigma_velocity_mps=0.01,
                       coast_cycles=COAST)
NO_ALARM_ETA = 1e9          # C(eta) = Q / eta never reaches 1: the detector is as good as off


def _tracked(n_cycles: int, eta: float, seed: int, **attack):
    """The chain's measurements (None where the detector refused the cycle) and the tracker's reports."""
    r = run_algorithm1(SCENE, n_cycles, seed=seed, attack="pull_off", attack_params={**PULL, **attack}, eta=eta)
    z = [None if r.alarm[k] else np.array([[r.range_m[k, 0], r.velocity_mps[k, 0]]]) for k in range(n_cycles)]
    return r, run(z, CONFIG)[1]


def _confirmed(report) -> np.ndarray:
    """Range of every confirmed track (coasting included) of a cycle's report."""
    return np.array([r for r, s in zip(report.range_m, report.status) if s != "tentative"])


@pytest.fixture(scope="module")
def undefended():
    return _tracked(1600, NO_ALARM_ETA, seed=5)


def test_without_carav_the_capture_keeps_the_cars_track(undefended):
    r, reports = undefended
    assert not r.alarm.any() and r.attack_active[START:].all()
    for k in range(20, START + CAPTURE):                       # before and during the capture: one track, on the car
        assert reports[k].id.tolist() == [0] and reports[k].status == ("confirmed",)
        assert abs(reports[k].range_m[0] - CAR_M) < 0.01


def test_without_carav_the_pull_off_drags_the_picture_away_at_its_speed(undefended):
    """While the false echo shares the car's range cell, the two echoes (7 dB apart, their phases turning as the
    drag goes) throw the measurements beyond the gate of a filter designed for the clean chain's errors: the car's
    track breaks, and tracks re-form on whatever the estimator reports. Once the false echo is more than a range cell
    (1.02 m) away, every track sits on it, none on the car, and the picture moves away at pull_mps."""
    _, reports = undefended
    attacker = make_attacker("pull_off", SCENE, **PULL)
    false_m = CAR_M + np.array([attacker.offset(k)[0] for k in range(len(reports))])
    late = [k for k in range(len(reports)) if false_m[k] - CAR_M > 1.2]
    assert len(late) > 400
    for k in late:
        assert np.all(np.abs(reports[k].range_m - false_m[k]) < 0.1), (k, reports[k].range_m, false_m[k])
    pictured = [k for k in late if _confirmed(reports[k]).size]
    assert len(pictured) > 0.9 * len(late)
    t = np.array(pictured) * SCENE.t_cycle_s
    seen = np.array([_confirmed(reports[k]).mean() for k in pictured])
    assert np.polyfit(t, seen, 1)[0] == pytest.approx(PULL["pull_mps"], rel=0.05)
    assert 0 in [i for rep in reports for i in rep.deleted]     # the car's own track is gone
    assert all(np.all(np.abs(rep.range_m - CAR_M) > 1.0) for rep in reports[late[0]:])


@pytest.mark.parametrize("n_attacked, kept", [(COAST - 14, True), (COAST + 100, False)])
def test_with_carav_the_track_coasts_through_the_refused_cycles_and_never_moves_to_the_false_range(n_attacked, kept):
    r, reports = _tracked(START + n_attacked + 150, 1.5, seed=6, capture_cycles=10, n_active_cycles=n_attacked)
    attacked = np.arange(START, START + n_attacked)
    assert r.alarm[attacked].all() and not r.alarm[:START].any()   # CARAV refuses every attacked cycle
    for rep in reports[20:]:
        assert np.all(np.abs(rep.range_m - CAR_M) < 0.05) and np.all(np.abs(rep.velocity_mps) < 0.1)
    coasting = reports[START:START + min(n_attacked, COAST)]
    assert all(rep.id.tolist() == [0] and rep.status == ("coasting",) and not rep.measured for rep in coasting)
    var = [rep.var_range_m2[0] for rep in coasting]
    assert all(b > a for a, b in zip(var, var[1:]))              # the covariance grows while it coasts
    after = reports[START + n_attacked + 10]
    if kept:
        assert after.id.tolist() == [0] and after.status == ("confirmed",)
        assert all(rep.deleted == () for rep in reports)
    else:
        assert reports[START + COAST].deleted == (0,)            # deleted after coast_cycles without an update
        assert all(rep.id.size == 0 for rep in reports[START + COAST: START + n_attacked])
        assert after.id.tolist() == [1] and after.status == ("confirmed",)   # the car found again, a new track


def test_the_graphs_tracker_design_fits_the_clean_chain():
    """graphs/table1_tracks.toml's R (the estimator's range and range-rate error RMS) is the clean chain's own: on
    the car without an attack, a filter that knows the car keeps its speed (no process noise) sees a mean NIS in its
    chi-square interval (2 n degrees of freedom over n updates). The graph's filter allows the car to brake and
    accelerate (sigma_accel_mps2), which a car at constant speed does not: its NIS lies lower, so its windowed NIS
    alarm fires less often than designed, never more."""
    graph = load_graph(ROOT / "graphs" / "table1_tracks.toml")
    block = graph.block_class("tracker")(**graph.nodes["tracker"].params)     # its defaults filled in
    design = {k: getattr(block, k) for k in ("sigma_range_m", "sigma_velocity_mps", "nis_pfa", "nis_window")}
    r = run_algorithm1(SCENE, 1200, seed=11)
    z = [np.array([[r.range_m[k, 0], r.velocity_mps[k, 0]]]) for k in range(1200)]
    n = 1199
    low, high = chi2.ppf(0.0005, 2 * n) / n, chi2.ppf(0.9995, 2 * n) / n
    for sigma_accel, within in ((0.0, True), (block.sigma_accel_mps2, False)):
        reports = run(z, TrackerConfig(dt_s=SCENE.t_cycle_s, sigma_accel_mps2=sigma_accel, **design))[1]
        assert all(rep.id.tolist() == [0] for rep in reports)
        nis = np.concatenate([rep.nis for rep in reports[1:]])
        assert nis.mean() < high and (nis.mean() > low) == within
        alarms = np.concatenate([rep.nis_alarm for rep in reports[design["nis_window"]:]])
        assert alarms.mean() <= 5 * design["nis_pfa"]
