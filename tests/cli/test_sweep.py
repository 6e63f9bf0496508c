"""`carav sweep` command module: options, JSON layout, plot, errors."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

import carav_stream.radar
from carav_stream.cli import main as carav
from carav_stream.cli import sweep as sweep_cli
from carav_stream.detect.stats import cfar_eta_closed_form


def _run(argv):
    parser = argparse.ArgumentParser()
    sweep_cli.configure(parser)
    return sweep_cli.run(parser.parse_args(argv))


@pytest.mark.slow
def test_sweep_cli_writes_json_curves_thresholds_and_plot(tmp_path, capsys):
    out, png = tmp_path / "s.json", tmp_path / "s.png"
    code = _run(["--model", "paper", "--preset", "table1", "--nr", "16", "--ns", "64", "--attack", "random,smart",
                 "--rarms", "0.5,4", "--trials", "200", "--eta", "0.8:3:0.1", "--seed", "2", "--json", str(out),
                 "--plot", str(png), "--quiet"])
    assert code == 0
    res = json.loads(out.read_text())
    assert [(c["attack"], c["rarms"]) for c in res["curves"]] == [("random", 0.5), ("random", 4.0),
                                                                   ("smart", 0.5), ("smart", 4.0)]
    c = res["curves"][1]
    assert len(c["pf_ci"]) == len(c["eta"]) == 23 and len(c["pm_ci"][0]) == 2
    assert set(res["thresholds"]) == {"minimax", "cfar", "min_sum"}
    assert png.stat().st_size > 10_000
    printed = capsys.readouterr().out
    assert "minimax" in printed and f"plot: {png} (PF and PM against eta on a log axis, the ROC beneath)" in printed


@pytest.mark.slow
def test_sweep_cli_is_reproducible_with_seed(tmp_path):
    args = ["--model", "paper", "--nr", "8", "--ns", "16", "--rarms", "1", "--trials", "50", "--eta", "1:2:0.5",
            "--seed", "4", "--quiet", "--method", "samples"]
    _run(args + ["--json", str(tmp_path / "a.json")])
    _run(args + ["--json", str(tmp_path / "b.json")])
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("a.json", "b.json"))
    assert a["curves"] == b["curves"]


def test_sweep_cli_rejects_unknown_attack_for_paper_model(capsys):
    assert carav(["sweep", "--model", "paper", "--attack", "ghost"]) == 3
    err = capsys.readouterr().err
    assert err == ("carav sweep: attack: 'ghost' is not available in the paper model; expected one of none, random, "
                   "smart (use --model radar for the others)\n")


def test_sweep_cli_rejects_bad_options_in_one_line_naming_the_option_before_any_work(capsys, tmp_path):
    assert carav(["sweep", "--model", "paper", "--eta", "2:1:0.1"]) == 2
    assert capsys.readouterr().err.startswith("carav sweep: --eta: need 0 < START <= STOP")
    for argv, text in [(["--rarms", "1,-2"], "argument --rarms: '-2' in '1,-2': must be >= 0, got -2"),
                       (["--rarms", "1,x"], "argument --rarms: 'x' in '1,x': expected a number, got 'x'"),
                       (["--trials", "0"], "argument --trials: must be >= 1, got 0"),
                       (["--json", str(tmp_path / "no" / "x.json")], "folder"),
                       (["--plot", str(tmp_path)], "is a folder, not a file")]:
        assert carav(["sweep", "--model", "paper", *argv]) == 2
        err = capsys.readouterr().err
        assert text in err and err.count("\n") == 1 and "Traceback" not in err, err


def test_sweep_cli_radar_chain_accepts_any_attacker(tmp_path):
    out = tmp_path / "g.json"
    code = _run(["--preset", "table1", "--nr", "8", "--ns", "64", "--attack", "ghost", "--rarms", "3",
                 "--trials", "20", "--eta", "1:2:0.5", "--seed", "1", "--quiet", "--json", str(out)])
    assert code == 0
    assert json.loads(out.read_text())["curves"][0]["attack"] == "ghost"


@pytest.mark.slow
def test_sweep_at_waveform_fidelity_sees_a_near_echo_leak_into_silent_slots_that_the_beat_fidelity_cannot(tmp_path):
    """The table1 car at 5 m, sampled from the ramp's reset: the IF filter smears the end of each active chirp's
    echo into the first samples of the next slot; at waveform fidelity the silent slots after an active one carry
    it and C(1.5) fires on benign cycles; the beat fidelity, which renders no such edge, raises none. As the preset
    samples (16 samples in), neither does."""
    preset = (Path(carav_stream.radar.__file__).parent / "presets" / "table1.toml").read_text()
    near = preset.replace('name = "table1"', 'name = "table1_5m"').replace("range_m = 43.0", "range_m = 5.0")
    settled = tmp_path / "settled.toml"
    settled.write_text(near)
    scene = tmp_path / "near.toml"
    scene.write_text(near.replace("t_adc_start_s = 1.0666666666666667e-07", "t_adc_start_s = 0.0")
                     .replace("n_samples = 1080", "n_samples = 1100"))
    assert _run(["--scene", str(settled), "--attack", "random", "--rarms", "3", "--trials", "40", "--eta",
                 "1.5:2:0.5", "--seed", "3", "--quiet", "--fidelity", "waveform", "--json",
                 str(tmp_path / "settled.json")]) == 0
    assert json.loads((tmp_path / "settled.json").read_text())["curves"][0]["pf"][0] == 0
    pf = {}
    for fidelity in ("beat", "waveform"):
        out = tmp_path / f"{fidelity}.json"
        assert _run(["--scene", str(scene), "--attack", "random", "--rarms", "3", "--trials", "40",
                     "--eta", "1.5:2:0.5", "--seed", "3", "--quiet", "--fidelity", fidelity,
                     "--json", str(out)]) == 0
        res = json.loads(out.read_text())
        assert res["scene"]["fidelity"] == fidelity
        pf[fidelity] = res["curves"][0]["pf"][0]
    assert pf["beat"] < 0.05 and pf["waveform"] >= 0.9, pf


def test_sweep_table_header_states_the_echo_snr_and_the_papers_reading(capsys):
    """table1's radar-equation echo is +2.2 dB per sample (MATLAB's hardware); the paper's runs set 0 dB."""
    base = ["--preset", "table1", "--rarms", "1", "--trials", "20", "--eta", "1:2:0.5", "--seed", "1", "--quiet"]
    assert _run(base) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "echo SNR +2.2 dB per sample (the paper's runs set 0 dB: --snr-db 0)" in header
    assert _run(base + ["--snr-db", "0"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "echo SNR +0.0 dB per sample," in header and "--snr-db 0" not in header


def test_sweep_scores_opt_in_detectors_on_the_same_cycles_with_a_detector_key_per_curve(tmp_path, capsys):
    """A ghost at RARMS 0.2 (7 dB per silent chirp in its bin): C(1.5) misses it, the integrated test at its
    PF = 1e-6 design (eta = 1) catches every cycle; the single-chirp test lies between."""
    out = tmp_path / "s.json"
    assert _run(["--attack", "ghost", "--attack-param", "ghost.range_m=25", "--rarms", "0.2", "--trials", "150",
                 "--detector", "carav,integrated", "--eta", "0.5:3:0.01", "--seed", "3", "--quiet",
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "detector integrated (threshold in units of its PF = 1e-6 value)" in text
    res = json.loads(out.read_text())
    assert res["detectors"] == ["carav", "integrated"] and set(res["thresholds_by_detector"]) == {"carav",
                                                                                                   "integrated"}
    by = {c["detector"]: c for c in res["curves"]}
    i15, i1 = res["eta"].index(1.5), res["eta"].index(1.0)
    assert by["carav"]["pm"][i15] == 1.0 and by["integrated"]["pm"][i1] == 0.0
    assert by["integrated"]["pf"][i1] == 0.0 and "closed_form" not in by["integrated"]


def test_sweep_scores_the_spill_test_against_a_late_reactive_repeater(tmp_path):
    """A repeater whose delay (30 m + 5 us) passes table1's longest visible round trip spills into the spill test's
    window: caught in every cycle at RARMS 1, where C(1.5) misses every cycle; at 100 ns (blind zone) never."""
    out = tmp_path / "s.json"
    for latency_s, pm_spill in (("5e-6", 0.0), ("1e-7", 1.0)):
        assert _run(["--attack", "reactive", "--attack-param", f"reactive.latency_s={latency_s}", "--rarms", "1",
                     "--trials", "40", "--detector", "carav,spill", "--eta", "0.5:3:0.01", "--seed", "4", "--quiet",
                     "--json", str(out)]) == 0
        by = {c["detector"]: c for c in json.loads(out.read_text())["curves"]}
        eta = json.loads(out.read_text())["eta"]
        assert by["spill"]["pm"][eta.index(1.0)] == pm_spill and by["spill"]["pf"][eta.index(1.0)] == 0.0
        assert by["carav"]["pm"][eta.index(1.5)] == 1.0


def test_sweep_refuses_an_opt_in_detector_it_cannot_serve(capsys):
    assert carav(["sweep", "--model", "paper", "--detector", "spectral", "--trials", "10", "--quiet"]) == 2
    assert "--detector spectral: " in capsys.readouterr().err
    assert carav(["sweep", "--detector", "spectral", "--method", "energy", "--trials", "10", "--quiet"]) == 2
    assert carav(["sweep", "--detector", "nope", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--detector: unknown 'nope'; expected carav, spectral, integrated, coherent, spill" in err


def test_sweep_cli_models_receivers_on_the_paper_model_and_refuses_other_counts_on_the_radar_chain(tmp_path, capsys):
    out = tmp_path / "rx.json"
    code = _run(["--model", "paper", "--nr", "8", "--ns", "16", "--iq", "--receivers", "4", "--rarms", "1",
                 "--trials", "40", "--eta", "1:2:0.5", "--seed", "3", "--quiet", "--json", str(out)])
    assert code == 0
    res = json.loads(out.read_text())
    assert res["scene"]["n_rx"] == 4 and res["pf_method"] == "samples"
    # 4 x 32 real components per chirp: the one-receiver threshold of 128
    assert res["closed_form"]["cfar_eta_pf_1e-6"] == cfar_eta_closed_form(1e-6, n_chirps=8, dof=128)
    assert len(res["curves"][0]["closed_form"]["pm"]) == 3
    assert "(paper, 4 receivers)" in capsys.readouterr().out
    assert carav(["sweep", "--preset", "table1", "--receivers", "2", "--quiet"]) == 3
    err = capsys.readouterr().err
    assert err == ("carav sweep: receivers: scene table1 has 1 receiver and the radar model renders the scene's "
                   "own, not 2 (the paper model takes any count)\n")
    assert carav(["sweep", "--model", "paper", "--receivers", "0"]) == 2
    assert "argument --receivers: must be >= 1, got 0" in capsys.readouterr().err
