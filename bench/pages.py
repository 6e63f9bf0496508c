"""The head of every benchmark page, docs/bench/NAME.md, rendered by `python3 dev.py bench report` from the
benchmark list (`bench.BENCHES`) and the benchmark's own options, so that no command, module or record path in it
is typed by hand:

    <!-- begin: dev.py bench report, head -->
    `python3 dev.py bench synth [--json FILE] [--cycles CYCLES] [--repeats REPEATS] [--presets PRESETS] [--quick]`
    Module `bench/synth.py`; records `docs/bench/records/synth.json` (written by its `--json`), rendered into this
    page and BENCHMARKS.md by `python3 dev.py bench report`.
    <!-- end: dev.py bench report, head -->

The page's own prose (what is measured, how, against which target) follows the head; the results sit between the
markers `report.BEGIN` and `report.END`.
"""
from __future__ import annotations

import argparse
import importlib
import textwrap

from bench import BENCHES

HEAD_BEGIN, HEAD_END = "<!-- begin: dev.py bench report, head -->", "<!-- end: dev.py bench report, head -->"
WIDTH = 118                  # the pages' line length


def command_of(name: str) -> tuple[str, str] | None:
    """(command, module) of the benchmark whose records are docs/bench/records/NAME.json (its module is bench.NAME),
    or None for records whose benchmark is not in the tree."""
    return next(((command, module) for command, (module, _) in BENCHES.items() if module == f"bench.{name}"), None)


def usage(command: str, module: str) -> str:
    """`python3 dev.py bench COMMAND [options]` as the benchmark's parser states it, on one line."""
    parser = argparse.ArgumentParser(prog=f"python3 dev.py bench {command}", add_help=False,
                                     formatter_class=lambda prog: argparse.HelpFormatter(prog, width=1 << 20))
    importlib.import_module(module).configure(parser)
    return " ".join(parser.format_usage().removeprefix("usage:").split())


def wrap(text: str, width: int = WIDTH) -> list[str]:
    """A usage line broken before its top-level options ("[--x X]", brackets nested inside kept whole)."""
    pieces, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch == "[" and depth == 0 and i > start:
            pieces.append(text[start:i].rstrip())
            start = i
        depth += {"[": 1, "]": -1}.get(ch, 0)
    pieces.append(text[start:])
    lines = [pieces[0]]
    for piece in pieces[1:]:
        if len(lines[-1]) + 1 + len(piece) <= width:
            lines[-1] += " " + piece
        else:
            lines.append(piece)
    return lines


def head(name: str, recorded_only: str | None = None) -> list[str]:
    """The head's lines for docs/bench/NAME.md: the command, the module, the record file."""
    records = f"`docs/bench/records/{name}.json`"
    found = command_of(name)
    if found is None:
        if recorded_only is None:
            raise ValueError(f"docs/bench/{name}.md: no benchmark of bench.BENCHES writes {records}, and it is not "
                             "listed as a recorded evaluation")
        return textwrap.wrap(f"Records {records}: {recorded_only}.", WIDTH, break_on_hyphens=False,
                             break_long_words=False)
    command, module = found
    lines = wrap(f"`{usage(command, module)}`", WIDTH)
    lines[-1] += "  "
    return lines + textwrap.wrap(f"Module `{module.replace('.', '/')}.py`; records {records} (written by its "
                                 "`--json`), rendered into this page and BENCHMARKS.md by `python3 dev.py bench "
                                 "report`.", WIDTH, break_on_hyphens=False, break_long_words=False)


def splice(text: str, begin: str, end: str, body: list[str], where: str) -> str:
    """text with what lies between the markers begin and end replaced by the lines of body."""
    if begin not in text or end not in text:
        raise ValueError(f"{where}: lacks the markers {begin} ... {end}")
    before, _, rest = text.partition(begin)
    _, _, after = rest.partition(end)
    return "\n".join([f"{before}{begin}", *body, f"{end}{after}"])
