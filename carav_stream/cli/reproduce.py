"""`carav reproduce`: the reproduction report and its figures, in reproduction/ by default (REPRODUCTION.md and
figures/repro_*.png under the working folder); `--in-place` regenerates the repository's docs/REPRODUCTION.md and
docs/figures instead. Nothing tracked is rewritten unless asked for.

Runs the paper's experiments (Figures 3, 4 and 5: random and smart attacks on the Table I and Table II scenes) through
the radar signal chain with full sample simulation, sets the paper's claims beside our numbers, and then goes beyond
the paper: every attacker model, realistic nuisances, the ghost attacker and the opt-in detectors of `extra`.
Deterministic for a given --seed (the activation sequences are seeded: simulation only).
"""
from __future__ import annotations

import argparse
import difflib
import os
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from carav_stream.console import jsonout
from carav_stream.console.errors import CommandError, Exit
from carav_stream.console.options import count, output_file, output_folder
from carav_stream.console.progress import ProgressBar
from carav_stream.experiments import doc_outputs
from carav_stream.experiments.errors import ExperimentError
from carav_stream.experiments.reporting import Reproduction
from carav_stream.experiments.reproduction import render

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=output_file, default=None,
                        help="markdown file to write (default: reproduction/REPRODUCTION.md)")
    parser.add_argument("--figures", type=output_folder, default=None,
                        help="folder for repro_*.png (default: figures/ next to --out)")
    parser.add_argument("--in-place", action="store_true",
                        help="regenerate docs/REPRODUCTION.md, docs/figures and every command output quoted in "
                             "README.md and docs/*.md (run from the repository's root)")
    parser.add_argument("--trials", type=count(1), default=1000, help="cycles per curve (paper: 1000)")
    parser.add_argument("--beyond-trials", type=count(1), default=300,
                        help="cycles per cell of the beyond-paper tables")
    parser.add_argument("--seed", type=count(0), default=2026)
    parser.add_argument("--skip-beyond", action="store_true", help="only the paper's figures and claims")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE",
                        help="also write every number as JSON")
    parser.add_argument("--check", action="store_true",
                        help="regenerate in a temporary folder and fail (exit 1) if docs/REPRODUCTION.md (or --out) "
                             "or a command output quoted in README.md or docs/*.md differs; writes nothing")
    parser.add_argument("--quiet", action="store_true")


def _say(args: argparse.Namespace, prefix: str = ""):
    """Where the progress lines go: standard error (each after `prefix`), or nowhere with --quiet."""
    return None if args.quiet else lambda line: print(prefix + line, file=sys.stderr, flush=True)


def _asked(args: argparse.Namespace, figure_link: str) -> Reproduction:
    """The reproduction the command line asks for, with a progress bar per sweep on a terminal."""
    return Reproduction(args.trials, args.beyond_trials, args.seed, args.skip_beyond, figure_link, _say(args),
                        ProgressBar if ProgressBar.wanted(args.quiet) else None)


def _differs(what: str, committed: str, now: str, source: str) -> str:
    """Print the start of a unified diff on stderr; returns the one-line verdict."""
    diff = list(difflib.unified_diff(committed.splitlines(), now.splitlines(), f"{what} (committed)",
                                     f"{source} (now)", lineterm="", n=0))
    changed = sum(1 for line in diff if line[:1] in "+-" and line[:3] not in ("+++", "---"))
    print("\n".join(diff[:60]), file=sys.stderr)
    return f"{what} differs from what the code produces ({changed} lines)"


def _check(args: argparse.Namespace, target: Path) -> int:
    """Regenerate into a temporary folder and compare with the committed document (text: every number of the
    tables and the prose; the figures are drawn from the same numbers); then, for the repository's documents, every
    quoted command output."""

    if not target.is_file():
        raise CommandError(f"--check: {target} does not exist (run from the repository's root, or give --out)")
    link = Path(os.path.relpath(args.figures or target.parent / "figures", target.parent)).as_posix()
    with ThreadPoolExecutor(1) as pool:      # the quoted commands run as processes beside this one's own work
        quoted = None if args.out else pool.submit(doc_outputs.stale, Path("."), _say(args, "checking "))
        with tempfile.TemporaryDirectory(prefix="carav-reproduce-") as tmp:
            text, _ = render(_asked(args, link), Path(tmp))
        try:
            stale = quoted.result() if quoted else []
        except ExperimentError as exc:       # a quoted command that failed: named in one line
            raise CommandError(str(exc)) from None
    problems = [] if text == target.read_text() else [_differs(str(target), target.read_text(), text,
                                                               "carav reproduce")]
    problems += [_differs(f"{q.path}: output of `{q.command}`", q.body, now, q.command) for q, now in stale]
    if not problems:
        quotes = "" if args.out else " and the command outputs quoted in README.md and docs/*.md are"
        print(f"{target} (--trials {args.trials}, --seed {args.seed}) is{quotes} what the code produces")
        return 0
    for p in problems:
        print(f"carav reproduce: {p}", file=sys.stderr)
    print("carav reproduce: regenerate with `carav reproduce --in-place`", file=sys.stderr)
    return int(Exit.FAILED)


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    if args.in_place or args.check:
        if args.in_place and (args.out or args.figures or args.check):
            raise CommandError("--in-place writes docs/REPRODUCTION.md and docs/figures; give it alone")
        if not args.out and not Path("docs").is_dir():
            raise CommandError(f"{'--in-place' if args.in_place else '--check'}: no docs/ folder here; run it "
                               "from the repository's root")
    if args.check:
        return _check(args, args.out or Path("docs/REPRODUCTION.md"))
    out = Path("docs/REPRODUCTION.md") if args.in_place else args.out or Path("reproduction/REPRODUCTION.md")
    out.parent.mkdir(exist_ok=True)              # the default folder; a given one was checked with the options
    fig_dir = args.figures or out.parent / "figures"
    fig_dir.mkdir(exist_ok=True)
    text, data = render(_asked(args, Path(os.path.relpath(fig_dir, out.parent)).as_posix()), fig_dir)
    out.write_text(text)
    if args.json:
        jsonout.write(args.json, data, indent=1)
    print(f"wrote {out} and {fig_dir}/repro_*.png in {time.perf_counter() - t0:.0f} s")
    if args.in_place:
        try:
            changed = doc_outputs.regenerate(Path("."), log=_say(args, "regenerating "))
        except ExperimentError as exc:
            raise CommandError(str(exc)) from None
        print(f"command outputs quoted in the documents: {len(changed)} document(s) changed "
              f"({', '.join(map(str, changed)) or 'none'})")
    return 0
