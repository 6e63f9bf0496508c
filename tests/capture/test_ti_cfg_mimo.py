"""TI profiles with several transmitters as MIMO scenes: the TDM schedule from the chirpCfg order, the transmitters'
and receivers' positions from the device's board layout (TI's AWR1642 BoosterPack: TX1 and TX2 two wavelengths
apart, RX1..RX4 half a wavelength apart; the AWR1243/1443/6843 boards: TX1, TX2, TX3 one wavelength apart in
azimuth), and the unambiguous velocity per transmitter repetition, lambda / (4 n_slots t_chirp), worked out here
from the profile's fields. A single-transmitter profile keeps its one-antenna scene."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from carav_stream.capture.ti_cfg import TiCfgError, profile_from_cfg, scene_toml
from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.radar.scene_loader import scene_from_dict

C = 299_792_458.0
# profileCfg: id startFreq(GHz) idle(us) adcStart(us) rampEnd(us) txPower txPhase slope(MHz/us) txStart(us)
#             samples rate(ksps) hpf1 hpf2 rxGain(dB)
# chirpCfg:   start end profile startFreqVar slopeVar idleVar adcStartVar txEnable
# frameCfg:   start end loops frames period(ms) trigger delay(ms)
TDM_2TX = """% xWR16xx TDM MIMO: TX1 on chirp 0, TX2 on chirp 1, 64 loops, four receivers
sensorStop
channelCfg 15 3 0
adcCfg 2 1
profileCfg 0 77 7 6 60 0 0 20 1 256 5000 0 0 30
chirpCfg 0 0 0 0 0 0 0 1
chirpCfg 1 1 0 0 0 0 0 2
frameCfg 0 1 64 0 40 1 0
sensorStart
"""
ONE_TX = TDM_2TX.replace("chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 0")   # TX1, then nothing


def fc_hz(start_ghz=77.0, slope_mhz_us=20.0, adc_start_us=6.0, samples=256, rate_ksps=5000.0) -> float:
    """The centre of the sampled band: startFreq + slope (adcStartTime + samples / 2 fs)."""
    return start_ghz * 1e9 + slope_mhz_us * 1e12 * (adc_start_us * 1e-6 + samples / (rate_ksps * 1e3) / 2)


def loaded(text: str, device: str | None = None):
    profile = profile_from_cfg(text, "p.cfg", device)
    return profile, scene_from_dict(tomllib.loads(scene_toml(profile)), "p.toml")


def test_a_two_transmitter_tdm_profile_is_an_eight_element_virtual_array_with_half_the_velocity():
    profile, scene = loaded(TDM_2TX)
    assert profile.mimo and profile.schedule == (0, 1) and profile.device.name == "awr1642" and profile.device_assumed
    assert scene.tx_positions_wl == (0.0, 2.0) and scene.tdm_schedule == (0, 1)
    assert scene.rx_positions_wl == (0.0, 0.5, 1.0, 1.5) and scene.n_rx == 4 and scene.n_chirps == 128
    # virtual element (slot j, receiver r) = tx(j) + rx(r): TX1 at 0 and TX2 at 2 wavelengths, receivers 0 .. 1.5
    np.testing.assert_array_equal(scene.virtual_positions_wl, [t + r for t in (0, 2) for r in (0, 0.5, 1, 1.5)])
    t_chirp = (7 + 60) * 1e-6                                    # idleTime + rampEndTime
    v_one = C / fc_hz() / (4 * t_chirp)                          # one chirp apart: what the profile was read as
    assert scene.max_velocity_mps == pytest.approx(v_one / 2, rel=1e-9)
    assert profile.pattern == "1" * 128 and scene.n_loops == 64
    line = profile.velocity_line()
    assert f"+-{v_one / 2:.4g} m/s" in line and f"not the single chirp's +-{v_one:.4g} m/s" in line


def test_a_single_transmitter_profile_keeps_its_one_antenna_scene():
    profile, scene = loaded(ONE_TX)
    assert not profile.mimo and profile.schedule == (0,) and profile.pattern == "10" * 64
    assert not {"tx_positions_wl", "rx_positions_wl", "tdm_schedule"} & set(profile.scene)
    assert scene.n_rx == 1 and scene.n_slots == 1 and not scene.has_array
    assert scene.max_velocity_mps == pytest.approx(C / fc_hz() / (4 * 67e-6), rel=1e-9)
    assert profile.scene["description"].startswith("TI profile p.cfg: 64 of 128 chirps silent")
    assert "rx_positions_wl = [0.0, 0.5, 1.0, 1.5]" in scene_toml(profile)   # how to make it a receiver array


def test_three_transmitters_take_the_three_transmitter_layout_and_the_device_assumed_is_said():
    text = TDM_2TX.replace("channelCfg 15 3 0", "channelCfg 15 7 0").replace(
        "chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 2\nchirpCfg 2 2 0 0 0 0 0 4").replace(
        "frameCfg 0 1 64", "frameCfg 0 2 64")
    profile, scene = loaded(text)
    assert profile.device.name == "iwr6843" and profile.device.lanes == 2
    assert "device iwr6843 (xWR68xx; assumed" in scene_toml(profile)
    assert scene.tx_positions_wl == (0.0, 1.0, 2.0) and scene.tdm_schedule == (0, 1, 2) and scene.n_chirps == 192
    assert scene.max_velocity_mps == pytest.approx(C / fc_hz() / (4 * 3 * 67e-6), rel=1e-9)
    profile, scene = loaded(text, "awr1443")                     # the same antennas, four lanes
    assert profile.device.lanes == 4 and not profile.device_assumed and scene.tx_positions_wl == (0.0, 1.0, 2.0)
    # TX1 and TX3 alone (the azimuth pair): transmitters at 0 and 2, schedule in chirpCfg order, TX3 first
    text = TDM_2TX.replace("channelCfg 15 3 0", "channelCfg 5 5 0").replace("0 0 0 0 0 1\n", "0 0 0 0 0 4\n").replace(
        "chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 1")
    profile, scene = loaded(text)
    assert scene.tx_positions_wl == (0.0, 2.0) and scene.tdm_schedule == (1, 0)
    assert scene.rx_positions_wl == (0.0, 1.0)                   # rxChannelEn 5: RX1 and RX3
    np.testing.assert_array_equal(scene.virtual_positions_wl, [2, 3, 0, 1])


def test_silent_loops_are_the_activation_and_the_loop_is_the_shortest_repetition():
    # chirps TX1, TX2, -, -: loops of two slots, every other loop silent
    text = TDM_2TX.replace("chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 2\nchirpCfg 2 3 0 0 0 0 0 0").replace(
        "frameCfg 0 1 64", "frameCfg 0 3 32")
    profile, scene = loaded(text)
    assert profile.schedule == (0, 1) and profile.pattern == "1100" * 32 and profile.balanced
    assert scene.n_slots == 2 and scene.n_loops == 64
    # chirps TX1, TX2, TX1, TX2 in one frame: still a loop of two slots
    text = TDM_2TX.replace("chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 2\nchirpCfg 2 2 0 0 0 0 0 1\n"
                           "chirpCfg 3 3 0 0 0 0 0 2").replace("frameCfg 0 1 64", "frameCfg 0 3 32")
    assert profile_from_cfg(text, "p.cfg").schedule == (0, 1)


def test_transmitters_fired_together_in_every_chirp_are_one_transmitter_for_the_scene():
    profile, scene = loaded(ONE_TX.replace("0 0 0 0 0 1\n", "0 0 0 0 0 3\n"))
    assert profile.together == (0, 1) and not profile.mimo and scene.n_slots == 1 and profile.pattern == "10" * 64
    assert "TX1+TX2 fire together" in scene_toml(profile)
    # a single transmitter's scene needs no positions: a transmitter beyond the assumed device's is no matter
    profile, scene = loaded(ONE_TX.replace("channelCfg 15 3 0", "channelCfg 15 15 0"))
    assert not profile.mimo and profile.pattern == "10" * 64 and scene.n_slots == 1


@pytest.mark.parametrize("change, device, message", [
    ((("chirpCfg 1 1 0 0 0 0 0 2", "chirpCfg 1 1 0 0 0 0 0 0\nchirpCfg 2 2 0 0 0 0 0 2\nchirpCfg 3 3 0 0 0 0 0 0"),
      ("frameCfg 0 1 64", "frameCfg 0 3 32")), None,                     # TX1, -, TX2, -
     "p.cfg:10: frameCfg: the frame's chirps fire TX1, -, TX2, -: not TDM loops"),
    ((("chirpCfg 0 0 0 0 0 0 0 1", "chirpCfg 0 0 0 0 0 0 0 3"),), None,
     "p.cfg:8: frameCfg: the frame's chirps fire TX1\\+TX2, TX2: several transmitters together"),
    ((("channelCfg 15 3 0", "channelCfg 15 7 0"),), "awr1642",
     "p.cfg:3: channelCfg: txChannelEn: 7 enables TX3; the awr1642 has 2 transmitters"),
    ((("channelCfg 15 3 0", "channelCfg 15 15 0"), ("0 0 0 0 0 2\n", "0 0 0 0 0 8\n")), None,
     r"p.cfg:8: frameCfg: the frame's chirps fire TX4; the iwr6843 \(assumed\) has 3 transmitters"),
])
def test_a_profile_that_is_not_tdm_over_the_device_s_transmitters_is_refused_naming_the_line(change, device, message):
    text = TDM_2TX
    for old, new in change:
        assert old in text
        text = text.replace(old, new)
    with pytest.raises(TiCfgError, match=message):
        profile_from_cfg(text, "p.cfg", device)


def test_carav_scenes_prints_the_virtual_array_the_device_and_the_velocity_per_transmitter_repetition(tmp_path,
                                                                                                        capsys):
    cfg, out = tmp_path / "mimo.cfg", tmp_path / "mimo.toml"
    cfg.write_text(TDM_2TX)
    assert carav(["scenes", "--from-ti-cfg", str(cfg), "--out", str(out)]) == Exit.OK
    printed = capsys.readouterr().out
    v = C / fc_hz() / (4 * 2 * 67e-6)
    assert "device awr1642 (xWR16xx; assumed: the profile does not name its device, --device chooses)" in printed
    assert f"TDM over TX1, TX2 (2 slots a loop): unambiguous velocity +-{v:.4g} m/s" in printed
    assert "| antennas | 2 TX (TDM, 2 slots a loop) x 4 RX: 8 virtual elements at 0, 0.5, 1, 1.5, 2, 2.5, 3, 3.5 " \
           "wavelengths |" in printed
    assert f"| unambiguous velocity | +-{v:.4g} m/s (one transmitter repeats every 134 us) |" in printed
    assert carav(["scenes", "--from-ti-cfg", str(cfg), "--device", "awr1443"]) == Exit.OK
    assert "tx_positions_wl = [0.0, 1.0]" in capsys.readouterr().out        # TX1, TX2 of the three-TX board
    cfg.write_text(TDM_2TX.replace("frameCfg 0 1 64", "frameCfg 0 1 3"))    # three loops: not balanced over loops
    assert carav(["scenes", "--from-ti-cfg", str(cfg)]) == Exit.INVALID
    assert "even number of TDM loops of 2 slots" in capsys.readouterr().err
    assert carav(["scenes", "table1", "--device", "awr1642"]) != Exit.OK
    assert "--device go with --from-ti-cfg" in capsys.readouterr().err
