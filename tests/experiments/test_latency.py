"""`carav experiment latency`: the spill test's false alarms do not follow the echo power; it catches a repeater whose
reply outlasts the longest visible round trip and is blind to one within it."""
import numpy as np
import pytest

from carav_stream.detect.stats import clopper_pearson
from carav_stream.experiments import latency


@pytest.mark.slow
@pytest.mark.parametrize("preset, fidelity", [("table1", "beat"), ("table1", "waveform")])
def test_spill_test_false_alarms_do_not_follow_the_echo_power(preset, fidelity):
    n = 150
    rows = latency._false_alarms(preset, fidelity, n, seed=5)
    assert {r["echo_db"] for r in rows} == set(latency.ECHO_DB) and {r["scene"] for r in rows} == {"car",
                                                                                                 "four targets"}
    for r in rows:     # each cell's interval (99.9 %: 14 cells) holds the design PF, from -10 to +20 dB
        lo, hi = clopper_pearson(r["spill_pf_0_05"], n, 0.999)
        assert lo <= latency.PF_MEASURED <= hi, r
        assert r["spill_pf_1e_6"] == 0, r
    # the statistic it replaces: calibrated at the scene's echo, it alarms on nearly every cycle 10 dB above it
    loud = next(r for r in rows if r["scene"] == "car" and r["echo_db"] == 10)
    assert loud["head_tail"] > 0.9 * n


def test_spill_test_catches_late_repeaters_and_is_blind_within_the_visible_round_trip(monkeypatch):
    monkeypatch.setitem(latency.LATENCIES_US, "table1", (0.1, 2.0, 5.0, 7.0))
    n = 40
    for fidelity in ("beat", "waveform"):
        rows = {r["latency_us"]: r for r in latency._misses("table1", fidelity, n, seed=6)}
        for lat in (0.1, 2.0):                                  # delay < 3.67 us: blind, the reply is in band
            assert rows[lat]["own_in_band"] and not rows[lat]["spill_in_band"]
            assert rows[lat]["spill_missed"] == n and rows[lat]["c15_missed"] == n
        for lat in (5.0, 7.0):                                  # its spill reaches the window: every cycle caught
            assert rows[lat]["spill_in_band"] and rows[lat]["spill_missed"] == 0


def test_window_starts_after_the_longest_visible_round_trip():
    from carav_stream.radar.physics import max_visible_delay_s
    from carav_stream.radar.scene_loader import load_scene
    for preset in ("table1", "awr1642"):
        s = load_scene(preset)
        first = latency.window_start(s)
        assert s.t_adc_start_s + first / s.fs_hz >= max_visible_delay_s(s) + 16 / s.fs_hz
        assert np.isclose(max_visible_delay_s(s), 0.55 * s.fs_hz / s.slope_hz_per_s)
