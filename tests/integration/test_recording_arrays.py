"""carav record / replay / export of a receiver array with real processes: graphs/awr1642_mimo.toml (2 TX x 4 RX, a
secondary antenna at 30 degrees from cycle 32) recorded, then judged again: the live run's verdicts, Q, attacker's
azimuths and estimates (with the targets' azimuths) bit for bit, and the samples exported with their receiver axis."""
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

from carav_stream.capture.sigmf_io import open_recording
from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration
CYCLES = 48
SAME = ("cycles_judged", "alarms", "alarm_reasons", "raised_by", "attacked_cycles", "detected", "missed",
        "false_alarms", "range_error_m", "velocity_error_mps", "azimuth_error_deg", "attacker_direction",
        "target_list")


def annotations(folder: Path) -> list[dict]:
    return json.loads((folder / "recording.sigmf-meta").read_text())["annotations"]


def test_an_array_recording_replays_the_live_verdicts_attack_direction_and_estimates_and_exports_its_receivers(carav):
    live_dir = carav.workdir / "live"
    done = carav.cli("record", str(ROOT / "graphs" / "awr1642_mimo.toml"), "--out", str(live_dir), "--cycles",
                     str(CYCLES), "--json", str(carav.workdir / "live.json"), "--no-progress")
    assert done.returncode == 0, done.stderr
    live = json.loads((carav.workdir / "live.json").read_text())
    rec = open_recording(live_dir)
    assert rec.n_rx == 4 and rec.samples.shape == (CYCLES, 4, 128, 256)
    assert rec.meta["global"]["core:num_channels"] == 4 and rec.meta["global"]["carav:tx_positions_wl"] == [0.0, 2.0]
    ann = annotations(live_dir)
    attacked = [a for a in ann if a["carav:attack_active"]]
    assert len(attacked) == CYCLES - 32 and all(a["carav:gate"] == "attack" for a in attacked)
    assert all(abs(a["carav:attack_azimuth_deg"] - 30.0) < 1.0 for a in attacked)      # the attacker's direction
    clean = [a for a in ann if a["carav:gate"] == "clean"]
    assert len(clean) == 32 and all(abs(a["carav:azimuth_deg"][0] - 20.0) < 1.0 for a in clean)   # the car's
    # the replay through graphs/replay.toml, itself recorded: every annotation and every sample equal
    again = carav.workdir / "again"
    done = carav.cli("record", str(ROOT / "graphs" / "replay.toml"), "--out", str(again), "--no-progress",
                     "--set", f"source.path={live_dir}", "--set", 'scene="awr1642_mimo"', "--set", "batch=16")
    assert done.returncode == 0, done.stderr
    assert annotations(again) == ann
    assert (again / "recording.sigmf-data").read_bytes() == (live_dir / "recording.sigmf-data").read_bytes()
    # carav replay: the live run's figures, the attacker's direction and the targets' azimuths among them
    done = carav.cli("replay", str(live_dir), "--json", str(carav.workdir / "replay.json"), "--no-progress")
    assert done.returncode == 0, done.stderr
    replay = json.loads((carav.workdir / "replay.json").read_text())
    assert {k: replay[k] for k in SAME} == {k: live[k] for k in SAME}
    assert replay["attacker_direction"]["attacked_cycles_with_azimuth"] == CYCLES - 32
    assert replay["azimuth_error_deg"]["n"] == 32
    # carav export: the samples with their receiver axis, as open_recording gives them
    done = carav.cli("export", str(live_dir), "--mat", str(carav.workdir / "rec.mat"), "--quiet")
    assert done.returncode == 0, done.stderr
    assert f"adc {CYCLES} x 4 x 128 x 256 int16" in done.stdout
    m = loadmat(str(carav.workdir / "rec.mat"))
    np.testing.assert_array_equal(m["adc"], np.asarray(rec.samples))
    np.testing.assert_array_equal(m["activation"], rec.rho)
