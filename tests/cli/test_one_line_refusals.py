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


@pytest.mark.parametrize("setting, text", [
    ("run.queue_frames=0", "demo.toml: run.queue_frames: must be >= 1, got 0"),
    ("run.queue_frames=100000", "demo.toml: run.queue_frames: must be <= 1024, got 100000"),
    ("run.heartbeat_timeout_s=0", "demo.toml: run.heartbeat_timeout_s: must be > 0"),
    ("run.ready_timeout_s=1e9", "demo.toml: run.ready_timeout_s: must be < 3600"),
])
def test_validate_bounds_every_run_setting(capsys, setting, text):
    assert carav(["validate", DEMO, "--set", setting]) == Exit.INVALID
    err = error_of(capsys)
    assert text in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("line, text", [
    ("address = -9223372036854775809", "hosts.b.address: must be an IP address or a host name, got "
                                       "-9223372036854775809"),
    ('address = "10.0.0.300"', "hosts.b.address: must be an IP address or a host name, got '10.0.0.300'"),
    ('address = "host name"', "hosts.b.address: must be an IP address or a host name, got 'host name'"),
    ('bind = ["0.0.0.0"]', "hosts.b.bind: must be an IP address or a host name (or * for every interface)"),
])
def test_validate_refuses_a_host_address_no_socket_can_use(tmp_path, capsys, line, text):
    graph = tmp_path / "two.toml"
    graph.write_text(f'include = "{DEMO}"\n[hosts.b]\n{line}\nport_base = 47000\n')
    assert carav(["validate", str(graph)]) == Exit.INVALID
    err = error_of(capsys)
    assert f"two.toml: {text}" in err, err


def test_validate_takes_addresses_names_and_the_bind_wildcard(tmp_path):
    graph = tmp_path / "two.toml"
    graph.write_text(f'include = "{DEMO}"\n[hosts.b]\naddress = "radar-2.lab"\nbind = "*"\nport_base = 47000\n'
                     '[hosts.c]\naddress = "::1"\nport_base = 48000\n')
    assert carav(["validate", str(graph)]) == Exit.OK
