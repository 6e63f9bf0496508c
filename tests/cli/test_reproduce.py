"""`carav reproduce`: the markdown and its figures, on a tiny run."""
from __future__ import annotations

import difflib

import pytest

from carav_stream.cli import main as carav
from carav_stream.experiments import doc_outputs

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


@pytest.mark.slow
def test_a_quoted_command_that_fails_is_refused_in_one_line_naming_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "Y.md").write_text("<!-- output of: carav design --pf 7 -->\n```\n```\n"
                                            "<!-- end of output -->\n")
    assert carav(["reproduce", "--in-place", *QUICK]) == 2
    err = capsys.readouterr().err
    assert err.startswith("carav reproduce: docs/Y.md: `carav design --pf 7` failed (exit 2): ")
    assert err.count("\n") == 1


ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_committed_reproduction_document_is_what_the_code_produces(monkeypatch, capsys):
    """docs/REPRODUCTION.md is an output of `carav reproduce --in-place`: same defaults, same seed, same text. (The
    command outputs quoted in the documents, which `carav reproduce --check` checks too, are checked one by one
    below, so that test workers can share them out.)"""
    monkeypatch.chdir(ROOT)
    code = carav(["reproduce", "--check", "--out", "docs/REPRODUCTION.md", "--quiet"])
    err = capsys.readouterr().err
    assert code == 0, err[-3000:]


QUOTES = doc_outputs.all_quotes(ROOT)


def test_the_documents_quote_command_outputs():
    assert len(QUOTES) >= 10 and {q.path.name for q in QUOTES} >= {"DETECTION.md", "ESTIMATION.md", "SCENES.md"}


@pytest.mark.slow
@pytest.mark.parametrize("quote", QUOTES, ids=[f"{q.path.name}:{' '.join(q.command.split()[1:4])}:{i}"
                                               for i, q in enumerate(QUOTES)])
def test_a_quoted_command_output_is_what_the_code_prints(quote, tmp_path):
    """Each output a document quotes is what its command prints now (`carav reproduce --in-place` regenerates them);
    the files the command would write go to a scratch folder."""
    now = doc_outputs.output(quote, ROOT, tmp_path)
    diff = "\n".join(difflib.unified_diff(quote.body.splitlines(), now.splitlines(), "quoted", "now", lineterm="",
                                          n=0))
    assert doc_outputs.same(quote.body, now), \
        f"{quote.path.relative_to(ROOT)}: `{quote.command}` prints otherwise now:\n{diff[:3000]}"


@pytest.mark.slow
def test_check_fails_naming_the_document_when_it_was_edited_by_hand(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    doc = tmp_path / "R.md"
    assert carav(["reproduce", *QUICK, "--out", str(doc)]) == 0
    capsys.readouterr()
    assert carav(["reproduce", *QUICK, "--out", str(doc), "--check"]) == 0
    assert "is what the code produces" in capsys.readouterr().out
    doc.write_text(doc.read_text().replace("| 0.25 |", "| 0.26 |", 1))
    assert carav(["reproduce", *QUICK, "--out", str(doc), "--check"]) == 1
    err = capsys.readouterr().err
    assert f"{doc} differs from what the code produces (2 lines)" in err and "-| 0.26 |" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["R.md", "figures"]     # --check wrote nothing new
