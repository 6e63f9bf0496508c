"""`carav experiment cfar`: the map-level false-alarm rate and the Swerling 1 Pd against the textbook, parsed from
what the command prints (a second, independent route to the claims of tests/detect/test_cfar.py)."""
from __future__ import annotations

import pytest

from carav_stream.cli import main as carav
from carav_stream.detect.stats import clopper_pearson


@pytest.mark.slow
def test_cfar_experiment_meets_its_design_and_the_textbook_curve(capsys):
    n = 300
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
