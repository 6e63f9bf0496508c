"""carav study without a cluster: the study file checked whole, and its points' batches, drawn by the task function,
give `carav sweep`'s curves bit for bit (the Dask runs are tested in tests/integration/test_study_dask.py)."""
import json
from pathlib import Path

import numpy as np
import pytest

from carav_stream.cli import main as carav
from carav_stream.montecarlo.engine import eta_grid, sweep
from carav_stream.montecarlo.sources import source_from_spec
from carav_stream.montecarlo.study import plan, results, run_batches
from carav_stream.montecarlo.study_file import StudyError, load_study

GOOD = """
description = "t"
seed = 11
trials = 300
eta = "0.5:3:0.05"
[[scenes]]
preset = "table1"
ideal_adc = true
[[attacks]]
kind = "random"
rarms = [0.5, 1.2, 3.0]
[[attacks]]
kind = "smart"
rarms = [0.5, 1.2, 3.0]
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def drawn_in_process(study, points) -> dict:
    """Every task of the study run here, in any order, as a Dask worker would run it."""
    draws = {}
    for pt in points:
        spec = json.dumps(study.groups[pt.group].spec, sort_keys=True)
        parts = [run_batches(spec, "carav", pt.attack, pt.rarms, pt.used, study.seed, b) for b in pt.tasks()[::-1]]
        parts = parts[::-1]
        draws[(pt.group, pt.job)] = (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))
    return draws


def test_every_problem_of_a_study_file_is_reported_at_once_and_located(tmp_path, capsys):
    bad = GOOD.replace("seed = 11", "seeds = 11").replace('preset = "table1"', 'preset = "table9"') \
        .replace('kind = "smart"', 'kind = "clever"').replace('eta = "0.5:3:0.05"', 'eta = "3:1:0.1"') \
        .replace("trials = 300", 'trials = -4\ndetectors = ["carav", "psychic"]')
    with pytest.raises(StudyError) as info:
        load_study(write(tmp_path, bad))
    text = str(info.value)
    for line in ("s.toml: seeds: unknown parameter (did you mean 'seed'?)", "s.toml: seed: missing required parameter",
                 "s.toml: trials: must be >= 1, got -4", "s.toml: eta: need 0 < START <= STOP",
                 "s.toml: detectors[1]: unknown detector 'psychic'", "s.toml: attacks[1].kind: expected one of",
                 "s.toml: scenes[0].preset: no such preset 'table9'"):
        assert line in text, (line, text)
    assert carav(["study", str(tmp_path / "s.toml")]) == 3                  # Exit.INVALID, the same lines
    err = capsys.readouterr().err
    assert err.startswith(f"carav study: {tmp_path / 's.toml'} is not valid:\n") and all(line in err for line in
                                                                                    text.splitlines()[1:])


def test_a_scene_file_is_found_next_to_the_study_and_a_bad_parameter_is_named(tmp_path):
    with pytest.raises(StudyError, match=r"scenes\[0\].file: .*nope.toml not found"):
        load_study(write(tmp_path, GOOD.replace('preset = "table1"', 'file = "nope.toml"')))
    with pytest.raises(StudyError, match=r"attacks\[0\].rarms\[1\]: must be float, got str 'x'"):
        load_study(write(tmp_path, GOOD.replace("[0.5, 1.2, 3.0]", '[0.5, "x"]', 1)))
    with pytest.raises(StudyError, match=r"s.toml: scenes\[0\]: .*range_m"):
        load_study(write(tmp_path, GOOD.replace('kind = "random"', 'kind = "ghost"\nparams = { range_m = -3 }')))


def test_the_study_draws_are_those_of_carav_sweep_with_the_same_seed(tmp_path):
    study = load_study(write(tmp_path, GOOD))
    points = plan(study)
    # the sufficient-statistic path (an ideal ADC here) cuts a point into independent tasks; on every sample the
    # source keeps state (attacker, activation stream): a point is one task, its batches in order
    assert [(p.used, p.independent) for p in points] == [("energy", True)] * 7
    quantised = plan(load_study(write(tmp_path, GOOD.replace("ideal_adc = true", ""))))
    assert [(p.used, p.independent) for p in quantised] == [("samples", False)] * 7
    draws = drawn_in_process(study, points)
    (group,), rows = results(study, draws)
    reference = sweep(source_from_spec(study.groups[0].spec), attacks=["random", "smart"], rarms=[0.5, 1.2, 3.0],
                      n_trials=300, eta=eta_grid("0.5:3:0.05"), seed=11)
    assert group["result"]["curves"] == reference["curves"]
    assert group["result"]["thresholds"] == reference["thresholds"]
    assert [(r["attack"], r["rarms"], r["measure"]) for r in rows][:2] == [("none", 0.0, "false_alarms"),
                                                                           ("random", 0.5, "misses")]
    assert all(0 <= r["rate_lo"] <= r["rate"] <= r["rate_hi"] <= 1 for r in rows)


@pytest.mark.slow
def test_grouping_batches_into_tasks_changes_no_number(tmp_path):
    text = GOOD.replace("trials = 300", "trials = 50000\ntask_cycles = 40000").replace("[0.5, 1.2, 3.0]", "[1.2]")
    study = load_study(write(tmp_path, text))
    points = plan(study)
    assert [[len(t) for t in p.tasks()] for p in points] == [[2, 1]] * 3          # batches of 20000, 20000, 10000
    draws = drawn_in_process(study, points)
    (group,), _ = results(study, draws)
    reference = sweep(source_from_spec(study.groups[0].spec), attacks=["random", "smart"], rarms=[1.2],
                      n_trials=50000, eta=eta_grid("0.5:3:0.05"), seed=11)
    assert group["result"]["curves"] == reference["curves"]
