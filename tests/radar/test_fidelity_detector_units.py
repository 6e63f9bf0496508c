"""The beat and waveform fidelities agree in the detector's own units, except where `carav scenes` says they differ.

For a fixed activation sequence and each fidelity's noise-free echoes, the expected per-slot statistics are

    D0(k) = sqrt(1 + E_k / (N_s sigma^2))                     silent slot k (E_k: the echo energy it holds)
    D1(k) = |r_k - Rbar| / (Rbar + sigma),  r_k = sigma sqrt(1 + E_k / (N_s sigma^2))    active slot k

and the fidelities' difference in each, over the distance from 1 to the threshold designed for PF 1e-6 per cycle,
is what moves an alarm. Away from the IF filter's transition band it stays within TOLERANCE of that distance for
strong near echoes and for loud targets a tenth of the maximum range clear of the band, on both presets; inside the
band (the ranges `carav scenes` names) it need not, and for a loud target it does not. Sampled from the ramp's reset
(t_adc_start_s = 0), the near car alone differs by more than twice the distance at 2-7 m and by 0.68 of it at 10 m.
"""
import dataclasses

import numpy as np
import pytest

from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.radar import physics
from carav_stream.radar.scene_loader import load_scene

PATTERN = np.array([True, False, True, True, False, False, True, False, False, True, True, False, True, False,
                    False, True])          # balanced; silent slots after active ones and after silent ones


TOLERANCE = 0.15           # of the distance from 1 to the designed threshold


def _stats(scene, fidelity: str):
    t = physics.echo_templates(scene, fidelity)
    rho = np.resize(PATTERN, scene.n_chirps)
    x = rho[:, None] * t.main_sum.astype(np.complex128)
    if t.tail_sum is not None:
        x[1:] += rho[:-1, None] * t.tail_sum[1:].astype(np.complex128)
    e = np.sum(np.abs(x) ** 2, axis=1)[1:]                # slot 0's predecessor belongs to another cycle
    sigma = scene.sigma_n
    r = sigma * np.sqrt(1 + e / (scene.n_samples * sigma ** 2))
    active = rho[1:]
    rbar = r[active].mean()
    return np.where(active, np.abs(r - rbar) / (rbar + sigma), r / sigma), active


def _difference(scene) -> float:
    """max over slots of |beat - waveform| in D0 (silent) and D1 (active), over eta_designed - 1; a statistic as far
    beyond the threshold as the threshold is beyond 1 alarms in either fidelity, so both are clipped there."""
    eta = rms_threshold(scene_law(scene), 1e-6)
    top = 2 * eta - 1
    (d_beat, _), (d_wave, _) = _stats(scene, "beat"), _stats(scene, "waveform")
    return float(np.max(np.abs(np.minimum(d_beat, top) - np.minimum(d_wave, top))) / (eta - 1))


def _at(preset: str, fraction_of_max: float, iq: bool, snr_db: float | None = None):
    base = load_scene(preset, {"iq": iq})
    car = dataclasses.replace(base.targets[0], range_m=fraction_of_max * base.max_range_m)
    s = dataclasses.replace(base, targets=(car,))
    if snr_db is not None:                              # a loud target: the per-sample SNR set, as snr_db does
        s = load_scene(preset, {"iq": iq, "targets[0].range_m": car.range_m, "snr_db": snr_db})
    return s


def _inside(scene) -> bool:
    r = scene.targets[0].range_m
    return any(lo <= r < hi for lo, hi in physics.fidelity_dependent_ranges_m(scene))


@pytest.mark.parametrize("range_m", [2.0, 5.0, 7.0, 10.0, 43.0])
@pytest.mark.parametrize("iq", [False, True])
def test_table1s_car_near_and_at_its_range_agrees(range_m, iq):
    s = load_scene("table1", {"iq": iq, "targets[0].range_m": range_m})
    assert not _inside(s) and _difference(s) < TOLERANCE


@pytest.mark.parametrize("range_m", [1.0, 5.0, 20.0])
def test_awr1642s_car_near_and_at_its_range_agrees(range_m):
    s = load_scene("awr1642", {"targets[0].range_m": range_m})
    assert not _inside(s) and _difference(s) < TOLERANCE


@pytest.mark.parametrize("preset", ["table1", "awr1642"])
@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("fraction", [0.5, 0.8, 1.2])
def test_a_loud_target_outside_the_transition_band_agrees(preset, iq, fraction):
    # +20 dB per sample, at fractions of the maximum range a tenth of it clear of the band. Measured on table1 (I
    # only): 0.04 at 0.5, 0.10 at 0.8, 0.14 at 0.85 and 0.13 at 1.1: its spill beats at -(1 - tau / T_c) fs, close to
    # the band whenever its echo is, and the waveform renders the splatter of the spill's gated ends, which the
    # beat fidelity's ideal filter removes. The leak's exact rate takes the larger of the two (firmware/leak.py).
    s = _at(preset, fraction, iq, snr_db=20.0)
    assert not _inside(s) and _difference(s) < TOLERANCE


@pytest.mark.parametrize("preset", ["table1", "awr1642"])
@pytest.mark.parametrize("iq", [False, True])
def test_inside_the_transition_band_the_fidelities_differ_and_scenes_says_where(preset, iq):
    base = load_scene(preset, {"iq": iq})
    lo, hi = physics.fidelity_dependent_ranges_m(base)[0]
    diffs = []
    for where in (0.25, 0.5, 0.75):
        s = _at(preset, (lo + where * (hi - lo)) / base.max_range_m, iq, snr_db=20.0)
        assert _inside(s)
        diffs.append(_difference(s))
    assert max(diffs) > 0.5               # a loud target there moves D0 or D1 half-way to the threshold in one only
