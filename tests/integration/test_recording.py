"""carav record / replay and the DCA1000 player with real processes: a recording judged again gives the live run's
verdicts, Q and estimates bit for bit; a TI capture of the same samples gives the same; a truncated one fails after
its whole cycles, naming the file."""
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

from carav_stream.capture.sigmf_io import open_recording
from tests.capture.ti_dca1000 import capture_bytes
from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration
CYCLES = 48
LIVE = ["--cycles", str(CYCLES), "--set", "attacker.start_cycle=20", "--set", "attacker.rarms=1.2", "--no-progress"]
SAME = ("cycles_judged", "alarms", "alarm_reasons", "raised_by", "attacked_cycles", "detected", "missed",
        "false_alarms", "range_error_m", "range_error_attacked_missed_m", "velocity_error_mps")


def annotations(folder: Path) -> list[dict]:
    return json.loads((folder / "recording.sigmf-meta").read_text())["annotations"]


@pytest.fixture
def recorded(carav):
    """The demo graph (smart attacker, RARMS 1.2 from cycle 20: some attacked cycles pass, some alarm) recorded."""
    out = carav.workdir / "live"
    done = carav.cli("record", str(ROOT / "graphs" / "demo.toml"), "--out", str(out), "--json",
                     str(carav.workdir / "live.json"), "--mat", str(carav.workdir / "live.mat"), *LIVE)
    assert done.returncode == 0, done.stderr
    return out, json.loads((carav.workdir / "live.json").read_text())


def test_a_replay_gives_the_live_verdicts_q_and_estimates_bit_for_bit(carav, recorded):
    live_dir, live = recorded
    ann = annotations(live_dir)
    assert len(ann) == CYCLES and live["recording"]["cycles"] == CYCLES
    gates = [a["carav:gate"] for a in ann]
    assert gates.count("attack") >= 3 and gates.count("clean") >= 20, gates   # both kinds of cycle are judged
    # the replay, itself recorded: every annotation (verdict, Q, estimates, cycle fields) and every sample equal
    again = carav.workdir / "again"
    done = carav.cli("record", str(ROOT / "graphs" / "replay.toml"), "--out", str(again), "--no-progress",
                     "--set", f"source.path={live_dir}")
    assert done.returncode == 0, done.stderr
    assert annotations(again) == ann
    assert (again / "recording.sigmf-data").read_bytes() == (live_dir / "recording.sigmf-data").read_bytes()
    assert (again / "recording.activation").read_text() == (live_dir / "recording.activation").read_text()
    # carav replay: the run summary of the live run
    done = carav.cli("replay", str(live_dir), "--json", str(carav.workdir / "replay.json"), "--no-progress")
    assert done.returncode == 0, done.stderr
    replay = json.loads((carav.workdir / "replay.json").read_text())
    assert {k: replay[k] for k in SAME} == {k: live[k] for k in SAME}
    assert replay["detected"] > 0 and replay["range_error_m"]["n"] > 0


def test_a_run_and_its_recording_exported_to_matlab_say_what_its_json_and_open_recording_say(carav, recorded):
    live_dir, live = recorded
    done = carav.cli("export", str(carav.workdir / "live.json"), "--mat", str(carav.workdir / "json.mat"), "--quiet")
    assert done.returncode == 0, done.stderr
    by_run, by_export = (loadmat(str(carav.workdir / f), simplify_cells=True)["summary"]
                         for f in ("live.mat", "json.mat"))
    assert repr(by_run) == repr(by_export) and by_run["cycles"] == CYCLES == live["cycles"]
    done = carav.cli("export", str(live_dir), "--mat", str(carav.workdir / "rec.mat"), "--quiet")
    assert done.returncode == 0, done.stderr
    rec, m = open_recording(live_dir), loadmat(str(carav.workdir / "rec.mat"))
    assert m["adc"].shape == rec.samples.shape[:3] == (CYCLES, 64, rec.samples.shape[2])
    samples = np.asarray(rec.samples)
    np.testing.assert_array_equal(m["adc"], samples[..., 0] + 1j * samples[..., 1] if samples.ndim == 4 else samples)
    np.testing.assert_array_equal(m["activation"], rec.rho)
    alarms = [a["carav:alarm"] for a in annotations(live_dir)]
    np.testing.assert_array_equal(loadmat(str(carav.workdir / "rec.mat"), simplify_cells=True)["per_cycle"]["alarm"],
                                  alarms)


def test_recording_and_replay_refuse_bad_folders_in_one_line(carav, recorded):
    live_dir, _ = recorded
    done = carav.cli("record", str(ROOT / "graphs" / "demo.toml"), "--out", str(live_dir), "--cycles", "8")
    assert done.returncode == 2 and "holds a recording already" in done.stderr and len(done.stderr.splitlines()) == 1
    (live_dir / "recording.activation").unlink()
    done = carav.cli("replay", str(live_dir))
    assert done.returncode == 3 and "recording.activation: activation log not found" in done.stderr
    assert "Traceback" not in done.stderr


def dca_graph(carav, capture: Path, log: Path) -> Path:
    return carav.graph(f"""
scene = "table1"
batch = 32
connections = ["source.frames -> detector.frames", "source.rho -> detector.rho", "source.frames -> gate.frames",
               "detector.verdict -> gate.verdict", "gate.clean -> ranging.frames",
               "ranging.estimates -> summary.estimates", "gate.alarms -> summary.alarms"]
[blocks]
source = {{ type = "dca1000_source", path = "{capture}", activation = "{log}", n_rx = 2, rx = 1 }}
detector = {{ type = "rms_detector" }}
gate = {{ type = "gate" }}
ranging = {{ type = "range_estimator" }}
summary = {{ type = "run_summary" }}
""", "dca.toml")


def test_a_ti_capture_of_the_recorded_samples_is_judged_alike_and_a_truncated_one_fails_after_its_cycles(
        carav, recorded):
    live_dir, live = recorded
    rec = open_recording(live_dir)
    codes = np.asarray(rec.samples)                                   # (cycles, 64, 1100) 12-bit codes
    other = np.random.default_rng(0).integers(-2048, 2048, size=codes.shape).astype(np.int16)
    chirps = np.stack([other, codes], axis=2).reshape(-1, 2, codes.shape[2])   # receiver 1 is the recorded one
    capture = carav.workdir / "adc_data.bin"
    capture.write_bytes(capture_bytes(chirps, complex_data=False, adc_bits=12))
    log = live_dir / "recording.activation"
    done = carav.cli("run", str(dca_graph(carav, capture, log)), "--json", str(carav.workdir / "dca.json"),
                     "--no-progress")
    assert done.returncode == 0, done.stderr
    dca = json.loads((carav.workdir / "dca.json").read_text())
    assert dca["alarms"] == live["alarms"] and dca["alarm_reasons"] == live["alarm_reasons"]
    assert dca["range_error_m"] == live["range_error_m"] and dca["velocity_error_mps"] == live["velocity_error_mps"]
    # truncated inside cycle 40: cycles 0..39 are judged, then the node fails naming the file
    cut = carav.workdir / "cut.bin"
    cut.write_bytes(capture.read_bytes()[:capture.stat().st_size * 40 // CYCLES + 1000])
    done = carav.cli("run", str(dca_graph(carav, cut, log)), "--json", str(carav.workdir / "cut.json"),
                     "--no-progress")
    assert done.returncode == 1, done.stderr
    assert "cut.bin is truncated: 1000 bytes after its 40 whole cycles" in done.stderr + done.stdout
    assert "Traceback" not in done.stderr + done.stdout          # a data error, stated in one line
    cut_summary = json.loads((carav.workdir / "cut.json").read_text())
    assert cut_summary["cycles_judged"] == 40 and cut_summary["lost"] == 0
