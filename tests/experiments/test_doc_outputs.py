"""Command outputs quoted in the documents: found, regenerated, and a stale one caught (doc_outputs)."""
from __future__ import annotations

import pytest

from carav_stream.experiments import doc_outputs
from carav_stream.experiments.errors import ExperimentError
from carav_stream.firmware.design import rms_threshold, scene_law
from carav_stream.radar.scene_loader import load_scene

# a deterministic command that prints a designed number and takes --json; its Monte Carlo left out (a second)
CMD = "carav design --preset awr1642 --rarms 3 --trials 20 --benign-trials 0 --ghost-trials 0 --seed 3"
ETA = f"eta = {rms_threshold(scene_law(load_scene('awr1642')), 1e-6):.4f}"      # as `carav design` prints it


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
    assert ETA in text and "stale text" not in text
    assert doc_outputs.stale(tmp_path) == []
    assert doc_outputs.regenerate(tmp_path) == []               # nothing to change the second time


@pytest.mark.slow
def test_a_hand_edit_of_a_quoted_number_is_caught(tmp_path):
    doc = _repo(tmp_path, "")
    doc_outputs.regenerate(tmp_path)
    edited = ETA[:-1] + str((int(ETA[-1]) + 1) % 10)
    doc.write_text(doc.read_text().replace(ETA, edited))
    [(q, now)] = doc_outputs.stale(tmp_path)
    assert ETA in now and edited in q.body and ETA not in q.body


@pytest.mark.slow
def test_a_quoted_command_that_fails_names_the_document_and_the_command(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "Y.md").write_text("<!-- output of: carav design --pf 7 -->\n```\n```\n"
                                            "<!-- end of output -->\n")
    with pytest.raises(ExperimentError, match=r"docs/Y.md: `carav design --pf 7` failed \(exit 2\): .*--pf"):
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


RUN = """graph graphs/demo.toml  run demo-47f84a
  300 cycles in 921 ms of wall time: 326 cycles/s
  real-time factor 0.153 (radar time / wall time): radar time 141 ms = 300 cycles x the scene's cycle duration 469 us
  range error, first target: RMSE 2.43 mm, mean 0.201 mm, absolute maximum 7.13 mm over 150 cycles
"""


def test_a_quoted_run_is_compared_without_the_machines_own_figures():
    from carav_stream.experiments.doc_outputs import same

    other_machine = (RUN.replace("demo-47f84a", "demo-0b1c2d").replace("921 ms", "1.31 s").replace("326 cyc", "229 cyc")
                     .replace("factor 0.153", "factor 0.108"))
    assert same(RUN, other_machine)
    assert not same(RUN, RUN.replace("RMSE 2.43 mm", "RMSE 2.62 mm"))          # a figure of the seed's: checked
    assert not same(RUN, RUN.replace("300 cycles in", "299 cycles in"))        # the cycles too
    assert not same(RUN, RUN.replace("radar time 141 ms", "radar time 142 ms"))
