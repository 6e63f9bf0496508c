"""carav export: a recording or a summary as a MATLAB v5 file that scipy.io.loadmat (like MATLAB and Octave) reads
back as open_recording gives it; keys made MATLAB names; a large recording, a corrupt or absent input refused in one
line with the exit code of its class."""
import re
import stat

import numpy as np
import pytest
import scipy.io as sio

from carav_blocks.sigmf_sink import SigmfSink
from carav_stream.capture.sigmf_io import open_recording
from carav_stream.cli import main as carav
from carav_stream.console import jsonout, matout
from carav_stream.console.errors import Exit
from carav_stream.console.matout import matlab_name, matlab_names
from carav_stream.runtime import Frame
from tests.blocks.helpers import wire
from tests.capture.test_recording_blocks import GOLDEN, IQ_SCENE, N_CYCLES, record
from tests.cli.test_run_summary_text import summarised

MATLAB_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,62}")


def float_recording(base, dtype):
    """Five cycles of an ideal ADC's float32 or complex64 samples through a real sink (no verdicts: fields absent)."""
    rng = np.random.default_rng(3)
    scene = IQ_SCENE if dtype == np.complex64 else str(GOLDEN / "adc_small_i.toml")
    sink = SigmfSink(path=str(base), scene=scene, seed=2, batch=5)
    sink.start()
    x = rng.standard_normal((5, 4, 256)).astype(np.float32)
    x = (x + 1j * rng.standard_normal(x.shape)).astype(np.complex64) if dtype == np.complex64 else x
    sink.process(wire(Frame.of(x, cycle=10, cycles=5, per_cycle={"attack_active": [False] * 5}), 0))
    sink.process(None, wire(Frame.of(np.ones((5, 4), bool), cycle=10, cycles=5), 0))
    sink.finish()
    return x


def loaded(path):
    return sio.loadmat(str(path), simplify_cells=False)


def export(tmp_path, capsys, *extra, source="rec"):
    out = tmp_path / "out.mat"
    code = carav(["export", str(tmp_path / source), "--mat", str(out), "--quiet", *extra])
    return code, out, capsys.readouterr()


def texts(column) -> list[str]:
    """A cell column of text as loadmat gives it (an empty char array for '')."""
    return [x if isinstance(x, str) else "" if np.size(x) == 0 else repr(x) for x in column]


def recorded_adc(rec):
    s = np.asarray(rec.samples)
    return s[..., 0] + 1j * s[..., 1] if s.ndim == 4 else s


@pytest.mark.parametrize("slab_bytes", [matout.SLAB_BYTES, 3000])     # one slab; many (3000 bytes: 1 sample each)
@pytest.mark.parametrize("kind", ["ci16", "ri16", "cf32", "rf32"])
def test_a_recording_loads_back_in_matlab_as_open_recording_gives_it(tmp_path, capsys, monkeypatch, kind, slab_bytes):
    monkeypatch.setattr(matout, "SLAB_BYTES", slab_bytes)
    if kind in ("ci16", "ri16"):
        record(tmp_path / "rec", scene=IQ_SCENE if kind == "ci16" else str(GOLDEN / "adc_small_i.toml"),
               iq=kind == "ci16")
    else:
        float_recording(tmp_path / "rec", np.complex64 if kind == "cf32" else np.float32)
    code, out, said = export(tmp_path, capsys)
    assert code == Exit.OK, said.err
    rec = open_recording(tmp_path / "rec")
    m = loaded(out)
    want = recorded_adc(rec)
    assert m["adc"].shape == want.shape == (len(rec.cycles), 4, 256)
    np.testing.assert_array_equal(m["adc"], want)
    assert m["adc"].dtype == {"ci16": np.complex64, "ri16": np.int16, "cf32": np.complex64, "rf32": np.float32}[kind]
    classes = {n: c for n, _, c in sio.whosmat(str(out))}
    assert classes["adc"] == ("int16" if kind == "ri16" else "single") and classes["activation"] == "logical"
    np.testing.assert_array_equal(m["cycle_index"].ravel(), rec.cycles)
    assert m["cycle_index"].dtype == np.int64 and m["cycle_index"].shape == (len(rec.cycles), 1)
    np.testing.assert_array_equal(m["activation"], rec.rho)


def test_the_verdicts_estimates_scene_and_metadata_travel_as_columns_and_structs(tmp_path, capsys):
    record(tmp_path / "rec")
    code, out, _ = export(tmp_path, capsys)
    assert code == Exit.OK
    rec = open_recording(tmp_path / "rec")
    m = sio.loadmat(str(out), simplify_cells=True)
    per = m["per_cycle"]
    np.testing.assert_array_equal(per["q"], [a["carav:q"] for a in rec.annotations])
    np.testing.assert_array_equal(per["alarm"], [a["carav:alarm"] for a in rec.annotations])
    np.testing.assert_array_equal(per["attack_active"], [False, False, True, True, False, True])
    assert texts(per["gate"]) == ["clean", "", "attack", "attack", "", ""]       # "" where the gate said nothing
    assert per["range_m"][0] == 43.1 and np.isnan(per["range_m"][1:]).all()    # one target, NaN where no estimate
    assert texts(per["raised_by"]) == ["D1"] * N_CYCLES
    assert m["scene"]["n_chirps"] == 4 and m["scene"]["iq"] and m["scene"]["targets"]["range_m"] == 43.0
    assert m["scene"]["max_velocity_mps"] > 0 and m["scene"]["description"].endswith("iq = true")
    assert m["meta"]["core_datatype"] == "ci16_le" and m["meta"]["carav_seed"] == 11
    assert m["meta"]["carav_graph"] == {"file": "g.toml"}
    assert m["captures"]["core_frequency"] == 77e9


def test_a_file_with_the_activation_sequence_is_its_owners_alone_unless_left_out(tmp_path, capsys):
    record(tmp_path / "rec")
    code, out, said = export(tmp_path, capsys)
    assert code == Exit.OK and stat.S_IMODE(out.stat().st_mode) == 0o600 and "activation" in loaded(out)
    assert "mode 0600" in said.out
    code, out, _ = export(tmp_path, capsys, "--no-activation")
    assert code == Exit.OK and "activation" not in loaded(out) and stat.S_IMODE(out.stat().st_mode) & 0o044
    (tmp_path / "rec.activation").unlink()
    code, out, said = export(tmp_path, capsys)
    assert code == Exit.OK and "activation" not in loaded(out) and "no rec.activation" in said.out


def test_cycles_a_to_b_exports_those_rows_only(tmp_path, capsys):
    codes, rho, _ = record(tmp_path / "rec")
    code, out, said = export(tmp_path, capsys, "--cycles", "2:5")
    assert code == Exit.OK, said.err
    m = loaded(out)
    np.testing.assert_array_equal(m["adc"], codes[2:5, ..., 0] + 1j * codes[2:5, ..., 1])
    np.testing.assert_array_equal(m["cycle_index"].ravel(), [2, 3, 4])
    np.testing.assert_array_equal(m["activation"], rho[2:5])
    assert texts(sio.loadmat(str(out), simplify_cells=True)["per_cycle"]["gate"]) == ["attack", "attack", ""]
    code, _, said = export(tmp_path, capsys, "--cycles", "40:50")
    assert code == Exit.USAGE and "holds cycles 0 to 5" in said.err and len(said.err.splitlines()) == 1


def test_a_recording_over_the_variable_limit_is_refused_naming_the_cycles_that_fit(tmp_path, capsys, monkeypatch):
    record(tmp_path / "rec")                                    # 4 x 256 complex singles a cycle: 8192 bytes
    monkeypatch.setattr(matout, "MAX_VARIABLE_BYTES", 3 * 8192 + 100)
    code, out, said = export(tmp_path, capsys)
    assert code == Exit.USAGE and not out.exists() and not list(tmp_path.glob(".out.mat*"))
    assert len(said.err.strip().splitlines()) == 1, said.err
    assert "over the 2 GiB a MATLAB v5 variable holds; export at most 3 cycles at a time with --cycles A:B" in said.err
    code, out, said = export(tmp_path, capsys, "--cycles", "3:")
    assert code == Exit.OK and loaded(out)["adc"].shape == (3, 4, 256)


@pytest.mark.parametrize("key, name", [
    ("detection_rate", "detection_rate"), ("adc.frames -> detector.frames", "adc_frames____detector_frames"),
    ("1st", "x1st"), ("_private", "x_private"), ("end", "xend"), ("", "x"), ("Q\u00e9", "Q_"),
    ("k" * 80, "k" * 63),
])
def test_a_key_becomes_a_valid_matlab_name(key, name):
    assert matlab_name(key) == name and MATLAB_NAME.fullmatch(name)


def test_keys_that_would_clash_get_numbered_names():
    names = matlab_names(["a-b", "a_b", "a.b", "k" * 70, "k" * 64])
    assert list(names.values()) == ["a_b", "a_b_2", "a_b_3", "k" * 63, "k" * 61 + "_2"]


def test_a_summary_becomes_a_struct_of_valid_names_numbers_and_arrays(tmp_path, capsys):
    summary = {"graph": "demo.toml", "cycles": 300, "detection_rate": None, "wall_s": 1.5,
               "lost_by_edge": {"adc.frames -> detector.frames": 0, "end": 2}, "q": [1.0, float("inf"), 2.5],
               "velocity_error_mps": {"rmse": float("nan"), "n": 0}, "failures": [], "names": ["a", "b"],
               "swaps": [{"node": "attacker", "at_s": 1.0}, {"node": "gate", "at_s": 2.0}], "seed": 2 ** 62 + 1,
               "alarm": True, "matrix": [[1, 2], [3, 4]]}
    jsonout.write(tmp_path / "s.json", summary, indent=2)
    code, out, said = export(tmp_path, capsys, source="s.json")
    assert code == Exit.OK, said.err
    s = sio.loadmat(str(out), simplify_cells=True)["summary"]
    assert s["graph"] == "demo.toml" and s["cycles"] == 300.0 and s["wall_s"] == 1.5
    assert s["lost_by_edge"] == {"adc_frames____detector_frames": 0.0, "xend": 2.0}
    np.testing.assert_array_equal(s["q"], [1.0, np.inf, 2.5])
    assert np.isnan(s["velocity_error_mps"]["rmse"]) and s["detection_rate"].size == 0 and s["failures"].size == 0
    assert [w["node"] for w in s["swaps"]] == ["attacker", "gate"] and list(s["names"]) == ["a", "b"]
    assert s["seed"] == 2 ** 62 + 1 and s["alarm"] and s["matrix"].tolist() == [[1, 2], [3, 4]]
    raw = loaded(out)["summary"]
    assert raw["q"][0, 0].shape == (3, 1) and raw["swaps"][0, 0].shape == (2, 1)   # lists as columns
    assert raw["seed"][0, 0].dtype == np.int64 and raw["cycles"][0, 0].dtype == np.float64


def test_a_run_summary_exported_and_written_by_run_mat_are_the_same(tmp_path):
    per = {"cycle_index": list(range(8)), "attack_active": [False] * 3 + [True] * 5,
           "reason": ["no_verdict"] * 6 + ["attack"] * 2}
    summary = summarised(per, 8, 0.5)                      # a run_summary block's figures with the runtime's keys
    jsonout.write(tmp_path / "s.json", summary)
    assert carav(["export", str(tmp_path / "s.json"), "--mat", str(tmp_path / "a.mat")]) == Exit.OK
    matout.write(tmp_path / "b.mat", {"summary": jsonout.plain(summary)})     # what carav run --mat writes
    a, b = (sio.loadmat(str(tmp_path / f), simplify_cells=True)["summary"] for f in ("a.mat", "b.mat"))
    assert repr(a) == repr(b) and a["per_node"]["summary"]["block"] == "run_summary"
    assert a["refused"]["by_reason"] == {"no_verdict": 6.0} and a["detection_rate"] == 1.0


def corrupt_data(tmp_path):
    record(tmp_path / "rec")
    data = tmp_path / "rec.sigmf-data"
    data.write_bytes(b"\x01" + data.read_bytes()[1:])


@pytest.mark.parametrize("setup, argv, code, text", [
    (lambda d: None, ["nowhere"], Exit.USAGE, "nowhere: no such file, folder or recording"),
    (corrupt_data, ["rec"], Exit.INVALID, "rec.sigmf-data: "),
    (lambda d: (record(d / "rec"), (d / "rec.activation").chmod(0o644)), ["rec"], Exit.INVALID,
     "rec.activation: activation log has mode 0644"),
    (lambda d: (d / "s.json").write_text('{"graph": '), ["s.json"], Exit.INVALID,
     "s.json: neither a JSON summary nor a SigMF recording"),
    (lambda d: (d / "s.json").write_text("[1, 2]"), ["s.json"], Exit.INVALID, "s.json: a summary is a JSON object"),
    (lambda d: (d / "s.json").write_text("{}"), ["s.json", "--cycles", "1:2"], Exit.USAGE,
     "--cycles: only for a recording"),
    (lambda d: record(d / "rec"), ["rec", "--cycles", "5"], Exit.USAGE, "argument --cycles: expected A:B"),
    (lambda d: record(d / "rec"), ["rec", "--cycles", "5:2"], Exit.USAGE, "B must be greater than A"),
])
def test_a_bad_input_is_refused_in_one_line_with_its_exit_code(tmp_path, capsys, setup, argv, code, text):
    setup(tmp_path)
    got = carav(["export", str(tmp_path / argv[0]), *argv[1:], "--mat", str(tmp_path / "out.mat"), "--quiet"])
    err = capsys.readouterr().err
    assert got == code and text in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not (tmp_path / "out.mat").exists()
