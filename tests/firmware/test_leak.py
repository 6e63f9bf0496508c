"""The echoes' leak into the silent slots (firmware/leak.py, firmware/silent_slots.py): its tails against the rendered
slots, its exact false-alarm rate against the real chain (channel, ADC, detector) on scenes it was not worked out on,
its boundary against the exact rate, and the presets' ADC start against all three."""
import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy import stats

from carav_stream.core.units import C_MPS
from carav_stream.detect.detector import detect
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.firmware.leak import _turned, leak_warnings, scene_leaks, scene_rate
from carav_stream.firmware.silent_slots import mean_deficit, noncentrality, slot_deficits, slot_energies
from carav_stream.radar import physics
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene, scene_from_dict
from carav_stream.radar.synth import simulate_cycles

FROM_RESET = {"t_adc_start_s": 0.0, "n_samples": 1100}        # table1 sampled from the ramp's reset, as MATLAB's


def _car(range_m: float, **over):
    return load_scene("table1", {"targets[0].range_m": range_m, **over})


@pytest.mark.parametrize("n_chirps", [2, 4, 8, 12])
def test_the_recursion_is_the_mean_over_every_balanced_activation(n_chirps):
    q = np.random.default_rng(n_chirps).random(n_chirps)
    m = n_chirps // 2
    deficits = []
    for active in itertools.combinations(range(n_chirps), m):
        rho = np.isin(np.arange(n_chirps), active)
        after = [k for k in range(1, n_chirps) if rho[k - 1] and not rho[k]]     # the chirp before the cycle: silent
        deficits.append(1 - np.prod(1 - q[after]))
    assert mean_deficit(q) == pytest.approx(np.mean(deficits), rel=1e-12)


@pytest.mark.parametrize("range_m", [5.0, 7.0, 20.0])
@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_the_slot_energies_are_the_tails_the_channel_adds(range_m, fidelity):
    s = _car(range_m, **FROM_RESET)
    tau0, alpha = physics.target_delay(s, s.targets[0])
    amp = physics.echo_amplitude(s, s.targets[0])
    tails = physics.echo_templates(s, fidelity).tail_sum
    rendered = np.zeros(s.n_chirps - 1) if tails is None else np.sum(tails[1:].astype(np.float64) ** 2, axis=1)
    assert np.allclose(slot_energies(s, tau0, alpha, fidelity, amp)[1:], rendered, rtol=1e-5, atol=0)


def _alarms(scene, eta: float, fidelity: str, n: int, seed: int) -> int:
    rng = np.random.default_rng(seed)
    k = 0
    for done in range(0, n, 100):
        rho = balanced_rows(rng, min(100, n - done), scene.n_chirps)
        x = simulate_cycles(scene, rho, rng, fidelity=fidelity).frames
        k += int(np.sum(detect(x, rho, scene.sigma_n, eta).alarm))
    return k


CHAIN = [
    # awr1642 sampled from the ramp's reset: the cut echo at waveform fidelity, a fast target whose phase turns
    pytest.param("awr1642", {"t_adc_start_s": 0.0}, "waveform", 1.35, id="awr1642 from the reset, waveform"),
    pytest.param("awr1642", {"t_adc_start_s": 0.0}, "waveform", 1.4, id="awr1642 from the reset, waveform, 1.4"),
    # Table II read literally: no IF filter in the beat fidelity, the spill folds into the band
    pytest.param("awr1642_literal", {}, "beat", 3.1, id="awr1642_literal, beat"),
    # I/Q this time, the car at 9 m
    pytest.param("table1", {**FROM_RESET, "iq": True, "targets[0].range_m": 9.0}, "waveform", 1.22,
                 marks=pytest.mark.slow, id="table1 I/Q at 9 m from the reset, waveform"),
]


@pytest.mark.parametrize("preset, over, fidelity, eta", CHAIN)
def test_the_exact_rate_is_what_the_chain_measures(preset, over, fidelity, eta):
    # channel, ADC and detector on 400 attack-free cycles: the count within the binomial spread of the exact rate
    s = load_scene(preset, over)
    p = scene_rate(s, eta, fidelity)
    assert 0.05 < p < 0.95                                       # a rate the count can test both ways
    k = _alarms(s, eta, fidelity, 400, seed=2)
    assert stats.binomtest(k, 400, p).pvalue > 1e-3, (k, p)


def test_the_warning_states_the_exact_rate_of_the_worse_fidelity():
    # the table1 car at 7 m sampled from the reset, at the paper's eta: a quarter of the cycles, not "up to 1"
    s = _car(7.0, **FROM_RESET)
    (leak,) = scene_leaks(s, 1.5)
    assert leak.fidelity == "waveform"
    exact = max(scene_rate(s, 1.5, f) for f in ("beat", "waveform"))      # from the channel's float32 templates
    assert leak.pf == pytest.approx(exact, rel=1e-5)
    assert 0.2 < leak.pf < 0.3
    (w,) = leak_warnings(s, 1.5)
    assert f"alarms on {leak.pf:.2g} of attack-free cycles" in w and "0.25" in w


def _rates_at(scene, range_m: float, eta: float, n_phases: int = 8) -> list[float]:
    """The exact rate of the scene's radar (its ADC as set) with the target moved to range_m and then by up to half a
    wavelength more, at the fidelity where it is larger."""
    out = []
    for j in range(n_phases):
        t = dataclasses.replace(scene.targets[0], range_m=range_m + j * scene.wavelength_m / (4 * n_phases))
        moved = dataclasses.replace(scene, targets=(t,))
        out.append(max(scene_rate(moved, eta, f) for f in ("beat", "waveform")))
    return out


@pytest.mark.parametrize("preset, over, eta", [
    pytest.param("table1", {**FROM_RESET, "targets[0].range_m": 7.0}, 1.5, id="table1 car at 7 m, eta 1.5"),
    pytest.param("awr1642", {"t_adc_start_s": 0.0, "targets[0].range_m": 30.0}, None, id="awr1642 at 30 m, designed"),
])
def test_the_boundary_is_where_the_exact_rate_crosses_the_limit(preset, over, eta):
    # a few per cent beyond the boundary no carrier phase exceeds the limit; a few per cent within it, one does
    s = load_scene(preset, over)
    (leak,) = scene_leaks(s, eta)
    assert leak.exceeds
    (lo, hi), = leak.ranges_over
    assert lo == 0.25 and leak.range_m < hi
    eta = leak.eta
    assert max(_rates_at(s, 1.03 * hi, eta)) <= leak.limit
    assert max(_rates_at(s, 0.97 * hi, eta)) > leak.limit


def test_the_rcs_boundary_is_where_the_exact_rate_reaches_the_limit():
    s = _car(10.0, **FROM_RESET)
    (leak,) = scene_leaks(s)
    assert leak.exceeds and 0 < leak.rcs_limit_m2 < leak.rcs_m2
    eta = leak.eta
    for factor, over in ((0.97, False), (1.03, True)):
        t = dataclasses.replace(s.targets[0], rcs_m2=leak.rcs_limit_m2 * factor)
        moved = dataclasses.replace(s, targets=(t,))
        assert (max(scene_rate(moved, eta, f) for f in ("beat", "waveform")) > leak.limit) == over, factor


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
    assert slot_energies(s, tau0, alpha, "waveform").max() > 0.05     # a twentieth of one sample's echo power at least
    assert slot_energies(load_scene("awr1642"), tau0, alpha, "waveform").max() == 0.0    # 7 us in: nothing left
    assert leak_warnings(s) and not leak_warnings(load_scene("awr1642"))


def test_a_target_far_beyond_the_range_leaks_nothing_at_beat_fidelity():
    s = _car(0.5 * C_MPS * 0.2 * 7.33e-6)           # a round trip of a fifth of a chirp: spill beat -0.8 fs, filtered
    tau0, alpha = physics.target_delay(s, s.targets[0])
    assert not slot_energies(s, tau0, alpha, "beat").any()
    assert rms_threshold(scene_law(s), 1e-6) > 1


@pytest.mark.parametrize("preset, over, within", [
    ("table1", {**FROM_RESET, "targets[0].range_m": 7.0}, 0.01),
    ("awr1642", {"t_adc_start_s": 0.0}, 0.06),                  # 300 km/h closing: the range walks 0.1 sample a cycle
])
@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_the_boundarys_turned_tails_are_the_rendered_ones_within_what_the_docstring_says(preset, over, within,
                                                                                          fidelity):
    s = load_scene(preset, over)
    tau0, alpha = physics.target_delay(s, s.targets[0])
    rendered = slot_energies(s, tau0, alpha, fidelity)
    turned = _turned(s, tau0, alpha, fidelity)[0]                # the first of its phases: the echo's own
    scale = max(rendered.max(), 1e-300)
    assert np.max(np.abs(turned - rendered)) <= within * scale


MATLAB = {"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6, "n_chirps": 64,
          "radar_speed_kmh": 100.0, "targets": [{"range_m": 7.0, "velocity_kmh": 96.0, "rcs_m2": 100.0}]}


@pytest.mark.parametrize("range_m", [7.0, 10.0])
def test_a_scene_written_as_matlabs_example_gives_the_near_car_no_false_alarms(range_m):
    # no ADC start given: the settled default; the near car's rate at its designed eta and at 1.5 is the noise's own.
    # Said explicitly, 0 samples from the ramp's reset and is warned about
    written = {**MATLAB, "targets": [{**MATLAB["targets"][0], "range_m": range_m}]}
    s = scene_from_dict(written, "matlab.toml")
    eta = rms_threshold(scene_law(s), 1e-6)
    assert scene_rate(s, eta, "waveform") <= 1.01e-6 and scene_rate(s, 1.5, "waveform") < 1e-50
    assert leak_warnings(s) == [] and leak_warnings(s, 1.5) == []
    reset = scene_from_dict({**written, "t_adc_start_s": 0.0}, "reset.toml")
    assert scene_rate(reset, rms_threshold(scene_law(reset), 1e-6), "waveform") > 0.1 and leak_warnings(reset)


def test_a_leak_on_a_receiver_array_is_judged_on_every_receivers_components():
    """The tail reaches each of n_rx receivers with the same energy: the noncentrality and the degrees of freedom of
    the combined statistic are n_rx times one receiver's, whose chi-square law scipy gives directly."""
    scene = load_scene("awr1642")
    one, four = scene_law(scene, 1), scene_law(scene, 4)
    energies = np.array([0.0, 1e-3, 4e-3]) * scene.sigma_n ** 2 * scene.n_samples
    lam = noncentrality(four, scene, energies)
    np.testing.assert_allclose(lam, 4 * noncentrality(one, scene, energies), rtol=1e-15)
    eta = rms_threshold(four, 1e-6)
    nu = 4 * four.dof
    x = nu * (eta * four.sigma_n / four.sigma_eff) ** 2
    sf0 = stats.chi2.sf(x, nu)
    want = (stats.ncx2.sf(x, nu, lam[1:]) - sf0) / (1 - sf0)
    np.testing.assert_allclose(slot_deficits(four, eta, lam)[1:], want, rtol=1e-9)
    assert slot_deficits(four, eta, lam)[0] == 0.0
