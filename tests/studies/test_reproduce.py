"""`carav reproduce`: the markdown and its figures, on a tiny run."""
from __future__ import annotations

import pytest

from carav_stream.cli import main as carav

QUICK = ["--trials", "20", "--skip-beyond", "--quiet"]
FIGURES = ["repro_fig3_table1_random.png", "repro_fig4_table1_smart.png", "repro_fig5_awr1642_smart.png",
           "repro_fig5b_awr1642_random.png"]


@pytest.mark.slow
def test_reproduce_writes_outside_the_tracked_tree_by_default_and_is_deterministic(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "docs").mkdir()
    assert carav(["reproduce", *QUICK]) == 0
    text = (tmp_path / "reproduction" / "REPRODUCTION.md").read_text()
    assert "## The paper's claims beside ours" in text and "| No miss for RARMS >= 3" in text
    assert "![Fig. 3 reproduced](figures/repro_fig3_table1_random.png)" in text
    assert sorted(p.name for p in (tmp_path / "reproduction" / "figures").glob("repro_*.png")) == FIGURES
    assert list((tmp_path / "docs").iterdir()) == []                       # nothing in docs/ without --in-place
    assert carav(["reproduce", *QUICK, "--out", str(tmp_path / "again.md"), "--figures", str(tmp_path / "f")]) == 0
    again = (tmp_path / "again.md").read_text()
    assert "![Fig. 3 reproduced](f/repro_fig3_table1_random.png)" in again
    assert again.replace("](f/", "](figures/") == text                     # same seed, same document


def test_in_place_needs_the_repository_root_and_takes_no_other_output(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert carav(["reproduce", "--in-place", *QUICK]) == 2
    assert "no docs/ folder here" in capsys.readouterr().err
    (tmp_path / "docs").mkdir()
    assert carav(["reproduce", "--in-place", "--out", "x.md", *QUICK]) == 2
    assert "give it alone" in capsys.readouterr().err
