"""bench compare: each side runs its own tree's code (blocks and graphs included), alternated; medians and ratios."""
from __future__ import annotations

import shutil
import subprocess
import textwrap
from pathlib import Path

import pytest

from bench import compare

# A stand-in repository: its benchmark writes one record naming the version of each package it imported
PROBE = '''
import json, sys
import carav_blocks, carav_graphs, carav_stream
out = sys.argv[sys.argv.index("--json") + 1]
json.dump({"command": "probe", "machine": {}, "records": [{"mode": "probe", "stream": carav_stream.VERSION,
           "blocks": carav_blocks.VERSION, "graphs": carav_graphs.VERSION, "flag": True}]}, open(out, "w"))
'''


def _repo(path: Path) -> Path:
    subprocess.run(["git", "init", "-q", str(path)], check=True)
    (path / "bench").mkdir()
    (path / "bench" / "__init__.py").write_text("")
    (path / "bench" / "__main__.py").write_text(textwrap.dedent(PROBE))
    for folder in ("carav_stream", "blocks", "graphs"):
        (path / folder).mkdir()
    return path


def _version(path: Path, v: int) -> None:
    for folder in ("carav_stream", "blocks", "graphs"):
        (path / folder / "__init__.py").write_text(f"VERSION = {v}\n")


def _commit(path: Path, message: str) -> None:
    git = ["git", "-C", str(path), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git, "add", "-A"], check=True)
    subprocess.run([*git, "commit", "-q", "-m", message], check=True)


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_each_side_runs_its_own_trees_packages_and_the_worktree_goes(tmp_path):
    repo = _repo(tmp_path / "repo")
    _version(repo, 1)
    _commit(repo, "old")
    _version(repo, 2)                                   # the new side: uncommitted, as a tree under work is
    said = []
    info, runs = compare.measure(repo, "HEAD", ["probe"], 3, say=said.append)
    assert info["new"]["uncommitted"] and info["old"]["commit"] == info["new"]["commit"]
    assert said[0].endswith("with uncommitted changes") and said[1:] == [f"round {k} of 3 done" for k in (1, 2, 3)]
    assert [r[0]["stream"] for r in runs["old"]] == [1, 1, 1] and [r[0]["stream"] for r in runs["new"]] == [2, 2, 2]
    # the blocks and graphs too, which an editable install would otherwise map to one tree for both sides
    assert {(r[0]["blocks"], r[0]["graphs"]) for r in runs["old"]} == {(1, 1)}
    assert {(r[0]["blocks"], r[0]["graphs"]) for r in runs["new"]} == {(2, 2)}
    rows = compare.compare(runs["old"], runs["new"], ["stream", "blocks", "graphs", "flag"])
    assert [(r["field"], r["old_median"], r["new_median"], r["ratio"]) for r in rows] == [
        ("stream", 1, 2, 2.0), ("blocks", 1, 2, 2.0), ("graphs", 1, 2, 2.0)]       # a bool is not a figure
    assert rows[0]["record"] == "0: probe"
    listed = subprocess.run(["git", "-C", str(repo), "worktree", "list"], capture_output=True, text=True).stdout
    assert len(listed.strip().splitlines()) == 1, listed   # the old side's worktree is gone


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_a_failed_run_names_its_side_and_shows_its_output(tmp_path):
    repo = _repo(tmp_path / "repo")
    _version(repo, 1)
    _commit(repo, "old")
    (repo / "blocks" / "__init__.py").write_text("raise SystemExit('no blocks here')\n")
    with pytest.raises(RuntimeError, match=r"(?s)the new code.s run failed.*no blocks here"):
        compare.measure(repo, "HEAD", ["probe"], 1, say=lambda text: None)
    with pytest.raises(RuntimeError, match="git rev-parse"):
        compare.measure(repo, "no-such-revision", ["probe"], 1, say=lambda text: None)


def test_medians_ratios_nested_fields_and_the_records_matched_by_position():
    def runs(xs, ns):
        return [[{"mode": "a", "batch": 4, "x": x, "d": {"n": n}}] for x, n in zip(xs, ns)]

    old, new = runs([1.0, 3.0, 2.0], [2.0, 4.0, 6.0]), runs([1.0, 1.5, 1.0], [1.0, 2.0, 3.0])
    rows = compare.compare(old, new, ["x", "d.*"])
    assert [(r["record"], r["field"], r["old_median"], r["new_median"], r["ratio"]) for r in rows] == [
        ("0: a batch 4", "x", 2.0, 1.0, 0.5), ("0: a batch 4", "d.n", 4.0, 2.0, 0.5)]
    assert rows[0]["old"] == [1.0, 3.0, 2.0] and rows[0]["new"] == [1.0, 1.5, 1.0]
    with pytest.raises(ValueError, match="different numbers of records"):
        compare.compare(old, [[], [], []], ["x"])


def test_its_own_options_go_before_the_revision(capsys):
    from bench import main
    assert main(["compare", "HEAD", "--rounds", "2", "--", "pipeline"]) != 0
    assert "compare's own options before REV" in capsys.readouterr().err
