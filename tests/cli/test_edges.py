"""The commands at the edges of a scene: one chirp per group (N_r = 2) and chirps of one or two samples. Each gets a
clear answer or a one-line refusal naming the option and its value; the sweep's warning and `carav design` agree."""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.detect.detector import detect_from_rms
from carav_stream.detect.stats import pf_pm_closed_form
from tests.cli.test_errors import error_of

ROOT = Path(__file__).resolve().parents[2]


def test_with_one_chirp_per_group_c_is_d0_of_the_one_silent_chirp_exactly():
    # N_r = 2: the one active chirp is its own mean, D1 = 0, so PF is the chi-square tail of one silent chirp
    eta = np.array([0.5, 1.0, 1.5, 2.0])
    pf = pf_pm_closed_form(eta, n_chirps=2, dof=16, snr=3.0)
    assert np.allclose(pf["p_alarm"], stats.chi2.sf(16 * eta ** 2, 16), rtol=1e-12, atol=0)
    assert np.all(pf["quiet_d1"] == 1.0)
    rng = np.random.default_rng(5)
    rms = np.sqrt(rng.chisquare(16, size=(20000, 2)) / 16)
    q = detect_from_rms(rms, np.array([True, False]), 1.0, 1.0).q
    assert np.array_equal(q, rms[:, 1])                                  # Q is D0 of the silent chirp


def test_the_closed_form_refuses_an_odd_number_of_chirps_naming_it():
    with pytest.raises(ValueError, match="n_chirps: must be an even number >= 2.*got 3"):
        pf_pm_closed_form(1.5, n_chirps=3, dof=16)


def _warning_and_hint(capsys, argv):
    assert carav(["sweep", *argv, "--rarms", "1", "--trials", "20", "--eta", "1:2:0.5", "--seed", "1",
                  "--quiet"]) == Exit.OK
    err = capsys.readouterr().err
    m = re.search(r"`(carav design [^`]*)` gives eta = ([0-9.]+) for", err)
    assert m, err
    return m.group(1), float(m.group(2))


@pytest.mark.parametrize("argv", [["--nr", "2", "--ns", "16"], ["--nr", "4", "--ns", "1"],
                                  ["--model", "paper", "--nr", "2", "--ns", "8"],
                                  ["--nr", "2", "--ns", "8", "--snr-db", "10", "--ideal-adc"]])
def test_the_sweeps_warning_names_a_design_command_that_runs_and_gives_its_eta(capsys, argv):
    command, eta = _warning_and_hint(capsys, argv)
    args = shlex.split(command)[1:] + ["--trials", "10", "--benign-trials", "10", "--ghost-trials", "0",
                                       "--rarms", "1"]
    assert carav(args) == Exit.OK
    out = capsys.readouterr().out
    designed = float(re.search(r"eta = ([0-9.]+) +PF per cycle", out).group(1))
    assert designed == pytest.approx(eta, abs=6e-4), out


def test_design_says_the_spectral_tests_are_not_defined_on_a_two_sample_i_only_chirp(capsys):
    assert carav(["design", "--nr", "4", "--ns", "2", "--trials", "10", "--benign-trials", "10",
                  "--ghost-trials", "5", "--rarms", "3"]) == Exit.OK
    out = capsys.readouterr().out
    assert "spectral silent-chirp test       not defined: N_s = 2 I only" in out
    assert re.search(r"C\(eta\) [0-9.a-z]+ \(the opt-in tests are not defined here\)", out), out


@pytest.mark.parametrize("command", ["sweep", "design"])
@pytest.mark.parametrize("option, value, text", [("--nr", "3", "must be an even number"),
                                                 ("--nr", "0", "must be >= 2, got 0"),
                                                 ("--ns", "0", "must be >= 1, got 0")])
def test_chirps_and_samples_out_of_their_range_are_refused_in_one_line_naming_the_option(capsys, command, option,
                                                                                      value, text):
    assert carav([command, option, value]) == Exit.USAGE
    err = error_of(capsys)
    assert f"argument {option}: {text}" in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("detector, text", [("spectral", "N_s = 2 I only has none"),
                                            ("spill", "it takes N_s >= ")])
def test_the_sweep_refuses_an_opt_in_test_the_chirp_is_too_short_for_in_one_line(capsys, detector, text):
    code = carav(["sweep", "--nr", "4", "--ns", "2", "--detector", detector, "--rarms", "1", "--trials", "5",
                  "--quiet"])
    err = error_of(capsys)
    assert code == Exit.USAGE and f"--detector {detector}: " in err and text in err, err


def _car_at(tmp_path, range_m: float, **replace) -> str:
    text = (ROOT / "carav_stream" / "radar" / "presets" / "table1.toml").read_text()
    text = text.replace('name = "table1"', f'name = "car_{range_m:g}m"').replace("range_m = 43.0",
                                                                                   f"range_m = {range_m}")
    for old, new in replace.items():
        text = text.replace(old, new)
    path = tmp_path / f"car_{range_m:g}m.toml"
    path.write_text(text)
    return str(path)


def test_validate_judges_a_car_at_3_m_where_the_adc_step_exceeds_the_noise(tmp_path, capsys):
    # its echo lifts the 12-bit ADC's full scale to a step of 4.1 sigma_n: the silent slots quantise below the
    # noise, eta 1.5 raises no false alarm there (the chain: none in 100 cycles), and the graph is valid
    scene = _car_at(tmp_path, 3.0)
    assert carav(["validate", str(ROOT / "graphs" / "no_attack.toml"), "--set", f"scene={scene}",
                  "--set", "detector.eta=1.5"]) == Exit.OK
    err = error_of(capsys)
    assert "error" not in err and "raises false alarms" not in err, err


def test_validate_says_when_a_coarse_adc_leaves_a_leak_unjudged(tmp_path, capsys):
    scene = _car_at(tmp_path, 3.0, **{"t_adc_start_s = 1.0666666666666667e-07": "t_adc_start_s = 0.0",
                                      "n_samples = 1080": "n_samples = 1100"})
    assert carav(["validate", str(ROOT / "graphs" / "no_attack.toml"), "--set", f"scene={scene}"]) == Exit.OK
    err = error_of(capsys)
    assert "false-alarm rate is not stated: the ADC's step is coarse against the noise (0.245 steps)" in err, err


def test_design_gives_the_car_at_3_m_its_threshold_from_the_quantised_law(tmp_path, capsys):
    assert carav(["design", "--scene", _car_at(tmp_path, 3.0), "--trials", "10", "--benign-trials", "0",
                  "--ghost-trials", "0", "--rarms", "3"]) == Exit.OK
    out = capsys.readouterr().out
    assert "12-bit ADC (noise 0.245 steps: most silent samples quantise to 0" in out
    assert re.search(r"eta = 1\.13\d\d +PF per cycle 9\.9e-07 \(at the paper's eta = 1\.5: 2\.\d+e-34\)", out), out
