"""Command outputs quoted in the documents: found, regenerated, and a stale one caught (doc_outputs)."""
from __future__ import annotations

import pytest

from carav_stream.console.errors import CommandError
from carav_stream.experiments import doc_outputs

CMD = "carav design --preset table1 --rarms 3 --trials 20 --seed 3"


def _repo(tmp_path, body: str, fenced: bool = True):
    (tmp_path / "docs").mkdir()
    fence = "```\n" if fenced else ""
    doc = tmp_path / "docs" / "X.md"
    doc.write_text(f"# X\n\nbefore\n\n<!-- output of: {CMD} -->\n{fence}{body}{fence}<!-- end of output -->\n\nafter\n")
    return doc


@pytest.mark.slow
@pytest.mark.parametrize("fenced", [True, False])
def test_a_quote_is_regenerated_in_place_and_then_checks_clean(tmp_path, fenced):
    doc = _repo(tmp_path, "stale text\n", fenced)
    [q] = doc_outputs.quotes(doc)
    assert q.command == CMD and q.body == "stale text\n"
    assert [str(s[0].command) for s in doc_outputs.stale(tmp_path)] == [CMD]
    assert doc_outputs.regenerate(tmp_path) == [doc]
    text = doc.read_text()
    assert text.startswith("# X\n\nbefore\n\n") and text.endswith("<!-- end of output -->\n\nafter\n")
    assert "eta = 1.1181" in text and "stale text" not in text
    assert doc_outputs.stale(tmp_path) == []
    assert doc_outputs.regenerate(tmp_path) == []               # nothing to change the second time


@pytest.mark.slow
def test_a_hand_edit_of_a_quoted_number_is_caught(tmp_path):
    doc = _repo(tmp_path, "")
    doc_outputs.regenerate(tmp_path)
    doc.write_text(doc.read_text().replace("eta = 1.1181", "eta = 1.1182"))
    [(q, now)] = doc_outputs.stale(tmp_path)
    assert "eta = 1.1181" in now and "eta = 1.1182" in q.body


@pytest.mark.slow
def test_a_quoted_command_that_fails_names_the_document_and_the_command(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "Y.md").write_text("<!-- output of: carav design --pf 7 -->\n```\n```\n"
                                            "<!-- end of output -->\n")
    with pytest.raises(CommandError, match=r"docs/Y.md: `carav design --pf 7` failed \(exit 2\): .*--pf"):
        doc_outputs.stale(tmp_path)


@pytest.mark.slow
def test_a_check_writes_no_file_a_quoted_command_would_write(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "Z.md").write_text(
        f"<!-- output of: {CMD} --json out/d.json -->\n```\n```\n<!-- end of output -->\n")
    (tmp_path / "out").mkdir()
    doc_outputs.stale(tmp_path)
    assert not (tmp_path / "out" / "d.json").exists()
    doc_outputs.regenerate(tmp_path)
    assert (tmp_path / "out" / "d.json").exists()
