"""DCA1000 captures with every receiver: a scene with several receivers (rx_positions_wl) gets frames with a receiver
axis, (cycles, receivers, chirps, samples[, 2]), each receiver's samples where the radar put them (the captures are
written by tests/capture/ti_dca1000.py from TI's layout description, sample by sample); a one-receiver scene keeps
receiver rx alone; a capture whose receivers contradict the scene, and an activation that breaks the scene's TDM
loops, are refused in one line naming the parameter."""
from __future__ import annotations

import numpy as np
import pytest

from blocks.dca1000_source import Dca1000Source
from carav_stream.capture.activation_log import write_log
from tests.capture.ti_dca1000 import capture_bytes

N_CHIRPS, N_SAMPLES = 8, 16


def scene_file(tmp_path, iq=True, rx=None, tx=None, schedule=None, name="arr"):
    text = f"""name = "{name}"
fc_hz = 77e9
bandwidth_hz = 1.0e9
t_sweep_s = 50e-6
fs_hz = 2e6
n_chirps = {N_CHIRPS}
n_samples = {N_SAMPLES}
iq = {"true" if iq else "false"}
adc_bits = 16
adc_full_scale = 1.0
sigma_n = 9.1552734375e-4
"""
    for key, value in (("rx_positions_wl", rx), ("tx_positions_wl", tx), ("tdm_schedule", schedule)):
        if value is not None:
            text += f"{key} = {list(value)}\n"
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return str(path)


def capture(tmp_path, n_rx, iq=True, lanes=2, cycles=3, seed=0):
    """codes (cycles, n_chirps, n_rx, n_samples[, 2]) as the radar produced them, and the .bin TI's layout makes."""
    shape = (cycles, N_CHIRPS, n_rx, N_SAMPLES, *((2,) if iq else ()))
    x = np.random.default_rng(seed).integers(-2000, 2000, size=shape).astype(np.int16)
    path = tmp_path / "adc_data.bin"
    path.write_bytes(capture_bytes(x.reshape(cycles * N_CHIRPS, *shape[2:]), iq, 16, lanes))
    return x, str(path)


@pytest.mark.parametrize("iq, lanes", [(True, 2), (False, 2), (True, 4), (False, 4)])
def test_a_four_receiver_scene_gets_every_receiver_of_the_capture_on_a_receiver_axis(tmp_path, iq, lanes):
    x, path = capture(tmp_path, 4, iq, lanes)
    scene = scene_file(tmp_path, iq, rx=(0, 0.5, 1, 1.5), tx=(0, 2), schedule=(0, 1))
    block = Dca1000Source(path=path, scene=scene, pattern="1" * N_CHIRPS, n_rx=4, lanes=lanes, batch=2)
    frames = [block.generate(0), block.generate(1)]
    assert block.generate(2) is None
    got = np.concatenate([f["frames"].payload for f in frames])
    assert got.shape == (3, 4, N_CHIRPS, N_SAMPLES, *((2,) if iq else ())) and got.dtype == np.int16
    for r in range(4):                                            # receiver r of chirp k is where TI put it
        np.testing.assert_array_equal(got[:, r], x[:, :, r])
    assert [f["rho"].payload.shape for f in frames] == [(2, N_CHIRPS), (1, N_CHIRPS)]


def test_a_one_receiver_scene_keeps_receiver_rx_alone_and_receivers_picks_a_subset_for_a_smaller_array(tmp_path):
    x, path = capture(tmp_path, 4)
    one = Dca1000Source(path=path, scene=scene_file(tmp_path, name="one"), pattern="10" * 4, rx=2, batch=3)
    got = one.generate(0)["frames"].payload
    assert got.shape == (3, N_CHIRPS, N_SAMPLES, 2)
    np.testing.assert_array_equal(got, x[:, :, 2])
    assert Dca1000Source(path=path, scene=scene_file(tmp_path, name="one"), pattern="10" * 4,
                         receivers="3").generate(0)["frames"].payload.shape == (3, N_CHIRPS, N_SAMPLES, 2)
    pair = Dca1000Source(path=path, scene=scene_file(tmp_path, rx=(0, 1.0), name="pair"), pattern="10" * 4,
                         receivers="0,2", batch=3)
    got = pair.generate(0)["frames"].payload
    np.testing.assert_array_equal(got, np.moveaxis(x[:, :, [0, 2]], 2, 1))


@pytest.mark.parametrize("scene_rx, params, message", [
    ((0, 0.5, 1, 1.5), {"n_rx": 2}, r"n_rx, receivers: the capture's receivers \[0, 1\] \(n_rx = 2\) contradict the "
                                    r"scene arr's 4 receivers"),
    ((0, 0.5), {"n_rx": 4}, r"contradict the scene arr's 2 receivers"),
    ((0, 0.5), {"n_rx": 4, "receivers": "0,1,2"}, r"receivers \[0, 1, 2\] \(n_rx = 4\) contradict the scene arr's 2"),
    (None, {"n_rx": 4, "receivers": "all"}, "receivers: 'all' sends 4 receivers, but the scene arr has one"),
    ((0, 0.5), {"n_rx": 4, "receivers": "1,7"}, "receivers: '1,7': expected distinct receivers 0..3"),
    ((0, 0.5), {"n_rx": 4, "receivers": "1,1"}, "receivers: '1,1': expected distinct receivers"),
    ((0, 0.5), {"n_rx": 4, "receivers": "left"}, "receivers: expected 'all' or receivers such as '0,2'"),
    ((0, 0.5), {"n_rx": 4, "receivers": "0,1", "rx": 1}, "rx, receivers: give one of them"),
    (None, {"n_rx": 2, "rx": 3}, "rx: receiver 3 is not among the capture's n_rx = 2"),
])
def test_receivers_that_contradict_the_scene_or_the_capture_are_refused_naming_them(tmp_path, scene_rx, params,
                                                                                     message):
    _, path = capture(tmp_path, params["n_rx"])
    with pytest.raises(ValueError, match=message) as err:
        Dca1000Source(path=path, scene=scene_file(tmp_path, rx=scene_rx), pattern="10" * 4, **params)
    assert "\n" not in str(err.value)


def test_an_activation_that_breaks_the_scene_s_tdm_loops_is_refused(tmp_path):
    _, path = capture(tmp_path, 4)
    scene = scene_file(tmp_path, rx=(0, 0.5, 1, 1.5), tx=(0, 2), schedule=(0, 1))
    Dca1000Source(path=path, scene=scene, pattern="1100" * 2)       # whole loops of TX1, TX2: active or silent
    with pytest.raises(ValueError, match="pattern: chirps 0..1 mix active and silent chirps; the scene's TDM loops "
                                         "of 2 slots"):
        Dca1000Source(path=path, scene=scene, pattern="10" * 4)
    log = tmp_path / "adc_data.activation"
    write_log(log, [0, 1, 2], np.array([[1, 1, 0, 0] * 2, [1, 1, 0, 0] * 2, [1, 1, 0, 0, 0, 1, 1, 0]], bool))
    with pytest.raises(ValueError, match=f"activation: {log}: cycle 2, chirps 4..5 mix active and silent chirps"):
        Dca1000Source(path=path, scene=scene, activation=str(log))
