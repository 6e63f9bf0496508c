"""docs/BLOCKS.md: its pass-through block, copied from the document, runs in a real graph as the document says."""
import re
from pathlib import Path

import pytest

from tests.integration.conftest import ROOT, TOYS

pytestmark = pytest.mark.integration


def doc_block() -> str:
    text = (ROOT / "docs" / "BLOCKS.md").read_text()
    section = text[text.index("## A pass-through block"):text.index("## The contract")]
    code = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(code) == 1, "docs/BLOCKS.md should show exactly one block in that section"
    return code[0]


def test_the_documented_pass_through_block_has_at_most_15_lines_of_code():
    lines = [ln for ln in doc_block().splitlines() if ln.strip()]
    assert len(lines) <= 17, lines        # 15 lines of code, its docstring and import


def test_the_documented_block_runs_from_a_block_folder_and_its_summary_reaches_the_run_summary(carav):
    folder: Path = carav.workdir / "my_blocks"
    folder.mkdir()
    (folder / "passthrough.py").write_text(doc_block())
    graph = carav.workdir / "doc.toml"
    graph.write_text(f"""
block_paths = ["my_blocks", "{TOYS}"]
connections = ["src.out -> p.inp", "p.out -> log.inp"]
[run]
cycles = 12
[blocks]
src = {{ type = "counter_source", batch = 3 }}
p = {{ type = "passthrough", label = "tap" }}
log = {{ type = "jsonl_sink", path = "out.jsonl" }}
""")
    run = carav.run(graph)
    assert run.wait() == 0, run.stderr()
    history = run.summary()["per_node"]["p"]["history"]
    assert [h["summary"] for h in history] == [{"label": "tap", "frames": 4, "cycles": 12}]
