"""Bad input on the command line: one line naming the option, file or field, the documented exit code, and no
work started (so nothing is lost or left behind). Exit codes: console.errors.Exit."""
import os
from pathlib import Path

import pytest

from bench import main as run_bench
from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit

ROOT = Path(__file__).resolve().parents[2]
DEMO = str(ROOT / "graphs" / "demo.toml")


def error_of(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return err


def test_no_arguments_prints_the_help_with_the_exit_codes(capsys):
    assert carav([]) == Exit.USAGE
    err = error_of(capsys)
    assert "usage: carav" in err and "exit codes: 0 ok, 1 failed, 2 usage, 3 invalid, 130 interrupted" in err


@pytest.mark.parametrize("argv, code, text", [
    (["run", DEMO, "--cycles", "-5"], Exit.USAGE, "argument --cycles: must be >= 0, got -5"),
    (["run", str(ROOT / "graphs")], Exit.USAGE, "graphs: is a folder, not a graph file"),
    (["run", DEMO, "--set", "detector.eta=nan"], Exit.INVALID, "blocks.detector.eta: must be a finite number, got nan"),
    (["run", DEMO, "--set", "batch=0"], Exit.INVALID, "batch: must be >= 1, got 0"),
    (["run", DEMO, "--blocks", "/nonexistent"], Exit.INVALID, "block folder '/nonexistent' does not exist"),
    (["run", DEMO, "--set", "scene=nosuch"], Exit.INVALID, "scene: nosuch: no such scene file or preset"),
    (["validate", DEMO, "--set", "attacker.rarms=-1"], Exit.INVALID, "blocks.attacker.rarms: must be >= 0, got -1"),
    (["run", DEMO, "--json", "/nonexistent/dir/out.json"], Exit.USAGE,
     "argument --json: /nonexistent/dir/out.json: folder '/nonexistent/dir' does not exist"),
    (["run", DEMO, "--cycles", "x"], Exit.USAGE, "argument --cycles: expected a whole number, got 'x'"),
    (["experiment", "secondary-antenna", "--trials", "0"], Exit.USAGE, "argument --trials: must be >= 1, got 0"),
    (["stop", "no-such-run"], Exit.USAGE, "carav stop: no running graph matches 'no-such-run'"),
    (["nosuchcommand"], Exit.USAGE, "invalid choice: 'nosuchcommand'"),
])
def test_bad_input_is_refused_in_one_place_with_its_exit_code(capsys, argv, code, text):
    assert carav(argv) == code
    err = error_of(capsys)
    assert text in err, err
    assert scene_reported_once(err)


@pytest.mark.parametrize("argv, text", [
    (["pipeline", "--repeats", "0"], "dev.py bench pipeline: argument --repeats: must be >= 1, got 0"),
    (["transport", "--json", "/"], "argument --json: '/' is a folder, not a file"),
    (["nosuch"], "invalid choice: 'nosuch'"),
])
def test_the_benchmarks_refuse_bad_input_as_carav_does(capsys, argv, text):
    assert run_bench(argv) == Exit.USAGE
    err = error_of(capsys)
    assert text in err, err


def scene_reported_once(err: str) -> bool:
    return err.count("no such scene file or preset") <= 1


def test_a_scene_problem_is_reported_once_not_once_per_block(capsys):
    assert carav(["validate", DEMO, "--set", "scene=nosuch"]) == Exit.INVALID
    assert error_of(capsys).count("no such scene file or preset") == 1


def test_a_sink_that_could_not_write_its_file_is_refused_before_anything_runs(capsys, tmp_path):
    graph = tmp_path / "g.toml"
    graph.write_text(f'include = "{ROOT / "graphs" / "radar_chain.toml"}"\nconnections = ["gate.alarms -> log.inp"]\n'
                     f'[blocks]\nlog = {{ type = "jsonl_sink", path = "{tmp_path / "missing" / "a.jsonl"}" }}\n')
    assert carav(["run", str(graph)]) == Exit.INVALID
    assert f"blocks.log.path: cannot write '{tmp_path / 'missing' / 'a.jsonl'}': folder" in error_of(capsys)
    graph.write_text(graph.read_text().replace(str(tmp_path / "missing" / "a.jsonl"), str(tmp_path)))
    assert carav(["validate", str(graph)]) == Exit.INVALID
    assert "is a folder, not a file" in error_of(capsys)


def test_reproduce_refuses_zero_trials_and_leaves_no_figures_folder(capsys, tmp_path):
    figures = tmp_path / "figs"
    assert carav(["reproduce", "--trials", "0", "--figures", str(figures), "--out", str(tmp_path / "r.md")]) == 2
    assert "argument --trials: must be >= 1, got 0" in error_of(capsys)
    assert not figures.exists()


def test_an_unexpected_failure_is_one_line_and_debug_shows_the_traceback(capsys, monkeypatch):
    from carav_stream.cli import status

    def broken(args):
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(status, "run", broken)
    assert carav(["status"]) == Exit.FAILED
    err = error_of(capsys)
    assert err == "carav status: failed: RuntimeError: disk on fire (--debug shows the traceback)\n"
    with pytest.raises(RuntimeError, match="disk on fire"):
        carav(["status", "--debug"])


def test_a_ctrl_c_while_the_command_is_still_importing_is_one_line_and_exit_130(capsys, monkeypatch):
    import carav_stream.cli as cli

    def interrupted(argv, **tables):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)       # where the command's module is imported
    assert carav(["run", DEMO]) == Exit.INTERRUPTED
    assert error_of(capsys) == "carav: interrupted\n"


@pytest.mark.parametrize("argv, max_speed", [
    ([DEMO, "--set", "scene=awr1642"], "0"),                         # an estimator that reads the alias
    ([str(ROOT / "graphs" / "awr1642_smart.toml"), "--set", "ranging.max_speed_mps=50"], "50"),    # short of 83.3
])
def test_validate_warns_once_about_a_velocity_beyond_the_unambiguous_interval_the_estimator_reads_aliased(
        capsys, argv, max_speed):
    assert carav(["validate", *argv]) == Exit.OK
    err = error_of(capsys)
    assert err.count("beyond the unambiguous") == 1 and ".toml: warning: awr1642.toml: targets[0]" in err, err
    assert f"unless its max_speed_mps (now {max_speed} m/s) reaches 83.3 m/s" in err, err


def test_the_shipped_graphs_validate_without_a_warning_the_awr1642_car_unaliased_by_its_estimator(capsys):
    # graphs/awr1642_smart.toml's ranging follows the range walk up to 100 m/s: its car's 83.3 m/s comes out
    # unaliased (tests/estimate/test_migration.py), so its deliberate 300 km/h is no mistake to warn about
    assert carav(["validate", *sorted(str(p) for p in (ROOT / "graphs").glob("*.toml"))]) == Exit.OK
    assert "warning" not in error_of(capsys)
    assert carav(["scenes", "awr1642"]) == Exit.OK                   # the scene itself still says it aliases
    assert "beyond the unambiguous +-6.08 m/s" in capsys.readouterr().out


def test_validate_passes_every_shipped_graph_and_names_what_a_template_leaves_open(capsys):
    graphs = sorted(str(p) for p in (ROOT / "graphs").glob("*.toml"))
    assert carav(["validate", *graphs]) == Exit.OK
    out = capsys.readouterr().out
    assert out.count(": ok (") == len(graphs)
    assert "replay.toml: ok (5 nodes, 7 connections; a template leaving source.path open)" in out
    assert "a template" not in out.replace("replay.toml: ok (5 nodes, 7 connections; a template", "")
    assert carav(["run", str(ROOT / "graphs" / "replay.toml")]) == Exit.INVALID     # run, it needs its recording
    assert "give it with --set source.path=VALUE" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["status"], ["stop"], ["run", DEMO, "--cycles", "10"]])
def test_a_run_folder_open_to_others_is_refused_in_one_line_before_anything_runs(capsys, tmp_path, monkeypatch,
                                                                                   argv):
    monkeypatch.setenv("CARAV_RUN_DIR", str(tmp_path))
    root = tmp_path / f"carav-{os.getuid()}"
    root.mkdir()
    root.chmod(0o755)
    assert carav(argv) == Exit.FAILED
    err = error_of(capsys)
    assert err.startswith(f"carav {argv[0]}: run folder {root} has mode 0755, not 0700") and err.count("\n") == 1
    assert list(root.iterdir()) == []
