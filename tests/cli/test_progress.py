"""Progress of long commands: a bar on a terminal, a line every few seconds with the time left when redirected,
nothing at all from a command that ends before the first line is due."""
import io
import re

import pytest

from carav_stream.cli import main as carav
from carav_stream.console import progress
from carav_stream.console.errors import Exit
from carav_stream.console.progress import ProgressBar, left_words


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_redirected_progress_prints_a_line_every_interval_with_the_time_left():
    out, clock = io.StringIO(), Clock()
    bar = ProgressBar("interference", stream=out, every_s=10.0, clock=clock)
    for step in range(1, 101):                 # 1 % a second: 100 s in all
        clock.t = float(step)
        bar(step, 100)
    lines = out.getvalue().splitlines()
    assert len(lines) == 10                    # at 10, 20, ..., 100 s (the last one the end)
    assert lines[0] == "interference: 10.0 % (10/100 cycles), 10.0 s, about 90 s left"
    assert lines[3] == "interference: 40.0 % (40/100 cycles), 40.0 s, about 60 s left"
    assert lines[-1] == "interference: 100.0 % (100/100 cycles), 100.0 s"


def test_a_quick_redirected_command_prints_nothing():
    out, clock = io.StringIO(), Clock()
    bar = ProgressBar("sweep", stream=out, clock=clock)
    for step in range(1, 11):
        clock.t = step * 0.1
        bar(step, 10)
    assert out.getvalue() == ""


def test_a_terminal_gets_one_redrawn_line_ending_in_a_newline():
    class Tty(io.StringIO):
        def isatty(self):
            return True
    out, clock = Tty(), Clock()
    bar = ProgressBar("fig 3", stream=out, clock=clock)
    for step in range(1, 5):
        clock.t = step * 1.0
        bar(step, 4)
    text = out.getvalue()
    assert text.count("\r") == 4 and text.endswith("\n") and text.count("\n") == 1
    assert "4/4 cycles" in text and "about 1 s left" in text


def test_the_time_left_reads_in_seconds_minutes_or_hours():
    assert left_words(10.0, 1, 2) == "about 10 s left"
    assert left_words(60.0, 1, 4) == "about 3 min left"
    assert left_words(3600.0, 1, 3) == "about 2.0 h left"
    assert left_words(5.0, 0, 4) == "" and left_words(5.0, 4, 4) == ""


@pytest.mark.slow
def test_a_redirected_long_experiment_prints_progress_lines_on_stderr_only(capsys, monkeypatch):
    monkeypatch.setattr(progress, "EVERY_S", 0.0)               # a line at every step instead of every 10 s
    assert carav(["experiment", "fidelities", "--units", "detector", "--seed", "5"]) == Exit.OK
    said = capsys.readouterr()
    lines = said.err.splitlines()
    assert len(lines) == 24, said.err                            # one per case: 2 presets x 2 echoes x 6 ranges
    assert all(re.fullmatch(r"fidelities: [\d.]+ % \(\d+/24 cases\), [\d.]+ s(, about \d+ (s|min) left)?", line)
               for line in lines), said.err
    assert lines[0].startswith("fidelities: 4.2 % (1/24 cases)") and lines[-1].startswith("fidelities: 100.0 % (24/")
    assert "%" not in said.out and said.out.count("\n") == 26    # the table alone on stdout: 2 heading lines, 24 rows


def test_every_long_experiment_and_design_can_be_quietened():
    from carav_stream.cli import EXPERIMENTS, build_parser
    for name in ["design", *(f"experiment {e}" for e in EXPERIMENTS)]:
        argv = [*name.split(), "--quiet"]
        assert build_parser(argv).parse_args(argv).quiet is True, name


def test_the_end_is_written_once_however_often_it_is_told():
    out, clock = io.StringIO(), Clock()
    bar = ProgressBar("run", stream=out, every_s=10.0, clock=clock)
    for t, done in ((11.0, 50), (12.0, 100), (12.5, 100), (20.0, 100)):
        clock.t = t
        bar(done, 100)
    assert out.getvalue().splitlines() == ["run: 50.0 % (50/100 cycles), 11.0 s, about 11 s left",
                                           "run: 100.0 % (100/100 cycles), 12.0 s"]
