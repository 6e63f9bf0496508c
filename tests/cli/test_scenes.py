"""`carav scenes`: what a scene implies, checked against the textbook formulas computed here from Table I's numbers."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.radar.scene_loader import load_scene

C = 299_792_458.0


def _column(out: str, name: str) -> dict[str, str]:
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in out.splitlines() if line.startswith("| ")]
    col = rows[0].index(f"`{name}`")
    return {r[0]: r[col] for r in rows[1:]}


def test_table1_figures_are_the_textbook_ones(capsys):
    assert carav(["scenes", "table1"]) == Exit.OK
    t = _column(capsys.readouterr().out, "table1")
    # the preset: 150 MHz swept in 7.33 us (also the chirp period), 1080 samples at 150 MHz from 16 samples in,
    # 64 chirps, 77 GHz
    t_chirp, slope = 7.33e-6, 150e6 / 7.33e-6
    assert t["range resolution"] == f"{C / (2 * slope * 1080 / 150e6):.4g} m"      # c / 2 B_sampled
    assert t["unambiguous velocity"] == f"+-{C / 77e9 / (4 * t_chirp):.4g} m/s"     # lambda / 4 T_c
    assert t["max range"] == f"{75e6 * C / (2 * slope):.4g} m"                     # beat at fs / 2 (I only)
    assert t["cycle"].endswith(f"({1 / (64 * t_chirp):.5g} cycles/s)")
    assert t["SNR of target 1, per sample once its echo has arrived"] == "+2.20 dB" and t["warnings"] == "none"
    # averaged over the window (from 16 samples in; until the echo arrives at 0.287 us it holds none of it) and with
    # the ADC's quantisation noise lsb^2 / 12: what the detector's law sees, and what `carav design` prints
    s = load_scene("table1")
    window = s.n_samples / s.fs_hz
    held = (s.t_adc_start_s + window - 2 * 43 / C) / window
    lsb = s.adc_full_scale / 2 ** (s.adc_bits - 1)
    slot_snr = s.echo_power_w(s.targets[0]) / s.sigma_n ** 2 * held / (1 + lsb ** 2 / 12 / s.sigma_n ** 2)
    shown = t["echoes' SNR averaged over a slot, ADC noise included (what the detector's law sees)"]
    assert shown.endswith(" dB") and float(shown[:-3]) == pytest.approx(10 * math.log10(slot_snr), abs=0.015)
    # the car closes at 100 - 96 km/h; beat = S tau + 2 v / lambda with v the range rate
    v = (96 - 100) / 3.6
    beat = slope * 2 * 43 / C + 2 * v / (C / 77e9)
    assert t["beat of target 1 (with Doppler)"] == f"{beat / 1e6:.4g} MHz"


def test_every_preset_by_default_with_its_warnings_spelled_out(capsys):
    assert carav(["scenes"]) == Exit.OK
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "| | `awr1642` | `awr1642_literal` | `awr1642_mimo` | `table1` | `table1_following` |"
    assert "folds to 0.3811 MHz" in out and "- `awr1642`: " in out and "beyond the unambiguous" in out


def test_an_unknown_scene_is_one_line_and_invalid(capsys):
    assert carav(["scenes", "nope"]) == Exit.INVALID
    err = capsys.readouterr().err
    assert err.startswith("carav scenes: ") and "nope" in err and len(err.strip().splitlines()) <= 2


def test_scenes_names_where_the_fidelities_differ_and_the_leak_of_a_near_car(capsys, tmp_path):
    assert carav(["scenes", "table1"]) == Exit.OK
    t = _column(capsys.readouterr().out, "table1")
    slope = 150e6 / 7.33e-6
    # I only: the echo's beat S tau within +-0.05 fs of fs / 2; its spill's, S (tau - T_c) = -(fs - S tau) here
    # (S T_c = fs), within +-0.05 fs of -fs / 2: the same ranges
    lo, hi = (C * f * 150e6 / (2 * slope) for f in (0.45, 0.55))
    assert t["ranges where the fidelities differ (the IF filter's transition band)"] == f"{lo:.4g}-{hi:.4g} m"
    # the car at 7 m sampled from the ramp's reset is warned about, with its boundary; as the preset samples, it is not
    near = tmp_path / "near.toml"
    preset = (Path(__file__).parents[2] / "carav_stream/radar/presets/table1.toml").read_text()
    preset = preset.replace('name = "table1"', 'name = "near"')
    near.write_text(preset.replace("range_m = 43.0", "range_m = 7.0"))
    assert carav(["scenes", str(near)]) == Exit.OK
    assert _column(capsys.readouterr().out, "near")["warnings"] == "none"
    near.write_text(preset.replace("range_m = 43.0", "range_m = 7.0")
                    .replace("t_adc_start_s = 1.0666666666666667e-07", "t_adc_start_s = 0.0")
                    .replace("n_samples = 1080", "n_samples = 1100"))
    assert carav(["scenes", str(near)]) == Exit.OK
    out = capsys.readouterr().out
    assert _column(out, "near")["warnings"] == "1"
    assert "targets[0] (7 m, 100 m^2)" in out and "m^2 at 7 m; at 100 m^2 it exceeds at 0.25-" in out


def test_scenes_says_a_scenes_adc_start_is_the_default_and_why(capsys, tmp_path):
    path = tmp_path / "matlab.toml"
    path.write_text('fc_hz = 77e9\nbandwidth_hz = 150e6\nt_sweep_s = 7.33e-6\nfs_hz = 150e6\nn_chirps = 64\n')
    assert carav(["scenes", str(path), "table1"]) == Exit.OK
    out = capsys.readouterr().out
    assert _column(out, "matlab")["sampling window"] == (
        "7.227 us from 0.1067 us (the default: 16 samples in, once the IF filter has settled after the ramp's reset; "
        "t_adc_start_s = 0 samples from the reset)")
    assert _column(out, "table1")["sampling window"] == "7.2 us from 0.1067 us"          # said by the preset
