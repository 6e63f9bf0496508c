"""Command outputs quoted in the documents, regenerated and checked against the code (`carav reproduce --in-place`,
`carav reproduce --check`).

A document quotes what a command prints between two marker lines, in a fenced block or (for a command that prints
markdown, e.g. a table) as it is:

    <!-- output of: carav design --preset table1 --seed 1 -->
    ```
    ...what the command prints on stdout, verbatim...
    ```
    <!-- end of output -->

The command runs from the repository's root as `python -m carav_stream.cli ...` (the same interpreter, no terminal,
so no progress bars); it must be deterministic (seeded). Options that write files (--plot, --json) write them as given
when regenerating, and into a temporary folder when checking, so that a check writes nothing in the tree.
"""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from carav_stream.experiments.errors import ExperimentError

__all__ = ["Quote", "quotes", "all_quotes", "output", "regenerate", "stale", "DOCUMENTS"]

MARK = re.compile(r"^<!-- output of: (?P<cmd>carav [^\n]*?) -->\n(?:```[a-z]*\n(?P<fenced>.*?)^```\n|(?P<raw>.*?))"
                  r"^<!-- end of output -->$", re.M | re.S)
WRITES = ("--plot", "--json")
# What a run prints of the machine it ran on (its id, its wall time and rates): left out of the comparison, so a
# document may quote a whole `carav run`; every other figure of it is fixed by the graph's seed and is checked.
MACHINE = (re.compile(r"(?<=  run )[\w.]+-[0-9a-f]{6}$", re.M),
           re.compile(r"(?<= cycles in )[\d.]+ [mun]?s of wall time: \d+ cycles/s"),
           re.compile(r"(?<=real-time factor )[\d.]+"))


def same(quoted: str, now: str) -> bool:
    """Whether a quote still says what its command prints, the machine's own figures aside (MACHINE)."""
    def masked(text: str) -> str:
        for pattern in MACHINE:
            text = pattern.sub("...", text)
        return text
    return masked(quoted) == masked(now)
DOCUMENTS = ("README.md", "docs/*.md")


@dataclass(frozen=True)
class Quote:
    path: Path
    command: str
    body: str           # the quoted text, ending in a newline (or empty)
    start: int          # span of the body in the document's text
    end: int


def quotes(path: Path) -> list[Quote]:
    text = path.read_text()
    out = []
    for m in MARK.finditer(text):
        part = "fenced" if m["fenced"] is not None else "raw"
        out.append(Quote(path, m["cmd"], m[part], m.start(part), m.end(part)))
    return out


def documents(root: Path) -> list[Path]:
    return sorted({p for pattern in DOCUMENTS for p in root.glob(pattern) if p.is_file()})


def all_quotes(root: Path) -> list[Quote]:
    """Every quote of every document under `root`, in document order."""
    return [q for path in documents(root) for q in quotes(path)]


def output(q: Quote, root: Path, scratch: Path | None) -> str:
    """What `q`'s command prints now, run from `root`; with `scratch` (a folder), the files it would write go there
    instead of where the command names them. ExperimentError, naming the document and the command, if it fails."""
    argv = shlex.split(q.command)[1:]
    if scratch is not None:          # a check writes nothing in the tree
        argv = [str(scratch / Path(argv[i]).name) if i and argv[i - 1] in WRITES else a for i, a in enumerate(argv)]
    where = f"{q.path}: `{q.command}`"
    try:
        done = subprocess.run([sys.executable, "-m", "carav_stream.cli", *argv], cwd=root, capture_output=True,
                              text=True, timeout=1800, env={**os.environ, "COLUMNS": "120"})
    except subprocess.TimeoutExpired:
        raise ExperimentError(f"{where} did not finish in 30 min") from None
    if done.returncode:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise ExperimentError(f"{where} failed (exit {done.returncode}): {last}")
    return done.stdout


def _outputs(root: Path, scratch: Path | None, log) -> list[tuple[Quote, str]]:
    """(quote, what its command prints now) for every quote of every document; the commands run side by side, one
    per core (each is a process of its own)."""
    qs = all_quotes(root)

    def one(i: int) -> str:
        q = qs[i]
        if log:
            log(f"{q.path}: {q.command}")
        sub = None if scratch is None else scratch / str(i)      # files of equal names kept apart
        if sub is not None:
            sub.mkdir()
        return output(q, root, sub)

    with ThreadPoolExecutor(max_workers=max(1, os.cpu_count() or 1)) as pool:
        return list(zip(qs, pool.map(one, range(len(qs)))))


def regenerate(root: Path, log=None) -> list[Path]:
    """Rerun every quoted command and write its output into the documents; returns the documents changed."""
    by_path: dict[Path, list[tuple[Quote, str]]] = {}
    for q, now in _outputs(root, None, log):
        by_path.setdefault(q.path, []).append((q, now))
    changed = []
    for path, pairs in by_path.items():
        old = text = path.read_text()
        for q, now in sorted(pairs, key=lambda p: -p[0].start):     # from the end, so earlier spans stay valid
            text = text[:q.start] + now + text[q.end:]
        if text != old:
            path.write_text(text)
            changed.append(path)
    return changed


def stale(root: Path, log=None) -> list[tuple[Quote, str]]:
    """Every quote whose command now prints something else: (quote, what it prints now). Writes nothing."""
    with tempfile.TemporaryDirectory(prefix="carav-doc-outputs-") as tmp:
        return [(q, now) for q, now in _outputs(root, Path(tmp), log) if not same(q.body, now)]
