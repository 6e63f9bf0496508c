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


def test_a_receiver_array_is_judged_on_all_its_receivers_and_catches_fainter_ghosts():
    # the same 32 x 64 table1 car on one receiver and on a 4-receiver ULA: the integrated and coherent tests, their
    # bins summed over the receivers, catch a ghost of RARMS 0.3 that one receiver misses; without an attack the
    # array raises no alarm at the 1e-6 designs
    one, four = (miss_rates(load_scene("table1", {"n_rx": n_rx, "n_chirps": 32, "n_samples": 64}), "ghost",
                            (0.0, 0.3), 60, seed=4, fidelity="beat", params={"range_m": 25.0}) for n_rx in (1, 4))
    assert [r["n_rx"] for r in one + four] == [1, 1, 4, 4]
    assert four[0]["missed"] == dict.fromkeys(DETECTORS, 60)
    assert one[1]["missed"]["integrated"] >= 50 and one[1]["missed"]["coherent"] >= 30
    assert four[1]["missed"]["integrated"] <= 3 and four[1]["missed"]["coherent"] <= 3


def test_the_awr1642_mimo_preset_runs_with_its_tdm_loops():
    row = miss_rates(load_scene("awr1642_mimo"), "ghost", (0.1,), 10, seed=4, params={"range_m": 25.0})[0]
    assert row["n_rx"] == 4 and row["trials"] == 10 and row["missed"]["integrated"] <= 1
