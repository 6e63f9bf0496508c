"""`carav capture inspect`: on a capture written from TI's layout with a planted target and known noise, the
command reports the target's cell, range and velocity and the noise RMS the capture was written with."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from tests.capture.ti_dca1000 import capture_bytes

C = 299_792_458.0
SCENE = """name = "bench"
fc_hz = 77e9
bandwidth_hz = 1.0e9
t_sweep_s = 50e-6
t_chirp_s = 60e-6
fs_hz = 10e6
n_chirps = 32
n_samples = 64
iq = true
adc_bits = 16
sigma_n = 1e-3
adc_full_scale = 1.0
"""


def written_capture(tmp_path, sigma, k, l, lanes, encoding, cycles=6, n_rx=2):
    """A capture of noise (RMS sigma codes) and, on the active chirps, a tone in range bin k, Doppler bin l."""
    rng = np.random.default_rng(11)
    rho = np.array([rng.permutation(np.arange(32) < 16) for _ in range(cycles)])
    n, m = np.arange(64), np.arange(32)
    tone = 300.0 * np.exp(2j * np.pi * (k * n[None, :] / 64 + l * m[:, None] / 32))
    shape = (cycles, 32, n_rx, 64)
    x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * sigma / math.sqrt(2)
    x += rho[:, :, None, None] * tone[None, :, None, :]
    codes = np.rint(np.stack([x.real, x.imag], axis=-1)).astype(np.int16).reshape(cycles * 32, n_rx, 64, 2)
    path = tmp_path / "adc_data.bin"
    path.write_bytes(capture_bytes(codes, True, 16, lanes, encoding))
    log = tmp_path / "adc_data.activation"
    log.write_text("".join(f"{c} {''.join('1' if b else '0' for b in row)}\n" for c, row in enumerate(rho)))
    log.chmod(0o600)                                 # the sequence is private: a shared log is refused
    scene = tmp_path / "bench.toml"
    scene.write_text(SCENE)
    return path, log, scene


@pytest.mark.parametrize("lanes, encoding", [(2, "twos_complement"), (4, "offset_binary")])
def test_inspect_reports_the_planted_cell_and_the_noise_rms_of_a_written_capture(tmp_path, capsys, lanes, encoding):
    path, log, scene = written_capture(tmp_path, 30.0, 12, 6, lanes, encoding)
    out = tmp_path / "report.json"
    assert carav(["capture", "inspect", str(path), "--scene", str(scene), "--n-rx", "2", "--lanes", str(lanes),
                  "--encoding", encoding, "--activation", str(log), "--json", str(out)]) == Exit.OK
    text = capsys.readouterr().out
    r = json.loads(out.read_text())
    assert r["whole_cycles"] == 6 and r["bytes_left_over"] == 0 and r["warnings"] == []
    assert r["noise_rms"]["silent_chirps_codes"] == pytest.approx([30.0, 30.0], rel=0.05)
    top = r["cells"][0]
    assert (top["range_bin"], top["doppler_bin"]) == (12, 6)
    wavelength, slope = C / 77e9, 1.0e9 / 50e-6
    v = 6 / 32 * wavelength / (2 * 60e-6)
    assert top["velocity_mps"] == pytest.approx(v)
    assert top["range_m"] == pytest.approx(C / (2 * slope) * (12 * 10e6 / 64 - 2 * v / wavelength))
    assert "whole cycles 6" in text and "noise RMS, silent chirps" in text


def test_inspect_of_the_wrong_encoding_and_a_cut_capture_says_what_to_fix(tmp_path, capsys):
    path, log, scene = written_capture(tmp_path, 30.0, 12, 6, 2, "offset_binary")
    path.write_bytes(path.read_bytes()[:-100])
    assert carav(["capture", "inspect", str(path), "--scene", str(scene), "--n-rx", "2"]) == Exit.OK
    text = capsys.readouterr().out
    assert "whole cycles 5" in text and "bytes left over" in text
    assert 'probably encoding = "offset_binary"' in text and "not a whole number of cycles" in text


def test_inspect_names_a_bad_pattern_and_a_missing_file(tmp_path, capsys):
    path, log, scene = written_capture(tmp_path, 30.0, 12, 6, 2, "twos_complement")
    assert carav(["capture", "inspect", str(path), "--scene", str(scene), "--pattern", "0101"]) == Exit.USAGE
    assert "--pattern: expected 32 digits" in capsys.readouterr().err
    assert carav(["capture", "inspect", str(tmp_path / "none.bin"), "--scene", str(scene)]) == Exit.USAGE
    assert "none.bin: capture file not found" in capsys.readouterr().err


def test_inspect_of_a_tdm_capture_gives_each_transmitters_velocity_and_the_azimuth(tmp_path, capsys):
    """2 TX (0, 2 wavelengths) x 4 RX (0 .. 1.5): a target at sin(theta) = 0.25 and 0.6 of the per-transmitter
    unambiguous velocity; half the TDM loops silent, at random (a fixed pattern of every other loop would alias
    the Doppler spectrum by half the loops' rate)."""
    rng = np.random.default_rng(12)
    cycles, wavelength = 3, C / 77e9
    max_v = wavelength / (4 * 2 * 60e-6)
    nu = 2 * 0.6 * max_v * 60e-6 / wavelength                                  # cycles per chirp
    m, r, n = np.arange(32), np.arange(4), np.arange(64)
    x_wl = 2.0 * (m % 2)[:, None] + 0.5 * r[None, :]
    tone = 300.0 * np.exp(2j * np.pi * (12 * n[None, None, :] / 64 + (nu * m[:, None] + 0.25 * x_wl)[:, :, None]))
    pattern = "".join("11" if on else "00" for on in rng.permutation(np.arange(16) < 8))
    active = np.frombuffer(pattern.encode(), np.uint8) == ord("1")
    shape = (cycles, 32, 4, 64)
    x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * 30.0 / math.sqrt(2)
    x += active[None, :, None, None] * tone[None]
    codes = np.rint(np.stack([x.real, x.imag], axis=-1)).astype(np.int16).reshape(cycles * 32, 4, 64, 2)
    path = tmp_path / "adc_data.bin"
    path.write_bytes(capture_bytes(codes, True))
    scene = tmp_path / "mimo.toml"
    scene.write_text(SCENE + "tx_positions_wl = [0.0, 2.0]\ntdm_schedule = [0, 1]\n"
                             "rx_positions_wl = [0.0, 0.5, 1.0, 1.5]\n")
    out = tmp_path / "report.json"
    assert carav(["capture", "inspect", str(path), "--scene", str(scene), "--pattern", pattern,
                  "--json", str(out)]) == Exit.OK
    text = capsys.readouterr().out
    r = json.loads(out.read_text())
    assert r["warnings"] == [] and r["n_slots"] == 2 and r["max_velocity_mps"] == pytest.approx(max_v)
    top = r["cells"][0]
    assert top["range_bin"] == 12 and abs(top["velocity_mps"] - 0.6 * max_v) <= 2 * max_v / 16
    assert top["azimuth_deg"] == pytest.approx(math.degrees(math.asin(0.25)))
    assert "slot 1 (transmitter 1): noise RMS, floor" in text and f"+-{max_v:.4g} m/s" in text
    assert f"azimuth {math.degrees(math.asin(0.25)):+.1f} deg" in text
    # a pattern that splits a TDM loop is refused naming it
    assert carav(["capture", "inspect", str(path), "--scene", str(scene), "--pattern", "10" * 16]) == Exit.USAGE
    assert "--pattern: chirps 0..1 mix active and silent chirps" in capsys.readouterr().err
