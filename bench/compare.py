"""`python3 dev.py bench compare REV [--rounds N] [--fields GLOBS] [--json FILE] -- NAME [OPTIONS]`: one benchmark
run on the code of git revision REV ("old") and on this tree ("new"), alternated round by round, each figure's
medians side by side with their ratio new / old.

A shared machine's load drifts while a benchmark runs: the two sides run in turn (old then new, then new then old,
and so on), so that the drift falls on both, and each side's figure is the median of its rounds. REV is checked out
into a temporary git worktree, removed afterwards. Each side runs in its own tree with that tree's packages first on
PYTHONPATH: `carav_stream` and `bench`, and the blocks and graphs as `carav_blocks` and `carav_graphs` (the editable
install maps those two to this tree whatever the working directory, so an old tree alone would run this tree's
blocks); a graph's nodes inherit both. This tree runs as it is, uncommitted changes included: the output says so.

The two sides' records are matched by position (the same options give the same cases in the same order; a
different count is an error). Every numeric field of a record, one level of nested dicts flattened
(`busy_us_per_cycle.channel`), whose name matches one of the --fields globs is compared; a field that one side's
code does not record is left out (a new field has nothing to be compared with). Each side's output goes to
a log beside its records in the temporary folder; a failed run shows the end of its log.
"""
from __future__ import annotations

import argparse
import fnmatch
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from bench import records as bench_records
from carav_stream.console.options import count, output_file

ROOT = Path(__file__).resolve().parents[1]
# package name -> its folder in a tree
TREE_PACKAGES = {"carav_stream": "carav_stream", "bench": "bench", "carav_blocks": "blocks", "carav_graphs": "graphs"}
DEFAULT_FIELDS = "cycles_per_s,cpu_us_per_cycle,speedup_over_fused"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("rev", help="the git revision of the old code (a commit, a tag, HEAD~3)")
    parser.add_argument("bench", nargs=argparse.REMAINDER, metavar="-- NAME [OPTIONS]",
                        help="the benchmark to run and its options, after --")
    parser.add_argument("--rounds", type=count(1), default=5, help="runs of each side (default 5)")
    parser.add_argument("--fields", default=DEFAULT_FIELDS,
                        help=f"comma list of globs of the record fields to compare (default {DEFAULT_FIELDS}); "
                        "nested fields as parent.child, e.g. 'busy_us_per_cycle.*'")
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the comparison as JSON")


def flatten(record: dict[str, Any]) -> dict[str, float]:
    """The numeric fields of a record (bools and lists left out), a nested dict's as parent.child."""
    out: dict[str, float] = {}
    for key, value in record.items():
        items = value.items() if isinstance(value, dict) else [(None, value)]
        for sub, v in items:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out[key if sub is None else f"{key}.{sub}"] = float(v)
    return out


def label(i: int, record: dict[str, Any]) -> str:
    """Record i's case: its number, its short text fields (a preset, a mode) and its batch if it has one."""
    parts = [f"{i}:", *(v for v in record.values() if isinstance(v, str) and len(v) <= 24)]
    if "batch" in record:
        parts.append(f"batch {record['batch']}")
    return " ".join(parts)


def compare(old_runs: list[list[dict]], new_runs: list[list[dict]], globs: list[str]) -> list[dict[str, Any]]:
    """Rows {record, field, old, new (the rounds' values), old_median, new_median, ratio} for every field matching
    `globs` in records matched by position; ValueError when the runs disagree on how many records they wrote."""
    counts = {len(run) for run in old_runs + new_runs}
    if len(counts) != 1:
        raise ValueError(f"the runs wrote different numbers of records ({sorted(counts)}): the two codes do not run "
                         "the same cases with these options")
    rows = []
    for i in range(counts.pop()):
        old = [flatten(run[i]) for run in old_runs]
        new = [flatten(run[i]) for run in new_runs]
        fields = [f for f in old[0] if any(fnmatch.fnmatchcase(f, g) for g in globs)]
        for f in fields:
            a = [r[f] for r in old if f in r]
            b = [r[f] for r in new if f in r]
            if not a or not b:
                continue
            ma, mb = statistics.median(a), statistics.median(b)
            rows.append({"record": label(i, old_runs[0][i]), "field": f, "old": a, "new": b, "old_median": ma,
                         "new_median": mb, "ratio": mb / ma if ma else float("nan")})
    return rows


def _git(root: Path, *args: str) -> str:
    out = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(f"git {' '.join(args)}: {out.stderr.strip()}")
    return out.stdout.strip()


def _shim(tree: Path, folder: Path) -> Path:
    """A folder of links to `tree`'s packages, to put first on PYTHONPATH."""
    folder.mkdir()
    for name, sub in TREE_PACKAGES.items():
        (folder / name).symlink_to(tree / sub, target_is_directory=True)
    return folder


def _run(side: str, tree: Path, shim: Path, argv: list[str], out: Path) -> list[dict]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(shim), os.environ.get("PYTHONPATH")) if p)}
    log = out.with_suffix(".log")
    with open(log, "wb") as f:
        code = subprocess.run([sys.executable, "-m", "bench", *argv, "--json", str(out)], cwd=tree, env=env,
                              stdout=f, stderr=subprocess.STDOUT).returncode
    if code or not out.exists():
        tail = log.read_text(errors="replace").splitlines()[-12:]
        raise RuntimeError(f"the {side} code's run failed (exit {code}):\n  " + "\n  ".join(tail))
    return bench_records.read(out)["records"]


def measure(root: Path, rev: str, argv: list[str], rounds: int, say=print) -> tuple[dict, dict[str, list[list[dict]]]]:
    """Run `python -m bench *argv` `rounds` times on revision `rev` of the repository at `root` and as many on the
    tree at `root` itself, alternated; ({old, new: commits, uncommitted}, {old, new: each run's records})."""
    info = {"old": {"rev": rev, "commit": _git(root, "rev-parse", "--verify", f"{rev}^{{commit}}")},
            "new": {"commit": _git(root, "rev-parse", "HEAD"),
                    "uncommitted": bool(_git(root, "status", "--porcelain", "--untracked-files=no"))}}
    say(f"old: {rev} = {info['old']['commit'][:12]}; new: this tree, {info['new']['commit'][:12]}"
        + (" with uncommitted changes" if info["new"]["uncommitted"] else ""))
    runs: dict[str, list[list[dict]]] = {"old": [], "new": []}
    with tempfile.TemporaryDirectory(prefix="carav-compare-") as tmp:
        folder = Path(tmp)
        old_tree = folder / "old"
        _git(root, "worktree", "add", "--detach", "--quiet", str(old_tree), info["old"]["commit"])
        try:
            trees = {"old": (old_tree, _shim(old_tree, folder / "old-path")),
                     "new": (root, _shim(root, folder / "new-path"))}
            for k in range(rounds):
                for side in ("old", "new") if k % 2 == 0 else ("new", "old"):
                    tree, shim = trees[side]
                    runs[side].append(_run(side, tree, shim, argv, folder / f"{side}-{k}.json"))
                say(f"round {k + 1} of {rounds} done")
        finally:
            _git(root, "worktree", "remove", "--force", str(old_tree))
    return info, runs


def run(args: argparse.Namespace) -> int:
    argv = args.bench[1:] if args.bench[:1] == ["--"] else args.bench
    if "--" in argv or not argv or argv[0].startswith("-") or argv[0] in ("compare", "report"):
        raise ValueError("bench compare [--rounds N] [--fields GLOBS] [--json FILE] REV -- NAME [OPTIONS]: "
                         "compare's own options before REV, a benchmark and its options after --")
    print(bench_records.header(), flush=True)
    info, runs = measure(ROOT, args.rev, argv, args.rounds, say=lambda text: print(text, flush=True))
    rows = compare(runs["old"], runs["new"], [g for g in args.fields.split(",") if g])
    if not rows:
        print(f"no numeric field of the records matches {args.fields!r}", file=sys.stderr)
        return 1
    width = max(len(r["record"]) for r in rows)
    print(f"{'record':<{width}}  {'field':<32} {'old':>10} {'new':>10} {'new/old':>8}   "
          f"(medians of {args.rounds} rounds each)")
    for r in rows:
        print(f"{r['record']:<{width}}  {r['field']:<32} {r['old_median']:>10.4g} {r['new_median']:>10.4g} "
              f"{r['ratio']:>8.3f}")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "command": bench_records.command_line(args), "machine": bench_records.machine(), **info, "bench": argv,
            "rounds": args.rounds, "comparisons": rows}, indent=1) + "\n")
    return 0
