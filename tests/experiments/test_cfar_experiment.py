"""`carav experiment cfar`: the map-level false-alarm rate and the Swerling 1 Pd against the textbook, parsed from
what the command prints (a second, independent route to the claims of tests/detect/test_cfar.py)."""
from __future__ import annotations

import functools

import pytest

from carav_stream.cli import main as carav
from carav_stream.cli.experiment import cfar as cfar_command
from carav_stream.detect.stats import clopper_pearson
from carav_stream.experiments.cfar_experiment import cfar_experiment


@pytest.mark.slow
def test_cfar_experiment_meets_its_design_and_the_textbook_curve(capsys, monkeypatch):
    n = 300
    # the command's parts up to the two targets, which this test judges, with the figures they have in the whole
    # command (the parts share one random stream, in order); the resolution limit and the range migration, which
    # come after, are checked whole where docs/DETECTION.md quotes the command
    monkeypatch.setattr(cfar_command, "cfar_experiment", functools.partial(cfar_experiment, last="two_targets"))
    assert carav(["experiment", "cfar", "--preset", "awr1642", "--trials", str(n), "--seed", "9"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for kind in ("ca", "os"):
        row = next(r.split() for r in lines if r.startswith(kind + " "))
        assert abs(float(row[1]) / float(row[2]) - 1) < 0.2                 # cells above threshold vs design
    pd_rows = [r.split() for r in lines if r.strip().endswith(tuple("0123456789")) and " dB " in r
               and len(r.split()) == 4]
    assert len(pd_rows) == 5
    refined = [r.split() for r in lines if r.split()[:1] in (["table1"], ["awr1642"]) and " dB " in r]
    assert len(refined) == 6
    for row in refined:                          # RMSE over the CRLB, range and velocity: near the bound
        assert 0.7 < float(row[3]) < 1.35 and 0.7 < float(row[4]) < 1.35, row
    weak = {r.split(":")[0].strip(): float(r.split(":")[1]) for r in lines if r.strip().startswith(("ca_", "os_"))}
    assert weak["ca_cfar"] < 0.9 and weak["os_cfar"] >= 0.95
    for snr, _, measured, textbook in pd_rows:
        lo, hi = clopper_pearson(round(float(measured) * n), n, 0.999)
        assert lo - 0.005 <= float(textbook) <= hi + 0.005, (snr, measured, textbook)


def test_the_parts_up_to_the_last_asked_have_the_figures_of_a_longer_run():
    progress = []
    short = cfar_experiment("table1", 10, 1e-4, 3, last="false_alarms", progress=lambda d, n: progress.append((d, n)))
    longer = cfar_experiment("table1", 10, 1e-4, 3, last="detection")
    assert list(short) == ["false_alarms"] and list(longer) == ["false_alarms", "detection"]
    assert short["false_alarms"] == longer["false_alarms"]
    assert progress[-1] == (10, 10)          # the cycles of the parts run, all of them counted
