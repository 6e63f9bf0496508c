"""`carav reproduce`: the markdown and its figures, on a tiny run."""
from __future__ import annotations

import argparse

import pytest


@pytest.mark.slow
def test_reproduce_writes_markdown_with_claims_and_figures(tmp_path):
    from carav_stream.studies import reproduce
    parser = argparse.ArgumentParser()
    reproduce.configure(parser)
    args = parser.parse_args(["--trials", "20", "--skip-beyond", "--quiet", "--out", str(tmp_path / "R.md"),
                              "--figures", str(tmp_path / "figures")])
    assert reproduce.run(args) == 0
    text = (tmp_path / "R.md").read_text()
    assert "## The paper's claims beside ours" in text and "| No miss for RARMS >= 3" in text
    assert sorted(p.name for p in (tmp_path / "figures").glob("repro_*.png")) == [
        "repro_fig3_table1_random.png", "repro_fig4_table1_smart.png", "repro_fig5_awr1642_smart.png",
        "repro_fig5b_awr1642_random.png"]
