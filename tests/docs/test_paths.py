"""The documents name only what exists: every repository path in docs/, README.md and BENCHMARKS.md
(`carav_stream/...`, `bench/...`, `blocks/...`, `graphs/...`, `tests/...`, `docs/...`, and a path inside the
package such as `radar/noise.py`) names a file or folder of the tree, a pattern such as `graphs/*.toml` or
`docs/bench/records/NAME.json` matches one, and every dotted name of the package or the benchmarks
(`carav_stream.runtime.supervisor.NODE_ENV`) imports. A benchmark's record file, which its `--json` writes, may be
named before its first run (BENCHMARKS.md says "No records yet")."""
import importlib
import importlib.util
import re
from pathlib import Path

import pytest

from bench.pages import command_of

ROOT = Path(__file__).resolve().parents[2]
DOCUMENTS = sorted([ROOT / "README.md", ROOT / "BENCHMARKS.md", *(ROOT / "docs").rglob("*.md")])

PATH = re.compile(r"(?<![\w./-])((?:carav_stream|bench|blocks|graphs|tests|docs)/[\w./*<>{}-]*)")
SUBPACKAGES = sorted(p.parent.name for p in (ROOT / "carav_stream").glob("*/__init__.py"))
IN_PACKAGE = re.compile(r"(?<![\w./-])((?:" + "|".join(SUBPACKAGES) + r")/[\w./*<>{}-]+)")   # radar/noise.py
DOTTED = re.compile(r"(?<![\w./-])((?:carav_stream|bench|carav_graphs)(?:\.[A-Za-z_]\w*)+)")
PLACEHOLDERS = ("NAME", "TYPE", "FILE", "DIR")        # upper-case words standing for any name, as in usage lines
RECORDS = re.compile(r"docs/bench/records/(\w+)\.json")


def _glob(token: str) -> str | None:
    """The glob a path pattern stands for, None for a plain path."""
    pattern = re.sub(r"<[^>]*>|\b(?:" + "|".join(PLACEHOLDERS) + r")\b", "*", token)
    pattern = re.sub(r"\{[^}]*\}", "*", pattern)
    return pattern if "*" in pattern else None


def missing_paths(text: str, root: Path = ROOT) -> list[str]:
    """The path-looking tokens of a document's text that name nothing in root (with their line)."""
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        for base, rx in ((root, PATH), (root / "carav_stream", IN_PACKAGE)):
            for m in rx.finditer(line):
                token = m.group(1).rstrip(".,:;")
                if (base / token).exists():
                    continue
                record = RECORDS.fullmatch(token) if base == root else None
                if record and command_of(record.group(1)) is not None:     # a benchmark's output, not yet written
                    continue
                pattern = _glob(token)
                if pattern is None or not any(base.glob(pattern.rstrip("/"))):
                    found.append(f"{n}: {token}")
    return found


def _imports(name: str) -> bool:
    """A dotted name is a module, or an attribute of the longest module it starts with."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            spec = importlib.util.find_spec(".".join(parts[:i]))
        except ImportError:
            spec = None
        if spec is not None:
            obj = importlib.import_module(".".join(parts[:i]))
            for attr in parts[i:]:
                if not hasattr(obj, attr):
                    return False
                obj = getattr(obj, attr)
            return True
    return False


def missing_names(text: str) -> list[str]:
    return [f"{n}: {m.group(1)}" for n, line in enumerate(text.splitlines(), 1)
            for m in DOTTED.finditer(line) if not _imports(m.group(1))]


@pytest.mark.parametrize("doc", DOCUMENTS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_path_a_document_names_exists(doc):
    assert missing_paths(doc.read_text()) == []


@pytest.mark.parametrize("doc", DOCUMENTS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_module_a_document_names_imports(doc):
    assert missing_names(doc.read_text()) == []


def test_a_stale_path_or_module_is_found_and_a_pattern_is_matched():
    text = ("module `carav_stream/bench/wire.py`; graphs in graphs/*.toml, records docs/bench/records/NAME.json,\n"
            "generators tests/golden/make_<block>.py; nothing in graphs/*.nope; bench/chain.toml; radar/noise.py,\n"
            "radar/wire.py, `my_blocks/x.py`; docs/bench/records/gr_bridge.json, docs/bench/records/nope.json\n"
            "`carav_stream.runtime.supervisor.NODE_ENV`, `carav_stream.bench.estimation`, `bench.pages.head`")
    assert missing_paths(text, ROOT) == ["1: carav_stream/bench/wire.py", "2: graphs/*.nope",
                                         "3: docs/bench/records/nope.json", "3: radar/wire.py"]
    assert missing_names(text) == ["4: carav_stream.bench.estimation"]
