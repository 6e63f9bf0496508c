"""Blind zones per scene: every detector judged on the same attacked cycles, and the weakest attack it catches."""
from carav_stream.firmware.blind_zone import DETECTORS, miss_rates, weakest_caught
from carav_stream.radar.scene_loader import load_scene


def _rows(missed_by_rarms: dict, n: int = 10) -> list[dict]:
    return [{"rarms": r, "trials": n, "missed": {d: m for d in DETECTORS}} for r, m in missed_by_rarms.items()]


def test_weakest_caught_is_where_the_miss_rate_stays_low_from_then_on():
    # 2 misses in 10 at 0.5 are more than one in ten: the lucky 0 at 0.2 below it does not count
    assert weakest_caught(_rows({0.1: 10, 0.2: 0, 0.5: 2, 1.0: 0})) == dict.fromkeys(DETECTORS, 1.0)
    assert weakest_caught(_rows({0.1: 10, 0.2: 0, 0.5: 1, 1.0: 0})) == dict.fromkeys(DETECTORS, 0.2)
    assert weakest_caught(_rows({0.1: 1, 0.2: 0})) == dict.fromkeys(DETECTORS, 0.1)
    assert weakest_caught(_rows({0.1: 10, 0.2: 10})) == dict.fromkeys(DETECTORS, None)


def test_a_faint_ghost_hides_from_every_detector_and_a_strong_one_from_none():
    rows = miss_rates(load_scene("table1"), "ghost", (0.02, 3.0), 60, seed=1, fidelity="beat",
                      params={"range_m": 25.0})
    assert all(rows[0]["missed"][d] >= 54 for d in DETECTORS)
    assert all(rows[1]["missed"][d] == 0 for d in DETECTORS)


def test_fewer_samples_a_cycle_widen_the_integrated_tests_blind_zone():
    # table1 gives the integrated test 32 x 1080 silent samples a cycle: a ghost of RARMS 0.1 shows in every cycle;
    # 24 x 300 hide it in most
    long = miss_rates(load_scene("table1"), "ghost", (0.1,), 60, seed=2, params={"range_m": 25.0})[0]
    short = miss_rates(load_scene("table1", {"n_chirps": 48, "n_samples": 300}), "ghost", (0.1,), 60, seed=2,
                       params={"range_m": 25.0})[0]
    assert long["missed"]["integrated"] <= 3 and short["missed"]["integrated"] >= 30
