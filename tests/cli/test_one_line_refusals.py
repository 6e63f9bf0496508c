"""Inputs and faults at the edges of the commands: each refused or reported in one line naming the culprit, with
its exit code, never a traceback."""
import subprocess
import sys
from pathlib import Path

import pytest

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from tests.cli.test_errors import error_of

ROOT = Path(__file__).resolve().parents[2]
DEMO = str(ROOT / "graphs" / "demo.toml")


@pytest.mark.parametrize("setting, text", [
    ("seed=99999999999999999999", "demo.toml: seed: must be <= 9223372036854775807 (64 signed bits)"),
    ("seed=-2", "demo.toml: seed: must be >= -1, got -2"),
    ("attacker.start_cycle=99999999999999999999",
     "demo.toml: blocks.attacker.start_cycle: must be <= 9223372036854775807 (64 signed bits)"),
])
def test_validate_refuses_an_integer_parameter_beyond_what_a_run_can_hold(capsys, setting, text):
    assert carav(["validate", DEMO, "--set", setting]) == Exit.INVALID
    err = error_of(capsys)
    assert text in err, err
    assert len(err.strip().splitlines()) == 1, err


def test_a_reader_that_closes_the_pipe_early_ends_the_command_quietly():
    proc = subprocess.Popen([sys.executable, "-m", "carav_stream.cli", "blocks"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()             # the reader is gone before the first line: every write meets a closed pipe
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == Exit.INTERRUPTED
    assert err == "", err


@pytest.mark.parametrize("argv, text", [
    (["run", DEMO, "--cycles", "-5"], "argument --cycles: must be >= 0, got -5"),
    (["run", "no_such_graph.toml"], "argument graph: no_such_graph.toml: no such file"),
    (["record", str(ROOT / "graphs"), "--out", "x"], "is a folder, not a graph file"),
])
def test_a_bad_command_line_is_a_usage_error_naming_the_option(capsys, argv, text):
    assert carav(argv) == Exit.USAGE
    err = capsys.readouterr().err
    assert text in err and err.count("\n") == 1 and "Traceback" not in err, err
