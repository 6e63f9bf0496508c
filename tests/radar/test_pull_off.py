"""Range-gate pull-off: on the target during the capture, then a false echo walking away as its docstring's
equations say, with or without the Doppler of its walk; the beat and the chirp-to-chirp phase of the false echo
are checked against closed forms written here."""
import numpy as np
import pytest

from carav_stream.radar.attackers import AttackerError, make_attacker
from tests.radar.test_attackers import C, emit, phase_slope_hz


def _offset(t: float, pull: float, accel: float) -> tuple[float, float]:
    """The drag's range offset and speed t seconds into it, written from the model's equations."""
    if t <= 0:
        return 0.0, 0.0
    t1 = abs(pull) / accel
    walk = accel * t * t / 2 if t < t1 else abs(pull) * (t - t1 / 2)
    return np.sign(pull) * walk, np.sign(pull) * min(accel * t, abs(pull))


@pytest.mark.parametrize("pull, accel", [(4.0, 8.0), (-3.0, 20.0), (10.0, 1e4)])
def test_the_drag_builds_its_speed_up_then_walks_at_it(small_scene, pull, accel):
    s = small_scene()
    att = make_attacker("pull_off", s, start_cycle=5, capture_cycles=10, pull_mps=pull, pull_accel_mps2=accel)
    for cycle in (0, 5, 14, 15, 16, 100, 3000, 200_000):
        t = (cycle - 15) * s.t_cycle_s
        assert att.offset(cycle) == pytest.approx(_offset(t, pull, accel), rel=1e-12, abs=1e-15)
    late = [att.offset(c)[0] for c in (300_000, 300_001)]
    assert late[1] - late[0] == pytest.approx(pull * s.t_cycle_s, rel=1e-9)      # pull_mps of range per second


def test_it_rides_on_the_scenes_first_target_unless_told_otherwise(small_scene):
    s = small_scene()
    att = make_attacker("pull_off", s)
    assert (att.range_m, att.velocity_mps) == (43.0, s.targets[0].velocity_mps)
    assert make_attacker("pull_off", s, range_m=20.0, velocity_mps=1.0).range_m == 20.0
    with pytest.raises(AttackerError) as exc:
        make_attacker("pull_off", small_scene(targets=[]))
    assert [p for p, _ in exc.value.problems] == ["range_m", "velocity_mps"]
    assert make_attacker("pull_off", small_scene(targets=[]), range_m=20.0, velocity_mps=1.0).range_m == 20.0


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_during_the_capture_it_sends_what_a_ghost_on_the_target_sends(small_scene, fidelity):
    s = small_scene(iq=True, sigma_n=1.0)
    pull, _ = emit(make_attacker("pull_off", s, capture_cycles=3, rarms=2.0), 3, fidelity=fidelity)
    ghost, _ = emit(make_attacker("ghost", s, range_m=43.0, velocity_mps=s.targets[0].velocity_mps, rarms=2.0), 3,
                    fidelity=fidelity)
    np.testing.assert_array_equal(pull, ghost)


@pytest.mark.parametrize("doppler", [True, False])
def test_the_dragged_echo_beats_at_its_walked_range_with_the_doppler_asked_for(small_scene, doppler):
    """At cycle c of the drag: the beat S 2 R / c + 2 rdot / lambda and the chirp-to-chirp phase 2 pi 2 rdot T_c /
    lambda of a target at R = 43 m + walk, with rdot the target's range rate plus the drag's speed with doppler."""
    s = small_scene(iq=True, sigma_n=1.0)
    att = make_attacker("pull_off", s, capture_cycles=0, pull_mps=-300.0, pull_accel_mps2=6e4, doppler=doppler,
                        rarms=5.0)
    cycle = 1000                                                # 59 ms in: 17 m walked towards the radar
    walk, speed = _offset(cycle * s.t_cycle_s, -300.0, 6e4)
    a, active = emit(att, 1, cycle0=cycle)
    r = 43.0 + walk
    assert active.all() and 0 < r < 30
    rdot = s.targets[0].velocity_mps - s.radar_speed_mps + (speed if doppler else 0.0)
    lam = C / s.fc_hz
    m0 = int(np.ceil(2 * r / C * s.fs_hz)) + 1
    assert phase_slope_hz(a[0, 0, m0:], s.fs_hz) == pytest.approx(2 * s.slope_hz_per_s * r / C + 2 * rdot / lam,
                                                              rel=1e-4)
    step = np.angle(a[0, 1:, m0] * np.conj(a[0, :-1, m0]))
    expected = (2 * np.pi * 2 * rdot / lam * s.t_chirp_s + np.pi) % (2 * np.pi) - np.pi
    assert np.allclose(step, expected, atol=1e-3)


def test_a_drag_towards_the_radar_stops_at_zero_range(small_scene):
    s = small_scene(iq=True)
    att = make_attacker("pull_off", s, capture_cycles=0, pull_mps=-50.0, pull_accel_mps2=1e4, doppler=False)
    assert 43.0 + att.offset(20_000)[0] < 0 and 43.0 + att.offset(30_000)[0] < 0
    a, active = emit(att, 1, cycle0=20_000)
    b, _ = emit(att, 1, cycle0=30_000)
    assert active.all() and np.isfinite(a).all() and np.abs(a).max() > 0
    np.testing.assert_array_equal(a, b)                          # both at 0 m
