"""The echoes' leak into the silent slots (firmware/leak.py): its energy against the rendered slots, its false-alarm
rate against simulated cycles, its boundary against itself, and the presets' ADC start against all three."""
import dataclasses
import math

import numpy as np
import pytest

from carav_stream.core.units import C_MPS
from carav_stream.detect.detector import detect
from carav_stream.detect.stats import clopper_pearson
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.firmware.leak import leak_warnings, scene_leaks, silent_energy
from carav_stream.radar import physics
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

FROM_RESET = {"t_adc_start_s": 0.0, "n_samples": 1100}        # table1 sampled from the ramp's reset, as MATLAB's


def _car(range_m: float, **over):
    return load_scene("table1", {"targets[0].range_m": range_m, **over})


@pytest.mark.parametrize("range_m", [5.0, 7.0, 10.0, 20.0, 43.0])
@pytest.mark.parametrize("over", [FROM_RESET, {}], ids=["from the reset", "preset"])
def test_the_worst_phase_energy_bounds_every_rendered_silent_slot_and_is_reached(range_m, over):
    # The waveform fidelity's own templates over 64 chirps (the Doppler turns the phase) and eight sub-wavelength
    # shifts of the range: the largest energy of a silent slot after an active one is the bound within 5 % (the
    # range also walks over the cycle, which moves the edges a little: not a pure change of phase).
    base = _car(range_m, **over)
    car = base.targets[0]
    tau0, alpha = physics.target_delay(base, car)
    bound = silent_energy(base, tau0, alpha, "waveform")
    seen = []
    for j in range(8):
        shifted = dataclasses.replace(car, range_m=range_m + j * base.wavelength_m / 16)
        s = dataclasses.replace(base, targets=(shifted,))
        t = physics.waveform_replica(s, *physics.target_delay(s, shifted), 1.0)[1]
        seen.append(np.sum(np.abs(t[1:].astype(np.float64)) ** 2, axis=1))
    seen = np.concatenate(seen)
    assert 0.95 * bound <= seen.max() <= 1.05 * bound


def test_the_closed_form_does_not_understate_what_simulated_cycles_show():
    # the car at 7 m sampled from the reset: the simulated benign cycles alarm at 1.5 on about a fifth of the cycles;
    # the closed form, at the worst phase for every leaking slot, must not promise fewer
    s = _car(7.0, **FROM_RESET)
    rng = np.random.default_rng(3)
    rho = balanced_rows(rng, 200, s.n_chirps)
    x = simulate_cycles(s, rho, rng, fidelity="waveform").frames
    k = int(np.sum(detect(x, rho, s.sigma_n, 1.5).alarm))
    lo, _ = clopper_pearson(k, 200)
    assert k > 10                                               # the leak is real in the rendered cycles
    assert scene_leaks(s, 1.5)[0].pf >= lo


@pytest.mark.parametrize("over", [FROM_RESET, {}], ids=["from the reset", "preset"])
def test_the_rcs_boundary_separates_warned_from_quiet_scenes(over):
    s = _car(43.0, **over)
    (leak,) = scene_leaks(s)
    assert math.isfinite(leak.rcs_limit_m2) and not leak.exceeds
    for factor, warned in ((0.7, False), (1.4, True)):
        louder = load_scene("table1", {"targets[0].rcs_m2": leak.rcs_limit_m2 * factor, **over})
        assert bool(leak_warnings(louder)) == warned, factor


def test_the_warning_names_the_ranges_and_the_largest_rcs():
    (w,) = leak_warnings(_car(7.0, **FROM_RESET))
    (leak,) = scene_leaks(_car(7.0, **FROM_RESET))
    lo, hi = leak.ranges_over[0]
    assert lo <= 7.0 < hi and f"below {leak.rcs_limit_m2:.3g} m^2 at 7 m" in w and f"{hi:.3g} m" in w
    assert "waveform fidelity" in w and "t_adc_start_s" in w


@pytest.mark.parametrize("range_m", [5.0, 7.0, 10.0])
def test_the_presets_adc_start_leaves_no_warning_for_the_near_car(range_m):
    assert leak_warnings(_car(range_m)) == []
    assert leak_warnings(_car(range_m, **FROM_RESET))          # sampled from the reset, the same car is warned about
    assert scene_leaks(_car(range_m))[0].pf <= 1.01e-6


def test_awr1642_keeps_the_echo_cut_by_the_ramp_reset_at_waveform_fidelity():
    # Its spill beats near -2 GHz, beyond the grid: that part is dropped, but the previous chirp's echo is in band
    # until the ramp's reset and reaches the first samples through the IF filter, as on table1
    s = load_scene("awr1642", {"t_adc_start_s": 0.0})
    tau0, alpha = physics.target_delay(s, s.targets[0])
    assert silent_energy(s, tau0, alpha, "waveform") > 0.05          # a twentieth of one sample's echo power at least
    assert silent_energy(load_scene("awr1642"), tau0, alpha, "waveform") == 0.0    # 7 us in: nothing left
    assert leak_warnings(s) and not leak_warnings(load_scene("awr1642"))


def test_a_target_far_beyond_the_range_leaks_nothing_at_beat_fidelity():
    s = _car(0.5 * C_MPS * 0.2 * 7.33e-6)           # a round trip of a fifth of a chirp: spill beat -0.8 fs, filtered
    tau0, alpha = physics.target_delay(s, s.targets[0])
    assert silent_energy(s, tau0, alpha, "beat") == 0.0
    assert rms_threshold(scene_law(s), 1e-6) > 1
