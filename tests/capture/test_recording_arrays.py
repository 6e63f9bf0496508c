"""Recordings of a receiver array: SigMF's channels (core:num_channels = n_rx, interleaved sample by sample), the
array geometry and the attacker's and targets' azimuths in the metadata, the frames replayed with their receiver
axis bit for bit, exported with it, and a scene of another array refused by field."""
import json

import numpy as np
import pytest
import scipy.io as sio
import sigmf

from carav_blocks.sigmf_sink import SigmfSink
from carav_blocks.sigmf_source import SigmfSource
from carav_stream.capture.recording_export import AdcSlabs
from carav_stream.capture.sigmf_io import RecordingError, open_recording
from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire
from tests.capture.test_recording_blocks import GOLDEN, IQ_SCENE

N_CYCLES, N_RX = 5, 3
ARRAY = 'n_rx = 3\nn_tx = 2\ntdm_schedule = [0, 1]\n'      # 3 RX x 2 TX, a filled 6-element virtual array


def array_scene(tmp_path, base=IQ_SCENE, extra=ARRAY, name="array.toml"):
    """The small golden ADC scene (4 chirps x 256 samples, 12 bits) with a receiver array."""
    path = tmp_path / name
    path.write_text(open(base).read().replace("[[targets]]", f"{extra}\n[[targets]]"))
    return str(path)


def record_array(tmp_path, iq=True, dtype=np.int16):
    """Five cycles of three receivers in frames of 2 and 3 cycles, with an array's verdicts and estimates."""
    scene = array_scene(tmp_path, IQ_SCENE if iq else str(GOLDEN / "adc_small_i.toml"))
    rng = np.random.default_rng(8)
    shape = (N_CYCLES, N_RX, 4, 256, *((2,) if iq and dtype == np.int16 else ()))
    x = rng.integers(-2048, 2048, size=shape).astype(dtype)
    rho = np.array([[True, True, False, False], [False, False, True, True]] * 3)[:N_CYCLES]
    sink = SigmfSink(path=str(tmp_path / "rec"), scene=scene, seed=4, batch=3)
    sink.start()
    for seq, (a, b) in enumerate([(0, 2), (2, 5)]):
        n = b - a
        sink.process(wire(Frame.of(x[a:b], cycle=a, cycles=n, attack_model="secondary_antenna",
                                   per_cycle={"attack_active": [c >= 2 for c in range(a, b)], "clipped": [0] * n,
                                              "nonfinite": [0] * n}), seq))
        sink.process(None, wire(Frame.of(rho[a:b], cycle=a, cycles=n), seq))
        verdict = {"q": [0.25 * c for c in range(a, b)], "c": [0.2 * c for c in range(a, b)],
                   "alarm": [c >= 2 for c in range(a, b)], "invalid": [False] * n, "raised_by": ["D0"] * n,
                   "attack_azimuth_deg": [29.75 + c if c >= 2 else float("nan") for c in range(a, b)],
                   "attack_azimuth_std_deg": [0.5 if c >= 2 else float("nan") for c in range(a, b)],
                   "attack_reason": ["estimated" if c >= 2 else "no_attack" for c in range(a, b)]}
        sink.process(None, None, wire(Frame.of(rho[a:b], cycle=a, cycles=n, per_cycle=verdict), seq))
    sink.process(None, None, None, wire(Frame.of(None, cycles=2, per_cycle={
        "cycle_index": [0, 1], "range_m": [[20.1], [20.2]], "velocity_mps": [[0.0], [0.1]],
        "azimuth_deg": [[19.5], [20.5]], "azimuth_std_deg": [[0.3], [0.4]]}), 0))
    sink.finish()
    return scene, x, rho, sink


def test_an_array_recording_is_sigmfs_channels_interleaved_sample_by_sample_and_replays_bit_for_bit(tmp_path):
    scene, codes, rho, sink = record_array(tmp_path)
    assert sink.summary()["run"]["recording"]["bytes_per_cycle"] == N_RX * 4 * 256 * 2 * 2
    handle = sigmf.fromfile(str(tmp_path / "rec.sigmf-meta"), autoscale=False)   # the reference reader, hashed
    assert handle.num_channels == N_RX and handle.get_global_field("core:datatype") == "ci16_le"
    assert handle.sample_count == N_CYCLES * 4 * 256                 # a sample spans every channel
    by_sigmf = handle.read_samples()                                 # (samples, channels), I + jQ
    want = codes[..., 0] + 1j * codes[..., 1].astype(np.float32)     # (cycles, rx, chirps, samples)
    np.testing.assert_array_equal(by_sigmf, np.moveaxis(want, 1, 3).reshape(-1, N_RX))
    rec = open_recording(tmp_path / "rec")
    assert rec.n_rx == N_RX and rec.samples.shape == codes.shape
    np.testing.assert_array_equal(rec.samples, codes)
    src = SigmfSource(path=str(tmp_path / "rec"), scene=scene, batch=2)
    src.start()
    out = [src.generate(s) for s in range(4)]
    assert out[3] is None and [o["frames"].payload.shape[0] for o in out[:3]] == [2, 2, 1]
    assert all(o["frames"].payload.flags.c_contiguous for o in out[:3])
    np.testing.assert_array_equal(np.concatenate([o["frames"].payload for o in out[:3]]), codes)
    np.testing.assert_array_equal(np.concatenate([o["rho"].payload for o in out[:3]]), rho)
    assert out[1]["frames"].header["per_cycle"]["attack_active"] == [True, True]


def test_the_array_geometry_and_the_azimuths_travel_in_the_metadata(tmp_path):
    scene, *_ = record_array(tmp_path)
    meta = json.loads((tmp_path / "rec.sigmf-meta").read_text())
    g, ann = meta["global"], meta["annotations"]
    assert g["core:num_channels"] == 3 and g["carav:n_rx"] == 3
    assert (g["carav:rx_positions_wl"], g["carav:tx_positions_wl"], g["carav:tdm_schedule"]) == \
        ([0.0, 0.5, 1.0], [0.0, 1.5], [0, 1])
    s = load_scene(scene)
    assert tuple(g["carav:rx_positions_wl"]) == s.rx_positions_wl and tuple(g["carav:tdm_schedule"]) == s.tdm_schedule
    assert [a["core:sample_start"] for a in ann] == [i * 4 * 256 for i in range(N_CYCLES)]
    assert ann[0]["carav:attack_azimuth_deg"] == "nan" and ann[0]["carav:attack_reason"] == "no_attack"
    assert ann[3]["carav:attack_azimuth_deg"] == 32.75 and ann[3]["carav:attack_azimuth_std_deg"] == 0.5
    assert ann[1]["carav:azimuth_deg"] == [20.5] and ann[1]["carav:azimuth_std_deg"] == [0.4]


def test_a_one_antenna_recording_says_one_channel_and_no_geometry(tmp_path):
    from tests.capture.test_recording_blocks import record
    record(tmp_path / "rec")
    g = json.loads((tmp_path / "rec.sigmf-meta").read_text())["global"]
    assert g["core:num_channels"] == 1
    assert not {"carav:n_rx", "carav:rx_positions_wl", "carav:tx_positions_wl", "carav:tdm_schedule"} & set(g)
    assert open_recording(tmp_path / "rec").n_rx == 1


@pytest.mark.parametrize("other, message", [
    (None, r"global core:num_channels = 3 receivers, but scene adc_small_iq has n_rx = 1"),
    ('n_rx = 3\n', r"global carav:tx_positions_wl = \[0.0, 1.5\], but scene wide has tx_positions_wl = \[0.0\]"),
    ('rx_positions_wl = [0.0, 0.5, 2.0]\nn_tx = 2\ntdm_schedule = [0, 1]\n',
     r"global carav:rx_positions_wl = \[0.0, 0.5, 1.0\], but scene wide has rx_positions_wl = \[0.0, 0.5, 2.0\]"),
    ('n_rx = 3\nn_tx = 2\ntdm_schedule = [1, 0]\n', r"global carav:tdm_schedule = \[0, 1\], but scene wide has"),
])
def test_a_replay_through_a_scene_of_another_array_is_refused_naming_the_field(tmp_path, other, message):
    record_array(tmp_path)
    scene = IQ_SCENE if other is None else array_scene(tmp_path, extra=other, name="wide.toml")
    with pytest.raises(ValueError, match=message):
        SigmfSource(path=str(tmp_path / "rec"), scene=scene)


@pytest.mark.parametrize("edit, message", [
    (lambda g: g.update({"carav:n_rx": 4}), r"global carav:n_rx = 4, but core:num_channels = 3"),
    (lambda g: g.update({"core:num_channels": 2, "carav:n_rx": 2}),
     r"rec.sigmf-data: 61440 bytes, but the metadata .* describes 5 cycles of 8192 bytes \(4 chirps x 256 samples "
     r"x 2 receivers, ci16_le\)"),
    (lambda g: g.update({"carav:tdm_schedule": [0.5, 1]}), r"global carav:tdm_schedule: expected a list of integers"),
    (lambda g: g.update({"carav:rx_positions_wl": "0 0.5 1"}), r"global carav:rx_positions_wl: expected list"),
])
def test_a_defect_of_an_array_recordings_metadata_is_named(tmp_path, edit, message):
    record_array(tmp_path)
    path = tmp_path / "rec.sigmf-meta"
    meta = json.loads(path.read_text())
    edit(meta["global"])
    path.write_text(json.dumps(meta))
    with pytest.raises(RecordingError, match=message):
        open_recording(tmp_path / "rec", verify_hash=False)


@pytest.mark.parametrize("iq, dtype", [(True, np.int16), (False, np.int16), (False, np.float32)])
def test_an_array_recording_exports_with_its_receiver_axis(tmp_path, capsys, iq, dtype):
    _, x, rho, _ = record_array(tmp_path, iq=iq, dtype=dtype)
    want = x[..., 0] + 1j * x[..., 1] if x.ndim == 5 else x
    slabs = AdcSlabs(open_recording(tmp_path / "rec").samples, np.array([1, 3]), N_RX)
    assert slabs.shape == (2, N_RX, 4, 256)
    np.testing.assert_array_equal(slabs.columns(10, 20), want[[1, 3], ..., 10:20])
    out = tmp_path / "out.mat"
    assert carav(["export", str(tmp_path / "rec"), "--mat", str(out), "--quiet"]) == Exit.OK
    kind = "complex single" if iq else "int16" if dtype == np.int16 else "single"
    assert f"adc 5 x 3 x 4 x 256 {kind}, cycle_index" in capsys.readouterr().out
    m = sio.loadmat(str(out), simplify_cells=True)
    assert m["adc"].shape == (N_CYCLES, N_RX, 4, 256)
    np.testing.assert_array_equal(m["adc"], want)
    np.testing.assert_array_equal(m["activation"], rho)
    assert list(m["scene"]["rx_positions_wl"]) == [0.0, 0.5, 1.0]
    np.testing.assert_array_equal(m["per_cycle"]["attack_azimuth_deg"], [np.nan, np.nan, 31.75, 32.75, 33.75])
