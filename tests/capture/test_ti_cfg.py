"""TI mmWave CLI profiles as scenes: profiles written in TI's documented command format (mmWave SDK user guide,
"Configuration (.cfg) File Format"), the scene's values from TI's field definitions worked out here, and errors
that name the line and the field."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from carav_stream.capture.ti_cfg import TiCfgError, profile_from_cfg, scene_toml
from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.radar.scene_loader import load_scene, scene_from_dict

# profileCfg: id startFreq(GHz) idle(us) adcStart(us) rampEnd(us) txPower txPhase slope(MHz/us) txStart(us)
#             samples rate(ksps) hpf1 hpf2 rxGain(dB)
# chirpCfg:   start end profile startFreqVar slopeVar idleVar adcStartVar txEnable
# frameCfg:   start end loops frames period(ms) trigger delay(ms)
AWR1642 = """% xWR16xx: TX1 on even chirps, nothing on odd ones
sensorStop
flushCfg
dfeDataOutputMode 1
channelCfg 15 3 0
adcCfg 2 1
adcbufCfg -1 0 1 1 1
profileCfg 0 77 7 6 60 0 0 20 1 256 5000 0 0 30
chirpCfg 0 0 0 0 0 0 0 1
chirpCfg 1 1 0 0 0 0 0 0
frameCfg 0 1 32 0 40 1 0
lvdsStreamCfg -1 0 1 0
sensorStart
"""


def test_a_profile_becomes_the_scene_of_its_documented_fields():
    p = profile_from_cfg(AWR1642, "awr.cfg")
    s = p.scene
    slope = 20e6 / 1e-6                                          # 20 MHz/us
    assert s["fs_hz"] == pytest.approx(5e6) and s["n_samples"] == 256
    assert s["bandwidth_hz"] / s["t_sweep_s"] == pytest.approx(slope)
    assert s["t_sweep_s"] == pytest.approx(60e-6) and s["bandwidth_hz"] == pytest.approx(1.2e9)
    assert s["t_chirp_s"] == pytest.approx(67e-6) and s["t_adc_start_s"] == pytest.approx(6e-6)
    assert s["t_cycle_s"] == pytest.approx(40e-3) and s["n_chirps"] == 64
    assert s["iq"] is True and s["adc_bits"] == 16
    assert s["fc_hz"] == pytest.approx(77e9 + slope * (6e-6 + 256 / 5e6 / 2))   # centre of the sampled band
    assert p.n_rx == 4 and p.rx_channels == [0, 1, 2, 3]
    assert p.pattern == "10" * 32 and p.balanced
    assert "not the paper's secret per-cycle sequence" in s["description"]
    assert "sensorStop (line 2)" in p.not_read and "lvdsStreamCfg (line 12)" in p.not_read


def test_the_written_scene_is_accepted_by_the_scene_loader_and_keeps_the_adc_start_time():
    text = scene_toml(profile_from_cfg(AWR1642, "awr.cfg"), sigma_n=30 / 2 ** 15)
    scene = scene_from_dict(tomllib.loads(text), "awr.toml")
    assert scene.t_adc_start_s == pytest.approx(6e-6) and scene.n_chirps == 64 and scene.iq
    assert scene.sigma_n == pytest.approx(30 / 2 ** 15) and scene.adc_full_scale == 1.0
    assert "1010" in text and "not the secret per-cycle sequence" in text


def test_a_real_four_receiver_profile_with_every_chirp_transmitting_has_no_silent_chirp():
    text = AWR1642.replace("adcCfg 2 1", "adcCfg 1 0").replace("chirpCfg 1 1 0 0 0 0 0 0", "chirpCfg 1 1 0 0 0 0 0 2")
    p = profile_from_cfg(text.replace("channelCfg 15 3 0", "channelCfg 5 3 0"), "x.cfg")
    assert p.pattern == "1" * 64 and p.scene["iq"] is False and p.scene["adc_bits"] == 14
    assert p.n_rx == 2 and p.rx_channels == [0, 2]
    # a transmitter that channelCfg does not enable sends nothing: txEnable 4 with txChannelEn 3 is silent
    p = profile_from_cfg(AWR1642.replace("chirpCfg 1 1 0 0 0 0 0 0", "chirpCfg 1 1 0 0 0 0 0 4"), "x.cfg")
    assert p.pattern == "10" * 32


@pytest.mark.parametrize("change, message", [
    (("profileCfg 0 77 7 6 60 0 0 20 1 256 5000 0 0 30", "profileCfg 0 77 7 6 60 0 0 20 1 256"),
     "awr.cfg:8: profileCfg: expected 14 fields .* got 10: digOutSampleRate is missing"),
    (("profileCfg 0 77 7 6 60", "profileCfg 0 77 seven 6 60"), "awr.cfg:8: profileCfg: idleTime: expected a number"),
    (("256 5000", "400 5000"), "awr.cfg:8: profileCfg: numAdcSamples: 400 samples .* after rampEndTime 60 us"),
    (("chirpCfg 1 1 0 0 0 0 0 0", "chirpCfg 1 1 0 0 5 0 0 0"), "awr.cfg:10: chirpCfg: freqSlopeVar: 5 varies"),
    (("chirpCfg 1 1 0 0 0 0 0 0", "chirpCfg 2 2 0 0 0 0 0 0"), "awr.cfg:11: frameCfg: .* chirp 1 has no chirpCfg"),
    (("frameCfg 0 1 32 0 40 1 0", ""), "awr.cfg: frameCfg: expected exactly one, found 0"),
    (("adcCfg 2 1", "adcCfg 3 1"), "awr.cfg:6: adcCfg: numADCBits: expected 0 .* got 3"),
    (("chirpCfg 0 0 0 0 0 0 0 1", "chirpCfg 0 0 1 0 0 0 0 1"), "awr.cfg:11: frameCfg: the frame's chirps use "
                                                             "profiles \\[0, 1\\]"),
])
def test_a_bad_profile_is_refused_naming_the_line_and_the_field(change, message):
    with pytest.raises(TiCfgError, match=message):
        profile_from_cfg(AWR1642.replace(*change), "awr.cfg")


def test_carav_scenes_from_ti_cfg_writes_a_scene_that_loads(tmp_path, capsys):
    cfg, out = tmp_path / "awr.cfg", tmp_path / "awr.toml"
    cfg.write_text(AWR1642)
    assert carav(["scenes", "--from-ti-cfg", str(cfg), "--out", str(out), "--noise-codes", "30"]) == Exit.OK
    printed = capsys.readouterr().out
    assert "activation pattern 1010" in printed and "| sampling window | 51.2 us from 6 us |" in printed
    scene = load_scene(str(out))
    assert scene.sigma_n == pytest.approx(30 / 2 ** 15) and scene.n_samples == 256
    cfg.write_text(AWR1642.replace("adcCfg 2 1", "adcCfg 2"))
    assert carav(["scenes", "--from-ti-cfg", str(cfg)]) == Exit.INVALID
    assert "awr.cfg:6: adcCfg: expected 2 fields" in capsys.readouterr().err


def test_the_pattern_of_a_profile_drives_the_dca1000_source(tmp_path):
    from blocks.dca1000_source import Dca1000Source
    cfg, scene = tmp_path / "awr.cfg", tmp_path / "awr.toml"
    cfg.write_text(AWR1642)
    profile = profile_from_cfg(AWR1642, str(cfg))
    scene.write_text(scene_toml(profile))
    capture = tmp_path / "adc.bin"
    capture.write_bytes(np.zeros(3 * 64 * 4 * 256 * 2, "<i2").tobytes())   # 3 cycles, 4 receivers, complex
    block = Dca1000Source(path=str(capture), pattern=profile.pattern, scene=str(scene), batch=2)
    frames = block.generate(0)
    assert frames["rho"].payload.shape == (2, 64)
    assert (frames["rho"].payload == (np.arange(64) % 2 == 0)).all()
    with pytest.raises(ValueError, match="activation, pattern: give exactly one"):
        Dca1000Source(path=str(capture), scene=str(scene))
