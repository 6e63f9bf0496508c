"""`carav experiment angles`: the chain's azimuth of one target against the scene's bound, per fidelity, sampling and
azimuth."""
from __future__ import annotations

import json

import numpy as np
import pytest

from carav_stream.cli import main as carav
from carav_stream.estimate.angle_crlb import azimuth_crlb, effective_snr
from carav_stream.experiments.angles import PRESET, angles
from carav_stream.radar.scene_loader import load_scene


def test_the_bound_is_the_scenes_and_the_rows_cover_the_grid_and_the_json_is_what_the_engine_returns(tmp_path,
                                                                                                      capsys):
    ticks = []
    out = angles(20, 3, azimuths=(30.0,), fidelities=("beat",),
                 progress=lambda done, total: ticks.append((done, total)))
    assert [(r["fidelity"], r["iq"], r["azimuth_deg"]) for r in out["rows"]] == [("beat", False, 30.0),
                                                                                ("beat", True, 30.0)]
    assert ticks[-1] == (40, 40)
    for r in out["rows"]:
        scene = load_scene(PRESET, {"targets[0].azimuth_deg": 30.0, "iq": r["iq"]})
        snr_eff = 10 ** (scene.snr_db(0) / 10) * 256 * 32 * (1.0 if r["iq"] else 0.5)
        assert snr_eff == pytest.approx(float(effective_snr(scene.snr_db(0), 256, 32, iq=r["iq"])))
        assert r["bound_deg"] == pytest.approx(float(azimuth_crlb(snr_eff, scene.virtual_positions_wl, 30.0)["deg"]))
        assert r["n"] == 20 and 0.5 < r["ratio"] < 1.6 and r["ratio"] == r["rmse_deg"] / r["bound_deg"]
        assert r["reported_bound_rms_deg"] == pytest.approx(r["bound_deg"], rel=0.1)   # the SNR measured per cycle
    f = tmp_path / "a.json"
    assert carav(["experiment", "angles", "--cycles", "20", "--azimuths", "30", "--seed", "3", "--quiet",
                  "--json", str(f)]) == 0
    got = json.loads(f.read_text())
    beat = [r for r in got["rows"] if r["fidelity"] == "beat"]
    assert beat == out["rows"] and len(got["rows"]) == 4
    text = capsys.readouterr().out
    assert "one target at 20 m" in text and "not measured" in text and text.count("\n") == 2 + 4
    assert np.isfinite([r["rmse_deg"] for r in got["rows"]]).all()
