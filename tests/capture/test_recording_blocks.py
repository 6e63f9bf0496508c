"""sigmf_sink and sigmf_source in-process: what is recorded replays as it came, valid SigMF, rho kept private,
and every defect of a recording named by file and field."""
import json
import stat

import numpy as np
import pytest
import sigmf

from carav_blocks.sigmf_sink import SigmfSink
from carav_blocks.sigmf_source import SigmfSource
from carav_stream.capture.activation_log import write_log
from carav_stream.capture.sigmf_io import RecordingError, open_recording
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire
from tests.blocks.jig import GOLDEN

IQ_SCENE = str(GOLDEN / "adc_small_iq.toml")      # 4 chirps x 256 samples, I/Q, 12-bit ADC
N_CYCLES = 6


def record(base, scene=IQ_SCENE, iq=True, skip_rho=()):
    """Six cycles in frames of 2, 3 and 1 cycles, with verdicts, estimates and alarms, through a real sink."""
    rng = np.random.default_rng(5)
    sink = SigmfSink(path=str(base), scene=scene, seed=11, batch=3, graph=json.dumps({"file": "g.toml"}))
    sink.start()
    shape = (N_CYCLES, 4, 256, 2) if iq else (N_CYCLES, 4, 256)
    codes = rng.integers(-2048, 2048, size=shape).astype(np.int16)
    rho = np.array([rng.permutation([True, True, False, False]) for _ in range(N_CYCLES)])
    attacked = [False, False, True, True, False, True]
    for seq, (a, b) in enumerate([(0, 2), (2, 5), (5, 6)]):
        n, per = b - a, {"attack_active": attacked[a:b], "clipped": [0] * (b - a), "nonfinite": [0] * (b - a)}
        sink.process(wire(Frame.of(codes[a:b], cycle=a, cycles=n, attack_model="smart", per_cycle=per), seq))
        if seq not in skip_rho:
            sink.process(None, wire(Frame.of(rho[a:b], cycle=a, cycles=n), seq))
        q = [0.5 + i + 0.1234567890123 for i in range(a, b)]
        verdict = {"q": q, "c": [x / 1.5 for x in q], "alarm": [x >= 1.5 for x in q], "invalid": [False] * n,
                   "raised_by": ["D1"] * n, "k_max": [3] * n, "rbar": [1e-4] * n}
        sink.process(None, None, wire(Frame.of(rho[a:b], cycle=a, cycles=n, per_cycle=verdict), seq))
    sink.process(None, None, None, wire(Frame.of(None, cycles=1, per_cycle={"cycle_index": [0], "range_m": [[43.1]],
                                                                            "velocity_mps": [[-26.7]]}), 0))
    sink.process(None, None, None, None, wire(Frame.of(None, cycles=2, per_cycle={"cycle_index": [2, 3],
                                                                                  "reason": ["attack", "attack"]}), 0))
    sink.finish()
    return codes, rho, sink


def test_a_recording_replays_the_same_samples_rho_and_cycle_fields_and_is_valid_sigmf(tmp_path):
    codes, rho, sink = record(tmp_path / "rec")
    assert sink.summary()["run"]["recording"]["bytes_per_cycle"] == 4 * 256 * 2 * 2
    handle = sigmf.fromfile(str(tmp_path / "rec.sigmf-meta"))     # the reference reader opens it, hash checked
    assert handle.get_global_field("core:datatype") == "ci16_le" and handle.sample_count == N_CYCLES * 4 * 256
    src = SigmfSource(path=str(tmp_path), scene=IQ_SCENE, batch=4)
    src.start()
    out = [src.generate(s) for s in range(3)]
    assert out[2] is None
    np.testing.assert_array_equal(np.concatenate([o["frames"].payload for o in out[:2]]), codes)
    np.testing.assert_array_equal(np.concatenate([o["rho"].payload for o in out[:2]]), rho)
    first = out[0]["frames"].header
    assert first["cycle"] == 0 and first["cycles"] == 4 and first["attack_model"] == "smart"
    assert first["per_cycle"]["attack_active"] == [False, False, True, True]
    ann = json.loads((tmp_path / "rec.sigmf-meta").read_text())["annotations"]
    assert ann[0]["carav:range_m"] == [43.1] and ann[0]["carav:gate"] == "clean"
    assert ann[2]["carav:gate"] == "attack" and ann[1]["carav:q"] == 1.6234567890123
    assert json.loads((tmp_path / "rec.sigmf-meta").read_text())["global"]["carav:seed"] == 11


def test_the_activation_sequence_stays_out_of_the_recording_and_its_log_is_private(tmp_path):
    _, rho, _ = record(tmp_path / "rec")
    meta = (tmp_path / "rec.sigmf-meta").read_text()
    assert "k_max" not in meta and "rbar" not in meta and "rho" not in meta
    assert stat.S_IMODE((tmp_path / "rec.activation").stat().st_mode) == 0o600
    lines = (tmp_path / "rec.activation").read_text().splitlines()
    assert lines[-2] == "5 " + "".join("1" if b else "0" for b in rho[5]) and lines[-1].startswith("# sha256 ")


def test_a_real_adc_recording_is_ri16(tmp_path):
    codes, _, _ = record(tmp_path / "rec", scene=str(GOLDEN / "adc_small_i.toml"), iq=False)
    rec = open_recording(tmp_path / "rec")
    assert rec.meta["global"]["core:datatype"] == "ri16_le"
    np.testing.assert_array_equal(rec.samples, codes)


def corrupt(tmp_path, edit):
    record(tmp_path / "rec")
    meta_path = tmp_path / "rec.sigmf-meta"
    meta = json.loads(meta_path.read_text())
    edit(meta, tmp_path)
    meta_path.write_text(json.dumps(meta))


@pytest.mark.parametrize("edit, message", [
    (lambda m, d: m["annotations"].pop(), r"rec.sigmf-data: 24576 bytes, but the metadata \(rec.sigmf-meta: "
                                          r"annotations\) describes 5 cycles"),
    (lambda m, d: m["global"].update({"core:datatype": "ri8"}), r"global core:datatype: 'ri8' is not what an ADC"),
    (lambda m, d: m["global"].update({"core:datatype": "ri16_le"}), r"core:datatype ri16_le does not fit carav:iq"),
    (lambda m, d: m["global"].update({"carav:n_chirps": "4"}), r"global carav:n_chirps: expected int, got '4'"),
    (lambda m, d: (d / "rec.activation").unlink(), r"rec.activation: activation log not found"),
    (lambda m, d: write_log(d / "rec.activation", [0, 1], np.array([[1, 1, 0, 0], [0, 0, 1, 1]], bool)),
     r"rec.activation: 2 cycles, shorter than the recording's 6"),
    (lambda m, d: (d / "rec.sigmf-data").write_bytes(b"\x01" + (d / "rec.sigmf-data").read_bytes()[1:]),
     r"rec.sigmf-data: .*hash.*core:sha512"),
    (lambda m, d: m.update({"global": {**m["global"], "core:sample_rate": "fast"}}),
     r"rec.sigmf-meta: not valid SigMF: global/core:sample_rate: 'fast' is not of type 'number'"),
])
def test_every_defect_of_a_recording_is_named_by_file_and_field(tmp_path, edit, message):
    corrupt(tmp_path, edit)
    with pytest.raises(RecordingError, match=message):
        open_recording(tmp_path / "rec")


def test_a_replay_through_a_scene_that_does_not_describe_the_samples_is_refused(tmp_path):
    record(tmp_path / "rec")
    with pytest.raises(ValueError, match=r"global carav:n_chirps = 4, but scene table1 has n_chirps = 64"):
        SigmfSource(path=str(tmp_path / "rec"), scene="table1")


def test_cycles_whose_rho_never_came_are_counted_and_the_replay_refuses_the_recording(tmp_path):
    _, _, sink = record(tmp_path / "rec", skip_rho=(1,))
    assert sink.summary()["run"]["recording"]["cycles_without_activation"] == 3
    with pytest.raises(RecordingError, match="rec.activation: 3 cycles, shorter than the recording's 6"):
        open_recording(tmp_path / "rec")


def test_a_paced_replay_releases_cycles_no_sooner_than_the_radar_made_them(tmp_path, monkeypatch):
    import carav_blocks.sigmf_source as module

    class Clock:                                         # the block's time module, moved by the test
        now = 100.0

        def monotonic(self):
            return self.now

    clock = Clock()
    monkeypatch.setattr(module, "time", clock)
    record(tmp_path / "rec")
    text = (GOLDEN / "adc_small_iq.toml").read_text()
    slow = tmp_path / "slow.toml"                        # the same samples, a cycle every 50 ms
    slow.write_text(text.replace("n_chirps = 4\n", "n_chirps = 4\nt_cycle_s = 0.05\n"))
    src = SigmfSource(path=str(tmp_path / "rec"), scene=str(slow), batch=2, paced=True)
    src.start()
    # frame s holds cycles 2s, 2s + 1: due 2s cycle periods after the start (the runtime waits on ready_in)
    assert [src.ready_in(s) for s in range(3)] == pytest.approx([0.0, 0.1, 0.2])
    clock.now += 0.15
    assert src.ready_in(1) <= 0 and src.ready_in(2) == pytest.approx(0.05)
    assert [src.generate(s)["frames"].cycle for s in range(3)] == [0, 2, 4]
    unpaced = SigmfSource(path=str(tmp_path / "rec"), scene=str(slow), batch=2)
    unpaced.start()
    assert unpaced.ready_in(2) == 0.0


def test_the_trackers_tracks_of_every_cycle_go_into_its_annotation_and_export_as_columns(tmp_path):
    from carav_stream.capture.recording_export import recording_variables
    sink = SigmfSink(path=str(tmp_path / "rec"), scene=IQ_SCENE, seed=11, batch=3)
    sink.start()
    codes = np.zeros((3, 4, 256, 2), np.int16)
    rho = np.ones((3, 4), bool)
    sink.process(wire(Frame.of(codes, cycle=0, cycles=3, per_cycle={"attack_active": [False] * 3}), 0))
    sink.process(None, wire(Frame.of(rho, cycle=0, cycles=3), 0))
    tracks = {"cycle_index": [0, 1, 2], "measured": [True, True, False], "reason": [None, None, "attack"],
              "born": [[0], [1], []], "deleted": [[], [], [0]], "track_id": [[0], [0, 1], [1]],
              "status": [["tentative"], ["tentative", "tentative"], ["tentative"]],
              "range_m": [[43.0], [43.1, 60.2], [60.3]], "velocity_mps": [[0.0], [0.1, -2.0], [-2.1]],
              "var_range_m2": [[1e-6], [1e-6, 1e-6], [2e-6]], "var_velocity_m2ps2": [[1e-4], [1e-4, 1e-4], [2e-4]],
              "nis": [[None], [0.5, None], [None]], "nis_alarm": [None, None, None]}
    sink.process(None, None, None, None, None, wire(Frame.of(None, cycle=0, cycles=3, per_cycle=tracks), 0))
    sink.finish()
    ann = json.loads((tmp_path / "rec.sigmf-meta").read_text())["annotations"]
    for c, a in enumerate(ann):
        assert {k: v for k, v in a.items() if k.startswith("carav:track")} == {
            "carav:track_id": tracks["track_id"][c], "carav:track_status": tracks["status"][c],
            "carav:track_range_m": tracks["range_m"][c], "carav:track_velocity_mps": tracks["velocity_mps"][c],
            "carav:track_var_range_m2": tracks["var_range_m2"][c],
            "carav:track_var_velocity_m2ps2": tracks["var_velocity_m2ps2"][c]}     # no alarm column when it is off
    columns = recording_variables(open_recording(tmp_path / "rec"), slice(0, 3))[0]["per_cycle"]
    np.testing.assert_array_equal(columns["track_id"], [[0, np.nan], [0, 1], [1, np.nan]])
    np.testing.assert_array_equal(columns["track_range_m"], [[43.0, np.nan], [43.1, 60.2], [60.3, np.nan]])
    assert list(columns["track_status"]) == tracks["status"]
