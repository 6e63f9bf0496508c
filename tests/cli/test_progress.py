"""Progress of long commands: a bar on a terminal, a line every few seconds with the time left when redirected,
nothing at all from a command that ends before the first line is due."""
import io

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
